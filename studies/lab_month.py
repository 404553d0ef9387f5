"""A lab's month of force maps, scaled down and extrapolated (issue 56): the CPU time and peak
memory of ``turgorbayes curves --figures none --workers 1`` on 1, 2, 4 and 8 simulated whole
force maps, the line CPU-s = a + b * maps, and a month of 200 maps of 64 x 64 curves (819,200
curves) on one core and spread over several (docs/curves.md, "A lab's month").

Maps: rod-shaped cells as in studies/force_map_recovery.py (R_c 400-550 nm, cylinder 1.0-1.5
um, any axis angle, k_c 0.01-0.03 N/m, realistic 6.7 pN noise) on an N x N grid over 3 um,
written by afmformats as one ``.h5`` per map (turgorbayes.simulation.forcemap) and reduced as
whole maps (manifest ``curve_index`` = ``map``, empty ``Rc_nm``: the map fits R_c). The series
uses ``--grid`` (default 32: 1024 curves per map, a quarter of the month's maps, so the run
stays within minutes of CPU); one map of ``--check-grid`` curves (default 64, the month's
size) measures what a map of that size costs, to check b scaled by the number of curves.

CPU time is the child's user + system time (``os.wait4``: the ``curves`` process and every
process it waited for; far less sensitive to a busy machine than wall time), peak memory its
largest resident set (``ru_maxrss``). Each run starts a fresh interpreter and writes into a
fresh folder (its cache included, as a first run would), so ``a`` holds the start-up.

Each count, and the check, is run ``--rounds`` times (default 2; the series ascending, then
descending), and the line is fitted to every run: CPU time too grows when the machine's other
jobs compete for its caches and memory (a first run, beside a fit, put 8 maps 30 % above 4).

Run: .venv/bin/python studies/lab_month.py [--grid 32] [--check-grid 64] [--rounds 2]
         [--output-dir DIR | --update]   ->  lab_month.txt
"""

import argparse
import csv
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from turgorbayes import provenance
from turgorbayes.simulation.forcemap import RodCell, write_force_map

NAME = "lab_month.txt"
EXTENT = 3.0e-6  # [m] side of every map's grid
MAP_COUNTS = (1, 2, 4, 8)
MONTH_MAPS, MONTH_GRID = 200, 64
CORES = (1, 2, 4, 8, 16, 32)
HEADER = "file,cell_id,target,Rc_nm,Rc_err_nm,curve_index\n"


def _cell(rng):
    """A rod-shaped cell, substrate tilt and map seed (force_map_recovery.py's ranges)."""
    cell = RodCell(R=rng.uniform(400e-9, 550e-9), length=rng.uniform(1.0e-6, 1.5e-6),
                   angle=rng.uniform(-np.pi / 2, np.pi / 2),
                   center=tuple(rng.uniform(-150e-9, 150e-9, 2)),
                   k_c=float(np.exp(rng.uniform(np.log(0.01), np.log(0.03)))))
    return cell, tuple(rng.uniform(-0.03, 0.03, 2)), int(rng.integers(2**31))


def write_maps(folder, n_maps, grid, seed):
    """Write ``n_maps`` maps of ``grid`` x ``grid`` curves into ``folder``; their file names."""
    rng = np.random.default_rng(seed)
    names = []
    for i in range(n_maps):
        cell, tilt, map_seed = _cell(rng)
        names.append(f"map{grid}_{i}.h5")
        write_force_map(folder / names[-1], cell, n=grid, extent=EXTENT, tilt=tilt,
                        seed=map_seed)
    return names


def write_manifest(path, names):
    """A manifest of one whole-map cell-body row per map (R_c fitted by the map)."""
    path.write_text(HEADER + "".join(f"{n},c{i},cell,,,map\n" for i, n in enumerate(names)))
    return path


def measured_curves(manifest, out):
    """Run ``curves`` on ``manifest`` into ``out``; ``(cpu_s, peak_MB, wall_s, maps_ok)``."""
    argv = [sys.executable, "-m", "turgorbayes", "curves", str(manifest), "--out",
            str(out / "cells.csv"), "--figures", "none", "--workers", "1", "--no-progress"]
    start = time.perf_counter()
    child = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    err = child.stderr.read()
    _, status, usage = os.wait4(child.pid, 0)
    wall = time.perf_counter() - start
    child.returncode = os.waitstatus_to_exitcode(status)
    if child.returncode:
        raise RuntimeError(f"curves exited {child.returncode}: {err.decode()[-2000:]}")
    with open(out / "force_maps.csv", newline="") as fh:
        ok = sum(row["status"] == "ok" for row in csv.DictReader(fh))
    return usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024, wall, ok


def line_fit(x, y):
    """Least-squares ``y = a + b x``: ``(a, b, se_a, se_b)`` (standard errors from the
    residuals, ``len(x) - 2`` degrees of freedom)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    design = np.column_stack([np.ones_like(x), x])
    coef, *_ = np.linalg.lstsq(design, y, rcond=None)
    resid = y - design @ coef
    s2 = resid @ resid / (x.size - 2) if x.size > 2 else np.nan  # two points: no residual
    se = np.sqrt(np.diag(s2 * np.linalg.inv(design.T @ design)))
    return coef[0], coef[1], se[0], se[1]


def month_lines(a, b_month, how):
    """The month's CPU on one core and its wall time spread over cores (ideal scaling)."""
    cpu = a + MONTH_MAPS * b_month
    per_core = ", ".join(f"{c} core{'s' * (c > 1)} {cpu / c / 3600:.2f} h" for c in CORES)
    return [f"month ({MONTH_MAPS} maps x {MONTH_GRID ** 2} curves = "
            f"{MONTH_MAPS * MONTH_GRID ** 2:,} curves), b = {b_month:.1f} CPU-s per map {how}: "
            f"{cpu:.0f} CPU-s = {cpu / 3600:.2f} CPU-h on one core; spread over cores "
            f"(CPU-s / cores, a bound: no overhead, every core free): {per_core}"]


def _row(label, n, grid, measured):
    """A table line of one run: ``measured`` is :func:`measured_curves`'s tuple."""
    cpu, peak, wall, ok = measured
    curves = n * grid**2
    return (f"{label:>5} {n:>5} {curves:>7} {cpu:>8.1f} {1e3 * cpu / curves:>13.2f} {peak:>8.0f} "
            f"{wall:>7.1f} {os.getloadavg()[0]:>5.1f} {ok:>8}")


def series(args, folder, names):
    """The runs on 1, 2, 4 and 8 maps, ``args.rounds`` times (ascending, then descending, so a
    drift of the machine's load weighs on both ends); ``(maps, cpu_s, peak_MB)`` and lines."""
    runs, lines = [], []
    for r in range(args.rounds):
        for n in (args.counts if r % 2 == 0 else args.counts[::-1]):
            manifest = write_manifest(folder / f"m{n}.csv", names[:n])
            measured = measured_curves(manifest, folder / f"out{r}_{n}")
            runs.append((n, measured[0], measured[1]))
            lines.append(_row(f"s{r + 1}", n, args.grid, measured))
            print(lines[-1], flush=True)
    return runs, lines


def check_runs(args, folder, names):
    """The one map of ``args.check_grid`` curves, ``args.rounds`` times: CPU-s and lines."""
    manifest = write_manifest(folder / "check.csv", names)
    cpus, lines = [], []
    for r in range(args.rounds):
        measured = measured_curves(manifest, folder / f"out_check{r}")
        cpus.append(measured[0])
        lines.append(_row(f"c{r + 1}", 1, args.check_grid, measured))
        print(lines[-1], flush=True)
    return cpus, lines


def run(args, folder):
    """The measurements and the result file's lines."""
    t = time.process_time()
    names = write_maps(folder, max(args.counts), args.grid, args.seed)
    check = write_maps(folder, 1, args.check_grid, args.seed + 1) if args.check_grid else []
    size = (folder / names[0]).stat().st_size / 1e6
    lines = [f"# {len(names)} maps of {args.grid} x {args.grid} curves over "
             f"{EXTENT * 1e6:g} um (seed {args.seed}; {size:.0f} MB per .h5) and "
             f"{len(check)} of {args.check_grid} x {args.check_grid}, written in "
             f"{time.process_time() - t:.0f} CPU-s (not counted below), on {os.cpu_count()} "
             "cores shared with other jobs (load: the 1-minute load average after each run)",
             "# run: s = the series (round), c = the check map",
             f"{'run':>5} {'maps':>5} {'curves':>7} {'CPU-s':>8} {'CPU-ms/curve':>13} "
             f"{'peak MB':>8} {'wall s':>7} {'load':>5} {'maps ok':>8}"]
    runs, table = series(args, folder, names)
    cpus, check_table = check_runs(args, folder, check) if check else ([], [])
    lines += table + check_table
    a, b, se_a, se_b = line_fit([r[0] for r in runs], [r[1] for r in runs])
    scale = MONTH_GRID**2 / args.grid**2
    summary = [f"fit CPU-s = a + b * maps over the {len(runs)} series runs: a = {a:.1f} +- "
               f"{se_a:.1f} s (start-up), b = {b:.2f} +- {se_b:.2f} s per {args.grid} x "
               f"{args.grid} map ({1e3 * b / args.grid**2:.2f} ms per curve); peak memory "
               f"{min(r[2] for r in runs):.0f}-{max(r[2] for r in runs):.0f} MB whatever the "
               "number of maps"]
    summary += month_lines(a, b * scale, f"(b x {scale:g}: the series' cost per curve)")
    if cpus:
        b_check = float(np.mean(cpus)) - a
        summary.append(f"check: 1 map of {args.check_grid} x {args.check_grid} curves, mean of "
                       f"{len(cpus)} runs {np.mean(cpus):.1f} CPU-s; minus a: {b_check:.1f} "
                       f"CPU-s per map ({1e3 * b_check / args.check_grid**2:.2f} ms per curve, "
                       f"{b_check / (b * args.check_grid**2 / args.grid**2):.2f} x the "
                       "series' b scaled by curves)")
        if args.check_grid == MONTH_GRID:
            summary += month_lines(a, b_check, f"(the {MONTH_GRID} x {MONTH_GRID} map measured)")
    for line in summary:
        print(line)
    return lines + summary


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--grid", type=int, default=32, help="curves per side of the series' maps")
    parser.add_argument("--check-grid", type=int, default=MONTH_GRID,
                        help="curves per side of the one map that checks the scaling (0: none)")
    parser.add_argument("--rounds", type=int, default=2, help="runs of every map count")
    parser.add_argument("--seed", type=int, default=56)
    args = provenance.add_output_options(parser).parse_args()
    args.counts = MAP_COUNTS
    if args.smoke:  # one round of 1 and 2 maps of 10 x 10 curves, one check map of 10 x 10
        args.counts, args.grid, args.check_grid, args.rounds = (1, 2), 10, 10, 1
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    with tempfile.TemporaryDirectory() as tmp:
        lines = run(args, Path(tmp))
    path = provenance.study_path(args, NAME)
    path.write_text("\n".join([provenance.header_line(record), *lines]) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
