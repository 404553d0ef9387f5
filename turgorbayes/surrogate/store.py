"""Per-point records of a surrogate build: the fields kept from an FE run and their folder."""

import json
import os
from pathlib import Path

import numpy as np

from turgorbayes.errors import TurgorBayesError

__all__ = ["CURVE_FIELDS", "OPTIONAL_FIELDS", "SCALAR_FIELDS", "PointStore", "result_record"]

#: Per-point scalar fields copied from the FE result: name -> (netCDF name, units, description).
SCALAR_FIELDS = {
    "x": ("x_actual", "1", "inflation number P R_c/(E_perp t) produced by the FE"),
    "pressure_Pa": ("pressure_Pa", "Pa", "turgor pressure"),
    "R_c_m": ("R_c_m", "m", "inflated cell radius from the FE"),
    "k_over_PR": ("k_over_PR", "1", "secant stiffness F(h)/h at h = R/20, over P R_c"),
    "k_linear_over_PR": ("k_linear_over_PR", "1", "small-indentation stiffness over P R_c"),
    "wall_time_s": ("fe_wall_time_s", "s", "FE wall time reported by the point function"),
    "newton_iterations": ("newton_iterations", "1", "total Newton iterations"),
    "mesh_dofs": ("mesh_dofs", "1", "degrees of freedom of the FE mesh"),
}
#: Per-point curves: name -> (units, description).
CURVE_FIELDS = {"h_m": ("m", "indentation depth"), "F_N": ("N", "indentation force")}
#: Optional per-point scalars: stored when the point function provides them for every point.
OPTIONAL_FIELDS = {
    "max_penetration_m": ("max_penetration_m", "m",
                          "largest penetration of a node into the indenter (penalty error)"),
    "schedule": ("schedule", "1", "depth steps used: fixed, adaptive, or fixed after adaptive "
                 "failed (with the error)"),
    "buckled": ("buckled", "1", "the force fell before h = R/20: the wall buckled under the tip"),
}



def _jsonable(value):
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def result_record(res):
    """The fields of an ``IndentationResult`` the table stores, as JSON-ready values."""
    missing = [f for f in (*SCALAR_FIELDS, *CURVE_FIELDS, "ratio", "converged") if not hasattr(res, f)]
    if missing:
        raise TypeError(f"point function returned {type(res).__name__} without {missing}")
    rec = {f: _jsonable(getattr(res, f)) for f in (*SCALAR_FIELDS, *CURVE_FIELDS)}
    rec.update({f: _jsonable(getattr(res, f)) for f in OPTIONAL_FIELDS if hasattr(res, f)})
    rec["fe_ratio"] = float(res.ratio)
    return rec, bool(res.converged)


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
