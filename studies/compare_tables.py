"""How far is a surrogate table from FE points computed on another mesh?

Reads the per-point JSON records of a build (``--points-dir`` of ``turgorbayes surrogate
build``) and prints, per point, the FE k/(P R_c) and the table's interpolated value at the
point's own inflation number and anisotropy, with the relative difference. Used to map the
mesh error of the shipped table against a finer mesh before the finer table is complete.

Run: .venv/bin/python studies/compare_tables.py POINTS_DIR [--table FILE]
"""

import argparse
import json
from pathlib import Path

import numpy as np

from turgorbayes import provenance, surrogate

#: The FE points of the shipped table's build (what ``--smoke`` compares when given none).
SHIPPED_POINTS = Path(__file__).resolve().parents[1] / "surrogates" / "k_over_PR.points"


def rows(points_dir, table):
    out = []
    for f in sorted(Path(points_dir).glob("*.json")):
        rec = json.loads(f.read_text())
        if rec.get("status", "ok") != "ok":
            continue
        old = float(table(rec["x"], rec["ratio"], warn=False))
        out.append((rec["ratio"], rec["x"], rec["k_over_PR"], old, rec["k_over_PR"] / old - 1))
    return sorted(out)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("points_dir", nargs="?", default="",
                        help="--points-dir of a surrogate build (the FE points' JSON records)")
    parser.add_argument("--table", default=None, help="surrogate file (default: the shipped one)")
    provenance.add_output_options(parser)
    args = parser.parse_args()
    if args.smoke and not args.points_dir:  # the shipped table's own points
        args.points_dir = str(SHIPPED_POINTS)
    if not args.points_dir:
        parser.error("give POINTS_DIR")
    provenance.tee_stdout(args, "compare_tables.txt")
    print(provenance.header_line(), flush=True)
    table = surrogate.load(args.table)
    print(f"table {table.path} (sha256 {table.sha256[:12]}) against the FE points of "
          f"{args.points_dir}")
    print(f"{'ratio':>6} {'x':>8} {'FE k/PR':>9} {'table':>9} {'FE/table - 1':>13}")
    for ratio, x, k, old, d in rows(args.points_dir, table):
        shown = "outside" if np.isnan(d) else f"{100 * d:+12.2f}%"
        print(f"{ratio:6.3g} {x:8.4f} {k:9.4f} {old:9.4f} {shown:>13}")


if __name__ == "__main__":
    main()
