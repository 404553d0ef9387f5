"""A/B timing of two versions of the FE code on the same points, alternating, in one run.

Runs each point of the timing sweep with source tree A, then with B, each in a fresh
single-threaded process (so the two see the same machine load), and prints k/PR, wall time
and Newton iterations side by side with the time ratio B/A. Use it to show that a speed-up
of the FE code leaves the results unchanged. The settings are the shipped table's, read from
its metadata by each tree (mesh scale 3, 3 nm under the tip, 24 indentation steps). Usage::

    git worktree add /tmp/before HEAD~1
    python studies/fem_ab_timing.py /tmp/before .
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
            "n_indent_steps": 1, "step_tolerance": 0.0}

_CODE = """
import json, sys
from turgorbayes import fem, surrogate
from turgorbayes.fem import indentation_point, pressure_for_inflation_number
try:
    from turgorbayes.surrogate.build import config_from_metadata
except ImportError:  # a tree from before the subpackage layout
    from turgorbayes.surrogate_build import config_from_metadata
import turgorbayes
x, ratio = float(sys.argv[1]), float(sys.argv[2])
cfg = config_from_metadata(surrogate.load().metadata["fe_config"], fem.CapsuleConfig)
if len(sys.argv) > 3:  # settings over the table's (a smoke run's coarse mesh)
    import dataclasses
    cfg = dataclasses.replace(cfg, **json.loads(sys.argv[3]))
r = indentation_point(pressure_for_inflation_number(x, ratio, cfg), ratio, cfg)
print(json.dumps([r.k_over_PR, r.wall_time_s, r.newton_iterations, turgorbayes.__file__]))
"""


def run(tree, x, ratio, overrides=None):
    """(k/PR, seconds, iterations) of one point computed with the package in ``tree``.

    The child runs *in* ``tree``: ``python -c`` puts its working directory first on
    ``sys.path``, ahead of PYTHONPATH, so a child started elsewhere (e.g. in the other tree)
    would import that directory's package instead. The child reports the file it imported,
    and the run stops if it is not the tree's.
    """
    tree = Path(tree).resolve()
    env = {**os.environ, "PYTHONPATH": str(tree), "OMP_NUM_THREADS": "1",
           "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    extra = [json.dumps(overrides)] if overrides else []
    out = subprocess.run([sys.executable, "-c", _CODE, str(x), str(ratio), *extra], env=env, cwd=tree,
                         capture_output=True, text=True, check=True)
    k, t, it, path = json.loads(out.stdout.strip().splitlines()[-1])
    if not Path(path).resolve().is_relative_to(tree):
        raise RuntimeError(f"the child for tree {tree} imported {path}")
    return k, t, it


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tree_a", nargs="?", help="source tree A (the reference)")
    parser.add_argument("tree_b", nargs="?", help="source tree B")
    args = provenance.add_output_options(parser).parse_args()
    sweep, overrides = SWEEP, None
    if args.smoke:  # this tree against itself, the paper's point on the coarsest mesh
        root = str(Path(__file__).resolve().parents[1])
        args.tree_a, args.tree_b = args.tree_a or root, args.tree_b or root
        sweep, overrides = SWEEP[1:2], SMOKE_FE
    if not (args.tree_a and args.tree_b):
        parser.error("give TREE_A and TREE_B")
    provenance.tee_stdout(args, "fem_ab_timing.txt")
    print(provenance.header_line(), flush=True)
    print(f"{'x':>7} {'ratio':>6} {'k/PR A':>10} {'k/PR B':>10} {'s A':>7} {'s B':>7} "
          f"{'B/A':>6} {'it A':>5} {'it B':>5}", flush=True)
    total = [0.0, 0.0]
    for x, ratio in sweep:
        (ka, ta, ia), (kb, tb, ib) = (run(tree, x, ratio, overrides) for tree in (args.tree_a, args.tree_b))
        total[0] += ta
        total[1] += tb
        print(f"{x:7.4g} {ratio:6.3g} {ka:10.6f} {kb:10.6f} {ta:7.1f} {tb:7.1f} {tb / ta:6.2f} "
              f"{ia:5d} {ib:5d}", flush=True)
    print(f"sum of times: A {total[0]:.1f} s, B {total[1]:.1f} s, B/A {total[1] / total[0]:.2f}")


if __name__ == "__main__":
    main()
