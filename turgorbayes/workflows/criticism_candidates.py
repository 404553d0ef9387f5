"""The candidates of a criticism: each one's entry in the comparison
(:func:`candidate_entry`, :func:`failed_candidate`), its seed (:func:`candidate_seed`), its
mode search (:func:`candidate_laplace`), and its cache key and stored form
(:func:`candidate_key`, :func:`storable_entry`, :func:`restored_entry`).
"""

import hashlib
import json
from dataclasses import asdict, replace

import numpy as np

from turgorbayes import effects
from turgorbayes.cache import key as cache_key
from turgorbayes.criticism.loo import compare
from turgorbayes.inference.engine import stream_rng, stream_seed
from turgorbayes.inference.mode import laplace_fit
from turgorbayes.parallel import pool_map
from turgorbayes.workflows.criticism_setup import criticism_model

__all__ = ["MODE_STARTS", "NOT_IN_FIT", "candidate_entry", "candidate_key", "candidate_laplace",
           "candidate_seed", "data_digest", "failed_candidate", "fit_status", "model_summary",
           "restored_entry", "storable_entry"]

#: The fields of :class:`CriticismSettings` that do not change a candidate's fit (left out
#: of :func:`candidate_key`).
NOT_IN_FIT = ("workers", "scheduler", "progress", "effects", "n_rep", "flag_draws")


def candidate_key(cells, surrogate, name, guess, seed, settings):
    """The cache key of a candidate's fit (:func:`turgorbayes.cache.key`): the data's content
    (:func:`data_digest`), the surrogate's sha256, the candidate's name, its start (the
    baseline's mode), the seed, the settings that reach its fit (all but :data:`NOT_IN_FIT`)
    and the package version. None (not cached) for a surrogate without a sha256."""
    if surrogate.sha256 is None:
        return None
    fit = {k: v for k, v in asdict(settings).items() if k not in NOT_IN_FIT}
    return cache_key("candidate", data=data_digest(cells), surrogate=surrogate.sha256, name=name,
                     guess=guess, seed=seed, settings=fit)


def data_digest(cells):
    """The sha256 of the cells' content: ids, groups, every number to the bit and the extra
    columns (not their comments, path or file hash: the same data read from another file, or
    simulated, have the same digest)."""
    digest = hashlib.sha256(json.dumps([cells.cell_id, cells.group, dict(cells.extra)]).encode())
    for column in (cells.R_c, cells.R_c_err, cells.k_c, cells.k_c_err, cells.R_b, cells.R_b_err,
                   cells.k_b, cells.k_b_err, cells.h_b):
        digest.update(np.ascontiguousarray(column, dtype="<f8").tobytes())
    return digest.hexdigest()


def candidate_seed(seed, names):
    """The seed of a candidate model's fit and exact LOO: a stream of the workflow's ``seed``
    keyed by the model's effect names (:func:`turgorbayes.inference.engine.stream_seed`; stream
    18 for one effect, 20 for the selected effect with the runner-up, in that order), so that a
    candidate's draws do not depend on which other candidates are fitted, or in which order.
    """
    stream = {1: 18, 2: 20}[len(names)]
    return stream_seed(seed, stream, *names)


#: Further starts of a candidate's mode search when the first ends off a mode
#: (:func:`candidate_laplace`).
MODE_STARTS = 2


def candidate_laplace(model, names, start, seed):
    """The mode and Laplace covariance of a model with effects ``names``
    (:func:`turgorbayes.inference.mode.laplace_fit` from the physical ``start``).

    Where that search ends off a mode (the Hessian has a negative eigenvalue: a saddle, or a
    crease of the log posterior such as a table's node, where BFGS and Nelder-Mead stall while
    the posterior's mass lies elsewhere), it is searched again from :data:`MODE_STARTS` starts
    whose effect parameters are drawn from their priors (stream 22 of the model's ``seed``),
    and the highest mode is kept; its notes say so. Elsewhere the first search stands, so
    models whose search ends at a mode are fitted as before (docs/statistics.md, "Posterior
    engines of the criticism").
    """
    lap = pool_map(laplace_fit, model, [(model.to_u(start)[0],)])[0]
    if not names or lap.clipping is None or lap.clipping.smallest >= 0:
        return lap
    rng = stream_rng(seed, 22)
    params = [p for name in names for p in effects.get_effect(name).parameters]
    starts = [model.to_u(dict(start, **{p.name: float(p.prior.sample(rng)) for p in params}))[0]
              for _ in range(MODE_STARTS)]
    starts = [(u,) for u in starts if np.isfinite(model.log_posterior(u[None])[0])]
    best = lap
    for other in pool_map(laplace_fit, model, starts):  # side by side on a task pool
        if other.mode.log_post > best.mode.log_post:
            best = other
    if best is not lap:
        best.notes.insert(0, f"the first mode search ended off a mode (a Hessian eigenvalue of "
                             f"{lap.clipping.smallest:.3g}); a start drawn from the effects' "
                             f"priors found one {best.mode.log_post - lap.mode.log_post:.1f} "
                             "nats higher")
    return best


def storable_entry(entry):
    """A candidate's ``(name, posterior, loo, error, seconds)`` without its posterior's model
    (rebuilt from the data and the name: :func:`restored_entry`)."""
    name, post, loo, err, seconds = entry
    return name, None if post is None else replace(post, model=None), loo, err, seconds


def restored_entry(entry, cells, surrogate, settings):
    """:func:`storable_entry`'s entry with its posterior's model rebuilt (:func:`criticism_model`)."""
    name, post, loo, err, seconds = entry
    if post is not None:
        post = replace(post, model=criticism_model(cells, surrogate, [name], settings))
    return name, post, loo, err, seconds


def model_summary(post, name, seed, summaries):
    """``post.summary`` (stream 13 of ``seed``) of model ``name``, kept in ``summaries``: a
    candidate's estimate and the result's summaries are the same summary, computed once."""
    if name not in summaries:
        summaries[name] = post.summary(stream_rng(seed, 13))
    return summaries[name]


def _estimate(summary, model):
    """``{key: {mean, q05, q95}}`` of an effect's own parameters."""
    keys = [p.key for e in model.effects for p in e.parameters]
    return {k: {f: summary[k][f] for f in ("mean", "q05", "q95")} for k in keys}


def candidate_entry(name, post, loo, loo_base, seed, summaries):
    """The comparison's entry of candidate ``name`` fitted as ``post`` with exact LOO ``loo``:
    its gain over the baseline's ``loo_base`` (:func:`~turgorbayes.criticism.loo.compare`),
    its own parameters' estimates (:func:`model_summary`, kept in ``summaries``) and its
    convergence."""
    d, se, p = compare(loo, loo_base, seed)
    summary = model_summary(post, name, seed, summaries)
    return {"effect": name, "delta_elpd": d, "delta_se": se, "p_gain": p,
            "estimate": _estimate(summary, post.model),
            "converged": bool(post.converged), "convergence": post.convergence(),
            "failed": None}


def failed_candidate(name, err):
    """The entry of a candidate whose fit raised ``err`` (one of
    :data:`~turgorbayes.workflows.criticism_setup.NUMERICAL_FAILURES`): no gain, not
    converged, and ``failed`` the reason (the exception's type and message), so that the
    comparison leaves it out and the verdict names it."""
    reason = f"{type(err).__name__}: {err}".strip().rstrip(":")
    return {"effect": name, "delta_elpd": None, "delta_se": None, "p_gain": None,
            "estimate": {}, "converged": False,
            "convergence": {"engine": None, "converged": False, "reasons": [reason],
                            "attempts": [], "laplace": None},
            "failed": reason}


def fit_status(post, loo):
    """A fit in one line for the progress messages: engine, convergence, elpd and the cells
    with a high Pareto k."""
    conv = "converged" if post.converged else "NOT converged (" + "; ".join(post.reasons) + ")"
    if post.attempts:
        conv += f" after {len(post.attempts)} unconverged run(s)"
    return (f"{post.engine}, {conv}, elpd {loo['elpd']:.1f}, {loo['n_bad']} cells with high "
            f"Pareto k ({len(loo['refitted'])} refitted exactly)")
