"""Glass reference curves: a session's deflection sensitivity checked on a hard surface.

On glass the tip cannot indent, so in contact the recorded deflection rises with the piezo
travel at the slope ``s_glass = s_file / s_true`` (1 with a correct sensitivity); the session's
curves are then read with the sensitivity ``s_file / s_glass`` (docs/curves.md, Glass reference).
"""

import math
from dataclasses import dataclass, replace

import numpy as np

from turgorbayes.curves import baseline
from turgorbayes.curves.combine import combine_stiffness
from turgorbayes.curves.load import read_approach
from turgorbayes.curves.qc import OK, CurveRejected
from turgorbayes.curves.reduce import DEFAULT_SETTINGS, CurveResult, read_fields
from turgorbayes.errors import DataError

__all__ = ["FIT_FROM", "GLASS_COLUMNS", "MAX_CURVATURE", "SLOPE_RANGE", "GlassSlope", "SessionGlass",
           "corrected_manifest", "glass_fields", "glass_report", "glass_slope", "reduce_glass_curve",
           "session_glass"]

#: The slope is fitted from this fraction of the contact travel on (past a jump to contact).
FIT_FROM = 0.2
#: Accepted glass slopes; outside, the surface is not hard (or the sensitivity is absurd).
SLOPE_RANGE = (0.5, 1.5)
#: Largest accepted change of the slope across the fit window, relative (a soft sample curves).
MAX_CURVATURE = 0.05
#: Columns of the per-curve table that ``glass_fields`` fills.
GLASS_COLUMNS = ("sensitivity_nm_per_V", "glass_slope", "glass_slope_err", "glass_correction")


@dataclass(frozen=True)
class GlassSlope:
    """The contact slope of a glass curve.

    Attributes
    ----------
    slope, slope_err : float [-]
        ``s_glass``: slope of the baseline-corrected deflection on the piezo travel, and its
        standard error (the contact fit's and the baseline slope's, in quadrature).
    curvature : float [-]
        Change of the slope across the fit window relative to the slope (quadratic fit).
    z_contact : float [m]
        Contact (the two-piece fit's kink) in piezo travel.
    window : (float, float) [m]
        Piezo travel of the fit.
    baseline : turgorbayes.curves.baseline.Baseline
    n_points : int
        Points in the fit.
    """

    slope: float
    slope_err: float
    curvature: float
    z_contact: float
    window: tuple
    baseline: baseline.Baseline
    n_points: int


def _line(z, d):
    """Least-squares slope of ``d`` on ``z`` and its standard error (``scipy.stats.linregress``),
    and the relative change of the slope across the window (a quadratic's)."""
    # imported here: scipy.stats takes ~0.5 s to import, which a manifest without glass
    # curves (and every worker of one) does without
    from scipy import stats

    fit = stats.linregress(z, d)
    quad = np.polynomial.polynomial.polyfit(z - z.mean(), d, 2)
    return float(fit.slope), float(fit.stderr), float(2 * quad[2] * np.ptp(z) / fit.slope)


def glass_slope(approach, settings=DEFAULT_SETTINGS):
    r"""Slope of deflection on piezo travel in the contact part of a curve on a hard surface.

    The baseline (:func:`~turgorbayes.curves.baseline.fit_baseline`) is removed; the deflection
    ``d = F/k`` (the recorded one: ``F`` and ``k`` cancel any spring-constant error) is fitted
    with a line over the travel from :data:`FIT_FROM` of the way between the kink and the end:

    .. math:: d = a + s_\mathrm{glass}\, z, \qquad s_\mathrm{glass} = s_\mathrm{file}/s_\mathrm{true}

    Parameters
    ----------
    approach : turgorbayes.curves.load.Approach
    settings : turgorbayes.curves.reduce.ReductionSettings
        Its baseline and contact-point limits apply.

    Returns
    -------
    GlassSlope

    Raises
    ------
    CurveRejected
        A baseline status, ``contact_too_close_to_end`` or ``not_hard_surface``.
    """
    z = approach.z
    base = baseline.fit_baseline(z, approach.force, settings.min_baseline_points,
                                 max_noise_ratio=settings.max_noise_ratio)
    d = (approach.force - base(z)) / approach.spring_constant
    use = z >= base.hinge + FIT_FROM * (z[-1] - base.hinge)
    if use.sum() < settings.min_contact_points:
        raise CurveRejected("contact_too_close_to_end", f"{use.sum()} points in the glass slope "
                            f"fit, need >= {settings.min_contact_points}")
    slope, err, curvature = _line(z[use], d[use])
    before = z <= base.z_end  # the baseline's own slope error moves the corrected slope as much
    err = float(np.hypot(err, _line(z[before], d[before])[1]))
    if not SLOPE_RANGE[0] <= slope <= SLOPE_RANGE[1] or abs(curvature) > MAX_CURVATURE:
        raise CurveRejected("not_hard_surface", f"contact slope {slope:.4g} (accepted "
                            f"{SLOPE_RANGE[0]:g}-{SLOPE_RANGE[1]:g}), changing by "
                            f"{100 * curvature:+.2g} % across the fit (accepted +-"
                            f"{100 * MAX_CURVATURE:g} %)")
    return GlassSlope(slope=slope, slope_err=err, curvature=curvature, z_contact=base.hinge,
                      window=(float(z[use][0]), float(z[-1])), baseline=base,
                      n_points=int(use.sum()))


def reduce_glass_curve(path, settings=DEFAULT_SETTINGS, spring_constant=None, sensitivity=None,
                       curve_index=0, trace=None):
    """Read a glass reference curve and measure its slope; a rejection is returned, not raised.

    Parameters
    ----------
    path, settings, spring_constant, sensitivity, curve_index, trace
        As in :func:`turgorbayes.curves.reduce.reduce_curve` (the trace gets the approach and
        the baseline; no contact point or secant).

    Returns
    -------
    turgorbayes.curves.reduce.CurveResult
        ``slope``/``slope_err`` set, ``k`` NaN; ``contact_height`` is the kink's height.
    """
    try:
        approach = read_approach(path, spring_constant, sensitivity, curve_index)
    except CurveRejected as rej:
        return CurveResult(status=rej.status, detail=rej.detail, curve_index=curve_index)
    if trace is not None:
        trace.approach = approach
    try:
        if approach.sensitivity is None:
            raise CurveRejected("calibration_missing", "a glass reference needs the sensitivity "
                                "it was recorded with (in the file or sensitivity_m_per_V)")
        fit = glass_slope(approach, settings)
    except CurveRejected as rej:
        return CurveResult(status=rej.status, detail=rej.detail, **read_fields(approach))
    if trace is not None:
        trace.baseline, trace.z = fit.baseline, approach.z
        trace.force = approach.force - fit.baseline(approach.z)
    return CurveResult(status=OK, contact_height=approach.height0 - fit.z_contact,
                       baseline_noise=fit.baseline.noise_sd, slope=fit.slope,
                       slope_err=fit.slope_err, **read_fields(approach))


@dataclass(frozen=True)
class SessionGlass:
    """The glass reference of one session (docs/curves.md, Glass reference).

    Attributes
    ----------
    session : str
    lines : tuple of int
        Manifest lines of its glass rows.
    slope, slope_err : float [-]
        Combined glass slope ``s_glass`` of its accepted glass curves (NaN: none accepted).
    sensitivity_used : float [m/V]
        Sensitivity the glass curves were read with.
    sensitivity : float [m/V]
        The session's true sensitivity ``sensitivity_used / slope``.
    corrected : bool
        Whether its curves are read with ``sensitivity``.
    rejected : tuple of str
        Statuses of its rejected glass curves.
    n_curves : int
        Its other (cell and bulge) curves.
    """

    session: str
    lines: tuple
    slope: float
    slope_err: float
    sensitivity_used: float
    sensitivity: float
    corrected: bool
    rejected: tuple
    n_curves: int


def _used_sensitivity(manifest, session, pairs):
    used = {res.sensitivity for _, res in pairs}
    if max(used) > min(used) * (1 + 1e-9):
        raise DataError(f"the glass curves of session {session!r} were read with different "
                        f"sensitivities ({', '.join(f'{s * 1e9:.6g}' for s in sorted(used))} nm/V, "
                        f"lines {', '.join(str(r.line) for r, _ in pairs)}): one session has one",
                        path=manifest.path, line=pairs[-1][0].line, column="sensitivity_m_per_V")
    return pairs[0][1].sensitivity


def session_glass(manifest, results, settings=DEFAULT_SETTINGS):
    """Combine each session's glass curves (inverse-variance mean, Birge-scaled error).

    Parameters
    ----------
    manifest : turgorbayes.curves.manifest.Manifest
    results : sequence of CurveResult or None
        One per manifest row; only the glass rows' are used.
    settings : turgorbayes.curves.reduce.ReductionSettings

    Returns
    -------
    dict of str to SessionGlass
        The sessions that have a glass row, in manifest order.

    Raises
    ------
    turgorbayes.errors.DataError
        A session's accepted glass curves were read with different sensitivities.
    """
    glass = {}
    for row, res in zip(manifest.rows, results, strict=True):
        if row.target == "glass":
            glass.setdefault(row.session, []).append((row, res))
    out = {}
    for session, pairs in glass.items():
        ok = [(r, res) for r, res in pairs if res.ok]
        slope = err = used = math.nan
        if ok:
            slope, err, _ = combine_stiffness([res.slope for _, res in ok], [res.slope_err for _, res in ok],
                                              weights="inverse_variance")
            used = _used_sensitivity(manifest, session, ok)
        n_curves = sum(r.target != "glass" and r.session == session for r in manifest.rows)
        out[session] = SessionGlass(
            session=session, lines=tuple(r.line for r, _ in pairs), slope=slope, slope_err=err,
            sensitivity_used=used, sensitivity=used / slope, corrected=bool(ok) and settings.glass_correction,
            rejected=tuple(res.status for _, res in pairs if not res.ok), n_curves=n_curves)
    return out


def _reduce_glass_row(row, settings):
    return reduce_glass_curve(row.file, settings, row.spring_constant, row.sensitivity, row.curve_index)


def corrected_manifest(manifest, settings=DEFAULT_SETTINGS):
    """The manifest whose cell and bulge rows of each glass-referenced session carry the
    session's glass-measured sensitivity (replacing the file's and any override).

    Reads the glass curves. Unchanged without glass rows or with ``settings.glass_correction``
    False; glass rows themselves keep their sensitivity (they measure it).

    Parameters
    ----------
    manifest : turgorbayes.curves.manifest.Manifest
    settings : turgorbayes.curves.reduce.ReductionSettings

    Returns
    -------
    turgorbayes.curves.manifest.Manifest
    """
    if not settings.glass_correction or not any(r.target == "glass" for r in manifest.rows):
        return manifest
    results = [_reduce_glass_row(r, settings) if r.target == "glass" else None for r in manifest.rows]
    sessions = session_glass(manifest, results, settings)
    rows = tuple(
        replace(r, sensitivity=sessions[r.session].sensitivity)
        if r.target != "glass" and r.session in sessions and sessions[r.session].corrected else r
        for r in manifest.rows)
    return replace(manifest, rows=rows)


def glass_fields(row, result, sessions):
    """The per-curve table's :data:`GLASS_COLUMNS` of one row, as text.

    ``glass_correction`` is ``reference`` on glass rows, else ``applied``, ``off`` (measured,
    not applied) or ``none`` (no accepted glass curve in the row's session).
    """
    sens = "" if not np.isfinite(result.sensitivity) else f"{result.sensitivity * 1e9:.6g}"
    if row.target == "glass":
        slope, err, how = result.slope, result.slope_err, "reference"
    else:
        ref = sessions.get(row.session)
        if ref is None or not np.isfinite(ref.slope):
            return [sens, "", "", "none"]
        slope, err, how = ref.slope, ref.slope_err, "applied" if ref.corrected else "off"
    fmt = [("" if not np.isfinite(v) else f"{v:.6g}") for v in (slope, err)]
    return [sens, *fmt, how]


def _curves(n, noun="curve"):
    return f"{n} {noun}{'' if n == 1 else 's'}"


def _describe(ref, tolerance):
    """Report lines of one session's glass reference (warnings prefixed ``warning: ``)."""
    name = f"session {ref.session!r}"
    if not np.isfinite(ref.slope):
        return [f"warning: {name}: every glass curve rejected ({', '.join(ref.rejected)}; manifest "
                f"lines {', '.join(map(str, ref.lines))}); its {_curves(ref.n_curves)} not corrected"]
    n_ok = len(ref.lines) - len(ref.rejected)
    action = (f"its {_curves(ref.n_curves)} corrected" if ref.corrected
              else f"its {_curves(ref.n_curves)} not corrected (glass correction off)")
    lines = [f"glass reference, {name}: slope {ref.slope:.4f} +- {ref.slope_err:.4f} ({n_ok} of "
             f"{_curves(len(ref.lines), 'glass curve')}); sensitivity {ref.sensitivity_used * 1e9:.4g} -> "
             f"{ref.sensitivity * 1e9:.4g} nm/V; {action}"]
    if abs(ref.slope - 1) > tolerance:
        lines.append(f"warning: {name}: the glass slope {ref.slope:.4f} differs from 1 by "
                     f"{100 * (ref.slope - 1):+.1f} % (tolerance {100 * tolerance:g} %): the "
                     f"deflection sensitivity is off by a factor {ref.slope:.4f}")
    return lines


def glass_report(manifest, results, settings=DEFAULT_SETTINGS):
    """What the glass references found, one line per session (and which sessions had none).

    Parameters
    ----------
    manifest : turgorbayes.curves.manifest.Manifest
    results : sequence of CurveResult
        One per manifest row.
    settings : turgorbayes.curves.reduce.ReductionSettings

    Returns
    -------
    list of str
        Warnings start with ``warning: ``.
    """
    sessions = session_glass(manifest, results, settings)
    without = list(dict.fromkeys(r.session or "(no session)" for r in manifest.rows
                                 if r.target != "glass" and r.session not in sessions))
    if not sessions:
        return ["no glass reference curve: deflection sensitivities not checked, curves as recorded"]
    lines = [line for ref in sessions.values() for line in _describe(ref, settings.glass_tolerance)]
    if without:
        lines.append("sessions without a glass curve (sensitivity not checked, curves unchanged): "
                     + ", ".join(without))
    return lines
