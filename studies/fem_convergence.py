"""Mesh convergence of k/(P R_c) of the capsule model (docs/fem.md, Verification).

For each inflation number, runs the production mesh (mesh_scale = 1) and meshes with smaller
elements (mesh_scale = 0.5: half the element size in the wall's plane; n_thick = 2: two
elements through the wall), and prints k/(P R_c), the linear stiffness, DOFs and time side
by side with the relative differences. Usage::

    python studies/fem_convergence.py [x ...] [--ratio R] [--variants NAME ...]

Results go into ``turgorbayes.surrogate.mesh_convergence.MESH_CONVERGENCE``: append the output
to ``studies/results/fem_convergence_tip_mesh.txt`` and run
``scripts/fill_mesh_convergence.py``.
"""

import argparse
import json

from turgorbayes import provenance
from turgorbayes.fem import CapsuleConfig, indentation_point, pressure_for_inflation_number

#: A smoke run's FE settings: a coarse mesh, one nominal depth step (about 1 s a point).
SMOKE_FE = {"mesh_scale": 10.0, "h_min": 3e-9, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
            "n_indent_steps": 1, "step_tolerance": 0.0}
VARIANTS = {
    "production": {},
    "half_size": {"mesh_scale": 0.5},
    "two_layers": {"n_thick": 2},
    "coarse_1.5": {"mesh_scale": 1.5},
    "growth_0.5": {"growth": 0.5},
    "penalty_x4": {"penalty": 4e17, "support_penalty": 4e17},
    # the shipped surrogate's mesh (turgorbayes surrogate build --mesh-scale 3) and its halving
    "scale_3": {"mesh_scale": 3.0},
    "scale_1.5": {"mesh_scale": 1.5},
    # the same, with the element size at the indenter kept at 3 nm / 1.5 nm (h_min scaled back)
    "scale_3_tip": {"mesh_scale": 3.0, "h_min": 1e-9},
    "scale_1.5_tip": {"mesh_scale": 1.5, "h_min": 1e-9},
    "scale_0.75_tip": {"mesh_scale": 0.75, "h_min": 1e-9},
    # ... and also along the bottom line (substrate contact: 12 nm / 6 nm)
    "scale_3_tipbot": {"mesh_scale": 3.0, "h_min": 1e-9, "h_bottom": 4e-9},
    "scale_1.5_tipbot": {"mesh_scale": 1.5, "h_min": 1e-9, "h_bottom": 4e-9},
    "scale_3_tip_hmax": {"mesh_scale": 3.0, "h_min": 1e-9, "h_max": 40e-9},
    "scale_3_tip_growth": {"mesh_scale": 3.0, "h_min": 1e-9, "growth": 0.125},
    # candidate surrogate mesh: 3 nm at the tip, 12 nm along the substrate, 120 nm far away
    "tip_mesh": {"mesh_scale": 3.0, "h_min": 1e-9, "h_max": 40e-9, "h_bottom": 4e-9},
    "tip_mesh_half": {"mesh_scale": 1.5, "h_min": 1e-9, "h_max": 40e-9, "h_bottom": 4e-9},
}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("x", nargs="*", type=float, default=[0.01, 0.07, 0.5])
    parser.add_argument("--ratio", type=float, default=1.0)
    parser.add_argument("--variants", nargs="+", default=["production", "half_size", "two_layers"])
    args = provenance.add_output_options(parser).parse_args()
    smoke = {}
    if args.smoke:  # one point, the production and two-layer variants on a coarse mesh
        args.x, args.variants, smoke = args.x[1:2], ["production", "two_layers"], SMOKE_FE
    provenance.tee_stdout(args, "fem_convergence.txt")
    print(provenance.header_line(), flush=True)
    rows = []
    for x in args.x:
        ref = None
        for name in args.variants:
            cfg = CapsuleConfig(**{**VARIANTS[name], **smoke})
            P = pressure_for_inflation_number(x, args.ratio, cfg)
            r = indentation_point(P, args.ratio, cfg)
            ref = ref or r
            row = {"x_target": x, "variant": name, "x": r.x, "k_over_PR": r.k_over_PR,
                   "k_linear_over_PR": r.k_linear_over_PR, "dofs": r.mesh_dofs,
                   "iterations": r.newton_iterations, "wall_time_s": r.wall_time_s,
                   "rel_diff_k": r.k_over_PR / ref.k_over_PR - 1,
                   "rel_diff_k_linear": r.k_linear_over_PR / ref.k_linear_over_PR - 1}
            rows.append(row)
            print(f"x={x:<6} {name:<12} k/PR={r.k_over_PR:.5f} ({100 * row['rel_diff_k']:+.2f}%) "
                  f"klin/PR={r.k_linear_over_PR:.5f} ({100 * row['rel_diff_k_linear']:+.2f}%) "
                  f"dofs={r.mesh_dofs} it={r.newton_iterations} t={r.wall_time_s:.1f}s", flush=True)
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
