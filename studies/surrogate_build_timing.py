"""Timing of the FE sweep: one point, and a batch of points with 1 and with 2 workers.

Two modes:

* ``--run`` (default): runs ``--points`` FE points (x log-spaced in [0.01, 0.5] at ratio
  0.457, the paper's physiological anisotropy) once with 1 worker and once with 2, and prints
  per-point wall time, the batch's elapsed time, the speed-up and the projected time of the full
  production sweep (65 points). Takes ``points x ~1 min x 1.5`` on this machine.
* ``--summary DIR``: summarizes the points folder of a finished build (per-point times, the
  build sessions with their worker counts and elapsed times) without running anything.

Run: .venv/bin/python studies/surrogate_build_timing.py [--points 4] [--mesh-scale S] [--smoke]
     .venv/bin/python studies/surrogate_build_timing.py --summary surrogates/k_over_PR.points
"""

import argparse
import json
import os
import time
from pathlib import Path

import numpy as np

from turgorbayes import provenance
from turgorbayes.surrogate.build import parse_grid, run_points

N_SWEEP = len(parse_grid().points())
#: A smoke run's FE settings: a coarse mesh, one nominal depth step (about 1 s a point).
SMOKE_FE = {"mesh_scale": 10.0, "h_min": 3e-9, "h_bottom": 12e-9, "h_max": 80e-9, "growth": 0.5,
            "n_indent_steps": 1, "step_tolerance": 0.0}
#: The points folder of the shipped table's build (what ``--smoke`` summarizes).
SHIPPED_POINTS = Path(__file__).resolve().parents[1] / "surrogates" / "k_over_PR.points"


def run(n_points, mesh_scale, worker_counts, fe_settings=None):
    from turgorbayes import fem

    opts = dict(fe_settings or {})  # CapsuleConfig's defaults
    if mesh_scale is not None:
        opts["mesh_scale"] = mesh_scale
    cfg = fem.CapsuleConfig(**opts)
    points = [(float(x), 0.457) for x in np.geomspace(0.01, 0.5, n_points)]
    print(f"{n_points} points at ratio 0.457, mesh_scale={mesh_scale}, {os.cpu_count()} cores")
    elapsed = {}
    for workers in worker_counts:
        t0 = time.perf_counter()
        recs = list(run_points(points, fem.indentation_point, fem.pressure_for_inflation_number,
                               cfg, workers=workers))
        elapsed[workers] = time.perf_counter() - t0
        times = np.array([r["wall_time_s"] for r in recs])
        bad = [r for r in recs if r["status"] != "ok"]
        print(f"workers={workers}: batch {elapsed[workers]:7.1f} s, per point "
              f"min {times.min():.1f} / mean {times.mean():.1f} / max {times.max():.1f} s, "
              f"{len(bad)} failed; projected {N_SWEEP}-point sweep "
              f"{elapsed[workers] / n_points * N_SWEEP / 60:.0f} min")
        for r in sorted(recs, key=lambda r: r["x_target"]):
            extra = (f"k/PR={r['k_over_PR']:.4f} newton={r['newton_iterations']} "
                     f"dofs={r['mesh_dofs']}" if r["status"] == "ok" else r["error"])
            print(f"   x={r['x_target']:.4f} {r['wall_time_s']:6.1f} s  {extra}")
    if len(elapsed) > 1:
        w = sorted(elapsed)
        print(f"speed-up {w[-1]} vs {w[0]} workers: {elapsed[w[0]] / elapsed[w[-1]]:.2f}")


def summary(directory):
    directory = Path(directory)
    recs = [json.loads(p.read_text()) for p in sorted(directory.glob("ratio*_x*.json"))]
    ok = [r for r in recs if r["status"] == "ok"]
    times = np.array([r["wall_time_s"] for r in ok])
    print(f"{directory}: {len(recs)} records, {len(ok)} ok")
    print(f"per point: min {times.min():.1f} / median {np.median(times):.1f} / "
          f"max {times.max():.1f} s, sum {times.sum() / 60:.1f} min")
    for line in (directory / "sessions.jsonl").read_text().splitlines():
        s = json.loads(line)
        print(f"session {s['started_utc']}: workers={s['workers']} ran {s['points_to_run']} "
              f"points ({s['points_failed']} failed) in {s['elapsed_s'] / 60:.1f} min")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--points", type=int, default=4)
    ap.add_argument("--mesh-scale", type=float, default=None)
    ap.add_argument("--workers", default="1,2", help="comma-separated worker counts")
    ap.add_argument("--summary", metavar="DIR", help="summarize a build's points folder")
    args = provenance.add_output_options(ap).parse_args()
    fe_settings = None  # CapsuleConfig's
    if args.smoke:  # two points on a coarse mesh, one depth step, 1 and 2 workers; the summary
        args.points, args.mesh_scale, fe_settings, args.workers = 2, 10.0, SMOKE_FE, "1,2"
        args.summary = args.summary or (SHIPPED_POINTS if SHIPPED_POINTS.is_dir() else None)
    provenance.tee_stdout(args, "surrogate_build_timing.txt")
    print(provenance.header_line(), flush=True)
    if args.summary:
        summary(args.summary)
    if args.smoke or not args.summary:
        run(args.points, args.mesh_scale, [int(w) for w in args.workers.split(",")], fe_settings)


if __name__ == "__main__":
    main()
