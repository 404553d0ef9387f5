"""Old vs new FE code on the anchors and three table points, alternating, in one run.

Runs every case with source tree A, then with B, each in a fresh single-threaded process
(same machine load for both), and prints the physical outputs side by side with their
largest relative difference and the time ratio B/A: the anchors of ``studies/fem_anchors.py``
(pinched cylinder, pressurized sphere, capsule inflation) and three points of the shipped
table's settings. Element and DOF numbering may differ between the trees; only physical
outputs are compared (docs/fem.md). Usage::

    python studies/fem_skfem_migration.py /tmp/ref .
"""

import argparse
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from turgorbayes import provenance

POINTS = [(0.005, 1.0), (0.0706, 0.457), (0.3, 1.0)]
ANCHORS = ["pinched", "sphere:0.0", "sphere:0.85", "sphere:1.8", "inflate:0.05:1.0",
           "inflate:0.5:0.3"]
#: A smoke run's FE settings over the table's: a coarse mesh, one nominal depth step (about 1 s).
SMOKE_FE = {"mesh_scale": 10.0, "h_min": 3e-9, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
            "n_indent_steps": 1, "step_tolerance": 0.0}

_CODE = """
import json, math, sys, time
import numpy as np
import turgorbayes
from turgorbayes import fem, surrogate
from turgorbayes.fem import (CapsuleConfig, fe_inflated_radius, indentation_point,
                             pressure_for_inflation_number)
from turgorbayes.fem.anchors import pinched_cylinder, sphere_point_stiffness
try:
    from turgorbayes.surrogate.build import config_from_metadata
except ImportError:  # a tree from before the subpackage layout
    from turgorbayes.surrogate_build import config_from_metadata
case = sys.argv[1].split(":")
t0 = time.perf_counter()
if case[0] == "pinched":
    out = {"wEt/F": pinched_cylinder(h_min=5.0, h_max=25.0)}
elif case[0] == "sphere":
    E, t, R = 20e6, 6e-9, 500e-9
    P = 4 * float(case[1]) * (E * t**2 / math.sqrt(12.0)) / R**2
    r = sphere_point_stiffness(P, R, t, E, h_min=2e-9, h_max=80e-9, load_radius=t)
    out = {"k": r["k"], "R_inflated": r["R_inflated"], "k/k_vella": r["k"] / r["k_vella"]}
elif case[0] == "inflate":
    x, ratio = float(case[1]), float(case[2])
    cfg = CapsuleConfig()
    out = {"R_c": fe_inflated_radius(pressure_for_inflation_number(x, ratio, cfg), ratio, cfg)}
else:
    x, ratio = float(case[1]), float(case[2])
    cfg = config_from_metadata(surrogate.load().metadata["fe_config"], fem.CapsuleConfig)
    if len(sys.argv) > 2:  # settings over the table's (a smoke run's coarse mesh)
        import dataclasses
        cfg = dataclasses.replace(cfg, **json.loads(sys.argv[2]))
    r = indentation_point(pressure_for_inflation_number(x, ratio, cfg), ratio, cfg)
    out = {"x_actual": r.x, "R_c": r.R_c_m, "k/PR": r.k_over_PR, "klin/PR": r.k_linear_over_PR,
           "F(h)": list(np.interp(np.linspace(0, r.h_m[-1], 11), r.h_m, r.F_N)),
           "penetration": r.max_penetration_m, "iterations": r.newton_iterations}
out["seconds"] = time.perf_counter() - t0
print(json.dumps([out, turgorbayes.__file__]))
"""


def run(tree, case, overrides=None):
    """Outputs of one case computed with the package in ``tree`` (see fem_ab_timing.py)."""
    tree = Path(tree).resolve()
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    extra = [json.dumps(overrides)] if overrides else []
    out = subprocess.run([sys.executable, "-c", _CODE, case, *extra], env=env, cwd=tree,
                         capture_output=True, text=True, check=True)
    result, path = json.loads(out.stdout.strip().splitlines()[-1])
    if not Path(path).resolve().is_relative_to(tree):
        raise RuntimeError(f"the child for tree {tree} imported {path}")
    return result


def _rel(a, b):
    a, b = np.atleast_1d(a), np.atleast_1d(b)
    scale = np.maximum(np.abs(a).max(), 1e-300)
    return float(np.max(np.abs(a - b)) / scale)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tree_a", nargs="?", help="source tree A (the reference)")
    parser.add_argument("tree_b", nargs="?", help="source tree B")
    parser.add_argument("--cases", nargs="+", default=None,
                        help="cases to run (default: all anchors and points)")
    args = provenance.add_output_options(parser).parse_args()
    cases = args.cases or ANCHORS + [f"point:{x}:{r}" for x, r in POINTS]
    overrides = None
    if args.smoke:  # this tree against itself, the paper's point on a coarse mesh
        root = str(Path(__file__).resolve().parents[1])
        args.tree_a, args.tree_b = args.tree_a or root, args.tree_b or root
        cases, overrides = args.cases or ["point:0.0706:0.457"], SMOKE_FE
    if not (args.tree_a and args.tree_b):
        parser.error("give TREE_A and TREE_B")
    provenance.tee_stdout(args, "fem_skfem_migration.txt")
    print(provenance.header_line(), flush=True)
    worst, total = 0.0, [0.0, 0.0]
    for case in cases:
        a, b = run(args.tree_a, case, overrides), run(args.tree_b, case, overrides)
        total[0] += a["seconds"]
        total[1] += b["seconds"]
        print(f"{case}: time A {a['seconds']:.1f} s, B {b['seconds']:.1f} s, "
              f"B/A {b['seconds'] / a['seconds']:.2f}", flush=True)
        for key in a:
            if key == "seconds":
                continue
            rel = _rel(a[key], b[key])
            if key != "iterations":
                worst = max(worst, rel)
            va, vb = np.atleast_1d(a[key])[-1], np.atleast_1d(b[key])[-1]
            print(f"  {key:12s} A {va:.10g}  B {vb:.10g}  max rel diff {rel:.2e}", flush=True)
    print(f"largest relative difference: {worst:.2e}; sum of times A {total[0]:.1f} s, "
          f"B {total[1]:.1f} s, B/A {total[1] / total[0]:.2f}")


if __name__ == "__main__":
    main()
