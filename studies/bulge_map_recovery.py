"""R_b, k_b and h_b from whole synthetic force maps with a bulge, and k_b of single bulge curves
of the same laws reduced alone (docs/curves.md, Bulges on force maps).

Usage::

    python studies/bulge_map_recovery.py [--n 4] [--seed 2026]

writes force_map_bulge_recovery.txt (studies/output; studies/results with --update), whose
first line records the commit,
arguments, date, machine and version.
"""

import argparse
import functools
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from turgorbayes import provenance
from turgorbayes.curves.bulgemap import reduce_bulge_map
from turgorbayes.curves.load import Approach
from turgorbayes.curves.qc import CurveRejected
from turgorbayes.curves.reduce import reduce_approach
from turgorbayes.simulation.bulge_map import MapBulge
from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, bulge_force, synthetic_curve
from turgorbayes.simulation.forcemap import RodCell, write_force_map

NAME = "force_map_bulge_recovery.txt"
N_GRID, EXTENT, N_SINGLE = 16, 3.4e-6, 60
NOISES = (("low (2 pN)", 2.0), ("realistic (6.7 pN)", 6.7))


def _draw(rng):
    """One cell with a bulge: (RodCell, MapBulge, tilt, seed)."""
    cell = RodCell(R=rng.uniform(400e-9, 500e-9), length=rng.uniform(1.6e-6, 2.0e-6),
                   angle=rng.uniform(-np.pi / 2, np.pi / 2), center=tuple(rng.uniform(-100e-9, 100e-9, 2)),
                   k_c=float(np.exp(rng.uniform(np.log(0.01), np.log(0.03)))))
    bulge = MapBulge(R_b=rng.uniform(300e-9, 450e-9), P=float(np.exp(rng.uniform(np.log(5e3), np.log(25e3)))),
                     along=rng.choice([-1, 1]) * rng.uniform(0.3e-6, 0.5e-6),
                     h_over_Rb=rng.uniform(0.17, 0.27))
    return cell, bulge, tuple(rng.uniform(-0.03, 0.03, 2)), int(rng.integers(2**31))


def _one(folder, cell, bulge, tilt, seed, noise):
    path = folder / f"bulge{seed}.h5"
    write_force_map(path, cell, n=N_GRID, extent=EXTENT, tilt=tilt, seed=seed, bulge=bulge,
                    acquisition=replace(DEFAULT_ACQUISITION, noise_sd=noise * 1e-12))
    start = time.perf_counter()
    res = reduce_bulge_map(path)
    seconds = time.perf_counter() - start
    path.unlink()
    if not res.ok:
        return None, seconds, res.status
    d = res.dome
    return {"R": (d.R_b - bulge.R_b) * 1e9, "R_rel": 100 * (d.R_b / bulge.R_b - 1),
            "R_z": (d.R_b - bulge.R_b) / d.R_b_err, "k": 100 * (res.k / bulge.k_b - 1),
            "k_z": (res.k - bulge.k_b) / res.k_err, "h": 100 * (res.depth / bulge.h_b - 1),
            "apex": len(res.apex)}, seconds, res.status


def _single(rng, noise, seed):
    """k_b error [%] of one single bulge curve of a drawn law, reduced alone (None: rejected)."""
    _, bulge, _, _ = _draw(rng)
    law = functools.partial(bulge_force, P=bulge.P, R_b=bulge.R_b)
    curve = synthetic_curve(law, bulge.h_b, replace(DEFAULT_ACQUISITION, noise_sd=noise * 1e-12), seed=seed)
    height = curve.data["height (measured)"]
    approach = Approach(z=height[0] - height, force=curve.data["force"], height0=height[0],
                        spring_constant=DEFAULT_ACQUISITION.spring_constant,
                        height_column="height (measured)", path=None)
    try:
        return 100 * (reduce_approach(approach, "bulge", bulge.R_b).k / bulge.k_b - 1)
    except CurveRejected:
        return None


def _stats(rows, key):
    v = np.array([r[key] for r in rows])
    return f"{np.mean(v):+.2f} / {np.std(v, ddof=1):.2f}" if v.size > 1 else "-"


def _sd(rows, key):
    return float(np.std([r[key] for r in rows], ddof=1)) if len(rows) > 1 else np.nan


def _header(argv, n_single=N_SINGLE):
    return [provenance.header_line(provenance.run_record(argv)),
            f"# {N_GRID} x {N_GRID} curves over {EXTENT * 1e6:g} um; errors mean / sd over maps: R_b [nm] "
            "and [%], k_b and h_b [%]; z = (fit - truth)/reported error; single: k_b of "
            f"{n_single} single bulge curves of the same laws reduced alone",
            f"{'setting':<22}{'R_b nm':<16}{'R_b %':<16}{'sd(R z)':<9}{'k_b %':<16}{'sd(k z)':<9}"
            f"{'h_b %':<16}{'apex':<6}{'failed':<8}{'s/map':<7}single k_b %"]


def run_bulge(args, argv):
    """Run the bulge benchmark and write its result file."""
    lines = _header(argv, args.n_single)
    with tempfile.TemporaryDirectory() as tmp:
        for name, noise in NOISES:
            rng = np.random.default_rng(args.seed)
            rows, seconds, failed = [], [], []
            for _ in range(args.n):
                row, t, status = _one(Path(tmp), *_draw(rng), noise)
                seconds.append(t)
                rows.append(row) if row is not None else failed.append(status)
            srng = np.random.default_rng(args.seed + 1)
            single = [e for i in range(args.n_single) if (e := _single(srng, noise, args.seed + i)) is not None]
            lines.append(f"{name:<22}{_stats(rows, 'R'):<16}{_stats(rows, 'R_rel'):<16}{_sd(rows, 'R_z'):<9.2f}"
                         f"{_stats(rows, 'k'):<16}{_sd(rows, 'k_z'):<9.2f}{_stats(rows, 'h'):<16}"
                         f"{np.mean([r['apex'] for r in rows]):<6.1f}{len(failed):<8}{np.mean(seconds):<7.1f}"
                         f"{np.mean(single):+.2f} / {np.std(single, ddof=1):.2f} "
                         f"({args.n_single - len(single)} rejected)"
                         + (f"  failed: {', '.join(failed)}" if failed else ""))
            print(lines[-1], flush=True)
    out = provenance.study_path(args, NAME)
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=4, help="maps per noise level")
    parser.add_argument("--seed", type=int, default=2026)
    provenance.add_output_options(parser)
    args = parser.parse_args(argv)
    args.n_single = N_SINGLE
    if args.smoke:  # one map (the smallest grid a cross-section takes) and two single curves
        args.n, args.n_single = 1, 2
    run_bulge(args, argv)


if __name__ == "__main__":
    main()
