"""From simulated raw force curves to posteriors, as a user runs it: does the fit cover the truth?

For each seed: ``turgorbayes simulate --raw-curves DIR`` (the paper's experiment: 72 bulged +
42 intact cells, their force curves as afmformats ``.tab`` files, a manifest and the truths),
``turgorbayes curves`` (no figures) and ``turgorbayes fit``; the posterior's 90 % intervals are
compared with the simulation's wall parameters and the time of each step is printed. Every
stiffness the fit sees was read from a noisy curve by the package's own reduction, so this
checks the chain, not the likelihood alone (whose coverage is docs/validation.md's).

Beside it, the same seed's cell table (``turgorbayes simulate --out``: the same cells and
measured radii, stiffnesses with the simulator's own errors instead of curve readings) is
fitted: a seed whose draw of radii puts the truth in a tail does so on both paths, so the
difference of the two z scores is what the curves add.

Run: .venv/bin/python studies/raw_curves_end_to_end.py --seeds 1 2 3 \
         > studies/results/raw_curves_end_to_end.txt
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from turgorbayes import provenance

PARAMS = ("gamma", "E0t_N_per_m", "R0_nm", "P_phys_kPa")


def _run(args):
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-m", "turgorbayes", *args], capture_output=True,
                          text=True)
    if done.returncode:
        raise RuntimeError(f"turgorbayes {args[0]} exited {done.returncode}: "
                           f"{done.stderr.strip().splitlines()[-1:]}")
    return time.perf_counter() - t0


def one(seed, folder, sim_opts=(), fit_opts=()):
    raw, cells, fit = folder / "raw", folder / "cells.csv", folder / "fit"
    t_sim = _run(["simulate", "--raw-curves", str(raw), "--seed", str(seed), *sim_opts])
    t_curves = _run(["curves", str(raw / "manifest.csv"), "--out", str(cells), "--no-figures",
                     "--no-progress"])
    t_fit = _run(["fit", str(cells), "--out", str(fit), "--seed", str(seed), "--no-progress",
                  *fit_opts])
    table = folder / "table.csv"
    _run(["simulate", "--out", str(table), "--seed", str(seed), *sim_opts])
    _run(["fit", str(table), "--out", str(folder / "fit_table"), "--seed", str(seed), "--no-progress",
          *fit_opts])
    truth = json.loads((raw / "truth.json").read_text())["parameters"]
    summary = json.loads((fit / "summary.json").read_text())
    return {"seed": seed, "truth": truth, "parameters": summary["parameters"],
            "table": json.loads((folder / "fit_table" / "summary.json").read_text())["parameters"],
            "converged": summary["converged"], "time_s": {"simulate": t_sim,
                                                          "curves": t_curves, "fit": t_fit}}


def _z(q, true):
    return (q["mean"] - true) / q["sd"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    args = provenance.add_output_options(ap).parse_args()
    sim_opts, fit_opts = (), ()  # the CLI's defaults: the paper's cells, the full sampler
    if args.smoke:  # one seed of 8 + 6 cells, the shortest chains the CLI takes
        args.seeds = args.seeds[:1]
        sim_opts = ("--n-bulged", "8", "--n-intact", "6")
        fit_opts = ("--walkers", "10", "--ensembles", "2", "--max-steps", "100")
    provenance.tee_stdout(args, "raw_curves_end_to_end.txt")
    print(provenance.header_line(), flush=True)
    covered = {p: [0, 0] for p in PARAMS}
    z = {p: [[], []] for p in PARAMS}
    for seed in args.seeds:
        with tempfile.TemporaryDirectory() as tmp:
            try:
                row = one(seed, Path(tmp), sim_opts, fit_opts)
            except RuntimeError as err:
                print(f"seed {seed}: FAILED, {err}", flush=True)
                continue
        t = row["time_s"]
        print(f"seed {seed}: converged {row['converged']}; simulate {t['simulate']:.0f} s, "
              f"curves {t['curves']:.0f} s, fit {t['fit']:.0f} s")
        for p in PARAMS:
            true = row["truth"][p]
            for j, q in enumerate((row["parameters"][p], row["table"][p])):
                covered[p][j] += q["q05"] <= true <= q["q95"]
                z[p][j].append(_z(q, true))
            q = row["parameters"][p]
            print(f"  {p:<11} truth {true:.4g}  posterior {q['mean']:.4g} +- {q['sd']:.2g}  "
                  f"90 % [{q['q05']:.4g}, {q['q95']:.4g}]  z {z[p][0][-1]:+.2f}"
                  f"  {'covered' if q['q05'] <= true <= q['q95'] else 'MISSED'}"
                  f"  (cell table: z {z[p][1][-1]:+.2f})", flush=True)
    n = len(z[PARAMS[0]][0])
    print(f"90 % intervals covering the truth, of {n} seeds: from curves "
          + ", ".join(f"{p} {covered[p][0]}" for p in PARAMS) + "; from the cell table "
          + ", ".join(f"{p} {covered[p][1]}" for p in PARAMS))
    for p in PARAMS:
        a, b = np.array(z[p][0]), np.array(z[p][1])
        print(f"  {p:<11} mean z from curves {a.mean():+.2f} (sd {a.std(ddof=1):.2f}), "
              f"from the table {b.mean():+.2f} (sd {b.std(ddof=1):.2f}); curves - table "
              f"{(a - b).mean():+.2f} +- {(a - b).std(ddof=1) / np.sqrt(n):.2f}")


if __name__ == "__main__":
    main()
