"""Model extensions ("effects") of the baseline fit, one physical or statistical cause each.

Each effect module (:mod:`~turgorbayes.effects.radius_spread`,
:mod:`~turgorbayes.effects.pressure_error`, :mod:`~turgorbayes.effects.bad_curves`,
:mod:`~turgorbayes.effects.wall_softening`, :mod:`~turgorbayes.effects.outer_membrane`,
:mod:`~turgorbayes.effects.outliers`, :mod:`~turgorbayes.effects.calibration`,
:mod:`~turgorbayes.effects.heavy_tails`, the FE model's own settings
:mod:`~turgorbayes.effects.tip_radius`, :mod:`~turgorbayes.effects.wall_thickness`,
:mod:`~turgorbayes.effects.turgor_spread`, a drift with measurement order
:mod:`~turgorbayes.effects.drift`, a wall of a condition's own
:mod:`~turgorbayes.effects.own_wall` (data with several conditions), the recovery of turgor
after the shifts of an osmotic series :mod:`~turgorbayes.effects.osmoadaptation`, a correlation of each
cell's R_c and k_c errors :mod:`~turgorbayes.effects.correlated_errors`, and the generic
description of misfit
:mod:`~turgorbayes.effects.discrepancy`) defines one :class:`Effect` and registers it;
:class:`ExtendedModel` applies any list of them (docs/effects.md).
"""

# each effect module registers its effect on import; the registry order is the order
# the effects were added (a candidate's draws depend on its name, not on this order)
from turgorbayes.effects import (
    bad_curves,
    calibration,
    heavy_tails,
    outer_membrane,
    outliers,
    pressure_error,
    radius_spread,
    tip_radius,
    wall_softening,
    wall_thickness,
)
from turgorbayes.effects.base import Effect, Injection, SqrtCoordinate
from turgorbayes.effects.model import ExtendedModel
from turgorbayes.effects.registry import (
    EFFECTS,
    changes_wall,
    effect_names,
    effects_table,
    get_effect,
    model_name,
    parse_model_name,
    register_effect,
)
from turgorbayes.inference.context import (
    LikelihoodContext,
    baseline_radius_and_stiffness,
    default_cell_logpdf,
    gaussian_k_logpdf,
    gaussian_R_logpdf,
    walker_column,
)

# isort: split
# registered after every effect above (a new effect goes last)
from turgorbayes.effects import (
    correlated_errors,
    discrepancy,
    drift,
    osmoadaptation,
    own_wall,
    turgor_spread,
)

__all__ = [
    "EFFECTS",
    "Effect",
    "ExtendedModel",
    "Injection",
    "LikelihoodContext",
    "SqrtCoordinate",
    "bad_curves",
    "calibration",
    "changes_wall",
    "correlated_errors",
    "discrepancy",
    "drift",
    "baseline_radius_and_stiffness",
    "default_cell_logpdf",
    "effect_names",
    "effects_table",
    "heavy_tails",
    "gaussian_R_logpdf",
    "gaussian_k_logpdf",
    "get_effect",
    "model_name",
    "outer_membrane",
    "outliers",
    "osmoadaptation",
    "own_wall",
    "parse_model_name",
    "pressure_error",
    "radius_spread",
    "register_effect",
    "tip_radius",
    "turgor_spread",
    "walker_column",
    "wall_softening",
    "wall_thickness",
]
