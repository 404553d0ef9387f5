"""What a criticism of several conditions says about them: whether ``conditions_R_c_k_c`` ran,
what the fit assumes, the contrasts of the adopted model and of the model average, and what
to run next (docs/effects.md, "Several conditions").
"""

import numpy as np

from turgorbayes.criticism.checks import CONDITIONS_MIN_BULGED
from turgorbayes.inference.conditions import FREEABLE, contrast_sentence
from turgorbayes.inference.engine import stream_rng, weighted_quantiles
from turgorbayes.physics.parameters import QUANTITIES

__all__ = ["CHECK", "check_status", "condition_draws", "conditions_verdict", "own_quantities",
           "weighted_contrasts"]

#: The check that compares the conditions' bulged cells (turgorbayes.criticism.checks).
CHECK = "conditions_R_c_k_c"


def check_status(names, counts, checks):
    """Whether :data:`CHECK` ran on a baseline's ``checks``, and why not.

    Parameters
    ----------
    names : sequence of str
        The conditions, in file order.
    counts : dict
        Condition -> its number of bulged cells.
    checks : list of dict
        The baseline's checks (``name``, ``flagged``).

    Returns
    -------
    dict
        ``{"name", "ran", "flagged", "compared", "lacking", "reason"}``: ``compared`` the
        conditions with at least :data:`~turgorbayes.criticism.checks.CONDITIONS_MIN_BULGED`
        bulged cells, ``lacking`` the others, ``flagged`` None when it did not run, ``reason``
        (why not) None when it ran.
    """
    compared = [n for n in names if counts.get(n, 0) >= CONDITIONS_MIN_BULGED]
    lacking = [n for n in names if n not in compared]
    entry = next((c for c in checks if c["name"] == CHECK), None)
    reason = None
    if entry is None and lacking:
        few = [f"{n} has {_cells(counts.get(n, 0))}" for n in lacking]
        reason = (f"it needs bulged cells in two conditions (at least {CONDITIONS_MIN_BULGED} "
                  f"each) and {_and(few)}")
    elif entry is None:
        reason = "the predictive checks did not include it"
    return {"name": CHECK, "ran": entry is not None,
            "flagged": None if entry is None else bool(entry["flagged"]),
            "compared": compared, "lacking": lacking, "reason": reason}


def _cells(n):
    return "no bulged cells" if n == 0 else f"{n} bulged cell{'s' if n != 1 else ''}"


def _and(items):
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def own_quantities(model):
    """The quantities (``P_phys``, ``gamma``, ``E0t``) that differ between the conditions of
    ``model`` (a :class:`~turgorbayes.effects.conditions.ConditionsExtendedModel`): each
    condition's own, freed or given by an effect's wall ratio."""
    cs = model.conditions
    return {q for q in ("P_phys",) + FREEABLE
            if any(model.variable(q, c) != model.variable(q, cs.ref)
                   for c in range(len(cs.names)))}


def condition_draws(post, rng, quantities):
    """A posterior's draws of each condition's ``quantities``, named alike for every model:
    ``{(quantity, condition index): (S,) SI}`` (a shared quantity repeats the shared draws).

    Parameters
    ----------
    post : turgorbayes.inference.engine.Posterior
        Of a :class:`~turgorbayes.effects.conditions.ConditionsExtendedModel`, whose
        :meth:`~turgorbayes.effects.conditions.ConditionsExtendedModel.variable` names them.
    rng : numpy.random.Generator
    quantities : iterable of str
    """
    model, phys = post.model, post.physical(rng)
    return {(q, c): np.asarray(phys[model.variable(q, c)], float)
            for q in quantities for c in range(len(model.conditions.names))}


def weighted_contrasts(draws, weights, cs, own):
    """Each condition's own quantities and its contrasts with the reference, from weighted
    posterior draws (importance weights, or a model average's).

    Parameters
    ----------
    draws : dict
        ``(quantity, condition index) -> (S,)`` physical values (SI) of the quantities
        ``own`` (:func:`condition_draws`).
    weights : array_like (S,)
        Non-negative weights of the draws.
    cs : turgorbayes.inference.conditions.ConditionSet
        The conditions (names, reference).
    own : set of str
        The quantities to report (those of a condition's own in at least one model,
        :func:`own_quantities`).

    Returns
    -------
    values : dict
        Condition -> ``{key: {"q05", "q50", "q95"}}`` of ``P_phys`` and any wall quantity of
        its own (summary units, e.g. kPa).
    contrasts : list of dict
        As :func:`turgorbayes.inference.conditions.contrasts`: ``condition``, ``reference``,
        ``quantity``, ``difference`` (condition - reference: mean, q05, q50, q95 of the joint
        weighted draws), ``ratio`` (condition / reference, the same statistics),
        ``prob_greater`` (the weighted posterior probability that the
        condition's value is the larger), and ``sentence``
        (:func:`~turgorbayes.inference.conditions.contrast_sentence`).
    """
    w = np.asarray(weights, float)
    w = w / np.sum(w)

    def x(q, c):
        return draws[q, c] / QUANTITIES[q].factor

    def stats(a):
        q = weighted_quantiles(a, w, [0.05, 0.5, 0.95])
        return {"mean": float(np.sum(w * a)), "q05": float(q[0]), "q50": float(q[1]),
                "q95": float(q[2])}

    own = [q for q in ("P_phys",) + FREEABLE if q in own]
    values, contrasts = {}, []
    for c, name in enumerate(cs.names):
        values[name] = {QUANTITIES[q].key: {k: v for k, v in stats(x(q, c)).items()
                                            if k != "mean"} for q in own}
        if c == cs.ref:
            continue
        for q in own:
            d = x(q, c) - x(q, cs.ref)
            if not np.any(d):  # shared in every model: no contrast
                continue
            entry = {"condition": name, "reference": cs.reference,
                     "quantity": QUANTITIES[q].key, "difference": stats(d),
                     "ratio": stats(x(q, c) / x(q, cs.ref)),
                     "prob_greater": float(np.sum(w * (d > 0)))}
            entry["sentence"] = _sentence(entry, q)
            contrasts.append(entry)
    return values, contrasts


def _sentence(entry, q):
    """:func:`~turgorbayes.inference.conditions.contrast_sentence`, the unit spelled out, and
    for a wall quantity the ratio too (a wall "30 % softer" reads as a ratio)."""
    unit = QUANTITIES[q].unit
    text = contrast_sentence(dict(entry, quantity=f"{q}_{unit}" if unit else q))
    if q in FREEABLE:
        r = entry["ratio"]
        text += f"; ratio {r['q50']:.3g} [{r['q05']:.3g}, {r['q95']:.3g}]"
    return text


def _average_draws(posteriors, weights, rng):
    """The model average's draws (every model with a positive stacking weight, each
    condition's quantities named alike: :func:`condition_draws`) of the quantities of a
    condition's own in any of them, their weights (each model's importance weights times its
    stacking weight) and those quantities."""
    used = [(posteriors[name], weight) for name, weight in weights.items() if weight > 0]
    own = set().union(*(own_quantities(post.model) for post, _ in used))
    draws = [condition_draws(post, rng, own) for post, _ in used]
    w = [weight * np.asarray(post.weights, float) / np.sum(post.weights) for post, weight in used]
    return ({k: np.concatenate([d[k] for d in draws]) for k in draws[0]}, np.concatenate(w),
            own)


def conditions_verdict(result):
    """The verdict's ``conditions`` entry of a criticism, or None for one condition.

    Parameters
    ----------
    result : turgorbayes.workflows.criticize.CriticismResult
        Uses ``posteriors``, ``checks``, ``selected``, ``stacking``, ``seed``.

    Returns
    -------
    dict or None
        ``names``, ``reference``, ``bulged`` (condition -> bulged cells), ``freed`` (wall
        quantity -> its conditions of their own by ``--per-condition``), ``adopted_walls``
        (the same, given by an effect of the adopted model: own_wall), ``check`` (:func:`check_status`),
        ``contrasts`` and ``values`` (``{"adopted": ..., "model_average": ...}``, by
        :func:`weighted_contrasts`; ``model_average`` None without stacking), ``adopted``
        (the adopted model's name), ``suggestion`` (the command to run next, or None) and
        ``text`` (a paragraph: what the check did, what the fit assumes, what to do).
    """
    base = result.posteriors.get("baseline")  # (a verdict may be read without posteriors)
    if base is None or base.model.conditions is None or len(base.model.conditions.names) < 2:
        return None
    model = base.model
    cs = model.conditions
    counts = {n: int(np.sum(model.obs.is_bulged[cs.index == c])) for c, n in enumerate(cs.names)}
    check = check_status(cs.names, counts, result.checks["baseline"])
    adopted = result.selected or "baseline"
    post = result.posteriors[adopted]
    rng = stream_rng(result.seed, 13)
    values, contrasts = {}, {}
    own = own_quantities(post.model)
    draws = condition_draws(post, rng, own)
    values["adopted"], contrasts["adopted"] = weighted_contrasts(draws, post.weights, cs, own)
    stacked = (result.stacking or {}).get("weights")
    values["model_average"] = contrasts["model_average"] = None
    if stacked:
        draws, w, own = _average_draws(result.posteriors, stacked, rng)
        values["model_average"], contrasts["model_average"] = weighted_contrasts(draws, w, cs,
                                                                                 own)
    freed = {q: list(n) for q, n in cs.freed.items()}
    walls = _effect_walls(post.model, freed)
    suggestion = None if walls else _suggestion(check, freed, cs)
    entry = {"names": list(cs.names), "reference": cs.reference, "bulged": counts,
             "freed": freed, "check": check, "adopted": adopted, "adopted_walls": walls,
             "contrasts": contrasts, "values": values, "suggestion": suggestion}
    entry["text"] = _text(entry)
    return entry


def _effect_walls(model, freed):
    """``{quantity: [condition, ...]}``: the wall quantities of a condition's own in the
    adopted ``model`` that an effect gives it (own_wall), beyond those ``freed``."""
    cs = model.conditions
    out = {}
    for q in FREEABLE:
        names = [n for c, n in enumerate(cs.names) if c != cs.ref
                 and model.variable(q, c) != model.variable(q, cs.ref)
                 and n not in freed.get(q, ())]
        if names:
            out[q] = names
    return out


def _suggestion(check, freed, cs):
    """``--per-condition E0t`` (every condition has bulged cells) or ``E0t:NAME`` for each
    other condition with them, when the check flags the shared wall and nothing is freed."""
    if not check["flagged"] or freed:
        return None
    if not check["lacking"]:
        return "--per-condition E0t"
    return " ".join(f"--per-condition E0t:{n}" for n in check["compared"] if n != cs.reference)


def _text(entry):
    """The paragraph of the ``conditions`` entry (module docstring)."""
    check, freed, ref = entry["check"], entry["freed"], entry["reference"]
    others = [n for n in entry["names"] if n != ref]
    shared = [q for q in FREEABLE if q not in freed]
    wall = " and ".join(shared) if shared else ""
    own = "; ".join(f"{q} of {_and(n)} {'is its' if len(n) == 1 else 'are their'} own "
                    "(--per-condition)" for q, n in freed.items())
    if not check["ran"]:
        text = (f"With several conditions ({_and(entry['names'])}) the check {CHECK} did not "
                f"run: {check['reason']}. The fit therefore assumes, untested, that the wall "
                f"({wall}) is the same in every condition: a treatment that changes the wall "
                f"would be read as a change of turgor (P_phys of {_and(others)}).")
        if check["lacking"]:
            text += (f" Bulged cells (at least {CONDITIONS_MIN_BULGED}) in "
                     f"{_and(check['lacking'])} as well would let the check run and let "
                     "`--per-condition E0t` free its wall; an osmotic series of the same cells "
                     "would also separate wall and turgor, which turgorbayes does not model "
                     "yet.")
    elif check["flagged"]:
        text = (f"The check {CHECK} flags the baseline: the bulged cells of "
                f"{_and(check['compared'])} sit off the {'shared ' if wall else ''}wall in ways "
                f"of their own, so the wall differs between conditions")
        if entry["suggestion"]:
            text += (f", and the P_phys contrast below, which assumes a shared wall, may be a "
                     f"wall change read as a turgor change. Free the wall of the conditions "
                     f"with bulged cells ({_and(check['compared'])}): `turgorbayes criticize "
                     f"DATA {entry['suggestion']}` (and `turgorbayes fit DATA "
                     f"{entry['suggestion']}`), then read the contrasts.")
        elif freed:
            text += (f" even with {own}: the wall may differ in more than that (free gamma "
                     "too), or the conditions differ in another way.")
        else:
            text += "."
    else:
        text = (f"The check {CHECK} ran on the bulged cells of {_and(check['compared'])} and "
                "did not flag a wall of a condition's own; a quiet check is no evidence of a "
                "shared wall (differences of 20-25 % mostly go unseen with 36 bulged cells per "
                "condition, docs/effects.md).")
    if freed and (not check["ran"] or not check["flagged"]):
        text += f" Here {own}: the P_phys contrast does not assume that wall shared."
    if entry["adopted_walls"]:
        walls = "; ".join(f"{q} of {_and(n)}" for q, n in entry["adopted_walls"].items())
        text += (f" The criticism adopts {entry['adopted']}, which gives {walls} a value of "
                 "its own (the extension this check points at): the contrasts of the adopted "
                 "model below do not assume that wall shared.")
    return text
