"""The tables of whole force maps: ``force_maps.csv`` (one row per map) and one pixel table per map
(every curve: grid position, contact height or why none, its role, and the crest curves' stiffness).
"""

import csv
import re
from pathlib import Path

import numpy as np

__all__ = ["MAP_COLUMNS", "MAP_FOLDER", "PIXEL_COLUMNS", "pixel_table_name", "write_force_map_tables"]

#: Folder of the per-map pixel tables, beside ``curves.csv``.
MAP_FOLDER = "force_maps"
#: Columns of ``force_maps.csv``.
MAP_COLUMNS = ("file", "manifest_line", "cell_id", "status", "detail", "n_curves", "n_contact",
               "n_substrate", "n_cell", "n_middle", "n_arc", "n_crest", "n_crest_ok", "Rc_fit_nm",
               "Rc_fit_err_nm", "Rc_used_nm", "Rc_used_err_nm", "axis_angle_deg",
               "axis_angle_err_deg", "axis_x_nm", "axis_y_nm", "cell_length_nm",
               "arc_residual_sd_nm", "substrate_slope_x", "substrate_slope_y", "k_N_per_m",
               "k_err_N_per_m", "k_shift_N_per_m", "pitch_nm", "seconds", "pixel_table",
               "target", "n_dome", "bulge_x_nm", "bulge_y_nm", "bulge_xy_err_nm", "dome_height_nm",
               "dome_threshold_nm", "Rb_fit_nm", "Rb_fit_err_nm", "Rb_used_nm", "Rb_used_err_nm",
               "sphere_residual_sd_nm", "apex_curves", "n_apex_ok", "h_b_nm", "h_b_err_nm")
#: Columns of a map's pixel table.
PIXEL_COLUMNS = ("curve_index", "grid_index_x", "grid_index_y", "x_nm", "y_nm", "status", "detail",
                 "contact_height_nm", "contact_err_nm", "elevation_nm", "axis_distance_nm",
                 "axis_position_nm", "substrate", "cell", "middle", "arc", "crest", "crest_status",
                 "crest_detail", "k_N_per_m", "k_err_N_per_m", "depth_nm", "dome_residual_nm",
                 "dome", "apex", "apex_status", "apex_detail", "apex_k_N_per_m",
                 "apex_k_err_N_per_m", "apex_depth_nm")


def _fmt(value, scale=1.0):
    return "" if value is None or not np.isfinite(value) else f"{value * scale:.6g}"


def pixel_table_name(row):
    """``0007_maps_cell3.csv``: manifest line and file of a whole-map row."""
    stem = re.sub(r"[^A-Za-z0-9._-]+", "_", str(Path(row.name).with_suffix(""))).strip("._")
    return f"{row.line:04d}_{stem or 'map'}.csv"


def _section_fields(res):
    s = res.section
    if s is None:
        return [""] * 18
    n = [int(np.count_nonzero(m)) for m in (s.substrate, s.cell, s.middle, s.arc, s.crest)]
    return [*n, sum(c.accepted for c in res.crest), _fmt(s.R, 1e9), _fmt(s.R_err, 1e9),
            _fmt(res.R_c, 1e9), _fmt(res.R_c_err, 1e9), _fmt(np.rad2deg(s.angle)),
            _fmt(np.rad2deg(s.angle_err)), _fmt(s.center[0], 1e9), _fmt(s.center[1], 1e9),
            _fmt(2 * s.half_length, 1e9), _fmt(s.residual_sd, 1e9), _fmt(s.plane[1]),
            _fmt(s.plane[2])]


def _map_row(row, res, table):
    pixels = res.pixels
    n_contact = "" if pixels is None else int(np.count_nonzero(np.isfinite(pixels.height)))
    return [row.name, row.line, row.cell_id, res.status, res.detail, res.n_curves, n_contact,
            *_section_fields(res), _fmt(res.k), _fmt(res.k_err), _fmt(res.k_shift),
            "" if pixels is None else _fmt(pixels.pitch, 1e9), _fmt(res.seconds, 1.0), table,
            res.target, *_dome_fields(res)]


def _dome_fields(res):
    """``force_maps.csv``'s bulge columns (empty without a dome)."""
    d = res.dome
    if d is None:
        return [""] * 15
    return [int(d.dome.sum()), _fmt(d.apex_x, 1e9), _fmt(d.apex_y, 1e9), _fmt(d.apex_xy_err, 1e9),
            _fmt(d.dome_height, 1e9), _fmt(d.threshold, 1e9), _fmt(d.R_b, 1e9), _fmt(d.R_b_err, 1e9),
            _fmt(res.R_b, 1e9), _fmt(res.R_b_err, 1e9), _fmt(d.residual_sd, 1e9),
            " ".join(str(int(i)) for i in d.apex_index), sum(c.accepted for c in res.apex),
            _fmt(res.depth, 1e9), _fmt(res.depth_err, 1e9)]


def _apex_fields(res, i):
    """A pixel table row's bulge columns."""
    d = res.dome
    if d is None:
        return [""] * 8
    apex = dict(zip(d.apex_index.tolist(), res.apex, strict=True))
    c = apex.get(i)
    fields = ["", "", "", "", ""] if c is None else [c.status, c.detail, _fmt(c.k), _fmt(c.k_err),
                                                     _fmt(c.depth, 1e9)]
    return [_fmt(d.residual[i], 1e9), int(d.dome[i]), int(d.apex[i]), *fields]


def _pixel_rows(res):
    p, s = res.pixels, res.section
    crest = dict(zip(res.crest_index.tolist(), res.crest, strict=True))
    for i in range(p.index.size):
        geo = ["", "", ""] + [""] * 5 if s is None else [
            _fmt(s.elevation[i], 1e9), _fmt(s.d[i], 1e9), _fmt(s.s[i], 1e9),
            *(int(m[i]) for m in (s.substrate, s.cell, s.middle, s.arc, s.crest))]
        c = crest.get(i)
        k_fields = ["", "", "", "", ""] if c is None else [
            c.status, c.detail, _fmt(c.k), _fmt(c.k_err), _fmt(c.depth, 1e9)]
        yield [int(p.index[i]), int(p.ix[i]), int(p.iy[i]), _fmt(p.x[i], 1e9), _fmt(p.y[i], 1e9),
               p.status[i], p.detail[i], _fmt(p.height[i], 1e9), _fmt(p.height_err[i], 1e9), *geo,
               *k_fields, *_apex_fields(res, i)]


def _write(path, header, rows):
    with open(path, "w", newline="", encoding="utf-8") as fh:
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)


def write_force_map_tables(curves_path, result):
    """Write ``force_maps.csv`` and ``force_maps/<line>_<file>.csv`` beside ``curves_path``.

    Parameters
    ----------
    curves_path : path-like
        The per-curve table (``curves.csv``); the map tables go in its folder.
    result : turgorbayes.curves.pipeline.ManifestResult

    Returns
    -------
    pathlib.Path
        ``force_maps.csv``.
    """
    folder = Path(curves_path).parent
    rows = []
    for row in result.manifest.rows:
        if not row.whole_map:
            continue
        res = result.maps[row.line]
        table = ""
        if res.pixels is not None:
            (folder / MAP_FOLDER).mkdir(parents=True, exist_ok=True)
            table = f"{MAP_FOLDER}/{pixel_table_name(row)}"
            _write(folder / table, PIXEL_COLUMNS, _pixel_rows(res))
        rows.append(_map_row(row, res, table))
    _write(folder / "force_maps.csv", MAP_COLUMNS, rows)
    return folder / "force_maps.csv"
