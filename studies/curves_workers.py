"""``turgorbayes curves`` on every core: time with 1 and 2 worker processes and on a Dask
LocalCluster of 2, alternated, on the worked example's raw curves (``simulate --raw-curves
--seed 1``: 107 cells, 558 curves), with ``--figures none`` and ``--no-cache`` (a cached run
reduces nothing); the ratios are taken triple by triple in one run (the machine is shared), and
the cells.csv and curves.csv of all three must be the same bytes.

With ``--maps N`` the workload is instead N simulated whole force maps of ``--grid`` x
``--grid`` curves (rod-shaped cells as in lab_month.py, seed 56; a scaled-down lab month),
where the work per run is long enough that a LocalCluster's start-up (its scheduler, and two
fresh interpreters importing the package) no longer dominates.

With ``--running-cluster`` the Dask leg runs on a LocalCluster of 2 that the study starts once
and warms with one untimed run (``--scheduler ADDRESS``, as a lab keeps one running), instead of
one that each run starts (``--scheduler local``).

Run: .venv/bin/python studies/curves_workers.py [--pairs 5] [--maps 4 --grid 32]
[--running-cluster] [--update]
"""

import argparse
import contextlib
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from turgorbayes.provenance import add_output_options, header_line, study_path
from turgorbayes.simulation.forcemap import RodCell, write_force_map

CLI = [sys.executable, "-m", "turgorbayes"]
#: A smoke run's raw curves: 3 bulged + 3 intact cells (``simulate``'s options).
SMOKE_CELLS = ["--n-bulged", "3", "--n-intact", "3"]


def timed(args):
    t = time.perf_counter()
    subprocess.run(CLI + args, check=True, capture_output=True)
    return time.perf_counter() - t


def write_maps(folder, n_maps, grid, seed=56):
    """``n_maps`` whole force maps (lab_month.py's rod-shaped cells) and their manifest."""
    rng = np.random.default_rng(seed)
    folder.mkdir(parents=True)
    rows = []
    for i in range(n_maps):
        cell = RodCell(R=rng.uniform(400e-9, 550e-9), length=rng.uniform(1.0e-6, 1.5e-6),
                       angle=rng.uniform(-np.pi / 2, np.pi / 2),
                       center=tuple(rng.uniform(-150e-9, 150e-9, 2)),
                       k_c=float(np.exp(rng.uniform(np.log(0.01), np.log(0.03)))))
        tilt, map_seed = tuple(rng.uniform(-0.03, 0.03, 2)), int(rng.integers(2**31))
        write_force_map(folder / f"map{i}.h5", cell, n=grid, extent=3.0e-6, tilt=tilt,
                        seed=map_seed)
        rows.append(f"map{i}.h5,c{i},cell,,,map\n")
    (folder / "manifest.csv").write_text("file,cell_id,target,Rc_nm,Rc_err_nm,curve_index\n"
                                         + "".join(rows))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--pairs", type=int, default=5)
    parser.add_argument("--maps", type=int, default=0,
                        help="time N whole force maps instead of the example's raw curves")
    parser.add_argument("--grid", type=int, default=32)
    parser.add_argument("--running-cluster", action="store_true",
                        help="the Dask leg on a LocalCluster of 2 started once by this study "
                             "(--scheduler ADDRESS) and warmed by one untimed run, as a lab keeps "
                             "one running, instead of one each run starts (--scheduler local)")
    add_output_options(parser)
    args = parser.parse_args()
    with _cluster(args.running_cluster) as address:
        _run(args, address)


@contextlib.contextmanager
def _cluster(running):
    """The address of a LocalCluster of 2 kept for the whole study, or ``"local"``."""
    if not running:
        yield "local"
        return
    from dask.distributed import LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster:
        yield cluster.scheduler_address


def _run(args, address):
    cells = []
    if args.smoke:  # one run of each leg on a handful of cells (or two tiny maps)
        args.pairs, cells, args.grid = 1, SMOKE_CELLS, 10
        args.maps = min(args.maps, 2)
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if args.maps:
            write_maps(tmp / "raw", args.maps, args.grid)
        else:
            subprocess.run(CLI + ["simulate", "--raw-curves", str(tmp / "raw"), "--seed", "1",
                                  *cells], check=True, capture_output=True)
        what = (f"{args.maps} whole force maps of {args.grid} x {args.grid} curves" if args.maps
                else "the worked example's raw curves")
        lines, ratios = [header_line(), f"# workload: {what}"], {"2": [], "dask": []}
        legs = {"1": ["--workers", "1"], "2": ["--workers", "2"],
                "dask": ["--workers", "2", "--scheduler", address]}
        if address != "local":  # the running cluster's workers import the pipeline once
            lines.append("# the Dask leg: a LocalCluster of 2 started once before the runs and "
                         "warmed by one untimed run (--scheduler ADDRESS)")
            timed(["curves", str(tmp / "raw" / "manifest.csv"), "--out", str(tmp / "warm.csv"),
                   "--figures", "none", "--no-progress", "--no-cache", *legs["dask"]])
        for i in range(args.pairs):
            t = {}
            for name, extra in legs.items():
                t[name] = timed(["curves", str(tmp / "raw" / "manifest.csv"), "--out",
                                 str(tmp / name / "cells.csv"), "--figures", "none",
                                 "--no-progress", "--no-cache", *extra])
            for name in ratios:
                ratios[name].append(t[name] / t["1"])
            lines.append(f"run {i + 1}: 1 worker {t['1']:.1f} s, 2 workers {t['2']:.1f} s "
                         f"(ratio {ratios['2'][-1]:.2f}), Dask LocalCluster of 2 "
                         f"{t['dask']:.1f} s (ratio {ratios['dask'][-1]:.2f})")
            print(lines[-1], flush=True)
        same = all((tmp / "1" / n).read_bytes() == (tmp / other / n).read_bytes()
                   for n in ("cells.csv", "curves.csv") for other in ("2", "dask"))
        for name, label in (("2", "2 workers"), ("dask", "Dask LocalCluster of 2")):
            r = sorted(ratios[name])
            lines.append(f"ratio {label} / 1 worker: median {r[len(r) // 2]:.2f} "
                         f"(runs {', '.join(f'{x:.2f}' for x in ratios[name])})")
        lines.append(f"cells.csv and curves.csv identical across the three: {same}")
    print("\n".join(lines[-3:]))
    suffix = (f"_maps{args.maps}" if args.maps else "") + ("_running" if address != "local" else "")
    path = study_path(args, f"curves_workers{suffix}.txt")
    path.write_text("\n".join(lines) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
