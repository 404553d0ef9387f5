"""The model's named quantities: one table of names, units and labels, and the paper's values.

Every output (``summary.json``, ``report.md``, the HTML report, the figures) reads names,
units and labels from :data:`QUANTITIES`; every default reference pressure is :data:`P0`;
every comparison with the paper uses :data:`PUBLISHED` and :data:`PUBLISHED_SD` (Deng, Sun &
Shaevitz, PRL 107, 158101 (2011), table 1; ``docs/physics.md``). Priors belong to the
statistical model (:mod:`turgorbayes.inference.priors`).
"""

from dataclasses import dataclass

__all__ = [
    "BASELINE",
    "DERIVED",
    "P0",
    "PUBLISHED",
    "PUBLISHED_SD",
    "QUANTITIES",
    "SUMMARY_PARAMETERS",
    "Quantity",
    "quantity",
]

#: Reference pressure of the wall law [Pa]: ``E0t`` and ``R0`` are the wall's values at P0.
P0 = 5e3


@dataclass(frozen=True)
class Quantity:
    """A named quantity of the model.

    Attributes
    ----------
    name : str
        Name in code and in ``posterior.nc`` (SI units).
    key : str
        Name in ``summary.json`` and the reports, with its display unit (``R0_nm``).
    unit : str
        Display unit (``""`` for dimensionless).
    factor : float
        SI value per display unit (1e-9 for nm, 1e3 for kPa).
    tex : str
        Axis label with unit, in matplotlib's TeX (``$R_0$ [nm]``).
    plain : str
        Plain-text label with unit (``R0 [nm]``).
    description : str
        What it is, in words (``R0 at 5 kPa``).
    ascii : str
        The same in ASCII, as ``report.md`` writes it.
    """

    name: str
    key: str
    unit: str
    factor: float
    tex: str
    plain: str
    description: str
    ascii: str = ""

    def to_display(self, value):
        """SI value(s) -> display unit."""
        return value / self.factor

    def from_display(self, value):
        """Display-unit value(s) -> SI."""
        return value * self.factor


#: Name -> :class:`Quantity`: the baseline's global parameters, then derived moduli.
QUANTITIES = {q.name: q for q in (
    Quantity("gamma", "gamma", "", 1.0, r"$\gamma$", "gamma", "stiffening exponent γ",
             "stiffening exponent gamma"),
    Quantity("E0t", "E0t_N_per_m", "N/m", 1.0, r"$E_0t$ [N/m]", "E0t [N m⁻¹]",
             "E0t at 5 kPa [N/m]", "E0 t at 5 kPa [N/m]"),
    Quantity("R0", "R0_nm", "nm", 1e-9, r"$R_0$ [nm]", "R0 [nm]", "R0 at 5 kPa [nm]",
             "R0 at 5 kPa [nm]"),
    Quantity("P_phys", "P_phys_kPa", "kPa", 1e3, r"$P_\mathrm{phys}$ [kPa]", "P_phys [kPa]",
             "physiological turgor P [kPa]", "physiological turgor [kPa]"),
    Quantity("E_perp", "E_perp_MPa", "MPa", 1e6, r"$E_\perp$ [MPa]", "E_perp [MPa]",
             "E⊥ at P [MPa] (t = 4.5 ± 1.5 nm)", "E_perp at P_phys [MPa] (t = 4.5 +- 1.5 nm)"),
    Quantity("E_par", "E_par_MPa", "MPa", 1e6, r"$E_\parallel$ [MPa]", "E_par [MPa]",
             "E∥ at P [MPa] (t = 4.5 ± 1.5 nm)", "E_par at P_phys [MPa] (t = 4.5 +- 1.5 nm)"),
)}
#: Posterior variable -> (its key in ``summary.json``, SI per display unit); what a fit's and a
#: stacked posterior's summaries report (:mod:`turgorbayes.workflows.fit`,
#: :mod:`turgorbayes.criticism.stacking`).
SUMMARY_PARAMETERS = {n: (q.key, q.factor) for n, q in QUANTITIES.items()}
#: The baseline model's sampled parameters, in order.
BASELINE = ("gamma", "E0t", "R0", "P_phys")
#: Quantities derived from the parameters and a drawn wall thickness.
DERIVED = ("E_perp", "E_par")

#: The paper's published values (SI): the wall law's parameters and the physiological turgor.
PUBLISHED = {"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3,
             "E_perp": 49e6, "E_par": 23e6}
#: Their published uncertainties (SI).
PUBLISHED_SD = {"gamma": 0.12, "E0t": 0.001, "R0": 0.9e-9, "P_phys": 3e3,
                "E_perp": 20e6, "E_par": 8e6}


def quantity(name):
    """The :class:`Quantity` called ``name`` (code name or summary key)."""
    if name in QUANTITIES:
        return QUANTITIES[name]
    for q in QUANTITIES.values():
        if q.key == name:
            return q
    raise KeyError(f"unknown quantity {name!r}; known: {', '.join(QUANTITIES)}")
