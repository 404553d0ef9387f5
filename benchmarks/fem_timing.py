"""Timing of the capsule model: one production point, and a small sweep with 1 and 2 workers.

Prints wall time, Newton iterations and DOFs per point; the sweep part runs the same four
points in a process pool of 1 and of 2 workers (each point single-threaded). Usage::

    python benchmarks/fem_timing.py [--no-sweep]
"""

import argparse
import time
from concurrent.futures import ProcessPoolExecutor

from turgorbayes.fem import CapsuleConfig, indentation_point, pressure_for_inflation_number

SWEEP = [(0.02, 1.0), (0.0706, 0.457), (0.2, 0.7), (0.5, 0.3)]


def _point(args):
    x, ratio = args
    cfg = CapsuleConfig()
    r = indentation_point(pressure_for_inflation_number(x, ratio, cfg), ratio, cfg)
    return x, ratio, r.k_over_PR, r.wall_time_s, r.newton_iterations, r.mesh_dofs


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-sweep", action="store_true")
    args = parser.parse_args()
    print("single points (production mesh):")
    for item in SWEEP:
        x, ratio, k, t, it, dofs = _point(item)
        print(f"  x={x:<7} ratio={ratio:<6} k/PR={k:.4f}  {t:6.1f} s  {it} Newton iterations  {dofs} DOFs",
              flush=True)
    if args.no_sweep:
        return
    for workers in (1, 2):
        t0 = time.perf_counter()
        with ProcessPoolExecutor(max_workers=workers) as pool:
            list(pool.map(_point, SWEEP))
        print(f"sweep of {len(SWEEP)} points, {workers} worker(s): {time.perf_counter() - t0:.1f} s",
              flush=True)


if __name__ == "__main__":
    main()
