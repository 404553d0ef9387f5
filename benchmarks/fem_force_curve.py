"""The secant stiffness curve F(h)/(h P R_c) of one FE point, to see snaps (force drops).

Prints k/PR at h = R/20 and F/(h P R_c) at every indentation step, labelled by the depth in
units of R/20. Usage::

    python benchmarks/fem_force_curve.py X RATIO [--mesh-scale 3] [--h-min 1e-9] [--steps 24]

The defaults are the shipped table's FE settings; ``--mesh-scale 1.5`` halves every element.
"""

import argparse

import numpy as np

from turgorbayes.fem import CapsuleConfig, indentation_point, pressure_for_inflation_number


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("x", type=float)
    parser.add_argument("ratio", type=float)
    parser.add_argument("--mesh-scale", type=float, default=3.0)
    parser.add_argument("--h-min", type=float, default=1e-9)
    parser.add_argument("--steps", type=int, default=24)
    args = parser.parse_args()
    cfg = CapsuleConfig(mesh_scale=args.mesh_scale, h_min=args.h_min, n_indent_steps=args.steps)
    P = pressure_for_inflation_number(args.x, args.ratio, cfg)
    r = indentation_point(P, args.ratio, cfg)
    h, F = np.asarray(r.h_m)[1:], np.asarray(r.F_N)[1:]
    print(f"x={args.x} ratio={args.ratio} mesh_scale={args.mesh_scale} steps={args.steps} "
          f"DOF={r.mesh_dofs} k/PR={r.k_over_PR:.5f} {r.wall_time_s:.0f} s")
    print(" ".join(f"{a * 20 / r.R_c_m:.2f}:{b / (a * P * r.R_c_m):.3f}"
                   for a, b in zip(h, F, strict=True)))


if __name__ == "__main__":
    main()
