"""Convergence and predictive diagnostics with ArviZ 1.x (arviz-base / arviz-stats).

* Rank-normalized split R-hat and bulk/tail effective sample sizes (Vehtari et al. 2021,
  Bayesian Analysis 16, 667) computed *across independent ensembles*, one ArviZ chain per
  ensemble (:mod:`turgorbayes.inference.sampling` explains why walkers are not chains).
* PSIS-LOO (Vehtari, Gelman & Gabry 2017) from the per-cell pointwise log-likelihood, with
  the count of Pareto k above ArviZ's sample-size dependent threshold
  ``min(1 - 1/log10(S), 0.7)``.

Convergence rule (:func:`is_converged`): every ensemble longer than 50 integrated
autocorrelation times, and for every parameter R-hat < 1.01 and bulk and tail ESS >= 400
(the thresholds recommended by Vehtari et al. 2021 for 4 chains).
"""

import numpy as np

__all__ = [
    "ESS_MIN",
    "RHAT_MAX",
    "chain_diagnostics",
    "is_converged",
    "loo_summary",
]

RHAT_MAX = 1.01
ESS_MIN = 400


def _values(tree):
    """``{name: float}`` from a DataTree/Dataset of scalar results."""
    ds = tree.to_dataset() if hasattr(tree, "to_dataset") else tree
    return {name: float(ds[name].values) for name in ds.data_vars}


def chain_diagnostics(dt, var_names, group="posterior"):
    """R-hat (rank), bulk ESS and tail ESS of scalar variables.

    Parameters
    ----------
    dt : xarray.DataTree
        With a ``posterior`` group of dims ``(chain, draw)``.
    var_names : sequence of str
    group : str

    Returns
    -------
    dict
        ``{name: {"r_hat": float, "ess_bulk": float, "ess_tail": float}}``; NaN where a
        statistic is undefined (e.g. a single chain for R-hat).
    """
    import arviz_stats as azs

    names = list(var_names)
    rhat = _values(azs.rhat(dt, group=group, var_names=names, method="rank"))
    bulk = _values(azs.ess(dt, group=group, var_names=names, method="bulk"))
    tail = _values(azs.ess(dt, group=group, var_names=names, method="tail"))
    return {n: {"r_hat": rhat[n], "ess_bulk": bulk[n], "ess_tail": tail[n]} for n in names}


def is_converged(sampler_converged, diagnostics, rhat_max=RHAT_MAX, ess_min=ESS_MIN):
    """Whether a run passes the convergence rule of the module docstring.

    Parameters
    ----------
    sampler_converged : bool
        Every ensemble longer than ``tol`` autocorrelation times.
    diagnostics : dict
        Output of :func:`chain_diagnostics` for the sampled parameters.

    Returns
    -------
    ok : bool
    reasons : list of str
        Why not, in words (empty if converged).
    """
    reasons = [] if sampler_converged else [
        "an ensemble is shorter than 50 integrated autocorrelation times"]
    for name, d in diagnostics.items():
        if not d["r_hat"] < rhat_max:
            reasons.append(f"R-hat of {name} is {d['r_hat']:.4f} (needs < {rhat_max})")
        for key in ("ess_bulk", "ess_tail"):
            if not d[key] >= ess_min:
                reasons.append(f"{key} of {name} is {d[key]:.0f} (needs >= {ess_min})")
    return not reasons, reasons


def loo_summary(dt, var_name=None):
    """PSIS-LOO of the pointwise log-likelihood.

    Parameters
    ----------
    dt : xarray.DataTree
        With ``posterior`` and ``log_likelihood`` groups.
    var_name : str, optional
        Log-likelihood variable (the only one if None).

    Returns
    -------
    dict
        ``elpd``, ``se``, ``p_loo``, ``n_pareto_k_bad`` (k above ``good_k``), ``good_k``,
        ``pareto_k`` (ndarray per cell), ``elpd_i`` (ndarray per cell).
    """
    import warnings

    import arviz_stats as azs

    with warnings.catch_warnings():
        # the high Pareto k cells are counted in n_pareto_k_bad and reported in words by the
        # fit's report and command line (a raw UserWarning would say it a second time)
        warnings.filterwarnings("ignore", message=".*[Pp]areto.*", category=UserWarning)
        res = azs.loo(dt, pointwise=True, var_name=var_name)
    k = np.asarray(res.pareto_k).ravel()
    good_k = float(res.good_k)
    return {
        "elpd": float(res.elpd), "se": float(res.se), "p_loo": float(res.p),
        "n_pareto_k_bad": int(np.count_nonzero(k > good_k)), "good_k": good_k,
        "pareto_k": k, "elpd_i": np.asarray(res.elpd_i).ravel(),
    }
