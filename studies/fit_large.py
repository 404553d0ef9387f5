"""``turgorbayes fit`` on 10^5 cells (issue 56: "fit on 100k rows is silent for 150 s (0.94 GB)
before anything shows"): wall time, CPU time, peak memory and when each line was printed.

Each fit runs as a user runs it (``python -m turgorbayes fit``, a fresh process, defaults) on
``turgorbayes simulate`` cells (60 % bulged, 40 % intact, the paper's ratio 72:42 rounded);
its stdout and stderr lines are timed as they arrive, and its CPU time (user + system) and
peak resident memory are the process's own (``os.wait4``).

1. Whole fits at ``--full`` sizes (default 1000 and 10 000 cells): the time of every line, the
   longest silence (between two lines, or from the start to the first), CPU and peak memory,
   and the power law through the two sizes extrapolated to ``--cells`` (default 100 000).
   A whole fit of 10^5 cells is not run: ~10x the 10 000-cell fit's CPU (about 2.5 CPU-hours)
   and memory (tens of GB on this 23 GB machine; see the extrapolation).
2. The fit of ``--cells`` cells up to the line that announces the posterior-mode search or the
   sampling (the data read and the model prepared; at most ``--limit`` s), then stopped with
   SIGKILL: its first lines (those of the first 10 s), CPU and peak memory up to there.
3. Before/after of the one fix (the FE-table check a block of draws at a time,
   turgorbayes.inference.table_check.CHUNK_POINTS): ``cell_shares`` on the largest whole fit's
   own draws all at once (as before) and in blocks, each in a fresh process; equal shares?

Run: .venv/bin/python studies/fit_large.py [--full 1000 10000] [--cells 100000]
         [--partial-only] [--output-dir DIR | --update]   ->  fit_large.txt
         (--partial-only: part 2 alone, -> fit_large_partial.txt)
"""

import argparse
import json
import os
import signal
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from turgorbayes import provenance

NAME = "fit_large.txt"
CLI = [sys.executable, "-m", "turgorbayes"]
BULGED_SHARE = 0.6
#: The lines that end part 2: the model is prepared, the mode search (announced when it is
#: long) or the sampling starts.
STOP_LINES = ("finding the posterior mode", "sampling to convergence")
FIRST_SECONDS = 10.0
#: A smoke run's ``fit`` options: short chains (the sizes are set in :func:`main`).
SMOKE_FIT = ["--walkers", "10", "--ensembles", "2", "--max-steps", "100"]

SHARES = """
import sys, time, numpy as np, xarray as xr
from turgorbayes import surrogate
from turgorbayes.cells.table import read_cells
from turgorbayes.inference import table_check
from turgorbayes.inference.observations import observations_from_cells
cells = read_cells(sys.argv[1])
post = xr.open_datatree(sys.argv[2])
draws = {n: post["posterior"][n].values for n in ("gamma", "E0t", "R0", "P_phys")}
table = surrogate.load()
observations_from_cells(cells)  # the population, deconvolved before the clock starts
t = time.process_time()
shares = table_check.cell_shares(draws, cells, table, chunk_points=float(sys.argv[3]))
print(time.process_time() - t)
np.savez(sys.argv[4], **shares)
"""


def simulate(path, n_cells, seed):
    """``turgorbayes simulate`` of ``n_cells`` cells into ``path``."""
    n_bulged = round(BULGED_SHARE * n_cells)
    subprocess.run(CLI + ["simulate", "--out", str(path), "--n-bulged", str(n_bulged),
                          "--n-intact", str(n_cells - n_bulged), "--seed", str(seed)],
                   check=True, capture_output=True)
    return path


def _reader(stream, name, start, lines, stop_at, stop):
    for line in stream:
        lines.append((time.perf_counter() - start, name, line.rstrip()))
        if any(marker in line for marker in stop_at):
            stop.set()


def timed_run(argv, stop_at=(), limit=None):
    """Run ``argv``; ``{"lines": [(s, stream, text)], "wall_s", "cpu_s", "peak_MB",
    "exit"}``, stopped with SIGKILL at the first line holding one of ``stop_at`` or after
    ``limit`` s."""
    start = time.perf_counter()
    child = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                             bufsize=1)
    lines, stop = [], threading.Event()
    readers = [threading.Thread(target=_reader, args=(s, n, start, lines, stop_at, stop))
               for s, n in ((child.stdout, "out"), (child.stderr, "err"))]
    for r in readers:
        r.start()
    killed = False
    while True:  # os.wait4, not Popen.poll: the child's rusage is read when it is reaped
        pid, status, usage = os.wait4(child.pid, os.WNOHANG)
        if pid:
            break
        if stop.is_set() or (limit is not None and time.perf_counter() - start > limit):
            os.kill(child.pid, signal.SIGKILL)
            killed = True
            _, status, usage = os.wait4(child.pid, 0)
            break
        time.sleep(0.2)
    wall = time.perf_counter() - start
    child.returncode = os.waitstatus_to_exitcode(status)
    for r in readers:
        r.join()
    lines.sort(key=lambda x: x[0])
    return {"lines": lines, "wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime,
            "peak_MB": usage.ru_maxrss / 1024, "exit": "killed" if killed else child.returncode}


def silence(run):
    """The longest stretch without a line: ``(seconds, the line that ended it)``."""
    times = [0.0] + [t for t, _, _ in run["lines"]]
    gaps = np.diff(times)
    i = int(np.argmax(gaps))
    return float(gaps[i]), run["lines"][i][2]


def run_lines(label, run):
    """The result file's lines of one run: totals, longest silence, every line's time."""
    err = [t for t, s, _ in run["lines"] if s == "err"]
    gap, after = silence(run)
    out = [f"{label}: exit {run['exit']}, wall {run['wall_s']:.0f} s, CPU {run['cpu_s']:.0f} s, "
           f"peak memory {run['peak_MB']:.0f} MB; first stderr line at "
           f"{err[0] if err else float('nan'):.1f} s, {sum(t < FIRST_SECONDS for t in err)} "
           f"stderr line(s) in the first {FIRST_SECONDS:g} s; longest silence {gap:.0f} s, "
           f"ended by: {after[:110]}"]
    out += [f"  {t:8.1f} s {s} {text[:150]}" for t, s, text in run["lines"]
            if not text.startswith("  ") or s == "err"]
    return out


def power_law(n, y):
    """``y = c n^p`` through two points: ``(c, p)``."""
    p = np.log(y[1] / y[0]) / np.log(n[1] / n[0])
    return y[0] / n[0] ** p, p


def full_fits(args, folder):
    """Part 1: whole fits at ``args.full`` sizes; their runs and lines."""
    runs, lines = {}, []
    for n in args.full:
        data = simulate(folder / f"c{n}.csv", n, args.seed)
        runs[n] = timed_run(CLI + ["fit", str(data), "--out", str(folder / f"fit{n}"),
                                   "--seed", str(args.seed), *args.fit_options])
        part = run_lines(f"whole fit, {n} cells", runs[n])
        print("\n".join(part), flush=True)
        lines += part
    return runs, lines


def extrapolation(args, runs, folder):
    """Part 1's power laws to ``args.cells`` (CPU, peak memory, posterior.nc size)."""
    sizes = sorted(runs)[-2:]
    big = sizes[-1]
    summary = json.loads((folder / f"fit{big}" / "summary.json").read_text())
    nc = (folder / f"fit{big}" / "posterior.nc").stat().st_size / 1e6
    out = [f"extrapolated to {args.cells} cells by the power law through {sizes[0]} and "
           f"{big} cells (y = c n^p):"]
    for key, what, scale, unit in (("cpu_s", "CPU time", 3600, "h"),
                                   ("wall_s", "wall time", 3600, "h"),
                                   ("peak_MB", "peak memory", 1024, "GB")):
        c, p = power_law(sizes, [runs[n][key] for n in sizes])
        out.append(f"  {what}: p = {p:.2f}, {c * args.cells ** p / scale:.2f} {unit}")
    out.append(f"  posterior.nc: {nc:.0f} MB at {big} cells ({summary['timing_s']:.0f} s fit); "
               f"its per-draw arrays (chain, draw, cell) grow with the cells: "
               f"~{nc * args.cells / big / 1e3:.1f} GB at {args.cells}")
    return out


def partial_fit(args, folder):
    """Part 2: the ``args.cells`` fit up to the mode search; its lines."""
    data = simulate(folder / f"c{args.cells}.csv", args.cells, args.seed)
    run = timed_run(CLI + ["fit", str(data), "--out", str(folder / "fit_partial"), "--seed",
                           str(args.seed), *args.fit_options], stop_at=STOP_LINES, limit=args.limit)
    lines = run_lines(f"fit of {args.cells} cells, stopped at the first line of "
                      f"{' or '.join(repr(m) for m in STOP_LINES)} (or at {args.limit:g} s)", run)
    print("\n".join(lines), flush=True)
    return lines


def table_check_ab(n, folder):
    """Part 3: the FE-table check of the ``n``-cell fit's draws, all at once then in blocks."""
    from turgorbayes.inference.table_check import CHUNK_POINTS

    out, shares = [f"FE-table check of the {n}-cell fit's draws (table_check.cell_shares; "
                   "each in a fresh process):"], []
    for label, chunk in (("before: all draws at once", 1e15),
                         (f"after: blocks of {CHUNK_POINTS:.0e} points", CHUNK_POINTS)):
        npz = folder / f"shares{chunk:.0e}.npz"
        run = timed_run([sys.executable, "-c", SHARES, str(folder / f"c{n}.csv"),
                         str(folder / f"fit{n}" / "posterior.nc"), repr(float(chunk)), str(npz)])
        printed = [text for _, stream, text in run["lines"] if stream == "out"]
        cpu = float(printed[-1]) if run["exit"] == 0 else float("nan")
        shares.append(np.load(npz) if npz.exists() else None)
        out.append(f"  {label}: cell_shares {cpu:.0f} CPU-s; the process {run['cpu_s']:.0f} "
                   f"CPU-s, peak memory {run['peak_MB']:.0f} MB (exit {run['exit']})")
        print(out[-1], flush=True)
    same = all(s is not None for s in shares) and all(
        np.array_equal(shares[0][k], shares[1][k]) for k in shares[0].files)
    out.append(f"  shares identical: {same}")
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--full", type=int, nargs="+", default=[1000, 10000])
    parser.add_argument("--cells", type=int, default=100_000)
    parser.add_argument("--limit", type=float, default=1200.0,
                        help="wall seconds after which part 2 is stopped anyway")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--partial-only", action="store_true",
                        help="part 2 only, into fit_large_partial.txt")
    args = provenance.add_output_options(parser).parse_args()
    args.fit_options = []
    if args.smoke:  # whole fits of 12 and 16 cells with short chains, the first stage of 24
        args.full, args.cells, args.limit, args.fit_options = [12, 16], 24, 20.0, SMOKE_FIT
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    lines = [f"# fit_large.py: {'' if args.partial_only else f'whole fits of {args.full} cells, '}"
             f"the first stage of {args.cells}; load average at start "
             f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores (shared); times: s from the "
             "start of the process, out/err: its stdout/stderr (stdout lines of the parameter "
             "table left out)"]
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        if not args.partial_only:
            runs, part = full_fits(args, folder)
            lines += part + extrapolation(args, runs, folder)
            print("\n".join(lines[-5:]), flush=True)
            lines += table_check_ab(max(args.full), folder)
        lines += partial_fit(args, folder)
    path = provenance.study_path(args, "fit_large_partial.txt" if args.partial_only else NAME)
    path.write_text("\n".join([provenance.header_line(record), *lines]) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
