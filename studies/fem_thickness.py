"""Thickness study: k/(P R_c) at fixed E t for t = 3, 4.5, 6, 9 nm at two inflation numbers.

The thin-shell scaling of the paper (supplement, "Scaling laws") says k/(P R) depends only
on x = P R/(E t), the anisotropy and the tip size; bending (B = E t^3/12) adds t/R. If the
spread exceeds 2%, the surrogate needs a t/R axis. Usage::

    python studies/fem_thickness.py [--x 0.02 0.2] [--ratio 1.0]
"""

import argparse
import json

from turgorbayes import provenance
from turgorbayes.fem import CapsuleConfig, indentation_point, pressure_for_inflation_number

E_T = 0.12  # N/m, the paper's E t
#: A smoke run's FE settings: a coarse mesh, one nominal depth step (about 1 s a point).
SMOKE_FE = {"mesh_scale": 10.0, "h_min": 3e-9, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
            "n_indent_steps": 1, "step_tolerance": 0.0}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--x", nargs="+", type=float, default=[0.02, 0.2])
    parser.add_argument("--ratio", type=float, default=1.0)
    parser.add_argument("--t-nm", nargs="+", type=float, default=[3.0, 4.5, 6.0, 9.0])
    parser.add_argument("--mesh-scale", type=float, default=1.0)
    args = provenance.add_output_options(parser).parse_args()
    smoke = {}
    if args.smoke:  # one point, 4.5 and 6 nm (the reference), on a coarse mesh
        args.x, args.t_nm = args.x[:1], [4.5, 6.0]
        args.mesh_scale, smoke = SMOKE_FE["mesh_scale"], {k: v for k, v in SMOKE_FE.items()
                                                          if k != "mesh_scale"}
    provenance.tee_stdout(args, "fem_thickness.txt")
    print(provenance.header_line(), flush=True)
    rows = []
    for x in args.x:
        ref = None
        for t_nm in args.t_nm:
            t = t_nm * 1e-9
            # same element sizes for every t; the penalty scales with E like the wall
            cfg = CapsuleConfig(thickness=t, E_perp=E_T / t, penalty=1e17 * 6e-9 / t,
                                support_penalty=1e17 * 6e-9 / t, mesh_scale=args.mesh_scale,
                                **smoke)
            P = pressure_for_inflation_number(x, args.ratio, cfg)
            r = indentation_point(P, args.ratio, cfg)
            ref = r if t_nm == 6.0 else ref
            rows.append({"x_target": x, "t_nm": t_nm, "x": r.x, "k_over_PR": r.k_over_PR,
                         "k_linear_over_PR": r.k_linear_over_PR, "wall_time_s": r.wall_time_s})
            print(f"x={x:<5} t={t_nm:>4} nm  E={cfg.E_perp / 1e6:6.2f} MPa  x_FE={r.x:.4f}  "
                  f"k/PR={r.k_over_PR:.4f}  klin/PR={r.k_linear_over_PR:.4f}  {r.wall_time_s:.0f}s",
                  flush=True)
        ks = [row["k_over_PR"] for row in rows if row["x_target"] == x]
        print(f"x={x}: spread (max-min)/value at 6 nm = {100 * (max(ks) - min(ks)) / ref.k_over_PR:.2f}%")
    print(json.dumps(rows))


if __name__ == "__main__":
    main()
