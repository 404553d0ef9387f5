"""Build the k_c/(P R_c) surrogate table: a sweep of finite-element indentation runs.

The sweep runs one FE indentation (:func:`turgorbayes.fem.indentation_point`) per grid point
``(x, ratio)``, where ``x = P R_c/(E_perp t)`` is the target inflation number (converted to a
pressure by :func:`turgorbayes.fem.pressure_for_inflation_number`) and ``ratio = E_par/E_perp``.
Points run serially, on a local process pool, or on a Dask distributed cluster, and each finished
point is written at once as one JSON record in a *points folder* (default ``<out>.points/``,
written atomically: temporary file, then rename). An interrupted build restarts with
``resume=True`` and redoes only unfinished or failed points. Failed points are recorded with
their error, reported at the end, and make the build raise :class:`BuildFailedError` (no table
is written with holes); the table is assembled from the records only when every grid point has
succeeded.

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

import dataclasses
import functools
import hashlib
import json
import os
import platform
import re
import subprocess
import sys
import time
import traceback
import warnings
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib.metadata import PackageNotFoundError, version
from multiprocessing import get_context
from pathlib import Path

import numpy as np

from turgorbayes.errors import TurgorBayesError
from turgorbayes.surrogate import FILE_FORMAT, FORMAT_VERSION, open_table

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
]

#: The production grid of the shipped table: 16 log-spaced target inflation numbers times 8
#: anisotropies (0.25-1: the anisotropies the wall model reaches for gamma in 0.6-2 at 0.5-40
#: kPa). The top target is above 0.5 because the table's domain is the FE's *actual* x, which
#: falls short of the target by up to ~3.5 % at x = 0.5 (and the interpolator never
#: extrapolates): the shipped domain is x in [0.005, 0.502].
DEFAULT_GRID_SPEC = "x=0.005:0.52:16log,ratio=0.25,0.3,0.4,0.5,0.6,0.7,0.85,1.0"

_AXES = ("x", "ratio")
# Per-point scalar fields copied from the FE result: name -> (netCDF name, units, description).
_SCALARS = {
    "x": ("x_actual", "1", "inflation number P R_c/(E_perp t) produced by the FE"),
    "pressure_Pa": ("pressure_Pa", "Pa", "turgor pressure"),
    "R_c_m": ("R_c_m", "m", "inflated cell radius from the FE"),
    "k_over_PR": ("k_over_PR", "1", "secant stiffness F(h)/h at h = R/20, over P R_c"),
    "k_linear_over_PR": ("k_linear_over_PR", "1", "small-indentation stiffness over P R_c"),
    "wall_time_s": ("fe_wall_time_s", "s", "FE wall time reported by the point function"),
    "newton_iterations": ("newton_iterations", "1", "total Newton iterations"),
    "mesh_dofs": ("mesh_dofs", "1", "degrees of freedom of the FE mesh"),
}
_CURVES = {"h_m": ("m", "indentation depth"), "F_N": ("N", "indentation force")}
# Optional per-point scalars: stored when the point function provides them for every point.
_OPTIONAL = {
    "max_penetration_m": ("max_penetration_m", "m",
                          "largest penetration of a node into the indenter (penalty error)"),
}


class GridSpecError(TurgorBayesError, ValueError):
    """A ``--grid`` specification cannot be parsed or holds invalid values."""


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


# --------------------------------------------------------------------------- grid


@dataclass(frozen=True)
class GridSpec:
    """Grid of the sweep: target inflation numbers ``x`` and anisotropies ``ratio``.

    Attributes
    ----------
    x : tuple of float
        Target ``P R_c/(E_perp t)``, strictly increasing, > 0.
    ratio : tuple of float
        ``E_par/E_perp``, strictly increasing, > 0.
    spec : str
        The text it was parsed from (recorded in the file).
    """

    x: tuple
    ratio: tuple
    spec: str

    def points(self):
        """All ``(x, ratio)`` pairs, ratio-major (the order of the table's rows)."""
        return [(x, r) for r in self.ratio for x in self.x]


def parse_grid(spec=DEFAULT_GRID_SPEC):
    """Parse a grid specification.

    Syntax: ``AXIS=ITEMS[,AXIS=ITEMS]`` for the axes ``x`` and ``ratio`` (both required; ``;``
    may also separate axes). ``ITEMS`` is a comma-separated list whose items are numbers or
    ranges ``START:STOP:Nlog`` (N log-spaced values, ends included) or ``START:STOP:N[lin]``
    (N evenly spaced). Items are merged, sorted and de-duplicated. Example:
    ``x=0.01:0.5:13log,ratio=0.3,0.4,0.5,0.7,1.0``.

    Parameters
    ----------
    spec : str

    Returns
    -------
    GridSpec

    Raises
    ------
    GridSpecError
        With the offending part of the text and what is allowed.
    """
    if not isinstance(spec, str) or not spec.strip():
        raise GridSpecError(f"grid spec must be a non-empty string, got {spec!r}")
    axes = {}
    for part in re.split(r"[;,]\s*(?=[A-Za-z_]\w*\s*=)", spec.strip()):
        name, sep, items = part.partition("=")
        name = name.strip()
        if not sep or name not in _AXES:
            raise GridSpecError(
                f"grid spec {spec!r}: bad axis {part!r}; expected 'x=...' or 'ratio=...'"
            )
        if name in axes:
            raise GridSpecError(f"grid spec {spec!r}: axis {name!r} given twice")
        axes[name] = _parse_axis(name, items, spec)
    missing = [a for a in _AXES if a not in axes]
    if missing:
        raise GridSpecError(f"grid spec {spec!r}: missing axis {missing} (both x and ratio needed)")
    return GridSpec(x=axes["x"], ratio=axes["ratio"], spec=spec.strip())


def _parse_axis(name, items, spec):
    values = []
    for item in items.split(","):
        item = item.strip()
        values.extend(_parse_range(item, spec) if ":" in item else [_parse_number(item, spec)])
    arr = np.unique(np.asarray(values, dtype=float))
    if arr.size > 1:  # merge values that differ only by rounding (e.g. a list item on a range)
        arr = arr[np.r_[True, np.diff(arr) > 1e-9 * np.abs(arr[1:])]]
    if not np.all(np.isfinite(arr) & (arr > 0)):
        raise GridSpecError(f"grid spec {spec!r}: {name} values must be finite and > 0, got {arr}")
    if arr.size < 4:
        raise GridSpecError(
            f"grid spec {spec!r}: {name} needs >= 4 distinct values for a cubic table, "
            f"got {arr.size}"
        )
    return tuple(float(v) for v in arr)


def _parse_number(text, spec):
    try:
        return float(text)
    except ValueError:
        raise GridSpecError(
            f"grid spec {spec!r}: {text!r} is not a number or a range START:STOP:N[log|lin]"
        ) from None


def _parse_range(text, spec):
    m = re.fullmatch(r"([^:]+):([^:]+):(\d+)(log|lin)?", text)
    if not m:
        raise GridSpecError(
            f"grid spec {spec!r}: bad range {text!r}; expected START:STOP:N, START:STOP:Nlin "
            "or START:STOP:Nlog"
        )
    start, stop = _parse_number(m[1], spec), _parse_number(m[2], spec)
    n = int(m[3])
    if n < 2 or not 0 < start < stop:
        raise GridSpecError(
            f"grid spec {spec!r}: range {text!r} needs 0 < START < STOP and N >= 2"
        )
    return np.geomspace(start, stop, n) if m[4] == "log" else np.linspace(start, stop, n)


# --------------------------------------------------------------------------- one point


def _jsonable(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def _result_record(res):
    """The fields of an ``IndentationResult`` the table stores, as JSON-ready values."""
    missing = [f for f in (*_SCALARS, *_CURVES, "ratio", "converged") if not hasattr(res, f)]
    if missing:
        raise TypeError(f"point function returned {type(res).__name__} without {missing}")
    rec = {f: _jsonable(getattr(res, f)) for f in (*_SCALARS, *_CURVES)}
    rec.update({f: _jsonable(getattr(res, f)) for f in _OPTIONAL if hasattr(res, f)})
    rec["fe_ratio"] = float(res.ratio)
    return rec, bool(res.converged)


def run_point(point_fn, pressure_fn, cfg, x, ratio):
    """Run one grid point and return its record; never raises for a failed FE run.

    Parameters
    ----------
    point_fn : callable
        ``point_fn(P, ratio, cfg)`` -> an ``IndentationResult``-like object
        (:func:`turgorbayes.fem.indentation_point`).
    pressure_fn : callable
        ``pressure_fn(x, ratio, cfg)`` -> pressure [Pa] for the target inflation number
        (:func:`turgorbayes.fem.pressure_for_inflation_number`).
    cfg : dataclass
        FE settings passed through.
    x : float
        Target inflation number [dimensionless].
    ratio : float
        ``E_par/E_perp`` [dimensionless].

    Returns
    -------
    dict
        ``status`` ("ok" or "failed"), ``x_target``, ``ratio``, the result fields or ``error``
        and ``traceback``, ``wall_time_s``, ``host``, ``pid``, ``started_utc``.
    """
    rec = {"x_target": float(x), "ratio": float(ratio), "host": platform.node(),
           "pid": os.getpid(), "started_utc": _now()}
    t0 = time.perf_counter()
    try:
        fields, converged = _result_record(point_fn(pressure_fn(x, ratio, cfg), ratio, cfg))
        rec.update(fields)
        rec["status"] = "ok" if converged else "failed"
        if not converged:
            rec["error"] = "the FE reported converged=False"
    except Exception as err:  # noqa: BLE001 -- every failure is recorded, none dropped
        rec.update(status="failed", error=f"{type(err).__name__}: {err}",
                   traceback=traceback.format_exc())
    rec["wall_time_s"] = time.perf_counter() - t0
    rec["fe_source_sha256"] = source_sha256(point_fn.__module__)
    return rec


@functools.cache
def source_sha256(module_name):
    """SHA-256 over the Python sources of a module's package (e.g. all of ``turgorbayes/fem``).

    Computed once per process, right after the point function was imported, so it fingerprints
    the FE code a worker actually runs (the working tree may change during a long build).

    Parameters
    ----------
    module_name : str

    Returns
    -------
    str
        Hex digest, or "unknown" if the sources cannot be found.
    """
    module = sys.modules.get(module_name)
    path = getattr(module, "__file__", None)
    if not path:
        return "unknown"
    path = Path(path)
    in_package = path.parent.joinpath("__init__.py").is_file()
    files = sorted(path.parent.glob("*.py")) if in_package else [path]
    digest = hashlib.sha256()
    for f in files:
        digest.update(f.name.encode() + b"\0" + f.read_bytes())
    return digest.hexdigest()


def _now():
    return datetime.now(UTC).isoformat(timespec="seconds")


# --------------------------------------------------------------------------- point store


class PointStore:
    """Folder of per-point JSON records (one file per grid point, written atomically).

    Parameters
    ----------
    directory : path-like
    config_sha256 : str
        Hash of the FE settings; a record made with other settings is never reused.
    """

    def __init__(self, directory, config_sha256):
        self.directory = Path(directory)
        self.config_sha256 = config_sha256

    def path_for(self, x, ratio):
        """File of grid point ``(x, ratio)``."""
        return self.directory / f"ratio{ratio:.9g}_x{x:.9g}.json"

    def write(self, record):
        """Write one record atomically (temporary file in the same folder, then rename)."""
        self.directory.mkdir(parents=True, exist_ok=True)
        record = {**record, "fe_config_sha256": self.config_sha256}
        final = self.path_for(record["x_target"], record["ratio"])
        tmp = final.with_name(f".{final.name}.{os.getpid()}.tmp")
        tmp.write_text(json.dumps(record, indent=1))
        os.replace(tmp, final)

    def read(self, x, ratio):
        """The record of a point, or None if it has none."""
        path = self.path_for(x, ratio)
        if not path.is_file():
            return None
        try:
            return json.loads(path.read_text())
        except json.JSONDecodeError as err:
            raise TurgorBayesError(f"corrupt point record {path}: {err}") from err

    def finished(self, grid):
        """Records of grid points that succeeded, keyed by ``(x, ratio)``.

        Raises
        ------
        TurgorBayesError
            If a record was made with different FE settings.
        """
        done = {}
        for x, r in grid.points():
            rec = self.read(x, r)
            if rec is None or rec.get("status") != "ok":
                continue
            if rec.get("fe_config_sha256") != self.config_sha256:
                raise TurgorBayesError(
                    f"{self.path_for(x, r)} was computed with other FE settings "
                    f"(config hash {rec.get('fe_config_sha256')}, now {self.config_sha256}); "
                    "use another --points-dir or delete the old records"
                )
            done[(x, r)] = rec
        return done

    def n_records(self):
        """Number of point records in the folder (any grid, any status)."""
        return len(list(self.directory.glob("ratio*_x*.json"))) if self.directory.is_dir() else 0

    def log_session(self, session):
        """Append one line describing a build invocation to ``sessions.jsonl``."""
        self.directory.mkdir(parents=True, exist_ok=True)
        with open(self.directory / "sessions.jsonl", "a") as fh:
            fh.write(json.dumps(session) + "\n")

    def sessions(self):
        """All logged build invocations, oldest first."""
        path = self.directory / "sessions.jsonl"
        if not path.is_file():
            return []
        return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


# --------------------------------------------------------------------------- executors


@contextmanager
def _thread_limits(n_threads):
    """Limit BLAS/OpenMP threads of the worker processes spawned inside the block.

    Two workers on two cores each running a multi-threaded solver oversubscribe the machine;
    a spawned child reads these variables when it starts. Variables the user set are kept.
    """
    names = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS")
    added = [n for n in names if n not in os.environ]
    for n in added:
        os.environ[n] = str(n_threads)
    try:
        yield
    finally:
        for n in added:
            os.environ.pop(n, None)


def _run_serial(tasks, job):
    for x, r in tasks:
        yield run_point(*job, x, r)


def _run_pool(tasks, job, workers):
    cores = os.cpu_count() or 1
    # spawn, not fork: the parent runs threads (tqdm's monitor) and fork + threads can deadlock.
    with _thread_limits(max(1, cores // workers)), ProcessPoolExecutor(
        max_workers=workers, mp_context=get_context("spawn")
    ) as pool:
        futures = {pool.submit(run_point, *job, x, r): (x, r) for x, r in tasks}
        try:
            for fut in as_completed(futures):
                yield _future_record(fut, *futures[fut])
        finally:
            pool.shutdown(wait=True, cancel_futures=True)


def _run_dask(tasks, job, scheduler):
    from dask.distributed import Client
    from dask.distributed import as_completed as dask_completed

    client = scheduler if isinstance(scheduler, Client) else Client(scheduler)
    try:
        futures = {
            client.submit(run_point, *job, x, r, pure=False, key=f"fe-point-r{r:.9g}-x{x:.9g}"):
            (x, r) for x, r in tasks
        }
        for fut in dask_completed(futures):
            yield _future_record(fut, *futures[fut])
    finally:
        if client is not scheduler:
            client.close()


def _future_record(fut, x, ratio):
    """Result of a future; an executor-level failure (dead worker) becomes a failed record."""
    try:
        return fut.result()
    except Exception as err:  # noqa: BLE001 -- recorded, not dropped
        return {"x_target": float(x), "ratio": float(ratio), "status": "failed",
                "error": f"{type(err).__name__} in the executor: {err}",
                "traceback": traceback.format_exc(), "wall_time_s": float("nan")}


def run_points(points, point_fn, pressure_fn, cfg, workers=1, scheduler=None):
    """Run FE points and yield their records (:func:`run_point`) in order of completion.

    Parameters
    ----------
    points : list of (float, float)
        ``(x, ratio)`` pairs.
    point_fn, pressure_fn, cfg
        As in :func:`run_point`.
    workers : int
        Local processes (spawned; BLAS/OpenMP threads limited to ``cores // workers``);
        1 runs in this process.
    scheduler : str or dask.distributed.Client, optional
        Dask scheduler address or client; overrides ``workers``.
    """
    return _executor(list(points), (point_fn, pressure_fn, cfg), workers, scheduler)


def _executor(tasks, job, workers, scheduler):
    if scheduler is not None:
        return _run_dask(tasks, job, scheduler)
    if workers > 1 and len(tasks) > 1:
        return _run_pool(tasks, job, min(workers, len(tasks)))
    return _run_serial(tasks, job)


# --------------------------------------------------------------------------- provenance


def _config_dict(cfg):
    if dataclasses.is_dataclass(cfg) and not isinstance(cfg, type):
        return dataclasses.asdict(cfg)
    raise TurgorBayesError(f"cfg must be a dataclass instance (CapsuleConfig), got {cfg!r}")


def _config_sha256(cfg_dict):
    text = json.dumps(cfg_dict, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def _git_info(exclude=()):
    """Commit of the source tree and its uncommitted changes under ``turgorbayes/``."""
    here = Path(__file__).resolve().parent

    def git(*args):
        out = subprocess.run(["git", "-C", str(here), *args], capture_output=True, text=True,
                             timeout=30, check=True)
        return out.stdout

    try:
        commit = git("rev-parse", "HEAD").strip()
        top = Path(git("rev-parse", "--show-toplevel").strip())
        lines = git("status", "--porcelain", "--", str(here)).splitlines()
    except (OSError, subprocess.SubprocessError):
        return {"git_commit": "unknown (not a git checkout)", "git_dirty": "unknown",
                "git_dirty_files": []}
    skip = {str(Path(p).resolve().relative_to(top)) for p in exclude
            if Path(p).resolve().is_relative_to(top)}
    dirty = [ln for ln in lines if ln[3:].strip() not in skip]
    return {"git_commit": commit, "git_dirty": "yes" if dirty else "no",
            "git_dirty_files": dirty[:50]}


def _library_versions():
    versions = {"python": platform.python_version()}
    for name in ("turgorbayes", "numpy", "scipy", "scikit-fem", "pypardiso", "xarray"):
        try:
            versions[name] = version(name)
        except PackageNotFoundError:
            continue
    return versions


def _source_counts(records):
    """How many points each FE source version (hash) computed."""
    counts = {}
    for rec in records:
        key = rec.get("fe_source_sha256", "unknown")
        counts[key] = counts.get(key, 0) + 1
    return counts


def _provenance(cfg_dict, grid, point_fn, mesh_convergence, sessions, records, out):
    times = np.array([r["wall_time_s"] for r in records])
    sources = _source_counts(records)
    attrs = {
        "file_format": FILE_FORMAT,
        "format_version": FORMAT_VERSION,
        "title": "Reduced indentation stiffness k_c/(P R_c) of a pressurized capsule (FE)",
        "fe_config": cfg_dict,
        "fe_config_sha256": _config_sha256(cfg_dict),
        "mesh_convergence": mesh_convergence if mesh_convergence is not None
        else "not recorded (the FE code provides no MESH_CONVERGENCE)",
        "point_function": f"{point_fn.__module__}.{point_fn.__qualname__}",
        "fe_source_sha256": next(iter(sources)) if len(sources) == 1 else sources,
        "fe_source_consistent": "yes" if len(sources) == 1 else "no",
        "turgorbayes_version": _library_versions().get("turgorbayes", "unknown"),
        "library_versions": _library_versions(),
        **_git_info(exclude=[out]),
        "created_utc": _now(),
        "host": platform.node(),
        "host_cores": os.cpu_count() or 0,
        "command_line": sessions[-1]["command_line"] if sessions else "",
        "grid_spec": grid.spec,
        "total_point_wall_time_s": float(times.sum()),
        "per_point_wall_time_s": {"min": float(times.min()), "median": float(np.median(times)),
                                  "max": float(times.max())},
        "build_sessions": sessions,
    }
    # netCDF attributes hold numbers and text; everything structured is stored as JSON text
    return {k: v if isinstance(v, int | float | str) and not isinstance(v, bool)
            else json.dumps(v, default=repr) for k, v in attrs.items()}


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
        Layout of the module docstring.
    """
    import xarray as xr

    shape = (len(grid.ratio), len(grid.x))
    rows = [[records[(x, r)] for x in grid.x] for r in grid.ratio]
    n_step = max(len(rec["h_m"]) for row in rows for rec in row)
    data = {}
    scalars = {**_SCALARS, "wall_time_s": (
        "wall_time_s", "s", "wall time of the whole point incl. the pressure search")}
    scalars.update({f: v for f, v in _OPTIONAL.items()
                    if all(f in rec for row in rows for rec in row)})
    for field, (name, units, desc) in scalars.items():
        values = np.array([[rec[field] for rec in row] for row in rows])
        data[name] = (("ratio", "x"), values.reshape(shape), {"units": units, "long_name": desc})
    for field, (units, desc) in _CURVES.items():
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
        mesh_convergence = getattr(fem, "MESH_CONVERGENCE", None)
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
        tqdm progress bar and one line per finished point on stderr.
    command_line : str, optional
        Recorded in the provenance (default: this process's argv).
    mesh_convergence : dict, optional
        Mesh-convergence estimate to record; default ``turgorbayes.fem.MESH_CONVERGENCE``
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
    cfg_dict = _config_dict(cfg)
    store = PointStore(points_dir or f"{out}.points", _config_sha256(cfg_dict))
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
    if len(_source_counts(records)) > 1:
        warnings.warn(
            f"the points of {out} were computed by {len(_source_counts(records))} different "
            "versions of the FE source code (the build was resumed after the code changed); see "
            "the fe_source_sha256 attribute, and rebuild from scratch for a consistent table",
            RuntimeWarning, stacklevel=2)
    attrs = _provenance(cfg_dict, grid, point_fn, mesh_convergence or fe_conv, store.sessions(),
                        records, out)
    _write_atomic(assemble_table(grid, done, attrs), out)
    open_table(out)  # read back: the file just written must load as a surrogate
    return BuildReport(Path(out), len(todo), len(grid.points()) - len(todo),
                       session["elapsed_s"])


def _start_session(workers, scheduler, command_line, n_todo, n_done):
    return {"started_utc": _now(), "t0": time.perf_counter(), "workers": int(workers),
            "scheduler": None if scheduler is None else str(scheduler),
            "command_line": command_line or " ".join(sys.argv), "host": platform.node(),
            "host_cores": os.cpu_count() or 0, "points_to_run": n_todo, "points_reused": n_done}


def _end_session(session, n_failed):
    session["elapsed_s"] = time.perf_counter() - session.pop("t0")
    session.update(finished_utc=_now(), points_failed=n_failed)
    return session


def _sweep(todo, job, store, done, workers, scheduler, progress):
    """Run the points, store each record as it arrives, return the failed records."""
    from tqdm import tqdm

    failed = []
    with tqdm(total=len(todo), desc="FE points", unit="pt", disable=not progress,
              file=sys.stderr) as bar:
        for rec in _executor(todo, job, workers, scheduler):
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


def check_surrogate(s, n=3, seed=0, *, points=None, cfg=None, point_fn=None, pressure_fn=None,
                    workers=1, progress=True):
    """Re-run FE points inside a table (random, or given) and compare them with its interpolation.

    Parameters
    ----------
    s : turgorbayes.surrogate.Surrogate
    n : int
        Number of random points: ``log x`` and ``log ratio`` uniform inside ``s.domain`` (kept
        2% away from its edges so that the FE's own ``x`` stays inside).
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
        tqdm progress bar on stderr.

    Returns
    -------
    list of dict
        Per point its record plus ``k_interp``, ``k_linear_interp`` and the relative errors
        ``err`` and ``err_linear`` (``s/k_FE - 1``; NaN for a failed point).
    """
    if points is None and int(n) < 1:
        raise TurgorBayesError(f"n must be >= 1, got {n}")
    if cfg is None:
        from turgorbayes import fem

        cfg = config_from_metadata(s.metadata["fe_config"], fem.CapsuleConfig)
    cfg, point_fn, pressure_fn, _ = _fe_defaults(cfg, point_fn, pressure_fn)
    tasks = _check_points(s, n, seed) if points is None else _given_points(s, points)
    from tqdm import tqdm

    records = []
    with tqdm(total=len(tasks), desc="FE check", unit="pt", disable=not progress, file=sys.stderr) as bar:
        for rec in _executor(tasks, (point_fn, pressure_fn, cfg), workers, None):
            records.append(_compare(s, rec))
            bar.update(1)
    return sorted(records, key=lambda r: (r["ratio"], r["x_target"]))


def _check_points(s, n, seed):
    """``n`` random (x, ratio), log-uniform inside the domain (x kept 2 % from its edges)."""
    rng = np.random.default_rng(seed)
    (xlo, xhi), (rlo, rhi) = s.domain["x"], s.domain["ratio"]
    xs = np.exp(rng.uniform(np.log(xlo * 1.02), np.log(xhi / 1.02), n))
    rs = np.exp(rng.uniform(np.log(rlo), np.log(rhi), n))
    return list(zip(xs.tolist(), rs.tolist(), strict=True))


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
           "err_linear": np.nan}
    if rec["status"] == "ok":
        rec["k_interp"] = s(rec["x"], rec["ratio"], warn=False)
        rec["k_linear_interp"] = s.linear(rec["x"], rec["ratio"], warn=False)
        rec["err"] = rec["k_interp"] / rec["k_over_PR"] - 1
        rec["err_linear"] = rec["k_linear_interp"] / rec["k_linear_over_PR"] - 1
    return rec
