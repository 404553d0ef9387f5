r"""``outliers``: a few readings of any measured quantity are gross errors.

Cause (docs/effects.md, outliers): real data sets hold a few entries that are simply wrong: a
radius measured on the wrong cell or a dividing pair, a stiffness typed in the wrong unit for
one cell, a force curve taken on the substrate or a neighbour, a bulge curve read at the wrong
depth. Unlike ``bad_curves`` (a systematic failure of the cell curves, always too soft), a gross
error can hit any quantity in either direction.

Model: every reading (``R_c``, ``k_c``, and the bulge, i.e. ``k_b`` and ``R_b`` through
``ln P_hat``) is, independently and with probability ``f`` (fitted), a gross error: instead of
its Gaussian measurement error it is lognormal around the model value with log-sd
``sigma_out`` = 1 (:data:`OUTLIER_LOG_SD`, a factor 2.7):

.. math::

    p(y \mid m) = (1-f)\,N(y;\ m,\ \delta y) + f\,\frac{1}{y}\,
    N(\ln y;\ \ln m,\ \sigma_{out}),
    \qquad
    \ln\hat P_i \sim (1-f)\,N(\ln P_i, s_i) + f\,N(\ln P_i, \sigma_{out}).

Why a broad mixture component and not Student-t tails: the component's posterior probability
is a per-reading answer a user can act on ("this R_c is a gross error with probability 0.98";
:func:`outlier_probabilities`), ``f = 0`` is exactly the baseline, and one shape serves every
quantity, since a log-scale component does not care about units. A log-sd of 1 carries almost
no information (a gross error may be off by any factor up to ~10), so the model does not try to
learn from the bad readings; the fraction ``f`` is identifiable from the good ones.

Likelihood: the bulge's gross-error branch is integrated over the latent ln P by a dense rule
over the whole population support (:meth:`turgorbayes.inference.likelihood.CellLikelihood.\
_context_bulged`); a cell whose bulge is wrong is then placed by its own ``R_c`` and ``k_c``.

Prior: ``f ~ Beta(1, 19)`` (mean 0.05, density largest at ``f = 0``).
"""

import numpy as np

from turgorbayes.effects.base import Effect, SqrtCoordinate
from turgorbayes.effects.registry import FAULTY_READINGS, register_effect
from turgorbayes.inference.context import walker_column
from turgorbayes.inference.models import Parameter
from turgorbayes.inference.observations import gaussian_logpdf, in_place
from turgorbayes.inference.priors import Beta
from turgorbayes.parallel import ordered_map, pool_map, pool_open

__all__ = ["F_PRIOR", "FLAG_DRAWS", "FLAG_PROBABILITY", "OUTLIER_LOG_SD", "QUANTITIES", "REFERENCE_F",
           "Outliers", "broad_logpdf", "flagged_cells", "outlier_probabilities", "reading_phrase"]

#: Log-sd of a gross-error reading around the model value.
OUTLIER_LOG_SD = 1.0
#: Prior on the fraction of gross-error readings.
F_PRIOR = Beta(1.0, 19.0)
#: The fraction assumed when a model without this effect is screened (``fit``).
REFERENCE_F = 0.01
#: A reading is flagged when its posterior probability of being a gross error exceeds this.
FLAG_PROBABILITY = 0.5
#: Posterior draws at which ``fit`` and ``criticize`` screen the readings (the score's Monte
#: Carlo sd is at most 0.5/sqrt(FLAG_DRAWS) = 0.035 for independent draws).
FLAG_DRAWS = 200
#: The readings screened, as named in ``flagged_cells``.
QUANTITIES = ("R_c", "k_c", "k_b/R_b")


def broad_logpdf(y, m):
    """Log density of a gross-error reading ``y`` given the model value ``m`` (same units):
    lognormal around ``m`` with log-sd :data:`OUTLIER_LOG_SD`."""
    y = np.asarray(y, float)
    with np.errstate(divide="ignore", invalid="ignore"):
        log_y = np.log(y)
        return in_place(np.subtract, gaussian_logpdf(log_y, np.log(m), OUTLIER_LOG_SD), log_y)


def _mixture(good, f, force):
    """``ln((1-f) good + f broad)``, or the broad branch alone (``force``, without ``f``).

    The density carries its ``good`` component and ``good_branch``, ``ln((1-f) good)``
    (-inf when forced broad): correlated readings condition that branch only
    (:func:`turgorbayes.inference.context.reading_logpdf`)."""
    def density(y, m, err):
        if force:
            return broad_logpdf(y, m)
        fw = walker_column(f, np.ndim(m))
        with np.errstate(divide="ignore"):
            broad = in_place(np.add, broad_logpdf(y, m), np.log(fw))
            return in_place(np.logaddexp, good(y, m, err) + np.log1p(-fw), broad, into=broad)

    def good_branch(y, m, err):
        if force:
            return np.full(np.broadcast_shapes(np.shape(y), np.shape(m)), -np.inf)
        return good(y, m, err) + np.log1p(-walker_column(f, np.ndim(m)))

    density.good, density.good_branch = good, good_branch
    return density


class Outliers(Effect):
    """Gross-error readings of any quantity with fitted fraction ``f_out`` (module docstring)."""

    gross_errors = True
    family = FAULTY_READINGS
    name = "outliers"
    parameters = (Parameter("f_out", SqrtCoordinate(F_PRIOR), "f_out", 1.0, r"$f_{out}$"),)
    size_parameter = "f_out"
    null_value = 0.0
    realistic_size = 0.02
    realistic_size_reason = (
        "f = 0.02 (about 7 of the 342 readings of 114 cells): a few wrong entries per data "
        "set, the rate at which hand-assembled tables of AFM and microscopy readings hold "
        "transcription, unit and wrong-cell errors")
    start = {"f_out": 0.005}
    cause = ("A few measurements are gross errors (about {size:.1%} of the readings): single "
             "entries far from what the cell's other readings and the other cells imply, as "
             "from a wrong cell, a wrong unit or a failed curve; the cells are listed in "
             "flagged_cells.")

    def apply(self, ctx, v, force=None):
        """Mixtures on every reading; ``force`` (a name in :data:`QUANTITIES`) keeps only the
        gross-error branch of that reading (without its weight ``f``), for
        :func:`outlier_probabilities`."""
        f = np.asarray(v["f_out"], float)
        ctx.R_logpdf = _mixture(ctx.R_logpdf, f, force == "R_c")
        ctx.k_logpdf = _mixture(ctx.k_logpdf, f, force == "k_c")
        log_f = np.zeros_like(f) if force == "k_b/R_b" else np.log(f)
        ctx.bulge_outlier = (log_f, OUTLIER_LOG_SD)

    def _corrupt(self, y, v, mask, rng):
        y = np.asarray(y, float)
        bad = (rng.random(y.shape) < v["f_out"]) & mask
        return np.where(bad, y * np.exp(OUTLIER_LOG_SD * rng.standard_normal(y.shape)), y)

    def observe_k(self, k_obs, k_true, v, is_cell, rng):
        return self._corrupt(k_obs, v, is_cell, rng)

    def observe_R(self, R_obs, v, is_cell, rng):
        return self._corrupt(R_obs, v, is_cell, rng)

    def observe_bulge(self, k_b, v, is_bulged, rng):
        return self._corrupt(k_b, v, is_bulged, rng)


OUTLIERS = register_effect(Outliers())


def outlier_probabilities(model, v):
    """Posterior probability, per draw, that each reading is a gross error.

    Parameters
    ----------
    model : turgorbayes.inference.models.BaselineModel or turgorbayes.effects.ExtendedModel
        Its effects other than ``outliers`` are kept.
    v : dict of ndarray (W,)
        Physical parameter values (posterior draws); without ``f_out`` (a model without this
        effect) the fraction is :data:`REFERENCE_F`.

    Returns
    -------
    dict
        Name in :data:`QUANTITIES` -> ``(W, n_cells)`` probabilities (0 for intact cells'
        bulge). Each is ``f p(data_i | reading bad) / p(data_i)`` with the other readings'
        mixtures integrated, the latent pressure integrated out.
    """
    v = {k: np.asarray(a, float) for k, a in v.items()}
    W = len(v["gamma"])
    if "f_out" not in v:
        v["f_out"] = np.full(W, REFERENCE_F)

    def log_lik(force):
        ctx = model.context(v, skip=(OUTLIERS.name,))  # the model's other effects kept
        OUTLIERS.apply(ctx, v, force)
        return model.lik.pointwise_context(ctx, v["P_phys"])

    full = log_lik(None)
    out = {}
    for q in QUANTITIES:
        with np.errstate(invalid="ignore", over="ignore"):
            p = np.exp(np.log(v["f_out"])[:, None] + log_lik(q) - full)
        p = np.where(np.isfinite(p), np.clip(p, 0.0, 1.0), 0.0)
        if q == "k_b/R_b":
            p[:, model.obs.intact] = 0.0
        out[q] = p
    return out


def flagged_cells(model, v, cell_ids, batch=64, gross=False, workers=1):
    """Readings whose posterior probability of being a gross error exceeds
    :data:`FLAG_PROBABILITY`, most certain first.

    The probability is a screen: it is called the probability of a gross error in the reason
    only with ``gross`` (a criticism whose verdict explains the data by gross errors);
    otherwise the reason says the reading does not fit, with its score.

    Parameters
    ----------
    model, v
        As in :func:`outlier_probabilities` (``v``: posterior draws, ``(W,)`` each).
    cell_ids : sequence of str
    batch : int
        Draws per likelihood call.
    gross : bool
        Word the reasons as gross errors (module docstring of :func:`flagged_cells`).
    workers : int
        Forked processes the batches are spread over (:func:`turgorbayes.parallel.ordered_map`);
        the batches and the order of their sums are the same on any number, so are the scores.

    Returns
    -------
    list of dict
        ``{"cell_id", "quantity", "score", "reason"}``: ``score`` is the probability.
    """
    W = len(v["gamma"])
    probs = {q: np.zeros(len(cell_ids)) for q in QUANTITIES}
    for part in _probability_batches(model, v, batch, workers):
        for q in QUANTITIES:
            probs[q] += part[q].sum(axis=0) / W
    f = float(np.mean(v["f_out"])) if "f_out" in v else REFERENCE_F
    flags = []
    for q in QUANTITIES:
        for i in np.flatnonzero(probs[q] > FLAG_PROBABILITY):
            flags.append({"cell_id": str(cell_ids[i]), "quantity": q,
                          "score": round(float(probs[q][i]), 4),
                          "reason": (_gross_reason if gross else _screen_reason)(
                              model, i, q, probs[q][i], f)})
    return sorted(flags, key=lambda d: -d["score"])


#: The model and draws of :func:`_probability_batches`' workers: set before the pool forks, so
#: they inherit them instead of receiving a pickled copy with every batch.
_SHARED = {}


def _probability_batches(model, v, batch, workers):
    """:func:`outlier_probabilities` of the draws ``v`` in order, in batches of at most
    ``batch`` draws and equal sizes (200 draws: four of 50, so two workers finish together),
    on an open :func:`turgorbayes.parallel.task_pool`, ``workers`` forked processes or here."""
    n = len(v["gamma"])
    k = -(-n // batch)
    parts = [({q: np.asarray(a)[n * j // k:n * (j + 1) // k] for q, a in v.items()},)
             for j in range(k)]
    if pool_open() or workers <= 1 or k <= 1:
        return pool_map(outlier_probabilities, model, parts)
    _SHARED.update(model=model, parts=parts)
    try:
        return ordered_map(_shared_batch, range(k), workers, chunksize=1)
    finally:
        _SHARED.clear()


def _shared_batch(j):
    """One batch of :func:`_probability_batches` (a worker's task)."""
    return outlier_probabilities(_SHARED["model"], *_SHARED["parts"][j])


def reading_phrase(model, i, quantity):
    """One reading of cell ``i`` in words with its reported error (``quantity``: ``R_c``,
    ``k_c`` or ``k_b``, the bulge's pressure)."""
    obs = model.obs
    if quantity == "R_c":
        return f"R_c = {obs.R_c[i] * 1e9:.0f} +- {obs.R_c_err[i] * 1e9:.0f} nm"
    if quantity == "k_c":
        return f"k_c = {obs.k_c[i]:.4g} +- {obs.k_c_err[i]:.2g} N/m"
    j = int(np.flatnonzero(obs.bulged == i)[0])
    return f"the bulge's pressure {np.exp(obs.log_P_bulge[j]) / 1e3:.3g} kPa"


def _screen_reason(model, i, quantity, p, f):
    return (f"{reading_phrase(model, i, quantity)} does not fit this cell's other readings and "
            f"the other cells (screen score {p:.2f})")


def _gross_reason(model, i, quantity, p, f):
    prior = f"if {f:.1%} of all readings were gross errors"
    return (f"{reading_phrase(model, i, quantity)} does not fit this cell's other readings and "
            f"the other cells: probability {p:.2f} that it is a gross error ({prior})")
