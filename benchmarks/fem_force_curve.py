"""The secant stiffness curve F(h)/(h P R_c) of one FE point, to see snaps (force drops).

Prints k/PR at h = R/20 and F/(h P R_c) at every indentation step, labelled by the depth in
units of R/20. Usage::

    python benchmarks/fem_force_curve.py X RATIO [--mesh-scale S] [--h-min H] [--steps N]

The FE settings are the shipped table's (read from its metadata: mesh scale 3, 1e-9 m under
the tip before scaling, 24 steps); the options override them (``--mesh-scale 1.5`` halves
every element).
"""

import argparse
import dataclasses

import numpy as np

from turgorbayes import fem, surrogate
from turgorbayes.fem import indentation_point, pressure_for_inflation_number
from turgorbayes.surrogate_build import config_from_metadata


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("x", type=float)
    parser.add_argument("ratio", type=float)
    parser.add_argument("--mesh-scale", type=float, default=None)
    parser.add_argument("--h-min", type=float, default=None)
    parser.add_argument("--steps", type=int, default=None)
    args = parser.parse_args()
    cfg = config_from_metadata(surrogate.load().metadata["fe_config"], fem.CapsuleConfig)
    overrides = {"mesh_scale": args.mesh_scale, "h_min": args.h_min, "n_indent_steps": args.steps}
    cfg = dataclasses.replace(cfg, **{k: v for k, v in overrides.items() if v is not None})
    P = pressure_for_inflation_number(args.x, args.ratio, cfg)
    r = indentation_point(P, args.ratio, cfg)
    h, F = np.asarray(r.h_m)[1:], np.asarray(r.F_N)[1:]
    print(f"x={args.x} ratio={args.ratio} mesh_scale={cfg.mesh_scale} steps={cfg.n_indent_steps} "
          f"DOF={r.mesh_dofs} k/PR={r.k_over_PR:.5f} {r.wall_time_s:.0f} s")
    print(" ".join(f"{a * 20 / r.R_c_m:.2f}:{b / (a * P * r.R_c_m):.3f}"
                   for a, b in zip(h, F, strict=True)))


if __name__ == "__main__":
    main()
