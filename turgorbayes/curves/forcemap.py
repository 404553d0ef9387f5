"""A whole force map -> the cell's radius from its height map and k_c from its crest curves.

Every curve's contact point gives the map's height map (docs/curves.md, Whole force maps);
:mod:`turgorbayes.curves.crosssection` fits the cell's cross-section on it; the curves along
the crest are reduced at ``R_c/20`` and combined like the curves of one cell
(:func:`turgorbayes.curves.combine.combine_stiffness`).
"""

import math
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from turgorbayes.curves import baseline, load
from turgorbayes.curves.bulgedome import cell_section
from turgorbayes.curves.combine import combine_stiffness
from turgorbayes.curves.contact_covariance import map_error_correlation
from turgorbayes.curves.crosssection import DEFAULT_SECTION
from turgorbayes.curves.qc import OK, CurveRejected
from turgorbayes.curves.reduce import DEFAULT_SETTINGS, CurveResult, locate_contact, read_fields, reduce_approach
from turgorbayes.errors import DataError
from turgorbayes.progress import progress as show_progress

__all__ = ["HARD_SLOPE", "ForceMapResult", "MapPixels", "height_map", "load_map", "map_grid",
           "map_approach", "reduce_map", "reduce_map_curves", "reduce_map_row", "row_result"]

#: A curve whose deflection rises past the contact guess by at least this fraction of the piezo
#: travel (a sample >= 9 x stiffer than the cantilever: the substrate, not a cell) takes the
#: two-piece fit's kink as its contact; the power law in separation is degenerate there.
HARD_SLOPE = 0.9


@dataclass(frozen=True)
class MapPixels:
    """Every curve of a map with its grid position and contact height (SI units).

    Attributes
    ----------
    index : ndarray of int
        The curve's ``curve_index`` (order in which afmformats lists the file's curves).
    x, y : ndarray [m]
        Grid position (afmformats' ``position x/y``).
    ix, iy : ndarray of int
        Grid indices.
    height, height_err : ndarray [m]
        Contact point as a height of the file's height column, and its error; NaN where the
        contact was not found.
    status, detail : tuple of str
        ``ok`` or why the contact was not found (:data:`turgorbayes.curves.qc.STATUSES`).
    pitch : float [m]
        Grid spacing (mean of x and y).
    """

    index: np.ndarray
    x: np.ndarray
    y: np.ndarray
    ix: np.ndarray
    iy: np.ndarray
    height: np.ndarray
    height_err: np.ndarray
    status: tuple
    detail: tuple
    pitch: float


@dataclass(frozen=True)
class ForceMapResult:
    """The reduction of one whole force map.

    Attributes
    ----------
    path : pathlib.Path
    status, detail : str
        ``ok``, or why the map gave no ``k_c`` (``map_too_small``, ``cross_section_failed``,
        ``no_crest_curve``, or ``unreadable_file`` / ``calibration_missing`` for the file).
    n_curves : int
    pixels : MapPixels or None
    section : turgorbayes.curves.crosssection.CrossSection or None
    R_c : float [m]
        Radius the crest curves were read with (the manifest's if given, else the fit's).
    R_c_err : float [m]
        Its error: the manifest's, else the fit's and the height calibration's
        (``SectionSettings.height_calibration`` x ``R``) in quadrature.
    crest : tuple of CurveResult
        One per crest pixel, in the order of ``numpy.flatnonzero(section.crest)``.
    k, k_err : float [N/m]
        Combined crest stiffness and its error.
    k_shift : float [N/m]
        Change of ``k`` when read at ``(R_c + R_c_err)/20`` instead (not in ``k_err``).
    seconds : float
        Wall time of the reduction.
    target : str
        ``cell``, or ``bulge`` (:func:`turgorbayes.curves.bulgemap.reduce_bulge_map`: ``k`` is
        the apex curves' combined ``k_b``, ``depth`` their ``h_b``).
    dome : turgorbayes.curves.bulgedome.BulgeDome or None
        A bulge found on the map (left out of the cell's arc and crest).
    apex : tuple of CurveResult
        Bulge maps: one per apex curve, in the order of ``dome.apex_index``.
    depth, depth_err : float [m]
        Bulge maps: combined ``h_b`` and its error.
    R_b, R_b_err : float [m]
        Bulge maps: the radius used (the manifest's, else the fit's with the height calibration).
    rho_R_k : float
        Correlation of the errors of ``R_c`` and ``k`` when ``R_c`` is the fit's
        (:func:`turgorbayes.curves.contact_covariance.map_error_correlation`); NaN otherwise.
    """

    path: Path
    status: str
    detail: str = ""
    n_curves: int = 0
    pixels: MapPixels = None
    section: object = None
    R_c: float = math.nan
    R_c_err: float = math.nan
    crest: tuple = ()
    k: float = math.nan
    k_err: float = math.nan
    k_shift: float = math.nan
    seconds: float = math.nan
    target: str = "cell"
    dome: object = None
    apex: tuple = ()
    depth: float = math.nan
    depth_err: float = math.nan
    R_b: float = math.nan
    R_b_err: float = math.nan
    rho_R_k: float = math.nan

    @property
    def ok(self):
        return self.status == OK

    @property
    def crest_index(self):
        """Indices into :attr:`pixels` of the crest curves reduced (empty without a
        cross-section, and on a bulge map, whose crest is not reduced)."""
        if self.section is None or self.target == "bulge":
            return np.array([], int)
        return np.flatnonzero(self.section.crest)


def load_map(path):
    """All curves of a multi-curve file, as afmformats lists them (JPK data are read lazily);
    read as :func:`turgorbayes.curves.load.read_approach` reads one.

    Raises
    ------
    CurveRejected
        ``unreadable_file``.
    turgorbayes.errors.DataError
        A file format turgorbayes refuses (as in :func:`~turgorbayes.curves.load.read_approach`).
    """
    return load.load_curves(Path(path))


def _meta(curve, key):
    from afmformats.meta import MetaDataMissingError  # a BaseException, not an Exception

    try:
        value = float(curve.metadata[key])
    except (MetaDataMissingError, KeyError, TypeError, ValueError):
        return math.nan
    return value


def _pitch(position, index, size, shape):
    """Grid spacing [m] along one axis: from the grid's size and shape, else the positions."""
    if np.isfinite(size) and shape > 0:
        return size / shape
    steps = np.abs(np.diff(position)) / np.maximum(np.abs(np.diff(index)), 1)
    steps = steps[steps > 0]
    return float(np.min(steps)) if steps.size else math.nan


def map_grid(curves, path):
    """Grid positions, indices and spacing of a map's curves from afmformats' metadata.

    Parameters
    ----------
    curves : list of afmformats.AFMForceDistance
    path : path-like
        The file (for errors).

    Returns
    -------
    x, y : ndarray [m]
        ``position x``, ``position y``.
    ix, iy : ndarray of int
        ``grid index x/y`` (afmformats derives them from the positions and the grid's centre,
        size and shape), else the positions in grid steps.
    pitch : float [m]

    Raises
    ------
    turgorbayes.errors.DataError
        A curve has no grid position: the file is not a map.
    """
    x = np.array([_meta(c, "position x") for c in curves])
    y = np.array([_meta(c, "position y") for c in curves])
    bad = np.flatnonzero(~(np.isfinite(x) & np.isfinite(y)))
    if bad.size:
        raise DataError(f"curve {bad[0]} (of {len(curves)}) has no grid position (afmformats "
                        "metadata 'position x/y'): not a force map", path=path)
    ix = np.array([_meta(c, "grid index x") for c in curves])
    iy = np.array([_meta(c, "grid index y") for c in curves])
    pitches = []
    for pos, idx, ax in ((x, ix, "x"), (y, iy, "y")):
        size, shape = _meta(curves[0], f"grid size {ax}"), _meta(curves[0], f"grid shape {ax}")
        pitches.append(_pitch(pos, idx, size, shape if np.isfinite(shape) else 0))
    pitch = float(np.nanmean(pitches)) if np.any(np.isfinite(pitches)) else math.nan
    if not np.all(np.isfinite(ix) & np.isfinite(iy)):
        step = pitch if np.isfinite(pitch) and pitch > 0 else 1.0
        ix, iy = np.rint((x - x.min()) / step), np.rint((y - y.min()) / step)
    return x, y, ix.astype(int), iy.astype(int), pitch


def map_approach(curves, path, index, spring_constant, sensitivity):
    """The approach of curve ``index`` of a loaded map, as :func:`turgorbayes.curves.load.read_approach`
    reads it (same columns and calibration overrides), without opening the file again."""
    curve = curves[index]
    force, height, column = load.approach_columns(curve, Path(path))
    scale, k = load.force_calibration(load.calibration_value(curve, "spring constant"),
                                 load.calibration_value(curve, "sensitivity"), spring_constant, sensitivity)
    order = np.argsort(height[0] - height, kind="stable")
    s_file = load.calibration_value(curve, "sensitivity")
    return load.Approach(z=(height[0] - height)[order], force=force[order] * scale,
                         height0=float(height[0]), spring_constant=k, height_column=column,
                         path=Path(path), sensitivity=sensitivity if sensitivity is not None else s_file,
                         curve_index=index)


def _hard_contact(approach):
    """Contact travel [m] and its error of a hard surface (the two-piece fit's kink), or None
    if the surface is softer than :data:`HARD_SLOPE`."""
    z = approach.z
    j, slope = baseline.hinge_contact(z, approach.force)
    if slope < HARD_SLOPE * approach.spring_constant:
        return None
    return float(z[j]), float(np.median(np.diff(z)))


def _contact_height(approach, settings):
    """Contact height [m] and its error of one approach: the kink on a hard surface, else the
    reduction's contact point. Points past contact are counted in piezo travel (a hard
    surface is not indented)."""
    hard = _hard_contact(approach)
    if hard is None:
        z, _, _, found = locate_contact(approach, settings, check=False)
        hard = (found.z0, found.z0_err)
    else:
        z = approach.z
    n_past = int(np.count_nonzero(z > hard[0]))
    if n_past < settings.min_contact_points:
        raise CurveRejected("contact_too_close_to_end", f"{n_past} points past the contact "
                            f"point, need >= {settings.min_contact_points}")
    return approach.height0 - hard[0], hard[1]


def height_map(curves, path, settings=DEFAULT_SETTINGS, spring_constant=None, sensitivity=None,
               progress=False):
    """Contact-point height of every curve of a map (docs/curves.md, Whole force maps).

    The contact is found as in a curve's reduction (:func:`turgorbayes.curves.reduce.locate_contact`),
    over the whole contact part (the radius, which sets a cell's fit window, is not known yet).

    Parameters
    ----------
    curves : list of afmformats.AFMForceDistance
    path : path-like
    settings : ReductionSettings
    spring_constant, sensitivity : float, optional
        Calibration overrides [N/m], [m/V].
    progress : bool
        Show progress over the curves (:func:`turgorbayes.progress.progress`).

    Returns
    -------
    MapPixels
    """
    x, y, ix, iy, pitch = map_grid(curves, path)
    n = len(curves)
    height, err = np.full(n, np.nan), np.full(n, np.nan)
    status, detail = [OK] * n, [""] * n
    for i in show_progress(range(n), desc=f"map {Path(path).name}", unit="curve",
                           enabled=progress):
        try:
            approach = map_approach(curves, path, i, spring_constant, sensitivity)
            height[i], err[i] = _contact_height(approach, settings)
        except CurveRejected as rej:
            status[i], detail[i] = rej.status, rej.detail
    return MapPixels(index=np.arange(n), x=x, y=y, ix=ix, iy=iy, height=height, height_err=err,
                     status=tuple(status), detail=tuple(detail), pitch=pitch)


def reduce_map_curves(curves, path, indices, target, radius, settings, spring_constant,
                      sensitivity):
    """Reduce the map's curves ``indices`` as ``target`` curves ("cell": the crest at
    ``radius`` = R_c, "bulge": the apex at ``radius`` = R_b) [m]; a rejected curve gives its
    status and reason.

    Returns
    -------
    tuple of CurveResult
    """
    results = []
    for i in indices:
        try:
            approach = map_approach(curves, path, int(i), spring_constant, sensitivity)
        except CurveRejected as rej:
            results.append(CurveResult(status=rej.status, detail=rej.detail, curve_index=int(i)))
            continue
        try:
            results.append(reduce_approach(approach, target, radius, settings))
        except CurveRejected as rej:
            results.append(CurveResult(status=rej.status, detail=rej.detail, **read_fields(approach)))
    return tuple(results)


def _combine(results):
    ok = [r for r in results if r.accepted]
    if not ok:
        return math.nan, math.nan
    k, k_err, _ = combine_stiffness([r.k for r in ok], [r.k_err for r in ok])
    return k, k_err


def _crest_summary(results):
    counts = {}
    for r in results:
        if not r.accepted:
            counts[r.status] = counts.get(r.status, 0) + 1
    rejected = ", ".join(f"{n} {s}" for s, n in sorted(counts.items()))
    n_ok = sum(r.accepted for r in results)
    return f"{n_ok} of {len(results)} crest curves accepted" + (f" ({rejected})" if rejected else "")


def reduce_map(path, R_c=None, R_c_err=None, settings=DEFAULT_SETTINGS,
               section_settings=DEFAULT_SECTION, spring_constant=None, sensitivity=None,
               progress=False):
    """Reduce a whole force map: height map, cross-section, crest stiffness.

    Parameters
    ----------
    path : path-like
        A multi-curve file afmformats reads with grid positions (``.jpk-force-map``,
        ``.jpk-qi-data``, afmformats ``.h5``).
    R_c, R_c_err : float [m], optional
        The cell's radius and error if known (they win over the fit, which is still reported);
        None: the fitted radius reads the crest curves.
    settings : ReductionSettings
    section_settings : turgorbayes.curves.crosssection.SectionSettings
    spring_constant, sensitivity : float, optional
        Calibration overrides [N/m], [m/V].
    progress : bool
        Progress bar over the map's curves.

    Returns
    -------
    ForceMapResult
        A failure is its status, never an exception.

    Raises
    ------
    turgorbayes.errors.DataError
        The file's curves have no grid positions.
    """
    start, path = time.perf_counter(), Path(path)
    try:
        curves = load_map(path)
    except CurveRejected as rej:
        return ForceMapResult(path, rej.status, rej.detail)
    if len(curves) < section_settings.min_curves:
        return ForceMapResult(path, "map_too_small", f"{path.name!r} has {len(curves)} curve"
                              f"{'s' if len(curves) != 1 else ''}, a cross-section of the cell "
                              f"needs >= {section_settings.min_curves}", n_curves=len(curves))
    pixels = height_map(curves, path, settings, spring_constant, sensitivity, progress)
    base = {"n_curves": len(curves), "pixels": pixels}
    try:
        section, found = cell_section(pixels, section_settings)
    except CurveRejected as rej:
        return ForceMapResult(path, rej.status, f"{path.name!r}: {rej.detail}", **base,
                              seconds=time.perf_counter() - start)
    user = R_c is not None and np.isfinite(R_c)
    radius, radius_err = (R_c, R_c_err) if user else (
        section.R, math.hypot(section.R_err, section_settings.height_calibration * section.R))
    crest = np.flatnonzero(section.crest)
    args = (curves, path, crest)
    results = reduce_map_curves(*args, "cell", radius, settings, spring_constant, sensitivity)
    k, k_err = _combine(results)
    shifted, _ = _combine(reduce_map_curves(*args, "cell", radius + radius_err, settings, spring_constant,
                                        sensitivity))
    status = OK if np.isfinite(k) else "no_crest_curve"
    detail = _crest_summary(results) if crest.size else "no pixel on the crest"
    if found is not None and found[2] is not None:
        detail += f"; a dome of {found[2].sum()} pixels above the cylinder left out of arc and crest"
    # one contact point, one covariance: known only when the radius is the map's own
    rho = (math.nan if user or status != OK else
           map_error_correlation(pixels, section, results, radius_err, k_err))
    return ForceMapResult(path, status, detail, **base, section=section, R_c=radius,
                          R_c_err=radius_err, crest=results, k=k, k_err=k_err, k_shift=shifted - k,
                          seconds=time.perf_counter() - start, rho_R_k=rho)


def reduce_map_row(row, settings=DEFAULT_SETTINGS, progress=False):
    """Reduce a manifest's whole-map row (``curve_index`` = ``map``).

    Parameters
    ----------
    row : turgorbayes.curves.manifest.ManifestRow
        Its ``R_c``/``R_c_err`` (NaN: fitted) and calibration overrides are used.
    settings : ReductionSettings
    progress : bool

    Returns
    -------
    ForceMapResult
    """
    given = not math.isnan(row.R_c)
    return reduce_map(row.file, row.R_c if given else None, row.R_c_err if given else None,
                      settings, spring_constant=row.spring_constant, sensitivity=row.sensitivity,
                      progress=progress)


def _radius_text(result, manifest_radius):
    s = result.section
    fit = f"R_c fit {s.R * 1e9:.1f} +- {s.R_err * 1e9:.2g} nm"
    used = (f"manifest's R_c {manifest_radius * 1e9:g} nm used" if np.isfinite(manifest_radius)
            else "used")
    return f"{fit} ({used}), axis {np.rad2deg(s.angle):.1f} deg"


def row_result(result, manifest_radius=math.nan):
    """The manifest row's :class:`~turgorbayes.curves.reduce.CurveResult` of a reduced map: the
    combined crest ``k`` at ``R_c/20`` (``n_points`` counts the map's curves).

    Parameters
    ----------
    result : ForceMapResult
    manifest_radius : float [m]
        The manifest's ``R_c`` (NaN: none, the fit's was used).

    Returns
    -------
    CurveResult
    """
    detail = result.detail
    if result.section is not None:
        detail = f"{_radius_text(result, manifest_radius)}; {detail}"
    fields = {"status": result.status, "detail": f"force map of {result.n_curves} curves: {detail}",
              "n_points": result.n_curves}
    if result.ok:
        fields.update(k=result.k, k_err=result.k_err, depth=result.R_c / 20, depth_err=0.0)
    return CurveResult(**fields)
