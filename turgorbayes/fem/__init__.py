"""Finite-element indentation of a pressurized orthotropic capsule (docs/fem.md).

Public interface (used by the surrogate builder)::

    from turgorbayes.fem import (CapsuleConfig, IndentationResult, indentation_point,
                                 pressure_for_inflation_number)

Layers inside: ``mesh`` (structured shell meshes on scikit-fem's ``MeshHex2``, ``ElementHex2``
and ``CellBasis``) -> ``material`` (orthotropic true-stress / log-strain law) -> ``assembly``
(vectorized kernels on the basis arrays, sparse pattern) -> ``loads``, ``contact`` ->
``solver`` (Newton, PARDISO) -> ``inflation`` (the law's inflated cylinder, the FE load
steps to P), ``depth_steps`` (the indenter's step control) -> ``indentation`` (the capsule
driver), ``anchors`` (verification problems with closed-form answers). The measured mesh
error of the table's settings is a record of the surrogate package
(:mod:`turgorbayes.surrogate.mesh_convergence`), so that updating it does not change the FE
sources a table's points are fingerprinted by.
"""

from turgorbayes.fem.config import SUPPORTS, TABLE_SETTINGS, CapsuleConfig, table_config
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
