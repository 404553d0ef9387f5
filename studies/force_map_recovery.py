"""Recovery of R_c, the axis angle and k_c from whole synthetic force maps, at three noise levels
and with a blunt tip, and the time per map (docs/curves.md, Whole force maps).

Each map (turgorbayes.simulation.forcemap) is a rod-shaped cell (spherocylinder) of R_c uniform
in 400-550 nm, cylindrical length 1.0-1.5 um, axis angle uniform in (-90, 90] deg, centred within
+-150 nm, on a substrate tilted by up to +-0.03 in x and y, on a 16 x 16 grid over 3 um
(187.5 nm pitch); crest curves (within 0.3 R of the axis) have k_c log-uniform 0.01-0.03 N/m,
the cell's flanks half of it, the substrate is a 1 N/m linear law. Written by afmformats as one
.h5 per map and reduced through reduce_map (the manifest's path). "tip 20 nm": the contact heights
are those of a spherical tip of 20 nm radius touching the surface (the arc model ignores the tip).
The last line reduces 300 single curves of the same laws and acquisition at 20 pN alone (no map),
at their true R_c: is a k_c bias of the maps the single-curve reduction's?

Run: .venv/bin/python studies/force_map_recovery.py [--n 8]  ->  studies/output/force_map_recovery.txt
(studies/results/ with --update)
"""

import argparse
import functools
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from turgorbayes import __version__, provenance
from turgorbayes.curves.combine import combine_stiffness
from turgorbayes.curves.forcemap import reduce_map
from turgorbayes.curves.load import Approach
from turgorbayes.curves.qc import CurveRejected
from turgorbayes.curves.reduce import reduce_approach
from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, cell_force, synthetic_curve
from turgorbayes.simulation.forcemap import RodCell, write_force_map

SETTINGS = (("low (2 pN)", 2.0, 0.0), ("realistic (6.7 pN)", 6.7, 0.0), ("high (20 pN)", 20.0, 0.0),
            ("realistic, tip 20 nm", 6.7, 20e-9))
NAME = "force_map_recovery.txt"
N_GRID, EXTENT = 16, 3.0e-6


def _cells(n, seed):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        cell = RodCell(R=rng.uniform(400e-9, 550e-9), length=rng.uniform(1.0e-6, 1.5e-6),
                       angle=rng.uniform(-np.pi / 2, np.pi / 2),
                       center=tuple(rng.uniform(-150e-9, 150e-9, 2)),
                       k_c=float(np.exp(rng.uniform(np.log(0.01), np.log(0.03)))))
        yield cell, tuple(rng.uniform(-0.03, 0.03, 2)), int(rng.integers(2**31))


def _angle_error(fitted, true):
    """Difference of two axis angles [deg], folded into (-90, 90]."""
    d = np.rad2deg(fitted - true)
    return (d + 90) % 180 - 90


def _one(folder, cell, tilt, seed, noise, tip):
    path = folder / f"map{seed}.h5"
    write_force_map(path, cell, n=N_GRID, extent=EXTENT, tilt=tilt, seed=seed, tip_radius=tip,
                    acquisition=replace(DEFAULT_ACQUISITION, noise_sd=noise * 1e-12))
    start = time.perf_counter()
    res = reduce_map(path)
    seconds = time.perf_counter() - start
    path.unlink()
    if not res.ok:
        return None, seconds
    s = res.section
    return {"R": (s.R - cell.R) * 1e9, "R_rel": 100 * (s.R / cell.R - 1), "R_z": (s.R - cell.R) / s.R_err,
            "angle": _angle_error(s.angle, cell.angle), "k": 100 * (res.k / cell.k_c - 1),
            "k_z": (res.k - cell.k_c) / res.k_err, "crest": res.crest_index.size,
            "k_mean": 100 * (combine_stiffness([c.k for c in res.crest if c.accepted],
                                                 [c.k_err for c in res.crest if c.accepted],
                                                 weights="inverse_variance")[0] / cell.k_c - 1)}, seconds


def _stats(rows, key, digits=2):
    v = np.array([r[key] for r in rows])
    return f"{np.mean(v):+.{digits}f} / {np.std(v, ddof=1):.{digits}f}"


def _single_curves(n, noise, seed):
    """Relative k_c errors [%] of ``n`` single crest-like curves reduced alone (no map)."""
    rng = np.random.default_rng(seed)
    errors = []
    for i in range(n):
        k_c, R = float(np.exp(rng.uniform(np.log(0.01), np.log(0.03)))), rng.uniform(400e-9, 550e-9)
        law = functools.partial(cell_force, k_c=k_c, h_ref=R / 20, a=0.1)
        curve = synthetic_curve(law, 2 * R / 20, replace(DEFAULT_ACQUISITION, noise_sd=noise * 1e-12),
                                seed=seed + i)
        height = curve.data["height (measured)"]
        approach = Approach(z=height[0] - height, force=curve.data["force"], height0=height[0],
                            spring_constant=DEFAULT_ACQUISITION.spring_constant,
                            height_column="height (measured)", path=None)
        try:
            errors.append(100 * (reduce_approach(approach, "cell", R).k / k_c - 1))
        except CurveRejected:
            continue
    return np.array(errors), n - len(errors)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=8, help="maps per setting")
    parser.add_argument("--seed", type=int, default=2026)
    args = provenance.add_output_options(parser).parse_args()
    settings, n_single = SETTINGS, 300
    if args.smoke:  # two maps of the tip setting, five single curves
        args.n, settings, n_single = 2, SETTINGS[-1:], 5
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    lines = [f"# force_map_recovery.py, turgorbayes {__version__}, {args.n} maps per setting, "
             f"{N_GRID} x {N_GRID} curves over {EXTENT * 1e6:g} um, seed {args.seed}",
             "# errors mean / sd over maps: R_c [nm] and [%], axis angle [deg], k_c [%]; "
             "z = (fit - truth)/reported fit error (sd ~ 1 if honest); weighted k: the inverse-variance "
             "mean of the accepted crest curves (the combination before 0.3) instead of the plain mean",
             f"{'setting':<22}{'R_c nm':<16}{'R_c %':<16}{'sd(R z)':<9}{'angle deg':<16}"
             f"{'k_c %':<16}{'sd(k z)':<9}{'weighted k %':<16}{'crest':<7}{'failed':<8}s/map"]
    with tempfile.TemporaryDirectory() as tmp:
        for name, noise, tip in settings:
            rows, seconds = [], []
            for cell, tilt, seed in _cells(args.n, args.seed):
                row, t = _one(Path(tmp), cell, tilt, seed, noise, tip)
                seconds.append(t)
                if row is not None:
                    rows.append(row)
            r_z = np.std([r["R_z"] for r in rows], ddof=1)
            k_z = np.std([r["k_z"] for r in rows], ddof=1)
            crest = np.mean([r["crest"] for r in rows])
            lines.append(f"{name:<22}{_stats(rows, 'R'):<16}{_stats(rows, 'R_rel'):<16}{r_z:<9.2g}"
                         f"{_stats(rows, 'angle'):<16}{_stats(rows, 'k'):<16}{k_z:<9.2f}{_stats(rows, 'k_mean'):<16}"
                         f"{crest:<7.1f}{args.n - len(rows):<8}{np.mean(seconds):.1f}")
            print(lines[-1], flush=True)
    errors, failed = _single_curves(n_single, 20.0, args.seed)
    lines.append(f"# single curves alone, 20 pN, true R_c: k_c {np.mean(errors):+.2f} +- "
                 f"{np.std(errors, ddof=1) / np.sqrt(errors.size):.2f} % (mean +- standard error; "
                 f"sd {np.std(errors, ddof=1):.2f} %) over {errors.size} curves, {failed} rejected")
    print(lines[-1])
    out = provenance.study_path(args, NAME)
    out.write_text("\n".join([provenance.header_line(record), *lines]) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
