r"""Model averaging of the criticism's models by stacking of predictive distributions.

Every fitted model is weighted by how well the mixture of their leave-one-out predictive
densities predicts the cells (Yao, Vehtari, Simpson & Gelman, Bayesian Analysis 13, 917, 2018;
weights by :func:`arviz_stats.compare`, ``method="stacking"``), and the shared parameters are
summarized over the weighted mixture of posteriors. Reported beside, not instead of, the
selection of :func:`turgorbayes.criticism.select`. See ``docs/effects.md``.
"""

import warnings

import numpy as np
import xarray as xr
from arviz_stats import compare
from arviz_stats.utils import ELPDDataLOO

from turgorbayes.inference.engine import weighted_quantiles, weighted_stats
from turgorbayes.physics.parameters import SUMMARY_PARAMETERS

__all__ = ["LINEAR", "stack", "stacked_summary", "stacking_weights", "weighted_quantiles", "weighted_stats"]


def stacking_weights(loos, n_samples=1000):
    """Stacking weights of models from their pointwise LOO values.

    Parameters
    ----------
    loos : dict
        ``{model name: {"elpd_i": (n,), "elpd", "se", "p_loo", "good_k", "n_bad"}}`` (the
        dicts of :func:`turgorbayes.criticism.psis_loo` / ``exact_loo``), same cells in the
        same order for every model.
    n_samples : int
        Draws per posterior (recorded only).

    Returns
    -------
    dict
        ``{model name: weight}``, non-negative, summing to 1, in the order of ``loos``.
    """
    elpd = {}
    for name, loo in loos.items():
        e = np.asarray(loo["elpd_i"], float)
        elpd[name] = ELPDDataLOO(
            elpd=float(e.sum()), se=float(loo["se"]), p=float(loo["p_loo"]),
            n_samples=int(n_samples), n_data_points=e.size, scale="log",
            warning=bool(loo.get("n_bad", 0)), good_k=float(loo.get("good_k", 0.7)),
            elpd_i=xr.DataArray(e, dims=["cell"]))
    if len(elpd) == 1:
        return {next(iter(elpd)): 1.0}
    with warnings.catch_warnings():
        # arviz's note that a difference may be due to chance concerns the ranking, not the
        # weights, which already reflect it
        warnings.filterwarnings("ignore", message="Difference in performance potentially")
        table = compare(elpd, method="stacking", round_to="none")
    w = np.clip(np.array([float(table.loc[n, "weight"]) for n in loos]), 0.0, None)
    return dict(zip(loos, (w / w.sum()).tolist(), strict=True))


#: Parameters whose bias (``stacked_summary``'s ``bias_sd``) is additive; the others are
#: positive and shift in their log.
LINEAR = ("gamma",)


def stacked_summary(posteriors, weights, rng, bias_sd=None):
    """Summaries of the shared parameters under the weighted mixture of posteriors.

    Parameters
    ----------
    posteriors : dict
        ``{model name: Posterior}`` (:class:`turgorbayes.criticism.Posterior`: ``weights``
        of its draws and ``physical(rng)``).
    weights : dict
        ``{model name: stacking weight}``.
    rng : numpy.random.Generator
        For the wall-thickness draws of the derived moduli (and the biases).
    bias_sd : dict, optional
        ``{parameter: sd}``: a bias of that sd added to every draw (in ``ln theta``, in
        ``theta`` for :data:`LINEAR`; :mod:`turgorbayes.criticism.misfit_band`); parameters
        without an entry are unchanged. None: the mixture itself.

    Returns
    -------
    dict
        ``{summary key: {"mean", "sd", "q05", "q50", "q95"}}`` in ``summary.json`` units, for
        gamma, E0t, R0, P_phys, E_perp and E_par.
    """
    values = {name: [] for name in SUMMARY_PARAMETERS}
    w_all = []
    for model, w in weights.items():
        if w <= 0:
            continue
        post = posteriors[model]
        phys = post.physical(rng)
        for name in SUMMARY_PARAMETERS:
            values[name].append(np.asarray(phys[name], float))
        w_all.append(w * post.weights / np.sum(post.weights))
    w_all = np.concatenate(w_all)
    out = {}
    for name, (key, unit) in SUMMARY_PARAMETERS.items():
        x = np.concatenate(values[name])
        s = (bias_sd or {}).get(name, 0.0)
        if s > 0:
            z = s * rng.standard_normal(x.size)
            x = x + z if name in LINEAR else x * np.exp(z)
        out[key] = weighted_stats(x / unit, w_all)
    return out


def stack(posteriors, loos, rng):
    """Stacking weights and the model-averaged summaries (module docstring).

    Returns
    -------
    dict
        ``{"weights": {model: weight}, "parameters": {key: {mean, sd, q05, q50, q95}}}``.
    """
    n = min(int(np.size(p.weights)) for p in posteriors.values())
    weights = stacking_weights(loos, n_samples=n)
    return {"weights": weights, "parameters": stacked_summary(posteriors, weights, rng)}
