"""Mesh error of the table's FE settings at the corners of the extended table domain.

For each (x, E_par/E_perp) runs the table's mesh (``turgorbayes.fem.TABLE_SETTINGS``: element
sizes x3, 3 nm under the tip) and the same with every element size halved (mesh scale 1.5,
1.5 nm under the tip), both with the table's depth steps, and prints k/(P R_c), the linear
stiffness, DOFs, the schedule and wall time side by side with the relative difference
(half-size - table) / table. One JSON line per point goes to ``--out``. Usage::

    python studies/fem_domain_corners.py [--points X,RATIO ...] [--out FILE.jsonl]
    python studies/fem_domain_corners.py --points 0.001,1.0 --variant '{"h_max": 8e-8}' ...

With ``--variant`` (JSON objects of settings over the table's), each variant is run once at
each point instead (no half-size run), to find which part of the mesh an error comes from.

Default points: the corners of the domain x = 0.001-0.6, ratio 0.15-1 that are not buckled,
and the physiological point x = 0.0706, ratio 0.457 (docs/fem.md, "Mesh convergence").
"""

import argparse
import json

from turgorbayes import fem, provenance

#: A smoke run's FE settings: a coarse mesh, one nominal depth step (about 1 s a point).
SMOKE_FE = {"mesh_scale": 10.0, "h_min": 3e-9, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
            "n_indent_steps": 1, "step_tolerance": 0.0}
POINTS = [(0.001, 1.0), (0.001, 0.15), (0.6, 1.0), (0.0706, 0.457)]


def _run(x, ratio, cfg):
    r = fem.indentation_point(fem.pressure_for_inflation_number(x, ratio, cfg), ratio, cfg)
    return {"x": r.x, "k_over_PR": r.k_over_PR, "k_linear_over_PR": r.k_linear_over_PR,
            "dofs": r.mesh_dofs, "schedule": r.schedule, "buckled": r.buckled,
            "wall_time_s": r.wall_time_s, "newton_iterations": r.newton_iterations}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--points", nargs="+", default=None, metavar="X,RATIO")
    parser.add_argument("--out", default=None)
    parser.add_argument("--variant", nargs="+", default=None, metavar="JSON",
                        help="settings over the table's, each run once per point")
    args = provenance.add_output_options(parser).parse_args()
    table_settings, half_settings = {}, {"mesh_scale": 1.5}
    if args.smoke:  # the paper's point on a coarse mesh and a finer one
        args.points = args.points or ["0.0706,0.457"]
        table_settings, half_settings = SMOKE_FE, {**SMOKE_FE, "mesh_scale": 7.0}
    provenance.tee_stdout(args, "fem_domain_corners.txt")
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    points = POINTS if args.points is None else [tuple(map(float, p.split(","))) for p in args.points]
    if args.variant:
        for x, ratio in points:
            for text in args.variant:
                r = _run(x, ratio, fem.table_config(**json.loads(text)))
                print(f"x={x:g} ratio={ratio:g} {text}: k/PR {r['k_over_PR']:.5f}, k_lin/PR "
                      f"{r['k_linear_over_PR']:.5f}, {r['dofs']} DOF, {r['wall_time_s']:.0f} s",
                      flush=True)
        return
    print(f"{'x':>7} {'ratio':>5} | {'k/PR table':>10} {'half-size':>10} {'diff':>7} | "
          f"{'klin table':>10} {'half-size':>10} {'diff':>7} | DOF, s", flush=True)
    for x, ratio in points:
        table = _run(x, ratio, fem.table_config(**table_settings))
        half = _run(x, ratio, fem.table_config(**half_settings))
        d = half["k_over_PR"] / table["k_over_PR"] - 1
        dl = half["k_linear_over_PR"] / table["k_linear_over_PR"] - 1
        print(f"{x:7.4g} {ratio:5.3g} | {table['k_over_PR']:10.5f} {half['k_over_PR']:10.5f} "
              f"{100 * d:+6.2f}% | {table['k_linear_over_PR']:10.5f} "
              f"{half['k_linear_over_PR']:10.5f} {100 * dl:+6.2f}% | {table['dofs']}/{half['dofs']}, "
              f"{table['wall_time_s']:.0f}/{half['wall_time_s']:.0f} s, {table['schedule'][:8]}/"
              f"{half['schedule'][:8]}{' BUCKLED' if table['buckled'] or half['buckled'] else ''}",
              flush=True)
        if args.out:
            with open(args.out, "a") as fh:
                fh.write(json.dumps({"x_target": x, "ratio": ratio, "table_mesh": table,
                                     "half_size": half, "rel_diff_k": d,
                                     "rel_diff_k_linear": dl, "provenance": record}) + "\n")


if __name__ == "__main__":
    main()
