"""``turgorbayes curves`` on every core: time with 1 and 2 worker processes and on a Dask
LocalCluster of 2, alternated, on the worked example's raw curves (``simulate --raw-curves
--seed 1``: 107 cells, 558 curves), with ``--figures none`` and ``--no-cache`` (a cached run
reduces nothing); the ratios are taken triple by triple in one run (the machine is shared), and
the cells.csv and curves.csv of all three must be the same bytes.

Run: .venv/bin/python studies/curves_workers.py [--pairs 5] [--update]
"""

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from turgorbayes.provenance import add_output_options, header_line, study_path

CLI = [sys.executable, "-m", "turgorbayes"]
#: A smoke run's raw curves: 3 bulged + 3 intact cells (``simulate``'s options).
SMOKE_CELLS = ["--n-bulged", "3", "--n-intact", "3"]


def timed(args):
    t = time.perf_counter()
    subprocess.run(CLI + args, check=True, capture_output=True)
    return time.perf_counter() - t


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", type=int, default=5)
    add_output_options(parser)
    args = parser.parse_args()
    cells = []
    if args.smoke:  # one run of each leg on a handful of cells
        args.pairs, cells = 1, SMOKE_CELLS
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        subprocess.run(CLI + ["simulate", "--raw-curves", str(tmp / "raw"), "--seed", "1", *cells],
                       check=True, capture_output=True)
        lines, ratios = [header_line()], {"2": [], "dask": []}
        legs = {"1": ["--workers", "1"], "2": ["--workers", "2"],
                "dask": ["--workers", "2", "--scheduler", "local"]}
        for i in range(args.pairs):
            t = {}
            for name, extra in legs.items():
                t[name] = timed(["curves", str(tmp / "raw" / "manifest.csv"), "--out",
                                 str(tmp / name / "cells.csv"), "--figures", "none",
                                 "--no-progress", "--no-cache", *extra])
            for name in ratios:
                ratios[name].append(t[name] / t["1"])
            lines.append(f"run {i + 1}: 1 worker {t['1']:.1f} s, 2 workers {t['2']:.1f} s "
                         f"(ratio {ratios['2'][-1]:.2f}), Dask LocalCluster of 2 "
                         f"{t['dask']:.1f} s (ratio {ratios['dask'][-1]:.2f})")
            print(lines[-1], flush=True)
        same = all((tmp / "1" / n).read_bytes() == (tmp / other / n).read_bytes()
                   for n in ("cells.csv", "curves.csv") for other in ("2", "dask"))
        for name, label in (("2", "2 workers"), ("dask", "Dask LocalCluster of 2")):
            r = sorted(ratios[name])
            lines.append(f"ratio {label} / 1 worker: median {r[len(r) // 2]:.2f} "
                         f"(runs {', '.join(f'{x:.2f}' for x in ratios[name])})")
        lines.append(f"cells.csv and curves.csv identical across the three: {same}")
    print("\n".join(lines[-3:]))
    path = study_path(args, "curves_workers.txt")
    path.write_text("\n".join(lines) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
