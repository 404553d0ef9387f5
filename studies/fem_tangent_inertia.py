"""Stability along an indentation: negative eigenvalues of the tangent's symmetric part.

Runs one point with the shipped table's FE settings and the ``"pardiso_sym"`` solver, whose
LDL^T factorizations report their inertia, and prints for every converged depth step the
depth and F/h relative to its final value, and, for every Newton solve in order (each
depth step's, then its contact updates'), the number of negative eigenvalues of its first
factorization (the tangent at the predicted state; later factorizations may be LU,
which report none). Zero everywhere: the loading path is stable; a
positive count where F/h falls: the snap is an instability of the discrete model, not a
solver artefact. Usage::

    python studies/fem_tangent_inertia.py X RATIO
"""

import argparse
import dataclasses

import numpy as np

from turgorbayes import fem, provenance, surrogate
from turgorbayes.fem import indentation_point, pressure_for_inflation_number
from turgorbayes.fem import solver as fem_solver
from turgorbayes.surrogate.build import config_from_metadata

#: A smoke run's FE settings: a coarse mesh, one nominal depth step (about 1 s a point).
SMOKE_FE = {"mesh_scale": 10.0, "h_min": 3e-9, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
            "n_indent_steps": 1, "step_tolerance": 0.0}


def _recording(log):
    """Wrap ShellProblem.newton to log the inertia of each solve's first factorization."""
    newton = fem_solver.ShellProblem.newton
    solve = fem_solver.LinearSolver.solve

    def solve_logged(self, A, b, key):
        x = solve(self, A, b, key)
        log["current"].append(self.negative_eigenvalues)
        return x

    def newton_logged(self, u, *args, **kwargs):
        log["current"] = []
        out = newton(self, u, *args, **kwargs)
        first = log["current"][0] if log["current"] else None
        log["solves"].append((bool(kwargs.get("bodies")), first))
        return out

    fem_solver.LinearSolver.solve = solve_logged
    fem_solver.ShellProblem.newton = newton_logged


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("x", type=float, nargs="?")
    parser.add_argument("ratio", type=float, nargs="?")
    args = provenance.add_output_options(parser).parse_args()
    if args.smoke:  # the paper's point on a coarse mesh
        args.x = 0.0706 if args.x is None else args.x
        args.ratio = 0.457 if args.ratio is None else args.ratio
    if args.x is None or args.ratio is None:
        parser.error("give X and RATIO")
    provenance.tee_stdout(args, "fem_tangent_inertia.txt")
    print(provenance.header_line(), flush=True)
    cfg = config_from_metadata(surrogate.load().metadata["fe_config"], fem.CapsuleConfig)
    cfg = dataclasses.replace(cfg, solver="pardiso_sym", **(SMOKE_FE if args.smoke else {}))
    log = {"solves": [], "current": []}
    _recording(log)
    r = indentation_point(pressure_for_inflation_number(args.x, args.ratio, cfg), args.ratio, cfg)
    print(f"x = {r.x:.4g}, ratio = {args.ratio:g}: k/PR = {r.k_over_PR:.5f}, "
          f"{len(r.h_m) - 1} steps, {r.wall_time_s:.0f} s")
    print("the inflation solves' first factorizations:",
          [neg for contact, neg in log["solves"] if not contact])
    # indentation solves: each depth step's first solve, then its contact (Uzawa) updates;
    # a step's own solve is the one whose depth is new, so pair by order with the steps
    indent = [neg for contact, neg in log["solves"] if contact]
    kh = r.F_N[1:] / r.h_m[1:]
    print(" h/h_end   F/h rel  negative eigenvalues (first)")
    print("  all solves in order:", indent)
    for h, v in zip(r.h_m[1:] / r.h_m[-1], kh / kh[-1], strict=True):
        print(f"  {h:6.3f}  {v:8.4f}")
    print(f"solves with a negative eigenvalue: {sum(1 for n in indent if n)} of {len(indent)}; "
          f"largest count {max((n for n in indent if n is not None), default=0)}")
    dips = np.flatnonzero(np.diff(r.F_N) < 0)
    print(f"steps where the force falls: {len(dips)} (first at h/h_end = "
          f"{(r.h_m / r.h_m[-1])[dips[0] + 1]:.3f})" if len(dips) else "the force never falls")


if __name__ == "__main__":
    main()
