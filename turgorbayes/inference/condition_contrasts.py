"""What a fit with several conditions reports: each condition's own quantities
(:func:`condition_entries`, ``summary["conditions"]``), its contrasts against the reference
(:func:`contrasts`, ``summary["contrasts"]``) and a contrast in words
(:func:`contrast_sentence`).
"""

import numpy as np

from turgorbayes.inference.condition_design import FREEABLE
from turgorbayes.physics.parameters import QUANTITIES

__all__ = ["condition_entries", "contrast_sentence", "contrasts", "modulus_variables",
           "variable"]


def _stats(x, fields=("mean", "sd", "q05", "q50", "q95")):
    x = np.asarray(x, float).ravel()
    q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
    out = {"mean": float(np.mean(x)), "sd": float(np.std(x, ddof=1)), "q05": float(q05),
           "q50": float(q50), "q95": float(q95)}
    return {k: out[k] for k in fields}


def variable(result, quantity, c, conditions=None):
    """The posterior variable of ``quantity`` in condition index ``c`` of a fit (the baseline
    name when the fit took the single-condition path)."""
    name = (result.conditions if conditions is None else conditions).variable(quantity, c)
    return name if name in result.draws else quantity


def _draws(result, quantity, c, conditions=None):
    """Draws of ``quantity`` in condition index ``c`` in summary units (kPa, nm ...)."""
    return np.asarray(result.draws[variable(result, quantity, c, conditions)], float) / QUANTITIES[
        quantity].factor


def modulus_variables(result, c):
    """``{"E_perp": variable, "E_par": variable}`` of condition index ``c`` in a fit's draws
    (the moduli at its own turgor; empty where the fit has none, e.g. a single condition's
    E_perp under another name)."""
    names = {m: result.conditions.modulus_variable(m, c) for m in ("E_perp", "E_par")}
    return {m: n for m, n in names.items() if n in result.draws}


def condition_entries(result):
    """``summary["conditions"]``: condition -> {key: {mean, sd, q05, q50, q95}} of each of
    its own quantities (``P_phys_kPa``, ``R0_nm`` and any freed one), then the wall moduli at
    its own turgor (``E_perp_MPa``, ``E_par_MPa``)."""
    cs = result.conditions

    def entry(q, name):  # statistics in SI, then the unit: as summary.json's parameters
        x = np.asarray(result.draws[name], float)
        return {k: v / QUANTITIES[q].factor for k, v in _stats(x).items()}

    # a wall quantity another condition has of its own: the reference's too, to compare
    walls = [q for q in FREEABLE if any(cs.own(q, c) for c in range(len(cs.names)))]

    def quantities(c):
        return cs.quantities(c) + tuple(q for q in walls if c == cs.ref and not cs.own(q, c))

    return {name: {**{QUANTITIES[q].key: entry(q, variable(result, q, c))
                      for q in quantities(c)},
                   **{QUANTITIES[m].key: entry(m, n) for m, n in modulus_variables(result, c).items()}}
            for c, name in enumerate(cs.names)}


def contrasts(result, conditions=None):
    """``summary["contrasts"]``: each condition against the reference, per own quantity.

    Returns
    -------
    list of dict
        ``{"condition", "reference", "quantity", "difference", "ratio", "prob_greater",
        "assumes", "checked_by_data"}``; ``difference`` (condition - reference, summary
        units) and ``ratio`` (condition / reference) with mean, q05, q50, q95 of the joint
        posterior draws; ``prob_greater`` the posterior probability that the condition's
        value is the larger; ``assumes`` what the model assumes of the two walls and
        ``checked_by_data`` whether the data can test it (:meth:`ConditionSet.assumptions`).
        ``conditions`` (a :class:`ConditionSet` of the same data) replaces the fit's: the
        contrasts of the shared-wall draws under that design's assumptions.
    """
    cs = result.conditions if conditions is None else conditions
    fields = ("mean", "q05", "q50", "q95")
    out = []
    for c, name in enumerate(cs.names):
        if c == cs.ref:
            continue
        for q in cs.quantities(c):
            x, ref = _draws(result, q, c, cs), _draws(result, q, cs.ref, cs)
            assumes, checked = cs.assumptions(c)
            out.append({"condition": name, "reference": cs.reference,
                        "quantity": QUANTITIES[q].key, "difference": _stats(x - ref, fields),
                        "ratio": _stats(x / ref, fields),
                        "prob_greater": float(np.mean(x > ref)),
                        "assumes": assumes, "checked_by_data": checked})
    return out


def contrast_sentence(contrast):
    """A contrast in words: ``"P_phys of treated is 6.1 kPa lower than wt [3.9, 8.4],
    probability 0.999"`` (the 90 % interval of the size of the difference, the probability
    of the direction stated)."""
    key = contrast["quantity"]
    if key == QUANTITIES["E0t"].key:  # a stiffness scale: its ratio says it
        r = contrast["ratio"]
        return (f"E0t of {contrast['condition']} is {r['q50']:.3g} times {contrast['reference']}'s "
                f"[{r['q05']:.3g}, {r['q95']:.3g}], probability "
                f"{max(contrast['prob_greater'], 1 - contrast['prob_greater']):.3f} that it is "
                f"{'larger' if contrast['prob_greater'] >= 0.5 else 'smaller'}")
    name, _, unit = key.rpartition("_")
    if name not in ("P_phys", "R0", "E0t", "gamma"):
        name, unit = key, ""
    d = contrast["difference"]
    lower = d["q50"] < 0
    sign = -1 if lower else 1
    lo, hi = sorted((sign * d["q05"], sign * d["q95"]))
    p = 1 - contrast["prob_greater"] if lower else contrast["prob_greater"]
    unit = {"kPa": " kPa", "nm": " nm", "N_per_m": " N/m", "": ""}.get(unit, " " + unit)
    return (f"{name} of {contrast['condition']} is {abs(d['q50']):.3g}{unit} "
            f"{'lower' if lower else 'higher'} than {contrast['reference']} "
            f"[{lo:.3g}, {hi:.3g}], probability {p:.3f}")
