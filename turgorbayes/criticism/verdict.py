r"""The verdict of a criticism: does the adopted model explain the misfit, and in what words.

:func:`verdict` reads the selection, the predictive checks of the baseline and of the adopted
model, and the generic ``discrepancy`` candidate, and returns one of :data:`STATUSES` with a
paragraph that never contradicts the checks (docs/effects.md, "The verdict").
"""

import numpy as np

from turgorbayes.criticism.conditions import conditions_verdict
from turgorbayes.criticism.evidence import LOG_BF_MIN
from turgorbayes.criticism.loo import compare
from turgorbayes.criticism.selection import (
    DELTA_ELPD_MIN,
    P_GAIN_MIN,
    cause_parts,
    cause_sentence,
    left_out_note,
)
from turgorbayes.effects.registry import effect_names, get_effect, parse_model_name

__all__ = ["HEADLINE", "STATUSES", "credit_sentence", "family_note", "family_sentence", "flagged_names",
           "generic_comparison", "gross_error_verdict", "names_cause", "verdict"]

#: The four verdicts, from no misfit to misfit no candidate explains.
STATUSES = ("no_misfit", "explained", "partly_explained", "unexplained")
#: The posterior quoted first, per status (docs/validation.md, "When the cause is not in the
#: library": the model average keeps P_phys's coverage whether or not the cause is named).
HEADLINE = dict.fromkeys(STATUSES, "model_average")


def flagged_names(checks):
    """Names of the flagged checks in a list of check dicts."""
    return [c["name"] for c in checks if c["flagged"]]


def gross_error_verdict(verdict):
    """True when the verdict names readings that are gross errors as the explained cause
    (an effect with ``gross_errors``): only then are flagged readings called gross errors."""
    return (verdict is not None and verdict["status"] == "explained"
            and any(get_effect(n).gross_errors for n in parse_model_name(verdict["selected"])))


def names_cause(model):
    """True when every effect of a model name is a named physical or statistical cause."""
    return all(get_effect(n).names_cause for n in parse_model_name(model))


def verdict(result, generic=None):
    """The verdict of a :class:`~turgorbayes.workflows.criticize.CriticismResult` (docs/effects.md,
    "The verdict").

    A named effect is *identified* when it beats the generic description of misfit
    (``discrepancy``) by the selection rule: otherwise the data show extra scatter that it
    describes no better than a model that names no cause, and the effect is worded as a
    description.

    Parameters
    ----------
    result : CriticismResult
        Uses ``selected``, ``checks``, ``loo``, ``summaries``, ``candidates``, ``posteriors``.
    generic : dict or None
        The best converged generic candidate (``names_cause`` False; the best unconverged one,
        with ``converged`` False, when none converged: a named effect is then not identified)
        with ``passes`` (it passes the selection rule against the baseline) and, when an
        effect was selected,
        ``selected_identified`` (the selected model beats it by the rule) and ``vs_selected``
        (its gain over the selected model: ``delta_elpd``, ``se``, ``p_gain``); None when there
        is none.

    Returns
    -------
    dict
        ``{"status", "selected", "remaining_checks", "text", "conditions"}``; with several
        conditions ``conditions`` is :func:`turgorbayes.criticism.conditions.conditions_verdict`
        (whether ``conditions_R_c_k_c`` ran, the contrasts, the advice) and its paragraph ends
        ``text``; None otherwise.
    """
    out = _status_and_text(result, generic)
    if out["status"] in ("partly_explained", "unexplained"):  # cause_sentence has it otherwise
        out["text"] += left_out_note(result.candidates)
    out["conditions"] = conditions_verdict(result)
    if out["conditions"] is not None:
        out["text"] += " " + out["conditions"]["text"]
    return out


def _status_and_text(result, generic):
    """:func:`verdict` without the conditions."""
    base_flags = flagged_names(result.checks["baseline"])
    selected = result.selected
    passes = generic is not None and generic.get("passes", False)
    if selected is None:
        if not base_flags and not passes:
            return _entry("no_misfit", None, [], cause_sentence(result))
        return _entry("unexplained", None, base_flags,
                      _unexplained_text(result, base_flags, generic if passes else None))
    remaining = flagged_names(result.checks[selected])
    identified = generic is None or bool(generic.get("selected_identified", False))
    if not remaining and identified:
        return _entry("explained", selected, [],
                      cause_sentence(result) + credit_sentence(selected, generic)
                      + family_sentence(selected) + family_note(result))
    return _entry("partly_explained", selected, remaining,
                  _partly_text(result, remaining, None if identified else generic))


def _entry(status, selected, remaining, text):
    return {"status": status, "selected": selected, "remaining_checks": list(remaining),
            "text": text}


def _unexplained_text(result, flags, generic):
    text = "Misfit that no effect in the library explains: "
    if flags:
        text += f"the baseline fails {_checks_phrase(flags)}"
    if generic is not None:
        text += ("; " if flags else "") + _generic_phrase(result, generic)
    best = _best_named(result)
    text += (". No candidate passes the selection rule, so no cause is named"
             + (f" (the closest, {best['effect']}, gains {best['delta_elpd']:.1f} +- "
                f"{best['delta_se']:.1f} nats)" if best else "")
             + ". The cause may lie outside the library; more cells of the same kind would not "
               "by themselves settle it. Quote the model average, which includes a model of "
               "extra scatter.")
    return text


def _partly_text(result, remaining, generic):
    parts = [p.rstrip(".") for p in cause_parts(result)]
    text = ("The data behave as if: " + "; ".join(p[0].lower() + p[1:] for p in parts)
            + f" ({result.selected} passes the selection rule), but ")
    if remaining:
        text += (f"this does not explain everything: under it {_checks_phrase(remaining)} "
                 f"{'is' if len(remaining) == 1 else 'are'} still flagged")
    if generic is not None and not generic.get("converged", True):
        text += (("; and " if remaining else "")
                 + f"the description that names no cause ({generic['effect']}) did not "
                   "converge, so whether the data show more than extra scatter is not known")
    elif generic is not None:
        text += (("; and " if remaining else "") + generic_comparison(generic["vs_selected"])
                 + "; " + _generic_phrase(result, generic) + "), so the data show that much "
                   "extra scatter, not which cause")
    family = family_sentence(result.selected).strip()
    return text + (". " + (family + " " if family else "")
                   + "The cause may lie outside the library: read the named effect as a "
                     "description, not a finding, and quote the model average.")


def generic_comparison(d):
    """How the generic description compares with the named effect, in words that match the
    numbers (``d``: the generic description's gain over the named effect, ``delta_elpd``,
    ``se``, ``p_gain``): "better" when it wins by the selection rule, "at least as well" when
    it gains within the rule's margin, "nearly as well" when the named effect gains, short of
    the rule. Ends inside an open parenthesis (the caller closes it)."""
    start = "a model of extra scatter that names no cause describes the data "
    gain, se = d["delta_elpd"], d["se"]
    if gain > DELTA_ELPD_MIN and d["p_gain"] >= P_GAIN_MIN:
        return (start + f"better than the named effect (it gains {gain:.1f} +- {se:.1f} nats "
                "over it, beyond the rule")
    if gain > 0:
        return (start + f"at least as well (it gains {gain:.1f} +- {se:.1f} nats over the named "
                "effect, within the rule's margin")
    return (start + f"nearly as well (the named effect gains {-gain:.1f} +- {se:.1f} nats over "
            "it, short of the rule")


def credit_sentence(selected, generic):
    """Why a named effect that a description naming no cause fits about as well is credited
    (``identified_by`` ``"bayes_factor"``, :mod:`turgorbayes.criticism.evidence`); empty
    otherwise. Starts with a space."""
    if generic is None or generic.get("identified_by") != "bayes_factor":
        return ""
    bf = generic["vs_selected"]["bayes_factor"]
    words = generic_comparison(generic["vs_selected"])
    return (" " + words[0].upper() + words[1:]
            + f"), but {selected} predicted the pattern that description has to fit: the "
              f"marginal likelihood favours it by a factor of {np.exp(bf['log_bf']):.0f} "
              f"(ln {bf['log_bf']:.1f}; a cause needs {np.exp(LOG_BF_MIN):.0f}: the description "
              "pays for the scatters it fitted, docs/statistics.md).")


def _checks_phrase(names):
    """``the check a`` or ``the checks a, b``."""
    return ("the check " if len(names) == 1 else "the checks ") + ", ".join(names)


def _generic_phrase(result, generic):
    what = get_effect(generic["effect"]).describe(result.summaries[generic["effect"]])
    return f"the data are described by {what}" if what else f"{generic['effect']} describes them"


def _best_named(result):
    named = [c for c in result.candidates if c["converged"] and names_cause(c["effect"])]
    return max(named, key=lambda c: c["delta_elpd"], default=None)


def family_sentence(model):
    """A sentence naming the families of a model's effects (effects that describe the same
    data near-equally, :attr:`turgorbayes.effects.base.Effect.family`); empty if none."""
    out = []
    for name in parse_model_name(model):
        fam = get_effect(name).family
        if fam:
            members = [n for n in effect_names() if get_effect(n).family == fam]
            out.append(f" {', '.join(members)} are near-equivalent descriptions of such data "
                       f"({fam}): the data do not tell them apart.")
    return "".join(out)


def family_note(result, seed=None):
    """A sentence naming a runner-up that describes the data about as well as the selected
    effect (a near-equivalent description: their gains differ by less than the rule's margin);
    empty when there is none."""
    sel = result.selected
    others = [c for c in result.candidates if c["converged"] and c["effect"] != sel
              and names_cause(c["effect"]) and "+" not in c["effect"]]
    notes = []
    for c in sorted(others, key=lambda c: -c["delta_elpd"])[:2]:
        d, se, p = compare(result.loo[sel], result.loo[c["effect"]],
                           result.seed if seed is None else seed)
        if not (d > DELTA_ELPD_MIN and p >= P_GAIN_MIN):
            notes.append(f"{c['effect']} ({d:.1f} +- {se:.1f} nats behind)")
    if not notes:
        return ""
    return (" Near-equivalent descriptions of the same data, not distinguished by the rule: "
            + ", ".join(notes) + ".")
