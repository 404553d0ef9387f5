"""A/B of two FE settings on the same points, alternating, in one run, against the shipped table.

Both variants start from the shipped table's FE settings (read from its metadata: mesh scale
3, 3 nm under the tip, 24 indentation steps) and apply their own ``KEY=VALUE`` overrides of
:class:`turgorbayes.fem.CapsuleConfig` (JSON values, as ``turgorbayes surrogate build --set``).
Each point runs variant A, then B, each in a fresh single-threaded process (so the two see the
same machine load), and the script prints k/PR of both with their difference from the table's
own FE value at that grid point (when the point is a grid point) or its interpolated value,
wall times with the ratio B/A, Newton iterations, depth steps, and failed Newton solves (step
cuts). Usage::

    python studies/fem_settings_ab.py --a step_tolerance=0.1 \\
        --b step_tolerance=0.1 contact_smoothing=1e-11 [--points X,RATIO ...] [--jsonl FILE]
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from turgorbayes import provenance
from turgorbayes.cli.surrogate import parse_setting  # the KEY=VALUE rule of `surrogate build --set`

# the grid points of studies/results/fem_adaptive_vs_table.txt, and the paper's point
POINTS = [(0.005, 0.25), (0.005, 1.0), (0.04368, 0.4), (0.0706, 0.457), (0.1106, 0.25),
          (0.1507, 0.5), (0.2799, 0.25), (0.2799, 1.0), (0.3815, 0.5)]
#: A smoke run's FE settings over the table's: a coarse mesh, one nominal depth step (about 1 s).
SMOKE_FE = {"mesh_scale": 10.0, "h_min": 3e-9, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
            "n_indent_steps": 1, "step_tolerance": 0.0}

_CODE = """
import dataclasses, json, sys
from turgorbayes import fem, surrogate
from turgorbayes.fem import indentation_point, pressure_for_inflation_number, solver
from turgorbayes.surrogate.build import config_from_metadata
x, ratio, overrides = float(sys.argv[1]), float(sys.argv[2]), json.loads(sys.argv[3])
fails = []
newton = solver.ShellProblem.newton
def counted(self, *args, **kw):
    try:
        return newton(self, *args, **kw)
    except solver.NewtonFailure:
        fails.append(1)
        raise
solver.ShellProblem.newton = counted
table = surrogate.load()
cfg = config_from_metadata(table.metadata["fe_config"], fem.CapsuleConfig)
cfg = dataclasses.replace(cfg, **overrides)
r = indentation_point(pressure_for_inflation_number(x, ratio, cfg), ratio, cfg)
print(json.dumps([r.k_over_PR, r.wall_time_s, r.newton_iterations, len(r.h_m) - 1, len(fails),
                  r.x, float(table(r.x, ratio, warn=False))]))
"""


def run(x, ratio, overrides):
    """([k/PR, seconds, iterations, steps, failed solves, x_actual, table], None) of one point,
    or (None, the error's last line) if the FE run failed."""
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": str(root), "OMP_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", _CODE, str(x), str(ratio), json.dumps(overrides)],
                         env=env, cwd=root, capture_output=True, text=True)
    if out.returncode:
        lines = out.stderr.strip().splitlines()
        return None, lines[-1] if lines else f"exit status {out.returncode}"
    return json.loads(out.stdout.strip().splitlines()[-1]), None


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--a", nargs="*", default=[], metavar="KEY=VALUE")
    parser.add_argument("--b", nargs="*", default=[], metavar="KEY=VALUE")
    parser.add_argument("--points", nargs="*", default=None, metavar="X,RATIO")
    parser.add_argument("--jsonl", default=None, help="also append one JSON row per point here")
    args = provenance.add_output_options(parser).parse_args()
    provenance.tee_stdout(args, "fem_settings_ab.txt")
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    a, b = (dict(parse_setting(item) for item in items) for items in (args.a, args.b))
    points = POINTS if not args.points else [tuple(map(float, p.split(","))) for p in args.points]
    if args.smoke:  # the paper's point, both sides on the coarsest mesh (B: 2 depth steps)
        points = points[3:4] if not args.points else points[:1]
        a, b = {**SMOKE_FE, **a}, {**SMOKE_FE, "n_indent_steps": 2, **b}
    print(f"A = table settings + {a}; B = table settings + {b}; dk = k/PR over the table's")
    print(f"{'x':>7} {'ratio':>6} {'k A':>9} {'dk A':>8} {'k B':>9} {'dk B':>8} {'s A':>6} "
          f"{'s B':>6} {'B/A':>5} {'it A':>5} {'it B':>5} {'st A':>4} {'st B':>4} {'fl A':>4} "
          f"{'fl B':>4}", flush=True)
    total = [0.0, 0.0]
    for x, ratio in points:
        (ra, err_a), (rb, err_b) = run(x, ratio, a), run(x, ratio, b)
        if err_a or err_b:
            print(f"{x:7.4g} {ratio:6.3g} FAILED: " + "; ".join(
                f"{name}: {err}" for name, err in (("A", err_a), ("B", err_b)) if err), flush=True)
            continue
        total[0] += ra[1]
        total[1] += rb[1]
        print(f"{x:7.4g} {ratio:6.3g} {ra[0]:9.6f} {ra[0] / ra[6] - 1:+8.3%} {rb[0]:9.6f} "
              f"{rb[0] / rb[6] - 1:+8.3%} {ra[1]:6.1f} {rb[1]:6.1f} {rb[1] / ra[1]:5.2f} "
              f"{ra[2]:5d} {rb[2]:5d} {ra[3]:4d} {rb[3]:4d} {ra[4]:4d} {rb[4]:4d}", flush=True)
        if args.jsonl:
            with open(args.jsonl, "a") as fh:
                fh.write(json.dumps({"x": x, "ratio": ratio, "a": a, "b": b, "A": ra, "B": rb,
                                     "provenance": record}) + "\n")
    print(f"sum of times: A {total[0]:.1f} s, B {total[1]:.1f} s, ratio {total[1] / total[0]:.2f}")


if __name__ == "__main__":
    main()
