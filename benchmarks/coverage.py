"""Calibration of the baseline posterior: how often do 90 % intervals cover the truth?

Simulates ``--n`` data sets (72 bulged + 42 intact cells, the paper's values unless told
otherwise, data seeds 1000, 1001, ...), fits each with the baseline model (the CLI's
default sampler settings) and records whether the central 90 % posterior interval of
gamma, E0t, R0 and P_phys contains the truth; beside it the same for the published
method (paper_wls, estimate -+ 1.645 standard errors, pressures plugged in). Target for the
baseline: 85-95 % for every parameter. Results are appended to a JSON-lines file as they
come (rerunning resumes), and the table is printed at the end with binomial 95 % intervals.

Run: .venv/bin/python benchmarks/coverage.py --n 50 --out benchmarks/coverage.jsonl
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy import stats

from turgorbayes import results, surrogate, synthetic

PARAMS = ("gamma", "E0t", "R0", "P_phys")
TRUTHS = synthetic.TRUTHS


def one(seed, truth, table, settings):
    cells, _ = synthetic.simulate_cells(seed=seed, truth=truth, surrogate=table)
    t = time.perf_counter()
    res = results.fit_cells(cells, "baseline", seed=seed, surrogate=table, settings=settings)
    row = {"seed": seed, "converged": res.converged, "time_s": time.perf_counter() - t,
           "steps": res.sampler["n_steps"]}
    for p in PARAMS:
        true = getattr(truth, p)
        lo, hi = np.quantile(res.draws[p], [0.05, 0.95])
        l68, h68 = np.quantile(res.draws[p], [0.16, 0.84])
        est, se = res.wls.estimate[p], res.wls.sd[p]
        row[p] = {"cover90": bool(lo < true < hi), "cover68": bool(l68 < true < h68),
                  "wls_cover90": bool(abs(est - true) < 1.6448536 * se),
                  "wls_cover68": bool(abs(est - true) < se),
                  "z_post": float((np.mean(res.draws[p]) - true) / np.std(res.draws[p])),
                  "z_wls": float((est - true) / se)}
    return row


def _ci(k, n):
    """Clopper-Pearson 95 % interval of a binomial proportion."""
    lo = stats.beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
    hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return lo, hi


def table_lines(rows):
    n = len(rows)
    lines = [f"{n} data sets, {sum(r['converged'] for r in rows)} converged; "
             f"median fit {np.median([r['time_s'] for r in rows]):.0f} s",
             f"{'parameter':10s} {'baseline 90%':>22s} {'baseline 68%':>13s} "
             f"{'paper_wls 90%':>22s} {'wls 68%':>8s} {'mean z post':>11s} {'mean z wls':>10s}"]
    for p in PARAMS:
        k = sum(r[p]["cover90"] for r in rows)
        kw = sum(r[p]["wls_cover90"] for r in rows)
        k68 = sum(r[p]["cover68"] for r in rows)
        kw68 = sum(r[p]["wls_cover68"] for r in rows)
        lo, hi = _ci(k, n)
        wlo, whi = _ci(kw, n)
        lines.append(
            f"{p:10s} {k / n:6.1%} [{lo:5.1%}, {hi:5.1%}] {k68 / n:13.1%} "
            f"{kw / n:6.1%} [{wlo:5.1%}, {whi:5.1%}] {kw68 / n:8.1%} "
            f"{np.mean([r[p]['z_post'] for r in rows]):+11.2f} "
            f"{np.mean([r[p]['z_wls'] for r in rows]):+10.2f}")
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=50)
    parser.add_argument("--truth", choices=sorted(TRUTHS), default="paper")
    parser.add_argument("--out", default="benchmarks/coverage.jsonl")
    parser.add_argument("--first-seed", type=int, default=1000)
    args = parser.parse_args()
    table = surrogate.load()
    out = Path(args.out)
    done = {}
    if out.is_file():
        for line in out.read_text().splitlines():
            row = json.loads(line)
            done[row["seed"]] = row
    settings = results.FitSettings(progress=False, max_draws_per_chain=500)
    truth = TRUTHS[args.truth]
    rows = []
    for seed in range(args.first_seed, args.first_seed + args.n):
        if seed not in done:
            done[seed] = one(seed, truth, table, settings)
            with out.open("a") as fh:
                fh.write(json.dumps(done[seed]) + "\n")
            r = done[seed]
            print(f"seed {seed}: {r['time_s']:.0f} s, converged {r['converged']}, covered "
                  + " ".join(f"{p}={'y' if r[p]['cover90'] else 'N'}" for p in PARAMS),
                  flush=True)
        rows.append(done[seed])
    print(f"truth: {args.truth} {truth}")
    print("\n".join(table_lines(rows)))


if __name__ == "__main__":
    main()
