"""A bulge on a whole force map -> its k_b, h_b and R_b (docs/curves.md, Bulges on force maps).

The map's height map and the cell's cylinder as for a cell-body map
(:mod:`turgorbayes.curves.forcemap`); the bulge is found on it
(:mod:`turgorbayes.curves.bulgedome`), its apex curves are reduced as single bulge curves
(:func:`turgorbayes.curves.reduce.reduce_approach` with ``target`` ``bulge``: the deepest point,
or the settings' ``bulge_depth`` / ``bulge_max_force``) and combined like the curves of one cell.
"""

import math
import time
from pathlib import Path

import numpy as np

from turgorbayes.curves.bulgedome import DEFAULT_BULGE, cell_section, find_dome
from turgorbayes.curves.combine import combine_stiffness
from turgorbayes.curves.crosssection import DEFAULT_SECTION
from turgorbayes.curves.forcemap import ForceMapResult, height_map, load_map, reduce_map_curves
from turgorbayes.curves.qc import OK, CurveRejected
from turgorbayes.curves.reduce import DEFAULT_SETTINGS, CurveResult

__all__ = ["bulge_row_result", "reduce_bulge_map", "reduce_bulge_map_row"]


def _combine(results):
    ok = [r for r in results if r.accepted]
    if not ok:
        return (math.nan,) * 4
    k, k_err, h_b = combine_stiffness([r.k for r in ok], [r.k_err for r in ok], [r.depth for r in ok])
    depth_err = float(np.sqrt(np.sum(np.square([r.depth_err for r in ok])))) / len(ok)
    return k, k_err, h_b, depth_err


def _dome_text(dome, indices, results, manifest_radius):
    used = (f"manifest's R_b {manifest_radius * 1e9:g} nm used" if np.isfinite(manifest_radius)
            else "used")
    n_ok = sum(r.accepted for r in results)
    rejected = sorted({r.status for r in results if not r.accepted})
    return (f"bulge at ({dome.apex_x * 1e9:.0f}, {dome.apex_y * 1e9:.0f}) nm, "
            f"{dome.dome_height * 1e9:.0f} nm above the cell, {dome.dome.sum()} dome pixels; "
            f"R_b fit {dome.R_b * 1e9:.1f} +- {dome.R_b_err * 1e9:.2g} nm ({used}); apex curves "
            f"{', '.join(str(int(i)) for i in indices)}: {n_ok} of {len(results)} accepted"
            + (f" ({', '.join(rejected)})" if rejected else ""))


def reduce_bulge_map(path, R_b=None, R_b_err=None, settings=DEFAULT_SETTINGS,
                     section_settings=DEFAULT_SECTION, bulge_settings=DEFAULT_BULGE,
                     spring_constant=None, sensitivity=None, progress=False):
    """Reduce the bulge of a whole force map: height map, cell, dome, apex curves.

    Parameters
    ----------
    path : path-like
        A multi-curve file with grid positions (as :func:`~turgorbayes.curves.forcemap.reduce_map`).
    R_b, R_b_err : float [m], optional
        The bulge radius and error if known (they win over the fit, which is still reported).
    settings : ReductionSettings
        Its bulge settings (``bulge_depth``, ``bulge_max_force``, ``bulge_window``) read ``k_b``.
    section_settings : SectionSettings
    bulge_settings : turgorbayes.curves.bulgedome.BulgeSettings
    spring_constant, sensitivity : float, optional
        Calibration overrides [N/m], [m/V].
    progress : bool

    Returns
    -------
    ForceMapResult
        ``target`` ``bulge``; a failure (``no_bulge``, ``bulge_fit_failed``, ``no_apex_curve``
        or a cross-section's status) is its status, never an exception.
    """
    start, path = time.perf_counter(), Path(path)
    try:
        curves = load_map(path)
    except CurveRejected as rej:
        return ForceMapResult(path, rej.status, rej.detail, target="bulge")
    base = {"n_curves": len(curves), "target": "bulge"}
    if len(curves) < section_settings.min_curves:
        return ForceMapResult(path, "map_too_small", f"{path.name!r} has {len(curves)} curves, a "
                              f"cross-section of the cell needs >= {section_settings.min_curves}",
                              **base)
    base["pixels"] = pixels = height_map(curves, path, settings, spring_constant, sensitivity, progress)
    try:
        section, found = cell_section(pixels, section_settings, bulge_settings)
        base["section"] = section
        dome = find_dome(pixels, section, found, bulge_settings)
    except CurveRejected as rej:
        return ForceMapResult(path, rej.status, f"{path.name!r}: {rej.detail}", **base,
                              seconds=time.perf_counter() - start)
    given = R_b is not None and np.isfinite(R_b)
    radius, radius_err = (R_b, R_b_err) if given else (
        dome.R_b, math.hypot(dome.R_b_err, section_settings.height_calibration * dome.R_b))
    indices = dome.apex_index
    results = reduce_map_curves(curves, path, indices, "bulge", radius, settings, spring_constant,
                                sensitivity)
    k, k_err, h_b, h_err = _combine(results)
    return ForceMapResult(path, OK if np.isfinite(k) else "no_apex_curve",
                          _dome_text(dome, indices, results, R_b if given else math.nan), **base,
                          dome=dome, apex=results, k=k, k_err=k_err, depth=h_b, depth_err=h_err,
                          R_b=radius, R_b_err=radius_err, seconds=time.perf_counter() - start)


def reduce_bulge_map_row(row, settings=DEFAULT_SETTINGS, progress=False):
    """Reduce a manifest's bulge row whose ``curve_index`` is ``map``.

    Parameters
    ----------
    row : turgorbayes.curves.manifest.ManifestRow
        Its ``R_b``/``R_b_err`` (NaN: fitted) and calibration overrides are used.
    settings : ReductionSettings
    progress : bool

    Returns
    -------
    ForceMapResult
    """
    given = not math.isnan(row.R_b)
    return reduce_bulge_map(row.file, row.R_b if given else None, row.R_b_err if given else None,
                            settings, spring_constant=row.spring_constant,
                            sensitivity=row.sensitivity, progress=progress)


def bulge_row_result(result):
    """The manifest row's :class:`~turgorbayes.curves.reduce.CurveResult` of a bulge map: the
    apex curves' combined ``k_b`` at their ``h_b`` (``n_points`` counts the map's curves).

    Parameters
    ----------
    result : ForceMapResult

    Returns
    -------
    CurveResult
    """
    fields = {"status": result.status, "n_points": result.n_curves,
              "detail": f"force map of {result.n_curves} curves: {result.detail}"}
    if result.ok:
        fields.update(k=result.k, k_err=result.k_err, depth=result.depth, depth_err=result.depth_err)
    return CurveResult(**fields)
