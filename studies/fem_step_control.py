"""Fixed against adaptive depth steps, on the timing points, alternating, in one run.

For each point of the timing sweep, runs the shipped table's FE settings (read from its
metadata: mesh scale 3, 3 nm under the tip, 24 fixed indentation steps) and the same settings
with adaptive depth steps (``CapsuleConfig.step_tolerance``), each in a fresh single-threaded
process, and prints k/PR, wall time, Newton iterations and depth steps side by side, with the
time ratio adaptive/fixed and the relative difference in k/PR. Usage::

    python studies/fem_step_control.py [--tol 0.1] [--points X,RATIO ...]
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

from turgorbayes import provenance

SWEEP = [(0.02, 1.0), (0.0706, 0.457), (0.2, 0.7), (0.5, 0.3)]
#: A smoke run's FE settings over the table's: a coarse mesh, one nominal depth step (about 1 s).
SMOKE_FE = {"mesh_scale": 10.0, "h_min": 3e-9, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
            "n_indent_steps": 1}

_CODE = """
import dataclasses, json, sys
from turgorbayes import fem, surrogate
from turgorbayes.fem import indentation_point, pressure_for_inflation_number
from turgorbayes.surrogate.build import config_from_metadata
x, ratio, tol = float(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3])
cfg = config_from_metadata(surrogate.load().metadata["fe_config"], fem.CapsuleConfig)
cfg = dataclasses.replace(cfg, step_tolerance=tol)
if len(sys.argv) > 4:  # settings over the table's (a smoke run's coarse mesh)
    cfg = dataclasses.replace(cfg, **json.loads(sys.argv[4]))
r = indentation_point(pressure_for_inflation_number(x, ratio, cfg), ratio, cfg)
print(json.dumps([r.k_over_PR, r.wall_time_s, r.newton_iterations, len(r.h_m) - 1]))
"""


def run(x, ratio, tol, overrides=None):
    """(k/PR, seconds, iterations, steps) of one point in a fresh single-threaded process."""
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": str(root), "OMP_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    extra = [json.dumps(overrides)] if overrides else []
    out = subprocess.run([sys.executable, "-c", _CODE, str(x), str(ratio), str(tol), *extra], env=env,
                         cwd=root, capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tol", type=float, default=0.1, help="step_tolerance of the adaptive runs")
    parser.add_argument("--points", nargs="*", default=None, help="X,RATIO pairs (default: the timing sweep)")
    args = provenance.add_output_options(parser).parse_args()
    points = SWEEP if not args.points else [tuple(map(float, p.split(","))) for p in args.points]
    overrides = None
    if args.smoke:  # the paper's point on the coarsest mesh
        points, overrides = points[1:2] if not args.points else points[:1], SMOKE_FE
    provenance.tee_stdout(args, "fem_step_control.txt")
    print(provenance.header_line(), flush=True)
    print(f"fixed = the shipped table's 24 steps; adaptive = step_tolerance {args.tol:g}")
    print(f"{'x':>7} {'ratio':>6} {'k fixed':>9} {'k adapt':>9} {'dk':>8} {'s fixed':>8} "
          f"{'s adapt':>8} {'ratio':>6} {'it f':>5} {'it a':>5} {'steps f':>7} {'steps a':>7}",
          flush=True)
    total = [0.0, 0.0]
    for x, ratio in points:
        (kf, tf, itf, nf), (ka, ta, ita, na) = run(x, ratio, 0.0, overrides), run(x, ratio, args.tol, overrides)
        total[0] += tf
        total[1] += ta
        print(f"{x:7.4g} {ratio:6.3g} {kf:9.6f} {ka:9.6f} {ka / kf - 1:+8.2%} {tf:8.1f} {ta:8.1f} "
              f"{ta / tf:6.2f} {itf:5d} {ita:5d} {nf:7d} {na:7d}", flush=True)
    print(f"sum of times: fixed {total[0]:.1f} s, adaptive {total[1]:.1f} s, "
          f"ratio {total[1] / total[0]:.2f}")


if __name__ == "__main__":
    main()
