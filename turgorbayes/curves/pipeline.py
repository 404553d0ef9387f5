"""A manifest of force curves -> per-curve results (``curves.csv``) and the cell-data table."""

import csv
import math
from dataclasses import dataclass

import numpy as np

from turgorbayes import __version__
from turgorbayes.curves import glass
from turgorbayes.curves.combine import combine_stiffness
from turgorbayes.curves.reduce import DEFAULT_SETTINGS, ReductionSettings, reduce_curve
from turgorbayes.io import CellData

__all__ = ["CURVE_COLUMNS", "ManifestResult", "cells_from_curves", "reduce_manifest", "reduce_row",
           "write_curves_table"]

#: Columns of ``curves.csv`` (then the manifest's extra columns).
CURVE_COLUMNS = ("file", "manifest_line", "cell_id", "target", "status", "detail",
                 "contact_height_nm", "contact_err_nm", "window_from_nm", "window_to_nm",
                 "depth_nm", "depth_err_nm", "k_N_per_m", "k_err_N_per_m", "exponent",
                 "baseline_noise_pN", "spring_constant_N_per_m", "n_points", "curve_index") + glass.GLASS_COLUMNS


@dataclass(frozen=True)
class ManifestResult:
    """Everything ``turgorbayes curves`` reports.

    Attributes
    ----------
    manifest : turgorbayes.curves.manifest.Manifest
        As reduced: rows of glass-corrected sessions carry their glass-measured sensitivity.
    settings : ReductionSettings
    results : tuple of CurveResult
        One per manifest row, in order.
    cells : turgorbayes.io.CellData or None
        The cells with at least one accepted curve per target they need (None if none).
    left_out : dict
        cell_id -> why the cell is not in ``cells``.
    """

    manifest: object
    settings: ReductionSettings
    results: tuple
    cells: CellData
    left_out: dict


def reduce_row(row, settings=DEFAULT_SETTINGS, trace=None):
    """Reduce the curve of one manifest row (:func:`~turgorbayes.curves.reduce.reduce_curve`).

    Parameters
    ----------
    row : turgorbayes.curves.manifest.ManifestRow
        Its radius (``R_c`` on cell rows, ``R_b`` on bulge rows) and calibration overrides are used.
    settings : ReductionSettings
    trace : turgorbayes.curves.reduce.CurveTrace, optional
        Filled with the intermediate arrays (for the curve's figure).

    Returns
    -------
    CurveResult
    """
    if row.target == "glass":  # a session's sensitivity reference (turgorbayes.curves.glass)
        return glass.reduce_glass_curve(row.file, settings, row.spring_constant, row.sensitivity,
                                        row.curve_index, trace)
    return reduce_curve(row.file, row.target, row.R_c if row.target == "cell" else row.R_b, settings,
                        row.spring_constant, row.sensitivity, trace, row.curve_index)


def reduce_manifest(manifest, settings=DEFAULT_SETTINGS, progress=False):
    """Reduce every curve of a manifest and combine them per cell.

    Parameters
    ----------
    manifest : turgorbayes.curves.manifest.Manifest
    settings : ReductionSettings
    progress : bool
        Show a tqdm progress bar over the files.

    Returns
    -------
    ManifestResult
    """
    from tqdm import tqdm

    manifest = glass.corrected_manifest(manifest, settings)  # glass-referenced sessions' sensitivity
    rows = tqdm(manifest.rows, desc="curves", unit="file", disable=not progress)
    results = tuple(reduce_row(r, settings) for r in rows)
    cells, left_out = cells_from_curves(manifest, settings, results)
    return ManifestResult(manifest, settings, results, cells, left_out)


def _cell_groups(manifest, results):
    groups = {}
    for row, res in zip(manifest.rows, results, strict=True):
        if row.target != "glass":  # glass rows belong to a session, never to a cell
            groups.setdefault(row.cell_id, []).append((row, res))
    return groups


def _combined(pairs, target):
    ok = [res for row, res in pairs if row.target == target and res.ok]
    if not ok:
        return None
    return combine_stiffness([r.k for r in ok], [r.k_err for r in ok], [r.depth for r in ok])


def _extra_value(pairs, column):
    values = list(dict.fromkeys(row.extra.get(column, "") for row, _ in pairs))
    return values[0] if len(values) == 1 else ";".join(values)


def cells_from_curves(manifest, settings, results):
    """Combine accepted curves into one row per cell (docs/curves.md, Combining curves).

    A cell whose cell-body curves (or, with bulge rows, whose bulge curves) were all rejected is
    left out, with the reason.

    Returns
    -------
    cells : CellData or None
    left_out : dict of str to str
    """
    rows, left_out = [], {}
    for cell_id, pairs in _cell_groups(manifest, results).items():
        bulged = any(row.target == "bulge" for row, _ in pairs)
        kc = _combined(pairs, "cell")
        kb = _combined(pairs, "bulge") if bulged else None
        if kc is None or (bulged and kb is None):
            missing = "cell-body" if kc is None else "bulge"
            reasons = sorted({res.status for row, res in pairs if not res.ok})
            left_out[cell_id] = f"every {missing} curve rejected ({', '.join(reasons)})"
            continue
        rows.append((cell_id, pairs[0][0], bulged, kc, kb, pairs))
    if not rows:
        return None, left_out
    nan = math.nan
    first = [r[1] for r in rows]
    cells = CellData(
        cell_id=[r[0] for r in rows], group=["bulged" if r[2] else "intact" for r in rows],
        R_c=[f.R_c for f in first], R_c_err=[f.R_c_err for f in first],
        k_c=[r[3][0] for r in rows], k_c_err=[r[3][1] for r in rows],
        R_b=[_bulge_row(r[5]).R_b if r[2] else nan for r in rows],
        R_b_err=[_bulge_row(r[5]).R_b_err if r[2] else nan for r in rows],
        k_b=[r[4][0] if r[2] else nan for r in rows], k_b_err=[r[4][1] if r[2] else nan for r in rows],
        h_b=[r[4][2] if r[2] else nan for r in rows],
        extra={c: [_extra_value(r[5], c) for r in rows] for c in manifest.extra_columns},
        comments=_comments(manifest, settings, results, left_out),
    )
    return cells, left_out


def _bulge_row(pairs):
    return next(row for row, _ in pairs if row.target == "bulge")


def _comments(manifest, settings, results, left_out):
    n_ok = sum(r.ok for r in results)
    lines = [f"# turgorbayes curves {__version__}: cells from the force curves of manifest "
             f"{manifest.path.name} (sha256 {manifest.sha256})",
             "# settings: " + ", ".join(f"{k} = {v}" for k, v in settings.as_dict().items())
             + " (SI units)",
             f"# curves: {n_ok} of {len(results)} accepted; per-curve results and rejection "
             "reasons in the curves table beside this file"]
    if left_out:
        lines.append(f"# cells left out (every curve of a target rejected): {', '.join(left_out)}")
    lines += [f"# {line}" for line in glass.glass_report(manifest, results, settings)]
    lines += [f"# manifest {c.lstrip('#').strip()}" for c in manifest.comments]
    return lines


def _fmt(value, scale=1.0):
    return "" if value is None or not np.isfinite(value) else f"{value * scale:.6g}"


def write_curves_table(path, result):
    """Write ``curves.csv``: one row per manifest row, accepted or not (:data:`CURVE_COLUMNS`).

    Parameters
    ----------
    path : str or pathlib.Path
    result : ManifestResult
    """
    manifest = result.manifest
    sessions = glass.session_glass(manifest, result.results, result.settings)
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(CURVE_COLUMNS + manifest.extra_columns)
        for row, res in zip(manifest.rows, result.results, strict=True):
            writer.writerow([
                row.name, row.line, row.cell_id, row.target, res.status, res.detail,
                _fmt(res.contact_height, 1e9), _fmt(res.contact_err, 1e9),
                _fmt(res.window[0], 1e9), _fmt(res.window[1], 1e9), _fmt(res.depth, 1e9),
                _fmt(res.depth_err, 1e9), _fmt(res.k), _fmt(res.k_err), _fmt(res.exponent),
                _fmt(res.baseline_noise, 1e12), _fmt(res.spring_constant), res.n_points,
                row.curve_index, *glass.glass_fields(row, res, sessions),
                *(row.extra.get(c, "") for c in manifest.extra_columns)])
