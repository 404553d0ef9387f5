"""Timing of the capsule model: single points, and a small sweep with 1 and 2 workers.

Prints wall time, Newton iterations and DOFs per point (run one at a time: the 1-worker
sweep), then the same four points in a process pool of 2 workers (each point
single-threaded) and the speed-up. Usage::

    python studies/fem_timing.py [--no-sweep] [--mesh-scale 3] [--h-min 1e-9] [--indent-steps 24]
                                    [--step-tolerance 0.1] [--threads 2] [--points X,RATIO ...]

``--mesh-scale 3 --h-min 1e-9 --indent-steps 24`` are the settings of the shipped surrogate
(``turgorbayes surrogate build --mesh-scale 3 --set h_min=1e-9 --set n_indent_steps=24``:
element sizes x3, but 3 nm under the tip); mesh scale 1 is the finer reference mesh of
``turgorbayes.surrogate.mesh_convergence.MESH_CONVERGENCE``.
"""

import argparse
import time
from concurrent.futures import ProcessPoolExecutor

from turgorbayes import provenance
from turgorbayes.fem import CapsuleConfig, indentation_point, pressure_for_inflation_number

SWEEP = [(0.02, 1.0), (0.0706, 0.457), (0.2, 0.7), (0.5, 0.3)]


def _point(args):
    x, ratio, scale, h_min, steps, tol, threads = args
    opts = {k: v for k, v in (("h_min", h_min), ("n_indent_steps", steps), ("step_tolerance", tol),
                              ("threads", threads)) if v is not None}
    cfg = CapsuleConfig(mesh_scale=scale, **opts)  # None: CapsuleConfig's default
    r = indentation_point(pressure_for_inflation_number(x, ratio, cfg), ratio, cfg)
    return x, ratio, r.k_over_PR, r.wall_time_s, r.newton_iterations, r.mesh_dofs


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-sweep", action="store_true")
    parser.add_argument("--mesh-scale", type=float, default=3.0)
    parser.add_argument("--h-min", type=float, default=None,
                        help="smallest element size before scaling [m] (default: CapsuleConfig's)")
    parser.add_argument("--indent-steps", type=int, default=None,
                        help="indentation steps (default: CapsuleConfig's; the shipped table: 24)")
    parser.add_argument("--step-tolerance", type=float, default=None,
                        help="adaptive depth steps (CapsuleConfig.step_tolerance; default: fixed)")
    parser.add_argument("--threads", type=int, default=None,
                        help="MKL/BLAS threads per point (CapsuleConfig.threads; default 1); the "
                             "2-worker sweep always runs its points single-threaded")
    parser.add_argument("--points", nargs="+", default=None, metavar="X,RATIO",
                        help="points to time instead of the default four")
    args = provenance.add_output_options(parser).parse_args()
    if args.smoke:  # the paper's point on a coarse mesh, one nominal depth step, both loops
        args.points = args.points or ["0.0706,0.457"]
        args.mesh_scale, args.indent_steps = 10.0, 1
    provenance.tee_stdout(args, "fem_timing.txt")
    print(provenance.header_line(), flush=True)
    points = SWEEP if args.points is None else [tuple(map(float, p.split(","))) for p in args.points]
    sweep = [(x, ratio, args.mesh_scale, args.h_min, args.indent_steps, args.step_tolerance,
              args.threads) for x, ratio in points]
    print(f"single points (mesh_scale {args.mesh_scale:g}, h_min {args.h_min}, "
          f"indent steps {args.indent_steps}, step tolerance {args.step_tolerance}, threads "
          f"{args.threads}), one at a time:")
    t0 = time.perf_counter()
    for item in sweep:
        x, ratio, k, t, it, dofs = _point(item)
        print(f"  x={x:<7} ratio={ratio:<6} k/PR={k:.4f}  {t:6.1f} s  {it} Newton iterations  {dofs} DOFs",
              flush=True)
    serial = time.perf_counter() - t0
    print(f"sweep of {len(sweep)} points, 1 worker (the loop above): {serial:.1f} s", flush=True)
    if args.no_sweep:
        return
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=2) as pool:
        list(pool.map(_point, [(*item[:-1], 1) for item in sweep]))
    two = time.perf_counter() - t0
    print(f"sweep of {len(sweep)} points, 2 workers: {two:.1f} s (speed-up {serial / two:.2f}x)",
          flush=True)

if __name__ == "__main__":
    main()
