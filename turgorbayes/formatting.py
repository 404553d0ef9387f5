"""Numbers as text, one rule each for reports, figures and the command line: a p-value that is
never a bare 0 or 1 (:func:`format_p_value`), ``mean ± sd`` rounded to the sd
(:func:`format_pm`)."""

import math

import numpy as np

__all__ = ["format_p_value", "format_pm"]


def format_p_value(p, n_rep=None):
    """A p-value as text, never as a bare "0" or "1" (reports, figures, the command line).

    Parameters
    ----------
    p : float or None
        The p-value (None or NaN: not available).
    n_rep : int, optional
        Number of posterior-predictive replicates it was counted from (:func:`turgorbayes.criticism.checks.replicates`).
        A count of none of them (p = 0) only says p < 1/n_rep, and all of them (p = 1) only
        p > 1 - 1/n_rep. None for an analytic p-value (the LOO-PIT uniformity test, a rank
        test), which is printed with three significant digits and as "< 1e-300" when it
        underflows to 0.

    Returns
    -------
    str
        ``"0.0123"``, ``"< 0.0014"`` (p = 0 from 700 replicates), ``"> 0.999"``, ``"n/a"``.
    """
    if p is None or not np.isfinite(p):
        return "n/a"
    if n_rep is None:
        return "< 1e-300" if p <= 0 else f"{p:.3g}"
    resolution = 1.0 / int(n_rep)
    if p < resolution / 2:  # none of the replicates as extreme
        return f"< {resolution:.2g}"
    if p > 1 - resolution / 2:
        return f"> {1 - resolution:.4g}"
    return f"{p:.3g}"


def format_pm(value, sd, digits=2):
    """``value ± sd`` with ``digits`` significant digits of ``sd`` and ``value`` to match.

    The report and the command line print ``mean ± sd`` with two significant digits of the
    sd; figures use the same rule. ``format_pm(0.0250034, 0.000976)`` is
    ``"0.02500 ± 0.00098"``, ``format_pm(467.91, 2.74)`` is ``"467.9 ± 2.7"``.

    Parameters
    ----------
    value, sd : float
    digits : int
        Significant digits of ``sd`` (at least 1).

    Returns
    -------
    str
    """
    if not (np.isfinite(value) and np.isfinite(sd)) or sd <= 0:
        return f"{value:.4g} ± {sd:.2g}"
    decimals = digits - 1 - math.floor(math.log10(sd))
    if decimals <= 0:
        return f"{round(value, decimals):.0f} ± {round(sd, decimals):.0f}"
    return f"{value:.{decimals}f} ± {sd:.{decimals}f}"
