"""One force curve -> one stiffness with its error, or the reason it was rejected."""

from dataclasses import asdict, dataclass

import numpy as np

from turgorbayes.curves import baseline, contact_point, stiffness
from turgorbayes.curves.load import read_approach
from turgorbayes.curves.qc import ACCEPTED, IMPRECISE, OK, CurveRejected

__all__ = ["DEFAULT_SETTINGS", "TARGETS", "CurveResult", "CurveTrace", "ReductionSettings",
           "locate_contact", "read_fields", "reduce_approach", "reduce_curve"]

TARGETS = ("cell", "bulge")


@dataclass(frozen=True)
class ReductionSettings:
    """How curves are reduced (docs/curves.md, Method).

    Attributes
    ----------
    method : str
        Contact-point method, ``"powerlaw"`` or ``"threshold"``.
    cell_depth_fraction : float [-]
        Cells: the stiffness is read at ``h = cell_depth_fraction * R_c`` (1/20, the FE table).
    cell_window : float [-]
        Cells: local fit over ``h (1 +- cell_window)``.
    contact_fit_depth : float [-]
        Cells: the contact fit uses indentations up to this multiple of the reading depth.
    bulge_window : float [-]
        Bulges: local fit over the deepest ``bulge_window`` of the indentation.
    bulge_max_force : float [N] or None
        Bulges: ignore the approach past the first force above this (None: the whole approach).
    bulge_depth : float [m] or None
        Bulges: read ``k_b`` at this fixed depth instead of the deepest point.
    min_baseline_points, min_contact_points : int
        Fewest baseline points, and points past contact, accepted.
    max_noise_ratio : float [-]
        Largest accepted baseline scatter as a fraction of the force rise.
    max_relative_error : float [-]
        Largest accepted standard error of a curve's stiffness as a fraction of its deep
        secant (:func:`~turgorbayes.curves.stiffness.deep_secant`; docs/curves.md, Quality
        control: a soft cell whose force at ``R_c/20`` is within the noise).
    glass_correction : bool
        Correct the deflection sensitivity of each session that has a glass reference curve
        (docs/curves.md, Glass reference); False reports the glass slope only.
    glass_tolerance : float [-]
        A session whose glass slope differs from 1 by more than this gets a warning.
    """

    method: str = "powerlaw"
    cell_depth_fraction: float = 1 / 20
    cell_window: float = 0.3
    contact_fit_depth: float = 2.0
    bulge_window: float = 0.15
    bulge_max_force: float = None
    bulge_depth: float = None
    min_baseline_points: int = 50
    min_contact_points: int = 30
    max_noise_ratio: float = 0.2
    max_relative_error: float = 1.0
    glass_correction: bool = True
    glass_tolerance: float = 0.02

    def __post_init__(self):
        if self.method not in contact_point.METHODS:
            raise ValueError(f"method must be one of {sorted(contact_point.METHODS)}, got {self.method!r}")
        if not (np.isfinite(self.glass_tolerance) and self.glass_tolerance > 0):
            raise ValueError(f"glass_tolerance must be a finite number > 0, got {self.glass_tolerance!r}")

    def as_dict(self):
        return asdict(self)


#: The documented defaults.
DEFAULT_SETTINGS = ReductionSettings()


@dataclass(frozen=True)
class CurveResult:
    """The reduction of one curve (SI units; NaN where the curve was rejected).

    Attributes
    ----------
    status : str
        ``"ok"``, ``"imprecise"`` (accepted, with an error larger than its value) or a
        rejection reason (:data:`turgorbayes.curves.qc.STATUSES`).
    detail : str
        Why, with numbers (empty when ok).
    k, k_err : float [N/m]
        Secant stiffness and its error.
    depth, depth_err : float [m]
        Indentation at which ``k`` was read (``R_c/20`` or ``h_b``).
    contact_height, contact_err : float [m]
        Contact point as a height of the file's height column, and its error.
    window : (float, float) [m]
        Indentation range of the stiffness fit.
    baseline_noise : float [N]
    spring_constant : float [N/m]
    exponent : float [-]
        Power-law exponent of the contact fit.
    n_points : int
        Points in the approach.
    curve_index : int
        Index of the curve in its file (force maps).
    sensitivity : float [m/V]
        Deflection sensitivity the force was computed with (NaN: unknown).
    slope, slope_err : float [-]
        Glass reference curves only: slope of deflection on piezo travel in contact, and its
        error (:mod:`turgorbayes.curves.glass`); ``k`` is NaN there.
    dk_dz0 : float [N/m^2]
        Change of ``k`` per unit of contact travel (:class:`turgorbayes.curves.stiffness.Secant`).
    """

    status: str
    detail: str = ""
    k: float = float("nan")
    k_err: float = float("nan")
    depth: float = float("nan")
    depth_err: float = float("nan")
    contact_height: float = float("nan")
    contact_err: float = float("nan")
    window: tuple = (float("nan"), float("nan"))
    baseline_noise: float = float("nan")
    spring_constant: float = float("nan")
    exponent: float = float("nan")
    n_points: int = 0
    curve_index: int = 0
    sensitivity: float = float("nan")
    slope: float = float("nan")
    slope_err: float = float("nan")
    dk_dz0: float = float("nan")

    @property
    def ok(self):
        """Accepted without remark (status ``ok``)."""
        return self.status == OK

    @property
    def accepted(self):
        """Its stiffness counts in its cell (status ``ok`` or ``imprecise``)."""
        return self.status in ACCEPTED


@dataclass
class CurveTrace:
    """The intermediate arrays of one reduction, for its figure (None where a step was not reached).

    :func:`reduce_approach` fills it step by step when given one; a rejected curve's trace holds
    the steps before the rejection. Figures re-run the reduction with a trace instead of keeping
    arrays in :class:`CurveResult`: thousands of curves would hold ~50 kB each, and the re-run
    takes the same code path, so it draws exactly the reduction reported.

    Attributes
    ----------
    approach : turgorbayes.curves.load.Approach
        The approach as read (piezo travel, recorded force, calibration).
    baseline : turgorbayes.curves.baseline.Baseline
        The last baseline fitted.
    z : ndarray [m]
        Piezo travel used (bulges: truncated at ``bulge_max_force``).
    force : ndarray [N]
        Force on ``z`` with the baseline removed (the contact offset not yet).
    contact : turgorbayes.curves.contact_point.Contact
        The contact point found on this baseline.
    secant : turgorbayes.curves.stiffness.Secant
    depth_target : float [m] or None
        Depth at which ``k`` is read (``R_c/20``, the fixed bulge depth; None: deepest point).
    """

    approach: object = None
    baseline: object = None
    z: np.ndarray = None
    force: np.ndarray = None
    contact: object = None
    secant: object = None
    depth_target: float = None


def _record(trace, **steps):
    if trace is not None:
        for name, value in steps.items():
            setattr(trace, name, value)


def _truncate(z, force, max_force):
    """Keep the approach up to the first 5-point mean above ``max_force`` [N]."""
    if max_force is None:
        return z, force
    mean5 = np.convolve(force, np.ones(5) / 5, mode="same")
    over = np.flatnonzero(mean5 > max_force)
    return (z, force) if over.size == 0 else (z[: over[0]], force[: over[0]])


def _check_contact(z, force, k, found, settings):
    h = stiffness.indentation(z, force, k, found.z0)
    n_in = int(np.count_nonzero(h > 0))
    if n_in < settings.min_contact_points:
        raise CurveRejected("contact_too_close_to_end", f"{n_in} points past the contact point, "
                            f"need >= {settings.min_contact_points}")


def _check_precision(sec, k_deep, noise_sd, limit):
    """Reject a stiffness whose standard error exceeds ``limit`` times the deep secant.

    Judged against the deep secant, not the reading itself: a rule on ``k_err / k`` keeps the
    curves that happen to read high (their relative error is smaller) and biased the accepted
    soft cells by +24 % at a force of 1x the noise (docs/curves.md, Quality control).
    """
    if sec.k_err > limit * k_deep:
        raise CurveRejected(
            "stiffness_undetermined",
            f"k = {sec.k:.3g} +- {sec.k_err:.2g} N/m, an error of {sec.k_err / k_deep:.0%} of "
            f"the deep secant {k_deep:.3g} N/m (limit {limit:.0%}): the force at the reading "
            f"depth {sec.depth * 1e9:.3g} nm is {sec.k * sec.depth * 1e12:.3g} pN against a "
            f"baseline noise of {noise_sd * 1e12:.3g} pN")


def _imprecision(sec, k_deep):
    """``("imprecise", why)`` for an accepted stiffness whose error exceeds the stiffness itself
    (kept: judged against the deep secant it passed, :func:`_check_precision`); else ok."""
    if sec.k_err <= sec.k:
        return OK, ""
    return IMPRECISE, (f"k = {sec.k:.3g} +- {sec.k_err:.2g} N/m, an error of "
                       f"{sec.k_err / sec.k:.0%} of the reading itself (of the deep secant "
                       f"{k_deep:.3g} N/m: {sec.k_err / k_deep:.0%}); kept in its cell's mean, "
                       "since leaving out the low readings biases soft cells high")


def locate_contact(approach, settings=DEFAULT_SETTINGS, fit_depth=None, max_force=None, trace=None,
                   check=True):
    """Baseline and contact point of an approach (docs/curves.md, Method, steps 2-3).

    Parameters
    ----------
    approach : turgorbayes.curves.load.Approach
    settings : ReductionSettings
    fit_depth : float [m], optional
        The contact fit uses separations up to this far past the contact guess (cells:
        ``contact_fit_depth * R_c/20``; None: the whole contact part).
    max_force : float [N], optional
        Ignore the approach past the first force above this (bulges' ``bulge_max_force``).
    trace : CurveTrace, optional
        Filled with the baseline, the corrected force and the contact.
    check : bool
        Require ``settings.min_contact_points`` points of positive indentation past the
        contact (False: the caller checks; a hard substrate is not indented).

    Returns
    -------
    z : ndarray [m]
        Piezo travel used (truncated at ``max_force``).
    force : ndarray [N]
        Force on ``z`` with the baseline removed.
    base : turgorbayes.curves.baseline.Baseline
    found : turgorbayes.curves.contact_point.Contact

    Raises
    ------
    CurveRejected
    """
    z, k = approach.z, approach.spring_constant
    z_contact = None
    for _ in range(3):  # a baseline ending clearly before the contact found, then refit
        base = baseline.fit_baseline(z, approach.force, settings.min_baseline_points,
                                     max_noise_ratio=settings.max_noise_ratio, z_contact=z_contact)
        zt, fc = _truncate(z, approach.force - base(z), max_force)
        _record(trace, baseline=base, z=zt, force=fc, contact=None)
        found = contact_point.contact_point(settings.method, zt, fc, k, base.hinge, base.noise_sd,
                                      fit_depth)
        _record(trace, contact=found)
        if found.z0 - base.z_end >= 0.2 * (zt[-1] - found.z0) or found.z0 <= zt[0]:
            break
        z_contact = found.z0
    if check:
        _check_contact(zt, fc, k, found, settings)
    return zt, fc, base, found


def reduce_approach(approach, target, radius, settings=DEFAULT_SETTINGS, trace=None):
    """Reduce an approach segment to a secant stiffness (docs/curves.md, Method).

    Parameters
    ----------
    approach : turgorbayes.curves.load.Approach
    target : str
        ``"cell"`` (read at ``R_c/20``) or ``"bulge"`` (read at the deepest point, or at
        ``settings.bulge_depth``).
    radius : float [m]
        ``R_c`` (cells; sets the reading depth) or ``R_b`` (bulges; unused by the reduction).
    settings : ReductionSettings
    trace : CurveTrace, optional
        Filled with the intermediate arrays (the result does not depend on it).

    Returns
    -------
    CurveResult
        Always ``ok`` (a rejection raises).

    Raises
    ------
    CurveRejected
    """
    k = approach.spring_constant
    h_read = settings.cell_depth_fraction * radius if target == "cell" else settings.bulge_depth
    fit_depth = None if h_read is None else settings.contact_fit_depth * h_read
    _record(trace, approach=approach, depth_target=h_read)
    max_force = settings.bulge_max_force if target == "bulge" else None
    z, fc, base, found = locate_contact(approach, settings, fit_depth, max_force, trace)
    f = fc - found.offset
    if h_read is None:
        sec = stiffness.secant_at_end(z, f, k, found, settings.bulge_window)
    else:
        sec = stiffness.secant_at_depth(z, f, k, found, h_read, settings.cell_window)
    _record(trace, secant=sec)
    if not (np.isfinite(sec.k) and sec.k > 0 and np.isfinite(sec.k_err)):
        raise CurveRejected("fit_failed", f"secant stiffness {sec.k!r} +- {sec.k_err!r} N/m")
    k_deep = stiffness.deep_secant(z, f, k, found.z0)
    _check_precision(sec, k_deep, base.noise_sd, settings.max_relative_error)
    status, detail = _imprecision(sec, k_deep)
    return CurveResult(status=status, detail=detail, k=sec.k, k_err=sec.k_err, depth=sec.depth,
                       depth_err=sec.depth_err, contact_height=approach.height0 - found.z0,
                       contact_err=found.z0_err, window=sec.window, baseline_noise=base.noise_sd,
                       exponent=found.exponent, dk_dz0=sec.dk_dz0, **read_fields(approach))


def read_fields(approach):
    """The :class:`CurveResult` fields that come from reading the file (also on a rejection)."""
    return {"spring_constant": approach.spring_constant, "n_points": int(approach.z.size),
            "curve_index": approach.curve_index,
            "sensitivity": float("nan") if approach.sensitivity is None else approach.sensitivity}


def reduce_curve(path, target, radius, settings=DEFAULT_SETTINGS, spring_constant=None,
                 sensitivity=None, trace=None, curve_index=0):
    """Read and reduce one force-curve file; a rejection is returned, not raised.

    Parameters
    ----------
    path : str or pathlib.Path
        Any file afmformats reads (JPK ``.jpk-force``, afmformats ``.tab``/``.h5``, ...).
    target, radius, settings
        As in :func:`reduce_approach`.
    spring_constant : float [N/m], optional
    sensitivity : float [m/V], optional
        Override the file's calibration.
    trace : CurveTrace, optional
        As in :func:`reduce_approach` (left empty when the file cannot be read).
    curve_index : int
        0-based index of the curve in a multi-curve file (a force map).

    Returns
    -------
    CurveResult

    Raises
    ------
    turgorbayes.errors.DataError
        The file has no curve ``curve_index`` (a bad index is the caller's error, not a
        rejection).
    """
    if target not in TARGETS:
        raise ValueError(f"target must be one of {TARGETS}, got {target!r}")
    try:
        approach = read_approach(path, spring_constant, sensitivity, curve_index)
    except CurveRejected as rej:
        return CurveResult(status=rej.status, detail=rej.detail, curve_index=curve_index)
    try:
        return reduce_approach(approach, target, radius, settings, trace)
    except CurveRejected as rej:
        return CurveResult(status=rej.status, detail=rej.detail, **read_fields(approach))
