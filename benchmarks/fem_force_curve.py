"""The secant stiffness curve F(h)/(h P R_c) of one FE point, to see snaps (force drops).

Prints k/PR at h = R/20 and F/(h P R_c) at every indentation step, labelled by the depth in
units of R/20. Usage::

    python benchmarks/fem_force_curve.py X RATIO [--mesh-scale S] [--h-min H] [--steps N]
                                         [--axial-refinement F]

The FE settings are the shipped table's (read from its metadata: mesh scale 3, 1e-9 m under
the tip before scaling, 24 steps); the options override them (``--mesh-scale 1.5`` halves
every element). ``--axial-refinement F`` divides only the axial (meridional) element size at
the crest by F (an experiment: the inflated wall stretches axially by exp(x / (2 ratio)), so
an axially soft wall's elements under the tip are longer than the tip can resolve).
"""

import argparse
import dataclasses

import numpy as np

from turgorbayes import fem, surrogate
from turgorbayes.fem import indentation, indentation_point, mesh, pressure_for_inflation_number
from turgorbayes.surrogate_build import config_from_metadata


def _axially_refined(factor):
    """``capsule_quadrant_mesh`` with the crest's meridional element size divided by ``factor``."""

    def build(R, length, thickness, h_min, h_max, growth, h_bottom, n_thick=1, half=False):
        assert not half
        s_end = 0.5 * length + 0.5 * np.pi * R
        b1 = mesh.graded_breaks(s_end, h_min / factor, h_max, growth)
        quarter = 0.5 * np.pi * R
        top = mesh.graded_breaks(quarter, h_min, h_max, growth)
        bottom = quarter - mesh.graded_breaks(quarter, h_bottom, h_max, growth)[::-1]
        b2 = np.concatenate([top, quarter + bottom[1:]]) / R
        return mesh.shell_mesh(mesh._capsule_surface(R, 0.5 * length), b1, b2, thickness, n_thick)

    return build


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("x", type=float)
    parser.add_argument("ratio", type=float)
    parser.add_argument("--mesh-scale", type=float, default=None)
    parser.add_argument("--h-min", type=float, default=None)
    parser.add_argument("--steps", type=int, default=None)
    parser.add_argument("--axial-refinement", type=float, default=None)
    args = parser.parse_args()
    if args.axial_refinement:
        indentation.capsule_quadrant_mesh = _axially_refined(args.axial_refinement)
    cfg = config_from_metadata(surrogate.load().metadata["fe_config"], fem.CapsuleConfig)
    overrides = {"mesh_scale": args.mesh_scale, "h_min": args.h_min, "n_indent_steps": args.steps}
    cfg = dataclasses.replace(cfg, **{k: v for k, v in overrides.items() if v is not None})
    P = pressure_for_inflation_number(args.x, args.ratio, cfg)
    r = indentation_point(P, args.ratio, cfg)
    h, F = np.asarray(r.h_m)[1:], np.asarray(r.F_N)[1:]
    print(f"x={args.x} ratio={args.ratio} mesh_scale={cfg.mesh_scale} steps={cfg.n_indent_steps} "
          f"axial refinement {args.axial_refinement} "
          f"DOF={r.mesh_dofs} k/PR={r.k_over_PR:.5f} {r.wall_time_s:.0f} s")
    print(" ".join(f"{a * 20 / r.R_c_m:.2f}:{b / (a * P * r.R_c_m):.3f}"
                   for a, b in zip(h, F, strict=True)))


if __name__ == "__main__":
    main()
