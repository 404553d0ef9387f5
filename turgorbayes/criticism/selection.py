r"""The selection rule: which extension of the baseline, if any, the data support.

An extension is adopted when its LOO gain over the baseline exceeds :data:`DELTA_ELPD_MIN`
nats and is positive with Bayesian-bootstrap probability at least :data:`P_GAIN_MIN`
(:func:`select`); the reasoning behind the thresholds is in ``docs/effects.md``.
"""

import numpy as np

__all__ = ["DELTA_ELPD_MIN", "DELTA_ELPD_WEAK", "P_GAIN_MIN", "cause_parts", "cause_sentence",
           "left_out_note", "select"]

#: Selection rule: the gain must exceed this many nats ...
DELTA_ELPD_MIN = 4.0
#: ... and be positive with at least this Bayesian-bootstrap probability (2 se if normal).
P_GAIN_MIN = 0.975
#: An unselected best extension gaining more than this is named as weak evidence in the cause
#: (not adopted): an outer membrane at its realistic size typically gains 2-4 nats only.
DELTA_ELPD_WEAK = 2.0


def select(candidates, delta_min=DELTA_ELPD_MIN, p_min=P_GAIN_MIN):
    """The selection rule: the largest gain, if it is large and clear enough.

    Candidates whose posterior did not converge are ignored (their gain is not known). Of the
    others, the one with the largest ``delta_elpd`` is selected when ``delta_elpd > delta_min``
    **and** ``p_gain >= p_min``; otherwise nothing is.

    Parameters
    ----------
    candidates : sequence of dict
        Each with ``effect``, ``delta_elpd`` [nats], ``p_gain`` and ``converged`` (bool).
    delta_min : float [nats]
    p_min : float

    Returns
    -------
    best : dict or None
        The best converged candidate if it passes the rule, else None.
    runner_up : dict or None
        The second best converged candidate (None if fewer than two).
    """
    for c in candidates:
        if not isinstance(c.get("converged"), (bool, np.bool_)):
            raise ValueError(f"candidate {c.get('effect')!r} needs a boolean 'converged' "
                             f"(whether its posterior converged), got {c.get('converged')!r}")
    ranked = sorted((c for c in candidates if c["converged"]), key=lambda c: -c["delta_elpd"])
    if not ranked:
        return None, None
    best = ranked[0]
    ok = best["delta_elpd"] > delta_min and best["p_gain"] >= p_min
    return (best if ok else None), (ranked[1] if len(ranked) > 1 else None)


def cause_sentence(result):
    """One sentence (or two, for a pair) naming the selected cause, with its fitted size.

    Parameters
    ----------
    result : turgorbayes.workflows.criticize.CriticismResult
        Uses ``selected``, ``candidates``, ``posteriors`` and ``summaries``.

    Returns
    -------
    str
    """
    if not result.selected:
        text = ("No cause found: the baseline model describes these data as well as any of the "
                f"{len(result.candidates)} candidate extensions by the selection rule.")
        best = max((c for c in result.candidates if c["converged"]),
                   key=lambda c: c["delta_elpd"], default=None)
        if best is not None and best["delta_elpd"] > DELTA_ELPD_WEAK:
            text += (f" Weak evidence for {best['effect']} (delta elpd {best['delta_elpd']:.1f} +- "
                     f"{best['delta_se']:.1f}, below the rule): if it is real, the baseline's "
                     "pressure and wall stiffness are biased; more cells would settle it.")
        return text + left_out_note(result.candidates)
    return " ".join(cause_parts(result)) + left_out_note(result.candidates)


def cause_parts(result):
    """Each effect's cause sentence of the selected model, with its fitted size (median)."""
    post = result.posteriors[result.selected]
    summary = result.summaries[result.selected]
    return [e.cause_text(summary) for e in post.model.effects]


def left_out_note(candidates):
    """Sentences naming the candidates left out: those whose fit failed (with the reason) and
    those whose posterior did not converge."""
    failed = [f"{c['effect']} ({c['failed']})" for c in candidates if c.get("failed")]
    names = [c["effect"] for c in candidates if not c["converged"] and not c.get("failed")]
    text = ""
    if failed:
        text += f" Could not be fitted, so not considered: {'; '.join(failed)}."
    if names:
        text += f" Not considered (posterior not converged after the re-runs): {', '.join(names)}."
    return text
