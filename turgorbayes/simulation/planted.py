"""Data of the paper's design with one effect planted at its realistic size, as the criticism's
studies simulate it (docs/validation.md, "When the cause is not in the library" and "Naming
the cause where the data tell it").

Two effects need a design of their own to be seen at that size: ``calibration`` needs
measurement sessions (6), and ``radius_spread``'s realistic size hides in the default radius
errors, so its data carry 8-12 nm ones (docs/effects.md, radius_spread).
"""

from turgorbayes import effects
from turgorbayes.simulation.cells import ErrorModel, simulate_cells

__all__ = ["PLANTED_DESIGNS", "planted_cells"]

#: Per effect, the design it is simulated with (``n_sessions``; ``R_c_err_nm`` as (lo, hi) nm).
PLANTED_DESIGNS = {"calibration": {"n_sessions": 6}, "radius_spread": {"R_c_err_nm": (8.0, 12.0)}}


def planted_cells(name, seed, surrogate, n_bulged=72, n_intact=42):
    """Cells with effect ``name`` at its realistic size (``"null"``: the baseline), drawn with
    that effect's design (:data:`PLANTED_DESIGNS`).

    Returns
    -------
    turgorbayes.cells.table.CellData
    """
    design = PLANTED_DESIGNS.get(name, {})
    inj = [] if name == "null" else [effects.get_effect(name).injection(
        effects.get_effect(name).realistic_size)]
    errors = (ErrorModel(R_c_sd=tuple(1e-9 * e for e in design["R_c_err_nm"]))
              if "R_c_err_nm" in design else ErrorModel())
    return simulate_cells(n_bulged, n_intact, seed=seed, surrogate=surrogate, effects=inj,
                          errors=errors, n_sessions=design.get("n_sessions"))[0]
