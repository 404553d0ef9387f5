r"""``wall_thickness``: the cell wall is thinner or thicker than the FE model's 6 nm.

Cause (docs/effects.md, wall_thickness): the k/(PR) table was computed for a 6 nm wall; at fixed
``E t`` a different thickness changes the wall's bending stiffness (``E t^3/12``) and with it
the indentation stiffness, most at low inflation number (FE: k/PR -7.5 % for 3 nm, +11.5 % for
9 nm at x = 0.01; docs/fem.md, "Wall thickness").

Model: every cell's ``k_c`` is the table's times the FE thickness correction at the fitted
thickness ``t`` (:func:`turgorbayes.surrogate.correction_factor`); ``t = 6 nm`` is the
baseline.

Prior: ``t`` log-uniform on [3, 9] nm, the tabulated range and the spread of published
*E. coli* peptidoglycan thicknesses by method (AFM of isolated sacculi, Yao et al.,
J. Bacteriol. 181, 6865 (1999); cryo-electron microscopy of frozen-hydrated cells, about
6 nm, Matias et al., J. Bacteriol. 185, 6112 (2003)).
"""

from turgorbayes.effects.fe_setting import FESetting
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import LogUniform

__all__ = ["THICKNESS_PRIOR", "WallThickness"]

#: Prior on the wall thickness [m] (module docstring).
THICKNESS_PRIOR = LogUniform(3e-9, 9e-9)


class WallThickness(FESetting):
    """The wall thickness of the FE model fitted (module docstring)."""

    name = "wall_thickness"
    parameters = (Parameter("thickness", THICKNESS_PRIOR, "thickness_nm", 1e-9, r"$t$ [nm]"),)
    size_parameter = "thickness"
    null_value = 6e-9
    realistic_size = 9e-9
    realistic_size_reason = (
        "t = 9 nm: the thick end of published E. coli peptidoglycan thicknesses")
    start = {"thickness": 5.5e-9}
    cause = ("The cell wall is not as thick as the simulation assumed: a wall of about "
             "{size:.2g} nm (the model's is 6 nm) bends differently, which changes the "
             "stiffness most in the least pressurized cells.")


register_effect(WallThickness())
