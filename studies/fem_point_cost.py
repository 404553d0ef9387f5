"""Where one FE table point spends its time, and its cost in sparse factorizations.

Runs one point (default: the paper's physiological point, x = 0.0706, E_par/E_perp = 0.457)
with the shipped table's settings (``turgorbayes.fem.TABLE_SETTINGS``), once with the fixed
24-step schedule and once with the table's default (adaptive depth steps below x = 0.4), each
under cProfile, and times one sparse LU factorization (PARDISO, or SuperLU without pypardiso)
of the tangent of the same mesh at the inflated state. Prints, per schedule: wall time, depth
steps, Newton iterations, factorizations, the time in the element kernels, sparse assembly,
factorization + solves, pressure and contact loads, and the point's time over one
factorization (a ratio, which the machine's load changes much less than seconds). Usage::

    python studies/fem_point_cost.py [--x 0.0706] [--ratio 0.457] [--settings JSON] [--out FILE.json]

``--settings '{"h_bottom": 1.2e-8, "h_max": 8e-8}'`` runs the 2026-11-23 table's mesh instead.
"""

import argparse
import cProfile
import json
import pstats
import time

import numpy as np

from turgorbayes import fem, provenance
from turgorbayes.fem import indentation as ind
from turgorbayes.fem.material import orthotropic_stiffness

#: A smoke run's FE settings over the table's: a coarse mesh, one nominal depth step (about 1 s).
SMOKE_FE = {"mesh_scale": 10.0, "h_min": 3e-9, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
            "n_indent_steps": 1}
#: Functions whose cumulative time is reported (module file suffix, function name).
PARTS = {
    "element kernels (residual + tangent)": ("assembly.py", "internal_force_and_tangent"),
    "sparse assembly": ("assembly.py", "matrix"),
    "factorization + solve": ("solver.py", "solve"),
    "solve with a reused factorization": ("solver.py", "resolve"),
    "follower pressure": ("loads.py", "pressure_load"),
    "indenter contact": ("contact.py", "indenter_contact"),
    "substrate contact": ("contact.py", "plane_contact"),
    "inflation (all of it)": ("indentation.py", "_inflate"),
    "indentation (all of it)": ("indentation.py", "_indent_with_fallback"),
}


def _profiled_point(cfg, P, ratio):
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    r = fem.indentation_point(P, ratio, cfg)
    prof.disable()
    wall = time.perf_counter() - t0
    stats = pstats.Stats(prof).stats
    parts = {}
    for label, (suffix, name) in PARTS.items():
        parts[label] = sum(v[3] for (f, _, fn), v in stats.items() if f.endswith(suffix) and fn == name)
    n_fact = sum(v[1] for (f, _, fn), v in stats.items() if f.endswith("solver.py") and fn == "solve")
    return r, wall, parts, n_fact


def _one_factorization(cfg, P, ratio, repeats=3):
    """Median time of factorizing (and solving with) the inflated capsule's tangent, after
    the symbolic analysis (done once per pattern in a run, as in Newton's iterations)."""
    from turgorbayes.fem.solver import LinearSolver

    with ind.threadpool_limits(limits=cfg.threads):
        model = ind.capsule_model(cfg, P, ratio)
        D = orthotropic_stiffness(cfg.E_perp, ratio * cfg.E_perp, cfg.E_perp, cfg.nu)
        u, _ = ind.inflate(model, P, ratio, D, cfg)
        problem = model.problem
        pat = problem.pattern(model.fixed[cfg.support])
        _, A, _ = problem.residual_and_tangent(u, D, pat, P, (), None)
        b = np.ones(A.shape[0])
        solver = LinearSolver(cfg.solver)
        t0 = time.perf_counter()
        solver.solve(A, b, pat.key)  # symbolic analysis + factorization + one solve
        t_first = time.perf_counter() - t0
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            solver.solve(A, b, pat.key)  # factorization + one solve
            times.append(time.perf_counter() - t0)
        solver.close()
    return float(np.median(times)), t_first, int(A.shape[0]), int(A.nnz)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--x", type=float, default=0.0706)
    parser.add_argument("--ratio", type=float, default=0.457)
    parser.add_argument("--out", default=None, help="also write the numbers as JSON")
    parser.add_argument("--settings", default="{}",
                        help="JSON object of settings over the table's, for both schedules")
    args = provenance.add_output_options(parser).parse_args()
    provenance.tee_stdout(args, "fem_point_cost.txt")
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    over = json.loads(args.settings)
    if args.smoke:  # a coarse mesh, one nominal depth step
        over = {**SMOKE_FE, **over}
    table = fem.table_config(**over)
    P = fem.pressure_for_inflation_number(args.x, args.ratio, table)
    t_fact, t_first, n, nnz = _one_factorization(table, P, args.ratio)
    print(f"point x = {args.x}, ratio = {args.ratio}; mesh {n} free DOF, tangent {nnz} nonzeros; "
          f"one factorization + solve: {t_fact:.3f} s (the first, with the symbolic analysis: "
          f"{t_first:.3f} s)", flush=True)
    rows = {}
    print(f"settings over the table's: {over or 'none'}")
    for label, cfg in (("fixed 24 steps", fem.table_config(**{**over, "step_tolerance": 0.0})),
                       ("table default", table)):
        r, wall, parts, n_fact = _profiled_point(cfg, P, args.ratio)
        rows[label] = {"wall_s": wall, "k_over_PR": r.k_over_PR, "schedule": r.schedule,
                       "depth_steps": len(r.h_m) - 1, "newton_iterations": r.newton_iterations,
                       "factorizations": n_fact, "parts_s": parts,
                       "point_over_factorization": wall / t_fact}
        print(f"\n{label} ({r.schedule}): {wall:.1f} s under the profiler = "
              f"{wall / t_fact:.0f} factorizations; k/PR {r.k_over_PR:.6f}; {len(r.h_m) - 1} "
              f"depth steps, {r.newton_iterations} Newton iterations, {n_fact} factorizations",
              flush=True)
        for part, t in parts.items():
            print(f"  {part:<38s} {t:7.1f} s  {100 * t / wall:5.1f} %")
    a, b = rows["fixed 24 steps"], rows["table default"]
    print(f"\ntable default / fixed: time {b['wall_s'] / a['wall_s']:.2f}, k/PR "
          f"{b['k_over_PR'] / a['k_over_PR'] - 1:+.2e}")
    if args.out:
        with open(args.out, "w") as fh:
            json.dump({"x": args.x, "ratio": args.ratio, "settings": over,
                       "factorization_s": t_fact,
                       "first_factorization_with_analysis_s": t_first,
                       "free_dofs": n, "nnz": nnz, "rows": rows, "provenance": record}, fh,
                      indent=1)


if __name__ == "__main__":
    main()
