"""Our PSIS-LOO of weighted draws against arviz-stats' on a model with an exact answer.

``criticism.psis_loo`` takes the draws' normalized log weights, which for an importance-sampled
posterior are already Pareto-smoothed (one smoothing of the posterior/proposal ratios, then a
second of the leave-one-out ratios); arviz-stats' ``loo_approximate_posterior`` takes the raw
target and proposal densities and smooths their combined ratio once. For draws of the posterior
itself (MCMC, equal weights) the reference is arviz-stats' ``loo``.

Model: y_i ~ N(theta, 1), i = 1..n, flat prior, where p(y_i | y_-i) = N(y_i; mean(y_-i),
1 + 1/(n-1)) exactly. Proposal for importance sampling: Student t (5 degrees of freedom) at the
mean with ``--scale`` times the posterior sd, as a Laplace-based proposal is. Data sets: normal
(``--outlier 0``) or with one reading shifted by ``--outlier`` sd (a cell with a large Pareto k).
Prints and writes the error of each estimator against the exact elpd_i (mean absolute, max,
error of the sum) over ``--reps`` data sets; every row records the commit, arguments, date,
machine and version.

Usage::

    python studies/loo_vs_arviz.py [--reps 200] [--n 114] [--draws 4000] \
        [--json studies/results/loo_vs_arviz.json]
"""

import argparse
import json
import warnings
from pathlib import Path

import numpy as np
import xarray as xr
from arviz_stats import loo, loo_approximate_posterior
from scipy import stats

from turgorbayes import criticism, provenance
from turgorbayes.inference.engine import psis_weights as _psis
from turgorbayes.provenance import header_line, run_record


def tree(ll):
    """A DataTree with the log-likelihood group arviz-stats reads (one chain)."""
    da = xr.DataArray(ll[None], dims=["chain", "draw", "cell"])
    return xr.DataTree.from_dict({"log_likelihood": xr.Dataset({"y": da}),
                                  "posterior": xr.Dataset({"theta": da.isel(cell=0)})})


def one(rng, n, draws, scale, outlier):
    """Errors of the three estimators against the exact elpd_i on one data set."""
    y = rng.normal(0.0, 1.0, n)
    y[0] += outlier
    exact = stats.norm.logpdf(y, (y.sum() - y) / (n - 1), np.sqrt(1 + 1 / (n - 1)))
    post = stats.norm(y.mean(), 1 / np.sqrt(n))
    q = stats.t(df=5, loc=y.mean(), scale=scale / np.sqrt(n))
    th = q.rvs(size=draws, random_state=rng)
    ll = stats.norm.logpdf(y[None, :], th[:, None], 1.0)
    log_p, log_q = post.logpdf(th), q.logpdf(th)
    log_w, _ = _psis(log_p - log_q)
    ours = criticism.psis_loo(ll, log_w)
    theirs = loo_approximate_posterior(tree(ll), log_p[None], log_q[None], pointwise=True)
    th_mc = post.rvs(size=draws, random_state=rng)
    ll_mc = stats.norm.logpdf(y[None, :], th_mc[:, None], 1.0)
    ours_mc = criticism.psis_loo(ll_mc, np.full(draws, -np.log(draws)))
    theirs_mc = loo(tree(ll_mc), pointwise=True)
    exact_mc = exact  # the same data set
    return {"importance": (ours["elpd_i"] - exact, np.asarray(theirs.elpd_i) - exact),
            "mcmc": (ours_mc["elpd_i"] - exact_mc, np.asarray(theirs_mc.elpd_i) - exact_mc),
            "k_ours": float(np.max(ours["pareto_k"])),
            "k_theirs": float(np.max(np.asarray(theirs.pareto_k)))}


def summary(errs):
    """Mean |error| per cell, largest |error|, mean and sd of the sum's error."""
    e = np.array(errs)
    return {"mean_abs": float(np.mean(np.abs(e))), "max_abs": float(np.max(np.abs(e))),
            "sum_bias": float(np.mean(e.sum(axis=1))), "sum_sd": float(np.std(e.sum(axis=1)))}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reps", type=int, default=200)
    parser.add_argument("--n", type=int, default=114, help="readings (the paper's 72 + 42)")
    parser.add_argument("--draws", type=int, default=4000)
    parser.add_argument("--scale", type=float, default=1.5, help="proposal scale / posterior sd")
    parser.add_argument("--outliers", default="0,6", help="shift of one reading, in sd")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", default=None)
    args = provenance.add_output_options(parser).parse_args(argv)
    if args.smoke:  # two data sets of 20 readings, 200 draws
        args.reps, args.n, args.draws = 2, 20, 200
        args.json = args.json or str(provenance.study_path(args, "loo_vs_arviz.json"))
    provenance.tee_stdout(args, "loo_vs_arviz.txt")
    rng = np.random.default_rng(args.seed)
    out = {"provenance": run_record(argv or []), "results": {}}
    print(header_line(out["provenance"]))
    print("| data | draws | estimator | mean abs err | max abs err | sum bias | sum sd | max k |")
    print("|---|---|---|---|---|---|---|---|")
    for shift in (float(s) for s in args.outliers.split(",")):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # arviz's k warnings are the outcome measured here
            rows = [one(rng, args.n, args.draws, args.scale, shift) for _ in range(args.reps)]
        for kind in ("importance", "mcmc"):
            for j, who in enumerate(("turgorbayes", "arviz-stats")):
                s = summary([r[kind][j] for r in rows])
                k = np.mean([r["k_ours" if j == 0 else "k_theirs"] for r in rows]) \
                    if kind == "importance" else float("nan")
                out["results"][f"outlier{shift:g}/{kind}/{who}"] = dict(s, mean_max_k=k)
                print(f"| outlier {shift:g} sd | {kind} | {who} | {s['mean_abs']:.4f} | "
                      f"{s['max_abs']:.3f} | {s['sum_bias']:+.4f} | {s['sum_sd']:.4f} | {k:.2f} |")
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    import sys

    main(sys.argv[1:])
