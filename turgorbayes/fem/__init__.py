"""Finite-element indentation of a pressurized orthotropic capsule (docs/fem.md).

Public interface (used by the surrogate builder)::

    from turgorbayes.fem import (CapsuleConfig, IndentationResult, indentation_point,
                                 pressure_for_inflation_number)

Layers inside: ``mesh`` (structured shell meshes on scikit-fem's ``MeshHex2``, ``ElementHex2``
and ``CellBasis``) -> ``material`` (orthotropic true-stress / log-strain law) -> ``assembly``
(vectorized kernels on the basis arrays, sparse pattern) -> ``loads``, ``contact`` ->
``solver`` (Newton, PARDISO) -> ``indentation`` (the capsule driver), ``anchors``
(verification problems with closed-form answers) and ``convergence`` (the measured mesh
error, :data:`MESH_CONVERGENCE`).
"""

from turgorbayes.fem.config import SUPPORTS, TABLE_SETTINGS, CapsuleConfig, table_config
from turgorbayes.fem.convergence import MESH_CONVERGENCE
from turgorbayes.fem.errors import FEConfigError, FEConvergenceError
from turgorbayes.fem.indentation import (
    IndentationResult,
    fe_inflated_radius,
    force_falls,
    indentation_point,
    inflated_radius,
    pressure_for_inflation_number,
)

__all__ = [
    "MESH_CONVERGENCE",
    "SUPPORTS",
    "TABLE_SETTINGS",
    "CapsuleConfig",
    "FEConfigError",
    "FEConvergenceError",
    "IndentationResult",
    "fe_inflated_radius",
    "force_falls",
    "indentation_point",
    "inflated_radius",
    "pressure_for_inflation_number",
    "table_config",
]
