"""The indenter's tip radius in the FE model: is the tip resolved, and how much does it matter?

For each tip radius, runs one point on meshes that differ only under the tip (mesh_scale 3,
36 nm along the substrate, 240 nm far away; 3 / 1.5 / 0.75 nm elements under the tip: the
variants ``tip_mesh``, ``tip_half`` (the tip-radius tables' mesh, 24,633 DOF) and
``tip_quarter``), and prints k/(P R_c), the linear stiffness, DOFs and time side by side, the
relative differences from the first variant run (docs/fem.md, "Indenter tip radius"). Usage::

    python studies/fem_tip_radius.py --tips 3 30 [--x 0.0706] [--ratio 0.457] [--out F]
        [--variants tip_half] [--thickness-nm 3]

(``--thickness-nm``: another wall thickness, to measure whether tip radius and thickness act
independently, as ``turgorbayes.surrogate.load`` assumes when both are changed.)

One JSON line per run is appended to ``--out`` (default ``fem_tip_radius.jsonl`` in
``studies/output``, or ``studies/results`` with ``--update``).
"""

import argparse
import json

from turgorbayes import provenance
from turgorbayes.fem import CapsuleConfig, indentation_point, pressure_for_inflation_number

#: the tip-radius tables' depth steps and mesh apart from the elements under the tip
MESH = {"mesh_scale": 3.0, "h_min": 1e-9, "n_indent_steps": 24, "step_tolerance": 0.1,
        "adaptive_below_x": 0.4}
VARIANTS = {"tip_mesh": {}, "tip_half": {"h_min": 0.5e-9}, "tip_quarter": {"h_min": 0.25e-9}}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tips", nargs="+", type=float, default=[3.0, 30.0], help="[nm]")
    parser.add_argument("--x", type=float, default=0.0706)
    parser.add_argument("--ratio", type=float, default=0.457)
    parser.add_argument("--variants", nargs="+", default=list(VARIANTS))
    parser.add_argument("--thickness-nm", type=float, default=6.0)
    parser.add_argument("--out", default=None,
                        help="JSON-lines file (default: fem_tip_radius.jsonl in --output-dir, or in "
                             "studies/results with --update)")
    provenance.add_output_options(parser)
    args = parser.parse_args()
    mesh = MESH
    if args.smoke:  # one tip, two variants, a coarse mesh with one nominal depth step
        args.tips, args.variants = args.tips[-1:], list(VARIANTS)[:2]
        mesh = {**MESH, "mesh_scale": 20.0, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
                "n_indent_steps": 1, "step_tolerance": 0.0}
    args.out = args.out or str(provenance.study_path(args, "fem_tip_radius.jsonl"))
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    for tip in args.tips:
        ref = None
        for name in args.variants:
            cfg = CapsuleConfig(**{**mesh, **VARIANTS[name], "tip_radius": tip * 1e-9,
                                   "thickness": args.thickness_nm * 1e-9})
            P = pressure_for_inflation_number(args.x, args.ratio, cfg)
            r = indentation_point(P, args.ratio, cfg)
            ref = ref or r
            row = {"tip_nm": tip, "thickness_nm": args.thickness_nm, "x_target": args.x,
                   "ratio": args.ratio, "variant": name,
                   "x": r.x, "k_over_PR": r.k_over_PR, "k_linear_over_PR": r.k_linear_over_PR,
                   "dofs": r.mesh_dofs, "wall_time_s": r.wall_time_s,
                   "rel_diff_k": r.k_over_PR / ref.k_over_PR - 1,
                   "rel_diff_k_linear": r.k_linear_over_PR / ref.k_linear_over_PR - 1}
            print(f"tip {tip:5.1f} nm  t {args.thickness_nm:g} nm  {name:9s} "
                  f"k/PR {r.k_over_PR:.5f} ({row['rel_diff_k']:+.2%})"
                  f"  linear {r.k_linear_over_PR:.5f} ({row['rel_diff_k_linear']:+.2%})"
                  f"  {r.mesh_dofs} DOF  {r.wall_time_s:.0f} s", flush=True)
            with open(args.out, "a") as fh:
                fh.write(json.dumps(dict(row, provenance=record)) + "\n")


if __name__ == "__main__":
    main()
