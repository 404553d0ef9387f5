"""``turgorbayes curves`` on every core: time with 1 and 2 worker processes, alternated, on the
worked example's raw curves (``simulate --raw-curves --seed 1``: 107 cells, 558 curves), with
``--figures none``; the ratio is taken pair by pair in one run (the machine is shared), and the
cells.csv and curves.csv of the two must be the same bytes.

Run: .venv/bin/python benchmarks/curves_workers.py [--pairs 3] [--update]
"""

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from turgorbayes.provenance import add_output_options, header_line, study_path

CLI = [sys.executable, "-m", "turgorbayes"]


def timed(args):
    t = time.perf_counter()
    subprocess.run(CLI + args, check=True, capture_output=True)
    return time.perf_counter() - t


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", type=int, default=3)
    add_output_options(parser)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        subprocess.run(CLI + ["simulate", "--raw-curves", str(tmp / "raw"), "--seed", "1"],
                       check=True, capture_output=True)
        lines, ratios = [header_line()], []
        for i in range(args.pairs):
            t = {}
            for w in ("1", "2"):
                t[w] = timed(["curves", str(tmp / "raw" / "manifest.csv"), "--out",
                              str(tmp / f"w{w}" / "cells.csv"), "--figures", "none",
                              "--no-progress", "--workers", w])
            ratios.append(t["2"] / t["1"])
            lines.append(f"pair {i + 1}: 1 worker {t['1']:.1f} s, 2 workers {t['2']:.1f} s, "
                         f"ratio {ratios[-1]:.2f}")
            print(lines[-1], flush=True)
        same = all((tmp / "w1" / n).read_bytes() == (tmp / "w2" / n).read_bytes()
                   for n in ("cells.csv", "curves.csv"))
        lines.append(f"ratio 2 workers / 1 worker: median {sorted(ratios)[len(ratios) // 2]:.2f} "
                     f"(pairs {', '.join(f'{r:.2f}' for r in ratios)}); cells.csv and curves.csv "
                     f"identical: {same}")
    print(lines[-1])
    path = study_path(args, "curves_workers.txt")
    path.write_text("\n".join(lines) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
