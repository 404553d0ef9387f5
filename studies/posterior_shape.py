"""Where a too-narrow interval comes from: coverage, skewness and point estimates per data set.

Fits ``--n`` simulated data sets of the paper's size (log-uniform bulge pressures, data seeds
from ``--first-seed``) with the criticism's posterior engine and records, per parameter: whether
the central 90 % interval and the symmetric Laplace interval (mode +- 1.645 sd, in sampler
coordinates) cover the truth, the posterior's skewness, and the z-scores of its mean, median
and mode. ``--bulge-error F`` simulates the bulges with log-sd errors F on k_b and R_b instead
of the simulator's 6-14 % (0.002: pressures practically known), which separates what the
latent bulge pressures contribute. Rows are appended to ``--out``; the table is printed.

Run: .venv/bin/python studies/posterior_shape.py --n 150 --bulge-error 0.002 \
         --out studies/results/posterior_shape_exact_bulges.jsonl
"""

import argparse
import dataclasses
import json

import numpy as np

from turgorbayes import criticism, effects, provenance, surrogate
from turgorbayes.criticism.stacking import weighted_stats
from turgorbayes.inference import models
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings

PARAMS = ("gamma", "E0t", "R0", "P_phys")
TRUTH = synthetic.TRUTHS["paper"]
#: A smoke run's posterior settings: few draws, short chains.
SMOKE_SETTINGS = {"n_draws": 200, "ess_min": 20, "n_ensembles": 2, "tol": 5, "check_every": 20,
                  "max_steps": 200}


def one(seed, table, errors, sizes=(72, 42), settings=None):
    cells, _ = synthetic.simulate_cells(*sizes, seed=seed, truth=TRUTH, surrogate=table,
                                        errors=errors)
    model = effects.ExtendedModel(cells, table, [])
    guess = models.PaperWLS(cells, table).fit().estimate
    post = criticism.fit_posterior(model, model.start_values(guess), seed,
                                   settings or CriticismSettings())
    phys, w = model.to_physical(post.u), post.weights / np.sum(post.weights)
    mode = model.to_physical(post.u_map[None])
    row = {"seed": seed, "converged": bool(post.converged)}
    for j, p in enumerate(PARAMS):
        x, t = phys[p], getattr(TRUTH, p)
        st = weighted_stats(x, w)
        m, sd, q05, q50, q95 = (st[k] for k in ("mean", "sd", "q05", "q50", "q95"))
        ends = []
        for sign in (-1, 1):
            u = post.u_map.copy()
            u[j] += sign * 1.6448536 * np.sqrt(post.cov[j, j])
            ends.append(float(model.to_physical(u[None])[p][0]))
        lo, hi = sorted(ends)
        row[p] = {"central": bool(q05 < t < q95), "laplace": bool(lo < t < hi),
                  "skew": float(np.sum(w * (x - m) ** 3) / sd**3),
                  "z_mean": float((m - t) / sd), "z_med": float((q50 - t) / sd),
                  "z_mode": float((mode[p][0] - t) / sd)}
    return row


def report(rows):
    rows = [r for r in rows if r["converged"]]
    lines = [f"{len(rows)} converged data sets",
             f"{'parameter':<9}{'central 90%':>12}{'Laplace 90%':>12}{'skewness':>10}"
             f"{'mean z':>8}{'sd z':>7}"]
    for p in PARAMS:
        z = np.array([r[p]["z_mean"] for r in rows])
        lines.append(f"{p:<9}{np.mean([r[p]['central'] for r in rows]):>12.3f}"
                     f"{np.mean([r[p]['laplace'] for r in rows]):>12.3f}"
                     f"{np.median([r[p]['skew'] for r in rows]):>10.2f}"
                     f"{z.mean():>+8.2f}{z.std():>7.2f}")
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--bulge-error", type=float, default=None,
                    help="log-sd of the k_b and R_b errors (default: the simulator's)")
    ap.add_argument("--out", default=None,
                    help="JSON-lines file (default: posterior_shape.jsonl in --output-dir, or in "
                         "studies/results with --update)")
    provenance.add_output_options(ap)
    ap.add_argument("--summarize", action="store_true", help="print the table of --out only")
    args = ap.parse_args()
    sizes, settings = (72, 42), CriticismSettings()
    if args.smoke:  # two data sets of 12 + 8 cells, short chains
        args.n, sizes = 2, (12, 8)
        settings = dataclasses.replace(settings, **SMOKE_SETTINGS)
    args.out = args.out or str(provenance.study_path(args, "posterior_shape.jsonl"))
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    if not args.summarize:
        e = args.bulge_error
        errors = (synthetic.ErrorModel() if e is None else
                  synthetic.ErrorModel(k_b_log_sd=(e, e), R_b_log_sd=(e, e)))
        table = surrogate.load()
        with open(args.out, "a") as f:
            for seed in range(args.first_seed, args.first_seed + args.n):
                f.write(json.dumps(dict(one(seed, table, errors, sizes, settings), provenance=record))
                        + "\n")
                f.flush()
    with open(args.out) as f:
        print("\n".join(report([json.loads(line) for line in f if line.strip()])))


if __name__ == "__main__":
    main()
