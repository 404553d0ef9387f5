"""From simulated raw force curves to posteriors, as a user runs it: does the fit cover the truth?

For each seed: ``turgorbayes simulate --raw-curves DIR`` (the paper's experiment: 72 bulged +
42 intact cells, their force curves as afmformats ``.tab`` files, a manifest and the truths),
``turgorbayes curves`` (no figures) and ``turgorbayes fit``; the posterior's 90 % intervals are
compared with the simulation's wall parameters and the time of each step is printed. Every
stiffness the fit sees was read from a noisy curve by the package's own reduction, so this
checks the chain, not the likelihood alone (whose coverage is docs/validation.md's).

Run: .venv/bin/python benchmarks/raw_curves_end_to_end.py --seeds 1 2 3 \
         > benchmarks/results/raw_curves_end_to_end.txt
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

PARAMS = ("gamma", "E0t_N_per_m", "R0_nm", "P_phys_kPa")


def _run(args):
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "turgorbayes", *args], check=True,
                   capture_output=True, text=True)
    return time.perf_counter() - t0


def one(seed, folder):
    raw, cells, fit = folder / "raw", folder / "cells.csv", folder / "fit"
    t_sim = _run(["simulate", "--raw-curves", str(raw), "--seed", str(seed)])
    t_curves = _run(["curves", str(raw / "manifest.csv"), "--out", str(cells), "--no-figures",
                     "--no-progress"])
    t_fit = _run(["fit", str(cells), "--out", str(fit), "--seed", str(seed), "--quiet"])
    truth = json.loads((raw / "truth.json").read_text())["parameters"]
    summary = json.loads((fit / "summary.json").read_text())
    return {"seed": seed, "truth": truth, "parameters": summary["parameters"],
            "converged": summary["converged"], "time_s": {"simulate": t_sim,
                                                          "curves": t_curves, "fit": t_fit}}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    args = ap.parse_args()
    covered = {p: 0 for p in PARAMS}
    for seed in args.seeds:
        with tempfile.TemporaryDirectory() as tmp:
            row = one(seed, Path(tmp))
        t = row["time_s"]
        print(f"seed {seed}: converged {row['converged']}; simulate {t['simulate']:.0f} s, "
              f"curves {t['curves']:.0f} s, fit {t['fit']:.0f} s")
        for p in PARAMS:
            q, true = row["parameters"][p], row["truth"][p]
            inside = q["q05"] <= true <= q["q95"]
            covered[p] += inside
            print(f"  {p:<11} truth {true:.4g}  posterior {q['mean']:.4g} +- {q['sd']:.2g}  "
                  f"90 % [{q['q05']:.4g}, {q['q95']:.4g}]  z {(q['mean'] - true) / q['sd']:+.2f}"
                  f"  {'covered' if inside else 'MISSED'}", flush=True)
    n = len(args.seeds)
    print("90 % intervals covering the truth: "
          + ", ".join(f"{p} {covered[p]}/{n}" for p in PARAMS))


if __name__ == "__main__":
    main()
