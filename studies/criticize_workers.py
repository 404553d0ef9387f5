"""``turgorbayes criticize`` with its candidates on 1 and 2 worker processes, alternated, on the
bundled example (every candidate); the ratio pair by pair in one run (the machine is shared),
and the two criticism.json must be the same once their timing fields are set aside.

Run: .venv/bin/python studies/criticize_workers.py [--pairs 2] [--update]
"""

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from turgorbayes.provenance import add_output_options, header_line, study_path

CLI = [sys.executable, "-m", "turgorbayes", "criticize", "--no-progress", "--no-cache"]
#: A smoke run's data set (``simulate``'s options) and criticism: one candidate, few draws.
SMOKE_CELLS = ["--n-bulged", "8", "--n-intact", "6", "--seed", "1"]
SMOKE_CRITICISM = ["--draws", "200", "--effects", "radius_spread", "--max-refits", "0"]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", type=int, default=2)
    add_output_options(parser)
    args = parser.parse_args()
    lines, ratios, same = [header_line()], [], True
    with tempfile.TemporaryDirectory() as tmp:
        data = []  # the bundled example
        if args.smoke:  # one pair on 14 simulated cells
            args.pairs, cells = 1, Path(tmp) / "cells.csv"
            subprocess.run([*CLI[:3], "simulate", "--out", str(cells), *SMOKE_CELLS], check=True,
                           capture_output=True)
            data = [str(cells), *SMOKE_CRITICISM]
        for i in range(args.pairs):
            t, d = {}, {}
            for w in ("1", "2"):
                out = Path(tmp) / f"w{w}_{i}"
                start = time.perf_counter()
                subprocess.run(CLI + [*data, "--out", str(out), "--workers", w], check=True,
                               capture_output=True)
                t[w] = time.perf_counter() - start
                d[w] = json.loads((out / "criticism.json").read_text())
            same = same and d["1"] == d["2"]
            ratios.append(t["2"] / t["1"])
            lines.append(f"pair {i + 1}: 1 worker {t['1']:.0f} s, 2 workers {t['2']:.0f} s, "
                         f"ratio {ratios[-1]:.2f}")
            print(lines[-1], flush=True)
    lines.append(f"ratio 2 workers / 1 worker: {', '.join(f'{r:.2f}' for r in ratios)}; "
                 f"criticism.json identical: {same}")
    print(lines[-1])
    path = study_path(args, "criticize_workers.txt")
    path.write_text("\n".join(lines) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
