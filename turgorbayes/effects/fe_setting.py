"""The shared form of the effects that put a finite-element setting on trial
(:mod:`~turgorbayes.effects.tip_radius`, :mod:`~turgorbayes.effects.wall_thickness`).

The baseline reads every stiffness off the k/(PR) table at the FE model's own settings (a
7.5 nm tip, a 6 nm wall). Such an effect fits one of them as a global parameter: every cell's
``k_c`` is the table's value times the FE correction to the fitted setting
(:func:`turgorbayes.surrogate.correction_factor`, through the wall parameters that
:func:`turgorbayes.physics.forward.fe_settings` picks out; ``docs/effects.md``).
"""

import numpy as np

from turgorbayes.effects.base import Effect

__all__ = ["FESetting"]


class FESetting(Effect):
    """An FE setting (a key of :data:`turgorbayes.surrogate.AXES`) fitted as a parameter.

    Subclasses set :attr:`size_parameter` to the axis name (the parameter in metres) and the
    usual :class:`Effect` attributes. Sizes on the command line are in nm.
    """

    size_unit = ("nm", 1e-9)

    def apply(self, ctx, v):
        value = np.asarray(v[self.size_parameter], float)[:, None]
        for group in ("bulged", "intact"):
            wall = ctx.walls[group]
            wall[self.size_parameter] = np.broadcast_to(value, wall["R0"].shape)

    def cell_walls(self, walls, v, is_bulged, rng):
        walls = dict(walls)
        walls[self.size_parameter] = np.broadcast_to(
            np.asarray(v[self.size_parameter], float), np.shape(walls["R0"]))
        return walls
