"""Sentences and number formats shared by the reports (``report.md`` of ``fit`` and
``criticize``, ``report.html``): the two wall thicknesses, Monte Carlo error (p-values:
:func:`turgorbayes.formatting.format_p_value`)."""

import math

from turgorbayes.inference.models import THICKNESS_MEDIAN, THICKNESS_SD

__all__ = ["monte_carlo_note", "table_thickness_nm", "thickness_note"]

#: Monte Carlo standard error of a posterior median and of a 5 % or 95 % quantile, in units
#: of sd/sqrt(ESS), for a Gaussian posterior: sqrt(pi/2) and sqrt(q(1-q))/phi(z_q) at q = 0.05.
MCSE_MEDIAN = math.sqrt(math.pi / 2)
MCSE_Q05 = math.sqrt(0.05 * 0.95) / (math.exp(-0.5 * 1.6448536269514722**2)
                                     / math.sqrt(2 * math.pi))

#: k/(PR) of a 4.5 nm wall relative to the 6 nm table at the physiological point
#: (docs/fem.md, "Wall thickness"; correction tables in turgorbayes/data/k_over_PR_t*nm.nc).
_K_CHANGE_AT_4P5_NM = "2.1 %"


def table_thickness_nm(surrogate):
    """Wall thickness [nm] of the FE stiffness table ``surrogate`` (None if not recorded)."""
    metadata = getattr(surrogate, "metadata", None) or {}
    t = metadata.get("thickness_m")  # a table at another thickness (fit --wall-thickness-nm)
    if t is None:
        config = metadata.get("fe_config")
        t = config.get("thickness") if isinstance(config, dict) else None
    return None if t is None else float(t) * 1e9


def thickness_note(fe_thickness_nm=None):
    """One sentence: which wall thickness the moduli use, which the FE table, and why.

    Parameters
    ----------
    fe_thickness_nm : float, optional
        Thickness of the FE table the fit used (:func:`table_thickness_nm`); None when
        unknown (then the shipped table's 6 nm is named, with the option that changes it).
    """
    t_med, t_sd = THICKNESS_MEDIAN * 1e9, THICKNESS_SD * 1e9
    moduli = (f"E_perp and E_par are the fitted E_perp t divided by t = {t_med:g} +- {t_sd:g} nm "
              "(lognormal, the thickness the paper assumed for its moduli, so its uncertainty "
              "is in their intervals)")
    if fe_thickness_nm is not None and abs(fe_thickness_nm - t_med) < 0.01:
        return (f"One wall thickness: {moduli}, and the FE stiffness table was computed for the "
                f"same {t_med:g} nm wall (`fit --wall-thickness-nm`; docs/outputs.md).")
    fe = ("6 nm wall (unless `fit --wall-thickness-nm` was given)" if fe_thickness_nm is None
          else f"{fe_thickness_nm:g} nm wall")
    return (f"Two wall thicknesses, two purposes: {moduli}, while the FE stiffness table was "
            f"computed for a {fe}, which reaches gamma, E0t, R0 and P_phys only through a small "
            f"bending correction (at the physiological point a 4.5 nm wall has a "
            f"{_K_CHANGE_AT_4P5_NM} lower k/(PR) than a 6 nm one: `fit --wall-thickness-nm 4.5`; "
            "docs/outputs.md).")


def monte_carlo_note(baseline, engine, key="gamma"):
    """One sentence: why the criticism's baseline differs slightly from ``fit``'s, and which to quote.

    Parameters
    ----------
    baseline : dict
        The criticism's baseline summary (``summary.json`` layout: per key ``sd`` and
        ``ess_bulk``).
    engine : str
        Engine of the criticism's baseline posterior (``importance`` or ``emcee``).
    key : str
        The quantity whose Monte Carlo error is quoted as the example.
    """
    entry = baseline[key]
    ess, sd = entry.get("ess_bulk"), entry["sd"]
    if not ess or not math.isfinite(ess) or ess <= 0:
        size = "by its Monte Carlo error"
    else:
        unit = sd / math.sqrt(ess)
        size = (f"by Monte Carlo error: with {ess:.0f} effective draws a median is uncertain by "
                f"about {MCSE_MEDIAN:.3g} sd/sqrt(ESS) ({key}: +-{MCSE_MEDIAN * unit:.2g}) and a "
                f"90 % bound by about {MCSE_Q05:.3g} sd/sqrt(ESS) (+-{MCSE_Q05 * unit:.2g})")
    return (f"The baseline here is the model `turgorbayes fit` samples, but drawn independently "
            f"(engine {engine}, medians), so its numbers differ from the fit's `summary.json` "
            f"{size}; quote the fit's for the baseline (emcee to 50 autocorrelation times, "
            "R-hat checked) and these to compare models within the criticism.")
