r"""``wall_softening``: the drug that makes the bulges also softens the wall of bulged cells.

Cause (docs/effects.md, wall_softening): the bulged cells were treated with vancomycin, which binds the
D-Ala-D-Ala ends of the peptidoglycan precursors and blocks cross-linking; the fit assumes the
bulged cells keep the intact cells' wall.

Model: the stiffness of the wall at ``P0`` of a bulged cell is a factor ``s`` times that of an
intact cell,

.. math:: (E_0t)_{bulged} = s\,(E_0t)_{intact},

with ``gamma`` and ``R0`` shared; ``E0t`` keeps its meaning (intact cells). ``s < 1`` is a
softer, ``s > 1`` a stiffer bulged-cell wall.

Prior: ``ln s ~ N(0, 0.5)`` (a factor 2.7 either way at 2 sd).
"""

import numpy as np

from turgorbayes.effects.base import Effect
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import LogNormal

__all__ = ["S_PRIOR", "WallSoftening"]

#: Prior on the softening factor.
S_PRIOR = LogNormal(median=1.0, sigma=0.5)


class WallSoftening(Effect):
    """Bulged-cell wall ``E0t`` scaled by a fitted factor ``s`` (module docstring)."""

    name = "wall_softening"
    changes_wall = True
    parameters = (Parameter("s_wall", S_PRIOR, "s_wall", 1.0, r"$s$"),)
    size_parameter = "s_wall"
    null_value = 1.0
    realistic_size = 0.7
    realistic_size_reason = (
        "s = 0.7 (bulged-cell wall 30 % softer): sub-lethal cell-wall antibiotics reduce E. coli "
        "wall stiffness by tens of percent in AFM and osmotic-shock measurements")
    start = {"s_wall": 0.95}
    cause = ("The drug used to make the bulges also softens the cell wall: the wall of bulged "
             "cells is about {size:.2g} times as stiff as that of untreated cells, so the bulged "
             "cells do not calibrate the untreated cells' wall exactly.")

    def apply(self, ctx, v):
        wall = ctx.walls["bulged"]
        wall["E0t"] = wall["E0t"] * np.asarray(v["s_wall"], float)[:, None]

    def cell_walls(self, walls, v, is_bulged, rng):
        walls = dict(walls)
        walls["E0t"] = walls["E0t"] * np.where(is_bulged, v["s_wall"], 1.0)
        return walls


register_effect(WallSoftening())
