"""A manifest of force curves -> per-curve results (``curves.csv``) and the cell-data table."""

import csv
import math
from dataclasses import asdict, dataclass, field

import numpy as np

from turgorbayes import __version__
from turgorbayes.cache import MISSING, file_sha256
from turgorbayes.cache import key as cache_key
from turgorbayes.cells.columns import CURVE_FLAGS, ERROR_CORRELATION
from turgorbayes.cells.table import CellData
from turgorbayes.curves import bulgemap, forcemap, glass
from turgorbayes.curves.combine import combine_stiffness
from turgorbayes.curves.reduce import DEFAULT_SETTINGS, CurveTrace, ReductionSettings, reduce_curve
from turgorbayes.errors import DataError
from turgorbayes.parallel import ordered_imap
from turgorbayes.progress import progress as show_progress

__all__ = ["CURVE_COLUMNS", "LOW_SIGNAL", "ManifestResult", "cells_from_curves", "curve_key", "low_signal_cells",
           "problem_rows", "reduce_manifest", "reduce_row", "write_curves_table"]

#: A cell-body reading whose force at the reading depth, ``k h``, is under this many baseline
#: sds is read high on average (+6 % at 2x, +24 % at 1x the noise; docs/curves.md, "From raw
#: curves to posteriors"): :func:`low_signal_cells` names such cells.
LOW_SIGNAL = 3.0

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
    cells : turgorbayes.cells.table.CellData or None
        The cells with at least one accepted curve per target they need (None if none).
    left_out : dict
        cell_id -> why the cell is not in ``cells``.
    maps : dict
        Manifest line -> :class:`~turgorbayes.curves.forcemap.ForceMapResult` of each whole-map
        row (``curve_index`` = ``map``; its entry in ``results`` is the map's combined crest
        stiffness).
    """

    manifest: object
    settings: ReductionSettings
    results: tuple
    cells: CellData
    left_out: dict
    maps: dict = field(default_factory=dict)


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
    if row.whole_map:  # every curve of a force map (turgorbayes.curves.forcemap)
        return map_row_result(reduce_map_row(row, settings), row.R_c)
    if row.target == "glass":  # a session's sensitivity reference (turgorbayes.curves.glass)
        return glass.reduce_glass_curve(row.file, settings, row.spring_constant, row.sensitivity,
                                        row.curve_index, trace)
    return reduce_curve(row.file, row.target, row.R_c if row.target == "cell" else row.R_b, settings,
                        row.spring_constant, row.sensitivity, trace, row.curve_index)


def problem_rows(result):
    """Which rows a user should look at: rejected curves, every curve of a cell left out or read
    with a low signal (:func:`low_signal_cells`), and whole force maps (one figure per map).

    Parameters
    ----------
    result : ManifestResult

    Returns
    -------
    list of bool
        One per manifest row.
    """
    rows, results = result.manifest.rows, result.results
    cells = set(result.left_out) | set(low_signal_cells(rows, results))
    return [(not res.ok) or row.whole_map or row.cell_id in cells
            for row, res in zip(rows, results, strict=True)]


def low_signal_cells(rows, results, ratio=LOW_SIGNAL):
    """Cells with an accepted cell-body reading whose force at its depth is under ``ratio``
    baseline sds (``k depth < ratio noise``), in manifest order, each once.

    Parameters
    ----------
    rows : sequence of ManifestRow
    results : sequence of CurveResult
        One per row.
    ratio : float [-]
    """
    out = []
    for row, res in zip(rows, results, strict=True):
        if (row.target == "cell" and res.accepted and res.k * res.depth < ratio * res.baseline_noise
                and row.cell_id not in out):
            out.append(row.cell_id)
    return out


def reduce_manifest(manifest, settings=DEFAULT_SETTINGS, progress=False, on_curve=None,
                    workers=1, scheduler=None, cache=None):
    """Reduce every curve of a manifest and combine them per cell.

    Parameters
    ----------
    manifest : turgorbayes.curves.manifest.Manifest
    settings : ReductionSettings
    progress : bool
        Show progress over the files (and over each force map's curves;
        :func:`turgorbayes.progress.progress`).
    on_curve : callable, optional
        Called as ``on_curve(row, result, trace)`` after each row reduced here: a single curve
        with its :class:`~turgorbayes.curves.reduce.CurveTrace`, a whole force map with its
        reduced map and None (e.g. :class:`turgorbayes.plots.curves.CurveFigureWriter`: every
        figure drawn without reducing its curve again). A single curve taken from ``cache``
        has no trace and is not passed.
    workers : int
        Processes that reduce the rows (:func:`turgorbayes.parallel.ordered_map`); the rows'
        results are the same, and in the same order, whatever their number.
    scheduler : str, optional
        A Dask scheduler's address (or ``"local"``) to reduce the rows on instead.
    cache : turgorbayes.cache.Cache, optional
        Rows whose entry (:func:`curve_key`) it holds are not reduced again; every row reduced
        is stored in it as soon as it is done. The results are the same with or without it.

    Returns
    -------
    ManifestResult
    """
    manifest = glass.corrected_manifest(manifest, settings)  # glass-referenced sessions' sensitivity
    keys = [curve_key(row, settings) if cache is not None else None for row in manifest.rows]
    stored = [MISSING if k is None else cache.get(k) for k in keys]
    todo = [row for row, hit in zip(manifest.rows, stored, strict=True) if hit is MISSING]
    jobs = [(row, settings, on_curve is not None, manifest.path) for row in todo]
    if workers > 1 or scheduler is not None:
        done = ordered_imap(_reduce_job, jobs, workers, scheduler)
    else:
        done = (_reduce_job(job, progress) for job in jobs)
    results, maps = [], {}
    for row, entry_key, hit in show_progress(
            zip(manifest.rows, keys, stored, strict=True), total=len(manifest.rows), desc="curves",
            unit="file", enabled=progress):
        if hit is MISSING:
            result, trace, reduced_map = next(done)
            if entry_key is not None:
                cache.put(entry_key, (result, reduced_map))
        else:
            (result, reduced_map), trace = hit, None
        results.append(result)
        if reduced_map is not None:
            maps[row.line] = reduced_map
        if on_curve is not None and (row.whole_map or trace is not None):
            on_curve(row, reduced_map if row.whole_map else result, trace)
    results = tuple(results)
    cells, left_out = cells_from_curves(manifest, settings, results, maps)
    return ManifestResult(manifest, settings, results, cells, left_out, maps)


def curve_key(row, settings):
    """The cache key of a manifest row's reduction (:func:`turgorbayes.cache.key`): the sha256
    of its file's bytes, the row's fields that reach the reduction (file, radii, calibration,
    curve index; not its line, cell or extra columns), the settings and the package version.
    None when the file cannot be read (its reduction then says why)."""
    try:
        digest = file_sha256(row.file)
    except OSError:
        return None
    fields = {k: v for k, v in asdict(row).items() if k not in ("line", "cell_id", "extra")}
    return cache_key("curve", file_sha256=digest, row=fields, settings=settings.as_dict())


def _reduce_job(job, progress=False):
    """One manifest row reduced (a worker's task): ``(result, trace or None, reduced map or
    None)``; the trace only when figures are drawn as the rows are reduced."""
    row, settings, traced, manifest_path = job
    if row.whole_map:
        reduced = reduce_map_row(row, settings, progress, manifest_path)
        return map_row_result(reduced, row.R_c), None, reduced
    trace = CurveTrace() if traced else None
    return reduce_row(row, settings, trace), trace, None


def map_row_result(result, manifest_radius):
    """The manifest row's result of a reduced map: a bulge map's
    (:func:`turgorbayes.curves.bulgemap.bulge_row_result`) or a cell map's
    (:func:`turgorbayes.curves.forcemap.row_result`)."""
    if result.target == "bulge":
        return bulgemap.bulge_row_result(result)
    return forcemap.row_result(result, manifest_radius)


def reduce_map_row(row, settings=DEFAULT_SETTINGS, progress=False, manifest_path=None):
    """:func:`turgorbayes.curves.forcemap.reduce_map_row` (a bulge row:
    :func:`turgorbayes.curves.bulgemap.reduce_bulge_map_row`), its errors naming the manifest row.

    Raises
    ------
    turgorbayes.errors.DataError
        The file is not a force map (no grid positions): manifest, line, column ``file``.
    """
    reduce = bulgemap.reduce_bulge_map_row if row.target == "bulge" else forcemap.reduce_map_row
    try:
        return reduce(row, settings, progress)
    except DataError as err:
        raise DataError(f"{row.name!r} cannot be reduced as a whole force map (curve_index "
                        f"'map'): {err}", path=manifest_path, line=row.line, column="file",
                        value=row.name) from None


def _cell_groups(manifest, results):
    groups = {}
    for row, res in zip(manifest.rows, results, strict=True):
        if row.target != "glass":  # glass rows belong to a session, never to a cell
            groups.setdefault(row.cell_id, []).append((row, res))
    return groups


def _combined(pairs, target):
    ok = [res for row, res in pairs if row.target == target and res.accepted]
    if not ok:
        return None
    return combine_stiffness([r.k for r in ok], [r.k_err for r in ok], [r.depth for r in ok])


def _extra_value(pairs, column):
    values = list(dict.fromkeys(row.extra.get(column, "") for row, _ in pairs))
    return values[0] if len(values) == 1 else ";".join(values)


def _curve_flags(cell_id, pairs, low):
    """The cell's :data:`~turgorbayes.cells.columns.CURVE_FLAGS` (flags joined by ";")."""
    flags = ["low_signal"] if cell_id in low else []
    if any(res.accepted and not res.ok for _, res in pairs):
        flags.append("imprecise_curve")
    return ";".join(flags)


def _with_flags(extra, flags):
    """``extra`` with the flags column, added only when a cell has a flag (joined to a
    manifest's own column of that name)."""
    if not any(flags):
        return extra
    old = extra.get(CURVE_FLAGS, [""] * len(flags))
    extra[CURVE_FLAGS] = [";".join(v for v in (o, f) if v) for o, f in zip(old, flags, strict=True)]
    return extra


def _radius(pairs, maps):
    """The cell's R_c and error: the manifest's, else its force map's fit."""
    first = pairs[0][0]
    if not math.isnan(first.R_c):
        return first.R_c, first.R_c_err
    fitted = next(maps[row.line] for row, _ in pairs if row.whole_map)
    return fitted.R_c, fitted.R_c_err


def _error_correlation(pairs, maps):
    """The correlation of the cell's R_c and k_c errors when its force map gave both (its
    radius fitted), else NaN (:func:`turgorbayes.curves.contact_covariance.map_error_correlation`)."""
    if not math.isnan(pairs[0][0].R_c):
        return math.nan
    return next(maps[row.line] for row, _ in pairs if row.whole_map).rho_R_k


def _with_correlation(extra, rhos):
    """``extra`` with :data:`~turgorbayes.cells.columns.ERROR_CORRELATION`, added only when a
    cell has one (a manifest's own entry of that name kept where none was computed)."""
    if not any(np.isfinite(rhos)):
        return extra
    old = extra.get(ERROR_CORRELATION, [""] * len(rhos))
    extra[ERROR_CORRELATION] = [f"{r:.4f}" if np.isfinite(r) else o
                                for r, o in zip(rhos, old, strict=True)]
    return extra


def cells_from_curves(manifest, settings, results, maps=None):
    """Combine accepted curves into one row per cell (docs/curves.md, Combining curves).

    A cell whose cell-body curves (or, with bulge rows, whose bulge curves) were all rejected is
    left out, with the reason. ``maps`` (manifest line -> ForceMapResult) gives the fitted R_c of
    cells whose manifest rows leave it empty. When a cell is low-signal (:func:`low_signal_cells`)
    or has an ``imprecise`` curve, the extra column
    :data:`~turgorbayes.cells.columns.CURVE_FLAGS` says so (``low_signal``, ``imprecise_curve``).
    A cell whose R_c and k_c both come from its force map gets the correlation of their errors
    in :data:`~turgorbayes.cells.columns.ERROR_CORRELATION` (docs/curves.md, Correlated
    readings).

    Returns
    -------
    cells : CellData or None
    left_out : dict of str to str
    """
    rows, left_out = [], {}
    low = set(low_signal_cells(manifest.rows, results))
    for cell_id, pairs in _cell_groups(manifest, results).items():
        bulged = any(row.target == "bulge" for row, _ in pairs)
        kc = _combined(pairs, "cell")
        kb = _combined(pairs, "bulge") if bulged else None
        why = _left_out_reason(pairs, kc, kb, bulged)
        if why:
            left_out[cell_id] = why
            continue
        rows.append((cell_id, _radius(pairs, maps or {}), bulged, kc, kb, pairs))
    if not rows:
        return None, left_out
    nan = math.nan
    cells = CellData(
        cell_id=[r[0] for r in rows], group=["bulged" if r[2] else "intact" for r in rows],
        R_c=[r[1][0] for r in rows], R_c_err=[r[1][1] for r in rows],
        k_c=[r[3][0] for r in rows], k_c_err=[r[3][1] for r in rows],
        R_b=[_bulge_radius(r[5], maps or {})[0] if r[2] else nan for r in rows],
        R_b_err=[_bulge_radius(r[5], maps or {})[1] if r[2] else nan for r in rows],
        k_b=[r[4][0] if r[2] else nan for r in rows], k_b_err=[r[4][1] if r[2] else nan for r in rows],
        h_b=[r[4][2] if r[2] else nan for r in rows],
        extra=_with_correlation(_with_flags({c: [_extra_value(r[5], c) for r in rows]
                                             for c in manifest.extra_columns},
                                            [_curve_flags(r[0], r[5], low) for r in rows]),
                                [_error_correlation(r[5], maps or {}) for r in rows]),
        comments=_comments(manifest, settings, results, left_out),
    )
    return cells, left_out


def _left_out_reason(pairs, kc, kb, bulged):
    """Why a cell cannot go to ``cells.csv`` ("" if it can)."""
    if kc is None or (bulged and kb is None):
        missing = "cell-body" if kc is None else "bulge"
        target = "cell" if kc is None else "bulge"
        reasons = sorted({res.status for row, res in pairs if not res.accepted and row.target == target})
        return f"every {missing} curve rejected ({', '.join(reasons)})"
    for name, (k, err, _) in [("k_c", kc)] + ([("k_b", kb)] if bulged else []):
        if err >= k:  # a reading within its own noise carries no information on the value
            return (f"stiffness undetermined: the combined {name} = {k:.3g} +- {err:.2g} N/m has "
                    "an error larger than its value (its curves are within the noise or "
                    "disagree; docs/curves.md, Combining curves)")
    return ""


def _bulge_row(pairs):
    return next(row for row, _ in pairs if row.target == "bulge")


def _bulge_radius(pairs, maps):
    """The cell's R_b and error: the manifest's, else its bulge map's fit."""
    row = _bulge_row(pairs)
    if not math.isnan(row.R_b):
        return row.R_b, row.R_b_err
    return maps[row.line].R_b, maps[row.line].R_b_err


def _comments(manifest, settings, results, left_out):
    n_ok = sum(r.accepted for r in results)
    lines = [f"# turgorbayes curves {__version__}: cells from the force curves of manifest "
             f"{manifest.path.name} (sha256 {manifest.sha256})",
             "# settings: " + ", ".join(f"{k} = {v}" for k, v in settings.as_dict().items())
             + " (SI units)",
             f"# curves: {n_ok} of {len(results)} accepted; per-curve results and rejection "
             "reasons in the curves table beside this file"]
    if left_out:
        lines.append(f"# cells left out (every curve of a target rejected, or the combined "
                     f"stiffness undetermined): {', '.join(left_out)}")
    lines += [f"# {line}" for line in glass.glass_report(manifest, results, settings)]
    lines += [f"# manifest {c.lstrip('#').strip()}" for c in manifest.comments]
    return lines


def _fmt(value, scale=1.0):
    return "" if value is None or not np.isfinite(value) else f"{value * scale:.6g}"


def write_curves_table(path, result):
    """Write ``curves.csv``: one row per manifest row, accepted or not (:data:`CURVE_COLUMNS`).

    Whole force maps also get ``force_maps.csv`` and one pixel table each in ``force_maps/``
    beside it (:func:`turgorbayes.curves.forcemap_tables.write_force_map_tables`).

    Parameters
    ----------
    path : str or pathlib.Path
    result : ManifestResult
    """
    if result.maps:
        from turgorbayes.curves.forcemap_tables import write_force_map_tables

        write_force_map_tables(path, result)
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
                "map" if row.whole_map else row.curve_index, *glass.glass_fields(row, res, sessions),
                *(row.extra.get(c, "") for c in manifest.extra_columns)])
