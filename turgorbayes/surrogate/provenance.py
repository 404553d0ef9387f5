"""Provenance of a surrogate table: FE settings and source hashes, git state, versions, times."""

import dataclasses
import functools
import hashlib
import json
import os
import platform
import sys
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

import numpy as np

from turgorbayes import __version__
from turgorbayes.errors import TurgorBayesError
from turgorbayes.provenance import git_state, utc_now
from turgorbayes.surrogate.table import FILE_FORMAT, FORMAT_VERSION

__all__ = ["config_dict", "config_sha256", "source_counts", "source_sha256", "table_attributes",
           "utc_now"]


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


def config_dict(cfg):
    """The FE settings dataclass as a plain dict."""
    if dataclasses.is_dataclass(cfg) and not isinstance(cfg, type):
        return dataclasses.asdict(cfg)
    raise TurgorBayesError(f"cfg must be a dataclass instance (CapsuleConfig), got {cfg!r}")


def config_sha256(cfg_dict):
    """SHA-256 of the FE settings (sorted JSON)."""
    text = json.dumps(cfg_dict, sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def _git_info(exclude=()):
    """Commit of the source tree and its uncommitted changes under ``turgorbayes/``."""
    here = Path(__file__).resolve().parents[1]  # the turgorbayes package
    state = git_state(here, pathspec=here, untracked=True)
    if state is None:
        return {"git_commit": "unknown (not a git checkout)", "git_dirty": "unknown",
                "git_dirty_files": []}
    top = state["top"]
    skip = {str(Path(p).resolve().relative_to(top)) for p in exclude
            if Path(p).resolve().is_relative_to(top)}
    dirty = [ln for ln in state["changes"] if ln[3:].strip() not in skip]
    return {"git_commit": state["commit"], "git_dirty": "yes" if dirty else "no",
            "git_dirty_files": dirty[:50]}


def _library_versions():
    # turgorbayes' own from its source (an editable install's metadata may be stale)
    versions = {"python": platform.python_version(), "turgorbayes": __version__}
    for name in ("numpy", "scipy", "scikit-fem", "pypardiso", "xarray"):
        try:
            versions[name] = version(name)
        except PackageNotFoundError:
            continue
    return versions


def source_counts(records):
    """How many points each FE source version (hash) computed."""
    counts = {}
    for rec in records:
        key = rec.get("fe_source_sha256", "unknown")
        counts[key] = counts.get(key, 0) + 1
    return counts


def table_attributes(cfg_dict, grid, point_fn, mesh_convergence, sessions, records, out):
    """Global attributes of a table (netCDF-ready: structured values as JSON text)."""
    times = np.array([r["wall_time_s"] for r in records])
    sources = source_counts(records)
    attrs = {
        "file_format": FILE_FORMAT,
        "format_version": FORMAT_VERSION,
        "title": "Reduced indentation stiffness k_c/(P R_c) of a pressurized capsule (FE)",
        "fe_config": cfg_dict,
        "fe_config_sha256": config_sha256(cfg_dict),
        "mesh_convergence": mesh_convergence if mesh_convergence is not None
        else "not recorded (no mesh-convergence record was given)",
        "point_function": f"{point_fn.__module__}.{point_fn.__qualname__}",
        "fe_source_sha256": next(iter(sources)) if len(sources) == 1 else sources,
        "fe_source_consistent": "yes" if len(sources) == 1 else "no",
        "turgorbayes_version": _library_versions().get("turgorbayes", "unknown"),
        "library_versions": _library_versions(),
        **_git_info(exclude=[out]),
        "created_utc": utc_now(),
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
