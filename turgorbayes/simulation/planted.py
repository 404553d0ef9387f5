"""Data of the paper's design with one effect planted at its realistic size, as the criticism's
studies simulate it (docs/validation.md, "When the cause is not in the library" and "Naming
the cause where the data tell it").

An effect that needs a design of its own to be seen at that size declares it
(:attr:`turgorbayes.effects.base.Effect.realistic_design`): e.g. a calibration error needs
measurement sessions, and a spread of radii hides in the default radius errors, so its data
carry smaller ones (docs/effects.md).
"""

from turgorbayes import effects
from turgorbayes.simulation.cells import ErrorModel, simulate_cells

__all__ = ["planted_cells"]


def planted_cells(name, seed, surrogate, n_bulged=72, n_intact=42):
    """Cells with effect ``name`` at its realistic size (``"null"``: the baseline), drawn with
    that effect's design (its ``realistic_design``).

    Returns
    -------
    turgorbayes.cells.table.CellData
    """
    effect = None if name == "null" else effects.get_effect(name)
    design = {} if effect is None else effect.realistic_design
    inj = [] if effect is None else [effect.injection(effect.realistic_size)]
    errors = (ErrorModel(R_c_sd=tuple(1e-9 * e for e in design["R_c_err_nm"]))
              if "R_c_err_nm" in design else ErrorModel())
    return simulate_cells(n_bulged, n_intact, seed=seed, surrogate=surrogate, effects=inj,
                          errors=errors, n_sessions=design.get("n_sessions"))[0]
