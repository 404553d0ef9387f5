"""Build the k_c/(P R_c) surrogate table: a sweep of finite-element indentation runs.

One FE indentation per grid point ``(x, E_par/E_perp)`` (:mod:`~turgorbayes.surrogate.grid`),
run serially, on a process pool or on Dask (:mod:`~turgorbayes.surrogate.runner`); each finished
point is stored at once (:mod:`~turgorbayes.surrogate.store`), so an interrupted build resumes,
and the table is written only when every point succeeded (layout: :func:`assemble_table`,
provenance: :mod:`~turgorbayes.surrogate.provenance`; ``docs/fem.md``).
"""

import dataclasses
import os
import platform
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from turgorbayes.errors import TurgorBayesError
from turgorbayes.progress import progress as show_progress
from turgorbayes.surrogate.grid import DEFAULT_GRID_SPEC, GridSpec, GridSpecError, parse_grid
from turgorbayes.surrogate.provenance import (
    config_dict,
    config_sha256,
    source_counts,
    source_sha256,
    table_attributes,
    utc_now,
)
from turgorbayes.surrogate.runner import executor, run_point, run_points
from turgorbayes.surrogate.store import CURVE_FIELDS, OPTIONAL_FIELDS, SCALAR_FIELDS, PointStore
from turgorbayes.surrogate.table import open_table

__all__ = [
    "DEFAULT_GRID_SPEC",
    "BuildFailedError",
    "BuildReport",
    "GridSpec",
    "GridSpecError",
    "PointStore",
    "assemble_table",
    "build_surrogate",
    "check_surrogate",
    "config_from_metadata",
    "parse_grid",
    "run_point",
    "run_points",
    "source_sha256",
    "write_check_records",
]


class BuildFailedError(TurgorBayesError):
    """Some grid points failed; ``failed`` holds their records (x, ratio, error)."""

    def __init__(self, failed, points_dir):
        self.failed = failed
        self.points_dir = points_dir
        lines = [f"  x={r['x_target']:.6g} ratio={r['ratio']:.6g}: {r['error']}" for r in failed]
        super().__init__(
            f"{len(failed)} FE point(s) failed (records in {points_dir}); no table written:\n"
            + "\n".join(lines)
            + "\nFix the cause and rerun with --resume to redo only these points."
        )


# --------------------------------------------------------------------------- assembly


def assemble_table(grid, records, attrs):
    """Assemble the surrogate :class:`xarray.Dataset` from one successful record per point.

    Parameters
    ----------
    grid : GridSpec
    records : dict
        ``(x, ratio) -> record`` (from :func:`run_point`), one per grid point.
    attrs : dict
        Global attributes (provenance).

    Returns
    -------
    xarray.Dataset
        Layout below.

    Notes
    -----
    File layout (netCDF4 via xarray + h5netcdf, format version 1)
    -------------------------------------------------------------
    Dimensions ``ratio`` (E_par/E_perp), ``x`` (target inflation number), ``step`` (load steps of
    the indentation curves, NaN-padded). Variables on ``(ratio, x)``: ``k_over_PR`` (secant stiffness
    ``F(h)/h`` at ``h = R/20`` over ``P R_c``), ``k_linear_over_PR`` (small-indentation stiffness),
    ``x_actual`` (the FE's own inflation number, the interpolation abscissa), ``pressure_Pa``,
    ``R_c_m``, ``wall_time_s`` (whole point, including the pressure search), ``fe_wall_time_s``,
    ``newton_iterations``, ``mesh_dofs``; on ``(ratio, x, step)``: ``h_m``, ``F_N``. Attributes
    (JSON text where structured): ``file_format``, ``format_version``, ``fe_config`` (every FE setting,
    ``dataclasses.asdict``), ``fe_config_sha256``, ``mesh_convergence``, ``point_function``,
    ``fe_source_sha256`` (hash of the FE package's sources as loaded by the workers; a dict of hash ->
    point count if a resumed build mixed code versions), ``fe_source_consistent``,
    ``turgorbayes_version``, ``library_versions``, ``git_commit``, ``git_dirty``,
    ``git_dirty_files``, ``created_utc``, ``host``, ``host_cores``, ``command_line``, ``grid_spec``,
    ``total_point_wall_time_s``, ``per_point_wall_time_s`` (min/median/max), ``build_sessions`` (one
    entry per invocation: workers, scheduler, elapsed time, points run).
    """
    import xarray as xr

    shape = (len(grid.ratio), len(grid.x))
    rows = [[records[(x, r)] for x in grid.x] for r in grid.ratio]
    n_step = max(len(rec["h_m"]) for row in rows for rec in row)
    data = {}
    scalars = {**SCALAR_FIELDS, "wall_time_s": (
        "wall_time_s", "s", "wall time of the whole point incl. the pressure search")}
    scalars.update({f: v for f, v in OPTIONAL_FIELDS.items()
                    if all(f in rec for row in rows for rec in row)})
    for field, (name, units, desc) in scalars.items():
        values = np.array([[rec[field] for rec in row] for row in rows])
        data[name] = (("ratio", "x"), values.reshape(shape), {"units": units, "long_name": desc})
    for field, (units, desc) in CURVE_FIELDS.items():
        curves = np.full((*shape, n_step), np.nan)
        for j, row in enumerate(rows):
            for i, rec in enumerate(row):
                curves[j, i, : len(rec[field])] = rec[field]
        data[field] = (("ratio", "x", "step"), curves, {"units": units, "long_name": desc})
    coords = {
        "ratio": ("ratio", np.array(grid.ratio), {"long_name": "E_par/E_perp"}),
        "x": ("x", np.array(grid.x), {"long_name": "target inflation number P R_c/(E_perp t)"}),
    }
    return xr.Dataset(data, coords=coords, attrs=attrs)


def _write_atomic(ds, out):
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.tmp")
    ds.to_netcdf(tmp, engine="h5netcdf")
    os.replace(tmp, out)


# --------------------------------------------------------------------------- driver


@dataclass
class BuildReport:
    """Outcome of :func:`build_surrogate`: output path, points run and skipped, elapsed time."""

    path: Path
    n_run: int
    n_skipped: int
    elapsed_s: float


def _fe_defaults(cfg, point_fn, pressure_fn):
    """Fill in the real FE model for arguments left as None (imported only here)."""
    mesh_convergence = None
    if cfg is None or point_fn is None or pressure_fn is None:
        from turgorbayes import fem

        cfg = fem.CapsuleConfig() if cfg is None else cfg
        point_fn = fem.indentation_point if point_fn is None else point_fn
        pressure_fn = fem.pressure_for_inflation_number if pressure_fn is None else pressure_fn
        from turgorbayes.surrogate.mesh_convergence import MESH_CONVERGENCE

        mesh_convergence = MESH_CONVERGENCE
    return cfg, point_fn, pressure_fn, mesh_convergence


def build_surrogate(out, grid=None, cfg=None, *, point_fn=None, pressure_fn=None, workers=1,
                    scheduler=None, resume=False, points_dir=None, progress=True,
                    command_line=None, mesh_convergence=None):
    """Run the FE sweep and write the surrogate table.

    Parameters
    ----------
    out : path-like
        netCDF file to write (atomically, only if every point succeeded).
    grid : GridSpec or str, optional
        Default :data:`DEFAULT_GRID_SPEC`.
    cfg : dataclass, optional
        FE settings, default ``turgorbayes.fem.CapsuleConfig()``.
    point_fn, pressure_fn : callable, optional
        Default :func:`turgorbayes.fem.indentation_point` and
        :func:`turgorbayes.fem.pressure_for_inflation_number`; must be picklable (module-level)
        for ``workers > 1`` or a scheduler.
    workers : int, default 1
        Local processes; 1 runs in this process.
    scheduler : str or dask.distributed.Client, optional
        Address of a Dask scheduler (or a client); overrides ``workers``.
    resume : bool, default False
        Reuse successful records in the points folder; without it a non-empty folder is an error.
    points_dir : path-like, optional
        Default ``<out>.points``.
    progress : bool, default True
        Progress (:func:`turgorbayes.progress.progress`) and one line per finished point on
        stderr.
    command_line : str, optional
        Recorded in the provenance (default: this process's argv).
    mesh_convergence : dict, optional
        Mesh-convergence estimate to record; default
        :data:`turgorbayes.surrogate.mesh_convergence.MESH_CONVERGENCE`
        when the real FE is used.

    Returns
    -------
    BuildReport

    Raises
    ------
    BuildFailedError
        If any point failed (their records are kept; rerun with ``resume=True``).
    TurgorBayesError
        For bad arguments or a points folder that cannot be reused.
    """
    grid = parse_grid(grid) if grid is None or isinstance(grid, str) else grid
    if int(workers) < 1:
        raise TurgorBayesError(f"workers must be >= 1, got {workers}")
    cfg, point_fn, pressure_fn, fe_conv = _fe_defaults(cfg, point_fn, pressure_fn)
    cfg_dict = config_dict(cfg)
    store = PointStore(points_dir or f"{out}.points", config_sha256(cfg_dict))
    if not resume and store.n_records():
        raise TurgorBayesError(
            f"{store.directory} already holds {store.n_records()} point records; pass --resume "
            "to reuse the finished ones, or delete the folder to start over"
        )
    done = store.finished(grid)
    todo = [p for p in grid.points() if p not in done]
    session = _start_session(workers, scheduler, command_line, len(todo), len(done))
    failed = _sweep(todo, (point_fn, pressure_fn, cfg), store, done, workers, scheduler, progress)
    store.log_session(_end_session(session, len(failed)))
    if failed:
        raise BuildFailedError(failed, store.directory)
    records = [done[p] for p in grid.points()]
    if len(source_counts(records)) > 1:
        warnings.warn(
            f"the points of {out} were computed by {len(source_counts(records))} different "
            "versions of the FE source code (the build was resumed after the code changed); see "
            "the fe_source_sha256 attribute, and rebuild from scratch for a consistent table",
            RuntimeWarning, stacklevel=2)
    attrs = table_attributes(cfg_dict, grid, point_fn, mesh_convergence or fe_conv, store.sessions(),
                        records, out)
    _write_atomic(assemble_table(grid, done, attrs), out)
    open_table(out)  # read back: the file just written must load as a surrogate
    return BuildReport(Path(out), len(todo), len(grid.points()) - len(todo),
                       session["elapsed_s"])


def _start_session(workers, scheduler, command_line, n_todo, n_done):
    return {"started_utc": utc_now(), "t0": time.perf_counter(), "workers": int(workers),
            "scheduler": None if scheduler is None else str(scheduler),
            "command_line": command_line or " ".join(sys.argv), "host": platform.node(),
            "host_cores": os.cpu_count() or 0, "points_to_run": n_todo, "points_reused": n_done}


def _end_session(session, n_failed):
    session["elapsed_s"] = time.perf_counter() - session.pop("t0")
    session.update(finished_utc=utc_now(), points_failed=n_failed)
    return session


def _sweep(todo, job, store, done, workers, scheduler, progress):
    """Run the points, store each record as it arrives, return the failed records."""
    failed = []
    with show_progress(total=len(todo), desc="FE points", unit="pt", enabled=progress) as bar:
        for rec in executor(todo, job, workers, scheduler):
            store.write(rec)
            key = (rec["x_target"], rec["ratio"])
            if rec["status"] == "ok":
                done[key] = rec
            else:
                failed.append(rec)
            bar.update(1)
            bar.set_postfix(failed=len(failed))
            if progress:
                bar.write(_point_line(rec), file=sys.stderr)
    return failed


def _point_line(rec):
    head = f"{rec['status']:6s} x={rec['x_target']:<8.4g} ratio={rec['ratio']:<5.3g}"
    if rec["status"] != "ok":
        return f"{head} {rec['error']}"
    return (f"{head} x_actual={rec['x']:<9.5g} k/PR={rec['k_over_PR']:<8.5g} "
            f"k_lin/PR={rec['k_linear_over_PR']:<8.5g} {rec['wall_time_s']:7.1f} s")


# --------------------------------------------------------------------------- check


def config_from_metadata(cfg_dict, cls):
    """Rebuild the FE settings dataclass recorded in a table (JSON turned tuples into lists).

    Parameters
    ----------
    cfg_dict : dict
        The ``fe_config`` attribute of a table.
    cls : type
        The dataclass (``turgorbayes.fem.CapsuleConfig``).
    """
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(cfg_dict) - set(fields))
    if unknown:
        raise TurgorBayesError(
            f"the table's FE settings have fields {unknown} that {cls.__name__} does not know; "
            "it was built by another version of the FE code"
        )
    return cls(**{k: tuple(v) if isinstance(v, list) else v for k, v in cfg_dict.items()})


def write_check_records(path, records):
    """Write the records of :func:`check_surrogate` to the JSON file ``path`` (numbers as
    floats)."""
    import json

    with open(path, "w", encoding="utf-8") as fh:
        json.dump(records, fh, indent=1, default=float)


def check_surrogate(s, n=3, seed=0, *, points=None, cfg=None, point_fn=None, pressure_fn=None,
                    workers=1, progress=True):
    """Re-run FE points inside a table (random, or given) and compare them with its interpolation.

    Parameters
    ----------
    s : turgorbayes.surrogate.Surrogate
    n : int
        Number of random points: ``log x`` and ``log ratio`` uniform inside ``s.domain`` (kept
        2% away from its edges so that the FE's own ``x`` stays inside) and outside the
        buckled region (:meth:`~turgorbayes.surrogate.Surrogate.buckled`, where the table gives
        no value; draws there are replaced by further draws of the same stream).
    seed : int
        Seed of :func:`numpy.random.default_rng`.
    points : sequence of (x, ratio), optional
        Held-out points to run instead of random ones (``n`` and ``seed`` are then unused);
        each must lie inside ``s.domain``.
    cfg, point_fn, pressure_fn : optional
        Default: the FE settings recorded in the table and the real FE model.
    workers : int
        Local processes.
    progress : bool
        Progress on stderr (:func:`turgorbayes.progress.progress`).

    Returns
    -------
    list of dict
        Per point its record plus ``k_interp``, ``k_linear_interp``, the relative errors
        ``err`` and ``err_linear`` (``s/k_FE - 1``; NaN for a failed point, and ``err`` NaN
        for a given point in the buckled region) and ``in_buckled_region``.
    """
    if points is None and int(n) < 1:
        raise TurgorBayesError(f"n must be >= 1, got {n}")
    if cfg is None:
        from turgorbayes import fem

        cfg = config_from_metadata(s.metadata["fe_config"], fem.CapsuleConfig)
    cfg, point_fn, pressure_fn, _ = _fe_defaults(cfg, point_fn, pressure_fn)
    tasks = _check_points(s, n, seed) if points is None else _given_points(s, points)
    records = []
    with show_progress(total=len(tasks), desc="FE check", unit="pt", enabled=progress) as bar:
        for rec in executor(tasks, (point_fn, pressure_fn, cfg), workers, None):
            records.append(_compare(s, rec))
            bar.update(1)
    return sorted(records, key=lambda r: (r["ratio"], r["x_target"]))


def _check_points(s, n, seed):
    """``n`` random (x, ratio), log-uniform inside the domain (x kept 2 % from its edges) and
    outside the buckled region."""
    rng = np.random.default_rng(seed)
    (xlo, xhi), (rlo, rhi) = s.domain["x"], s.domain["ratio"]
    points = []
    while len(points) < n:
        x = float(np.exp(rng.uniform(np.log(xlo * 1.02), np.log(xhi / 1.02))))
        ratio = float(np.exp(rng.uniform(np.log(rlo), np.log(rhi))))
        if not s.buckled(x, ratio):
            points.append((x, ratio))
    return points


def _given_points(s, points):
    """Validated (x, ratio) pairs: inside the table's domain, else a TurgorBayesError."""
    (xlo, xhi), (rlo, rhi) = s.domain["x"], s.domain["ratio"]
    tasks = []
    for i, p in enumerate(points):
        x, ratio = (float(v) for v in p)
        if not (xlo <= x <= xhi and rlo <= ratio <= rhi):
            raise TurgorBayesError(
                f"point {i + 1} (x={x:g}, ratio={ratio:g}) is outside the table's domain "
                f"x in [{xlo:.4g}, {xhi:.4g}], ratio in [{rlo:g}, {rhi:g}]")
        tasks.append((x, ratio))
    if not tasks:
        raise TurgorBayesError("no points given")
    return tasks


def _compare(s, rec):
    rec = {**rec, "k_interp": np.nan, "k_linear_interp": np.nan, "err": np.nan,
           "err_linear": np.nan, "in_buckled_region": False}
    if rec["status"] == "ok":
        rec["in_buckled_region"] = bool(s.buckled(rec["x"], rec["ratio"]))
        rec["k_interp"] = s(rec["x"], rec["ratio"], warn=False)
        rec["k_linear_interp"] = s.linear(rec["x"], rec["ratio"], warn=False)
        rec["err"] = rec["k_interp"] / rec["k_over_PR"] - 1
        rec["err_linear"] = rec["k_linear_interp"] / rec["k_linear_over_PR"] - 1
    return rec
