"""Correlated R_c-k_c errors: does the ``correlated_errors`` effect find them, and what do the
column and the effect do to P_phys?

Each data set: :func:`turgorbayes.simulation.cells.simulate_cells` with 64 bulged + 48 intact
cells at P_phys 33 kPa (the paper's wall), every cell's R_c and k_c errors correlated at
``--rho`` (the effect's injection; 0: a null). Fitted three ways (importance sampling, the
criticism's settings): the baseline reading the errors as independent (no column); the
baseline given each cell's true correlation (the ``rho_R_c_k_c`` column); the
``correlated_errors`` model without the column (its LOO gain over the baseline, the selection
rule's verdict: gain > 4 nats with probability >= 0.975, and its 90 % interval of ``rho_e``).
One JSON line per data set, then a ``RATE`` line. docs/effects.md, "correlated_errors".

Run: nice .venv/bin/python studies/correlated_errors.py --rho -0.7 --first-seed 1 --n 20 [--update]
"""

import argparse
import dataclasses
import json
import time

import numpy as np

from turgorbayes import effects
from turgorbayes import surrogate as sm
from turgorbayes.cells.correlation import with_error_correlation
from turgorbayes.criticism.loo import compare, psis_loo
from turgorbayes.criticism.selection import DELTA_ELPD_MIN, P_GAIN_MIN
from turgorbayes.effects import ExtendedModel
from turgorbayes.inference import models
from turgorbayes.inference.engine import fit_posterior
from turgorbayes.provenance import add_output_options, header_line, study_path
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings

SETTINGS = CriticismSettings(n_draws=1000, n_rep=700, max_refits=0, retry_factor=1,
                             n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                             max_steps=4000, flag_draws=50)
TRUTH = synthetic.Truth(P_phys=33e3)
#: A smoke run: 12 bulged + 8 intact cells, few draws and short chains.
SMOKE_CELLS = (12, 8)
SMOKE_SETTINGS = dataclasses.replace(SETTINGS, n_draws=200, n_rep=50, ess_min=20, n_ensembles=2,
                                     tol=5, check_every=20, max_steps=200, flag_draws=20)


def _q(summary, key, digits=3):
    return [round(summary[key][k], digits) for k in ("q05", "q50", "q95")]


def one(rho, seed, table, smoke=False):
    inj = [effects.get_effect("correlated_errors").injection(rho)] if rho else []
    cells, _ = synthetic.simulate_cells(*(SMOKE_CELLS if smoke else (64, 48)), truth=TRUTH,
                                        seed=seed, surrogate=table, effects=inj)
    settings = SMOKE_SETTINGS if smoke else SETTINGS
    guess = models.PaperWLS(cells, table).fit().estimate
    t = time.time()
    posts = {}
    for label, data, names in (("independent", cells, ()),
                               ("column", with_error_correlation(cells, rho), ()),
                               ("effect", cells, ("correlated_errors",))):
        model = ExtendedModel(data, table, names)
        posts[label] = fit_posterior(model, model.start_values(guess), seed, settings)
    s = {k: p.summary(np.random.default_rng(seed)) for k, p in posts.items()}
    delta, se, p_gain = compare(psis_loo(posts["effect"].log_lik, posts["effect"].log_w),
                                psis_loo(posts["independent"].log_lik,
                                         posts["independent"].log_w), seed)
    rho_e = _q(s["effect"], "rho_e")
    return {"rho": rho, "seed": seed, "delta_elpd": round(delta, 2), "se": round(se, 2),
            "p_gain": round(p_gain, 3),
            "selected": bool(delta > DELTA_ELPD_MIN and p_gain >= P_GAIN_MIN),
            "rho_e": rho_e, "rho_covered": bool(rho_e[0] <= rho <= rho_e[2]),
            "converged": {k: bool(p.converged) for k, p in posts.items()},
            **{f"P_{k}": _q(v, "P_phys_kPa", 2) for k, v in s.items()},
            "seconds": round(time.time() - t, 1)}


def _covers(rows, key):
    return sum(r[key][0] <= TRUTH.P_phys / 1e3 <= r[key][2] for r in rows)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rho", type=float, default=-0.7)
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--n", type=int, default=20)
    add_output_options(parser)
    args = parser.parse_args()
    if args.smoke:  # one small data set
        args.n = 1
    table = sm.load()
    tag = "null" if args.rho == 0 else f"{args.rho:+.1f}".replace("+", "p").replace("-", "m")
    path = study_path(args, f"correlated_errors_{tag}.jsonl")
    rows = []
    with open(path, "w") as f:
        print(header_line(), file=f, flush=True)
        for seed in range(args.first_seed, args.first_seed + args.n):
            rows.append(one(args.rho, seed, table, args.smoke))
            print(json.dumps(rows[-1]), file=f, flush=True)
            print(json.dumps(rows[-1]), flush=True)
        n = len(rows)
        width = {k: float(np.median([r[f"P_{k}"][2] - r[f"P_{k}"][0] for r in rows]))
                 for k in ("independent", "column", "effect")}
        line = (f"RATE rho {args.rho:+.2f}: correlated_errors selected {sum(r['selected'] for r in rows)}"
                f"/{n}; rho_e's 90 % interval covers the truth {sum(r['rho_covered'] for r in rows)}"
                f"/{n}; P_phys 90 % covers 33 kPa: independent {_covers(rows, 'P_independent')}/{n}, "
                f"column {_covers(rows, 'P_column')}/{n}, effect {_covers(rows, 'P_effect')}/{n}; "
                "median 90 % width [kPa]: " + ", ".join(f"{k} {v:.2f}" for k, v in width.items()))
        print(line, file=f)
    print(line)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
