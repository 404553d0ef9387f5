r"""``tip_radius``: the indenter's tip is blunter (or sharper) than the FE model's 7.5 nm.

Cause (docs/effects.md, tip_radius): the k/(PR) table was computed for a cone with a 7.5 nm
spherical tip; real AFM tips are 2-30 nm in radius and blunt with use. A blunter tip spreads
the load and stiffens the cell's response by an amount that depends on the inflation number
(FE: k/PR +9 % for a 30 nm tip, -4 % for a 3 nm one at the physiological point; docs/fem.md,
"Indenter tip radius"), so it is partly told apart from the wall parameters by data across
pressures.

Model: every cell's ``k_c`` is the table's times the FE tip-radius correction at the fitted
radius ``r_tip`` (:func:`turgorbayes.surrogate.correction_factor`); ``r_tip = 7.5 nm`` is the
baseline.

Prior: ``r_tip`` log-uniform on [3, 30] nm, the tabulated range: the nominal radii of the
silicon-nitride probes used on live cells in liquid are 2-20 nm (e.g. Bruker MSNL 2 nm, MLCT
20 nm nominal and up to 60 nm), and tips blunt with use; only the order of magnitude is known.
"""

from turgorbayes.effects.fe_setting import FESetting
from turgorbayes.effects.registry import register_effect
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.priors import LogUniform

__all__ = ["TIP_RADIUS_PRIOR", "TipRadius"]

#: Prior on the tip radius [m] (module docstring).
TIP_RADIUS_PRIOR = LogUniform(3e-9, 30e-9)


class TipRadius(FESetting):
    """The indenter's tip radius fitted (module docstring)."""

    name = "tip_radius"
    parameters = (Parameter("tip_radius", TIP_RADIUS_PRIOR, "tip_radius_nm", 1e-9,
                            r"$r_{tip}$ [nm]"),)
    size_parameter = "tip_radius"
    null_value = 7.5e-9
    realistic_size = 20e-9
    realistic_size_reason = (
        "r_tip = 20 nm: the nominal radius of common silicon-nitride probes for live cells "
        "(e.g. Bruker MLCT), and where a 7.5 nm tip ends up after use")
    start = {"tip_radius": 10e-9}
    cause = ("The AFM tip is blunter than the simulation assumed: a tip of about {size:.2g} nm "
             "radius (the model's is 7.5 nm) spreads the load and changes every cell's "
             "stiffness by an amount that depends on its pressure.")


register_effect(TipRadius())
