"""Wall thickness as an axis of the k/(PR) surrogate (the thickness face of
:mod:`turgorbayes.surrogate.axes`).

Bending (``E t^3/12``) brings ``t/R`` in beside ``x`` and ``E_par/E_perp``: at fixed ``E t`` the
FE stiffness changes by several percent between t = 3 and 9 nm (``docs/fem.md``, "Wall
thickness").
"""

from turgorbayes.surrogate.axes import (
    THICKNESS,
    CorrectedSurrogate,
    axis_value,
    shipped_correction,
)
from turgorbayes.surrogate.table import load as load_table

__all__ = ["REFERENCE_FILE", "THICKNESS_FILES", "load_at_thickness", "reference_thickness"]

#: Shipped correction tables (package data): thickness [m] -> file name.
THICKNESS_FILES = THICKNESS.files
#: The reference-thickness (6 nm) table on the same mesh as :data:`THICKNESS_FILES`.
REFERENCE_FILE = THICKNESS.reference_file


def reference_thickness(s):
    """Wall thickness [m] of the FE runs behind the surrogate ``s`` (from its provenance)."""
    return axis_value(s, "thickness")


def load_at_thickness(thickness, base=None):
    """The shipped (or given) main table at wall thickness ``thickness`` [m].

    Parameters
    ----------
    thickness : float [m]
        Within the tabulated 3-9 nm; the main table's own thickness returns it unchanged.
    base : Surrogate, optional
        Main table (the shipped one if None).

    Returns
    -------
    Surrogate or CorrectedSurrogate
    """
    base = load_table() if base is None else base
    if abs(thickness / reference_thickness(base) - 1) < 1e-9:
        return base
    return CorrectedSurrogate(base, {"thickness": (shipped_correction("thickness", base),
                                                   thickness)})
