r"""The cell's radius from a force map's contact-point height map (docs/curves.md, Whole force maps).

A rod-shaped cell lying on the substrate is, in its cylindrical middle, a cylinder of radius
``R`` whose axis is ``R`` above the substrate. Seen from above, at a distance ``d`` from the
axis, its top surface is

.. math:: h(d) = h_\mathrm{sub} + R + \sqrt{R^2 - d^2}, \qquad |d| < R .

Steps (:func:`cross_section`): the substrate plane (a plane fitted to the low pixels,
iterated), the cell (the largest connected group of pixels well above it), its long axis
(principal axis of those pixels), its cylindrical middle (the cell's length less ``R`` at each
end), and a least-squares fit of ``R``, the axis angle and the axis offset to the pixels of
the middle within ``arc_fraction R`` of the axis (the upper part of the arc, where ``h`` is
smooth in the parameters). The model is not convolved with the tip (docs: the bias).
"""

from dataclasses import dataclass

import numpy as np
from scipy import ndimage, optimize

from turgorbayes.curves.qc import CurveRejected

__all__ = ["DEFAULT_SECTION", "CrossSection", "SectionSettings", "arc_height", "axis_coordinates",
           "cross_section", "elevation_scale", "fit_arc", "long_axis", "substrate_plane"]


@dataclass(frozen=True)
class SectionSettings:
    """How the cross-section is found (dimensionless fractions).

    Attributes
    ----------
    low_fraction : float [-]
        The first substrate plane is fitted to the pixels below this height quantile.
    substrate_fraction : float [-]
        A pixel is substrate while it is less than this fraction of the cell's elevation
        above the plane (the ``min_arc_pixels``-th highest elevation: robust to fewer
        outliers, and to a cell covering few of the map's pixels).
    cell_fraction : float [-]
        A pixel is above the substrate (a cell candidate) when more than this fraction of the
        cell's elevation above the plane.
    min_contrast : float [-]
        The cell's elevation must exceed this many times the substrate's scatter (robust sd
        of its heights about the plane): else the map has no cell.
    arc_fraction : float [-]
        The arc is fitted to the middle's pixels within ``arc_fraction R`` of the axis.
    crest_fraction : float [-]
        Crest pixels: in the middle, within ``crest_fraction R`` of the fitted axis (their
        surface is less than ``1 - sqrt(1 - crest_fraction^2)`` of ``R`` below the top: 3.2 %
        for 0.25, 14 nm on a 450 nm cell).
    min_substrate_pixels, min_arc_pixels : int
        Fewest substrate pixels (plane) and arc pixels (fit of 3 parameters) accepted.
    height_calibration : float [-]
        Relative error of the instrument's height (z sensor) calibration. ``R`` is set by the
        cell's height (``2 R`` above the substrate), so the error written for a fitted ``R_c``
        is the fit's and this fraction of ``R`` in quadrature.
    """

    low_fraction: float = 0.25
    substrate_fraction: float = 0.1
    cell_fraction: float = 0.25
    min_contrast: float = 20.0
    arc_fraction: float = 0.8
    crest_fraction: float = 0.25
    min_substrate_pixels: int = 10
    min_arc_pixels: int = 8
    height_calibration: float = 0.01

    @property
    def min_curves(self):
        """Fewest curves with a contact point a cross-section can come from."""
        return self.min_substrate_pixels + self.min_arc_pixels


#: The documented defaults.
DEFAULT_SECTION = SectionSettings()


@dataclass(frozen=True)
class CrossSection:
    """The fitted cross-section of one map (SI units; arrays are per pixel, NaN-free masks).

    Attributes
    ----------
    R, R_err : float [m]
        Cell radius and its standard error (fit covariance scaled by the residual scatter).
    angle, angle_err : float [rad]
        Long axis' angle from the x axis, in (-pi/2, pi/2], and its standard error.
    center : (float, float) [m]
        A point of the axis (x, y): the middle of the cell's length.
    plane : (float, float, float) [m, -, -]
        Substrate height ``p0 + p1 x + p2 y``.
    elevation : ndarray [m]
        Height above the substrate plane (NaN where the contact was not found).
    d, s : ndarray [m]
        Signed distance from the fitted axis, and position along it from ``center``.
    substrate, cell, middle, arc, crest : ndarray of bool
        Substrate pixels (of the last plane fit), the cell's pixels, those in its cylindrical
        middle (``|s| <= half_length - R``), those fitted, and the crest.
    half_length : float [m]
        Half the cell's length along the axis (pixel centres, plus half a pixel at each end).
    residual_sd : float [m]
        Scatter of the arc fit's residuals.
    """

    R: float
    R_err: float
    angle: float
    angle_err: float
    center: tuple
    plane: tuple
    elevation: np.ndarray
    d: np.ndarray
    s: np.ndarray
    substrate: np.ndarray
    cell: np.ndarray
    middle: np.ndarray
    arc: np.ndarray
    crest: np.ndarray
    half_length: float
    residual_sd: float

    @property
    def n_arc(self):
        return int(np.count_nonzero(self.arc))


def arc_height(d, R):
    r"""Height above the substrate [m] of a cylinder of radius ``R`` lying on it, seen from
    above at distance ``d`` from its axis: :math:`R + \sqrt{R^2 - d^2}` for ``|d| < R``, 0
    outside (the bare substrate). Not convolved with the tip.

    Parameters
    ----------
    d : array_like [m]
        Distance from the axis (either sign).
    R : float [m]
        Cylinder radius.

    Returns
    -------
    ndarray [m]
    """
    d = np.asarray(d, float)
    inside = np.abs(d) < R
    return np.where(inside, R + np.sqrt(np.where(inside, R * R - d * d, 0.0)), 0.0)


def axis_coordinates(x, y, center, angle):
    """Position along (``s``) and signed distance from (``d``) the line through ``center`` at
    ``angle`` [rad]; all lengths in m."""
    dx, dy = np.asarray(x) - center[0], np.asarray(y) - center[1]
    c, s = np.cos(angle), np.sin(angle)
    return dx * c + dy * s, -dx * s + dy * c


def _plane_fit(x, y, h):
    A = np.column_stack([np.ones_like(x), x, y])
    return np.linalg.lstsq(A, h, rcond=None)[0]


def _plane(p, x, y):
    return p[0] + p[1] * x + p[2] * y


def substrate_plane(x, y, h, settings=DEFAULT_SECTION):
    """Substrate plane of a height map with a raised cell.

    A plane fitted to the pixels below the ``low_fraction`` quantile; then, until the set is
    stable (at most 10 times), refitted to the pixels less than ``substrate_fraction`` of the
    elevation scale (:func:`elevation_scale` of the heights above the plane) above it.

    Parameters
    ----------
    x, y, h : ndarray [m]
        Finite pixel positions and contact heights.
    settings : SectionSettings

    Returns
    -------
    plane : ndarray, shape (3,)
        ``h_sub = p0 + p1 x + p2 y`` [m, -, -].
    substrate : ndarray of bool
        The pixels of the last fit.
    """
    substrate = h <= np.quantile(h, settings.low_fraction)
    for _ in range(10):
        if substrate.sum() < 3:
            break
        p = _plane_fit(x[substrate], y[substrate], h[substrate])
        r = h - _plane(p, x, y)
        new = r < settings.substrate_fraction * elevation_scale(r, settings)
        if np.array_equal(new, substrate):
            break
        substrate = new
    return p, substrate


def elevation_scale(elevation, settings=DEFAULT_SECTION):
    """The cell's height above the substrate [m]: the ``settings.min_arc_pixels``-th highest
    elevation (robust to fewer outlying pixels; independent of how much of the map the cell
    covers)."""
    n = min(settings.min_arc_pixels, elevation.size)
    return float(np.partition(elevation, elevation.size - n)[elevation.size - n])


def largest_component(mask, ix, iy):
    """The pixels of ``mask`` in its largest 8-connected group on the grid (ix, iy)."""
    grid = np.zeros((ix.max() + 1, iy.max() + 1), bool)
    grid[ix[mask], iy[mask]] = True
    labels, n = ndimage.label(grid, structure=np.ones((3, 3)))
    if n == 0:
        return mask
    sizes = np.bincount(labels.ravel())[1:]
    return mask & (labels[ix, iy] == 1 + int(np.argmax(sizes)))


def long_axis(x, y):
    """Centroid (x, y) [m] and angle [rad, in (-pi/2, pi/2]] of the principal axis of points."""
    center = (float(np.mean(x)), float(np.mean(y)))
    cov = np.cov(np.vstack([x - center[0], y - center[1]]))
    w, v = np.linalg.eigh(cov)
    return center, _wrap(float(np.arctan2(v[1, -1], v[0, -1])))


def _wrap(angle):
    """An axis' angle [rad] folded into (-pi/2, pi/2]."""
    return float(angle - np.pi * np.ceil((angle - np.pi / 2) / np.pi))


def fit_arc(x, y, elevation, center, angle, R0):
    """Least-squares fit of the cylinder's radius, axis angle and axis offset.

    Residuals ``elevation - arc_height(d, R)`` with ``d`` the signed distance from the line
    through ``center`` (moved by ``offset`` across itself) at ``angle``; scipy's
    ``least_squares``. The covariance is ``(J^T J)^-1`` scaled by the residual variance.

    Parameters
    ----------
    x, y, elevation : ndarray [m]
        Pixels on the upper arc: positions and heights above the substrate.
    center : (float, float) [m]
    angle : float [rad]
    R0 : float [m]
        Starting radius.

    Returns
    -------
    params : ndarray
        ``R`` [m], angle [rad], offset [m].
    cov : ndarray, shape (3, 3)
    residual_sd : float [m]
    """
    def resid(p):
        _, d = axis_coordinates(x, y, center, p[1])
        return (arc_height(d - p[2] * R0, p[0] * R0) - elevation) / R0

    fit = optimize.least_squares(resid, [1.0, angle, 0.0], x_scale=[1.0, 0.1, 0.1])
    dof = max(elevation.size - 3, 1)
    var = 2 * fit.cost / dof
    cov = np.linalg.pinv(fit.jac.T @ fit.jac) * var
    scale = np.array([R0, 1.0, R0])
    if not (fit.success and np.all(np.isfinite(fit.x)) and fit.x[0] > 0):
        raise CurveRejected("cross_section_failed", f"arc fit: {fit.message}")
    return fit.x * scale, cov * np.outer(scale, scale), float(np.sqrt(var) * R0)


def _cell(x, y, h, ix, iy, settings):
    """Substrate plane, elevations, cell pixels and the cell's elevation scale."""
    plane, substrate = substrate_plane(x, y, h, settings)
    if substrate.sum() < settings.min_substrate_pixels:
        raise CurveRejected("map_too_small", f"{substrate.sum()} substrate pixels, need >= "
                            f"{settings.min_substrate_pixels} for its plane")
    elevation = h - _plane(plane, x, y)
    top = elevation_scale(elevation, settings)
    scatter = 1.4826 * float(np.median(np.abs(elevation[substrate])))
    if not top > settings.min_contrast * scatter:
        raise CurveRejected("map_too_small", f"no cell: the map's highest pixels are "
                            f"{top * 1e9:.3g} nm above the substrate, less than "
                            f"{settings.min_contrast:g} x its scatter ({scatter * 1e9:.2g} nm)")
    cell = largest_component(elevation > settings.cell_fraction * top, ix, iy)
    if cell.sum() < settings.min_arc_pixels:
        raise CurveRejected("map_too_small", f"{cell.sum()} pixels above the substrate, need >= "
                            f"{settings.min_arc_pixels}")
    return plane, substrate, elevation, cell, float(np.quantile(elevation[cell], 0.95))


def _middle(x, y, cell, center, angle, R, pitch):
    """Axis centre at the middle of the cell's length, half-length, and the middle's pixels."""
    s, _ = axis_coordinates(x, y, center, angle)
    lo, hi = s[cell].min() - pitch / 2, s[cell].max() + pitch / 2
    mid = 0.5 * (lo + hi)
    center = (center[0] + mid * np.cos(angle), center[1] + mid * np.sin(angle))
    half = 0.5 * (hi - lo)
    s, _ = axis_coordinates(x, y, center, angle)
    return center, half, cell & (np.abs(s) <= half - R)


def cross_section(x, y, h, ix, iy, pitch, settings=DEFAULT_SECTION, exclude=None):
    """Fit the cell's cross-section on a contact-height map (module docstring).

    Parameters
    ----------
    x, y : ndarray [m]
        Pixel positions.
    h : ndarray [m]
        Contact heights (NaN where no contact was found: those pixels are not used).
    ix, iy : ndarray of int
        Grid indices (connectivity of the cell's pixels).
    pitch : float [m]
        Grid spacing (the cell's ends are half a pixel beyond its outermost pixel centres).
    settings : SectionSettings
    exclude : ndarray of bool, optional
        Pixels left out of the arc fit and the crest (still part of the cell): a membrane
        bulge on it (:func:`turgorbayes.curves.bulgemap.cell_section`).

    Returns
    -------
    CrossSection

    Raises
    ------
    CurveRejected
        ``map_too_small`` (too few substrate, cell or arc pixels, no cylindrical middle) or
        ``cross_section_failed`` (the fit did not converge or gave a radius outside the map).
    """
    ok = np.isfinite(h)
    if ok.sum() < settings.min_curves:
        raise CurveRejected("map_too_small", f"{ok.sum()} curves with a contact point, a "
                            f"cross-section needs >= {settings.min_curves}")
    full = np.zeros(h.size, bool)
    keep = np.ones(ok.sum(), bool) if exclude is None else ~np.asarray(exclude, bool)[ok]
    plane, sub, elev, cell, top = _cell(x[ok], y[ok], h[ok], ix[ok], iy[ok], settings)
    center, angle = long_axis(x[ok][cell], y[ok][cell])
    R = 0.5 * top
    for _ in range(2):  # select with the principal axis, fit, select again with the fit's axis
        center, half, middle = _middle(x[ok], y[ok], cell, center, angle, R, pitch)
        if half <= R:
            raise CurveRejected("map_too_small", f"no cylindrical middle: the cell is "
                                f"{2 * half * 1e9:.0f} nm long and {2 * R * 1e9:.0f} nm wide")
        _, d = axis_coordinates(x[ok], y[ok], center, angle)
        arc = middle & keep & (np.abs(d) <= settings.arc_fraction * R)
        if arc.sum() < settings.min_arc_pixels:
            raise CurveRejected("map_too_small", f"{arc.sum()} pixels on the arc of the cell's "
                                f"middle, need >= {settings.min_arc_pixels}")
        p, cov, sd = fit_arc(x[ok][arc], y[ok][arc], elev[arc], center, angle, R)
        R, angle = float(p[0]), _wrap(float(p[1]))
        center = (center[0] - p[2] * np.sin(p[1]), center[1] + p[2] * np.cos(p[1]))
    if not (R < 0.5 * max(np.ptp(x), np.ptp(y))):
        raise CurveRejected("cross_section_failed", f"fitted radius {R * 1e9:.0f} nm is larger "
                            "than the map")

    def spread(mask):
        out = full.copy()
        out[np.flatnonzero(ok)[mask]] = True
        return out

    s_all, d_all = axis_coordinates(x, y, center, angle)
    crest = spread(middle & keep) & (np.abs(d_all) <= settings.crest_fraction * R)
    return CrossSection(
        R=R, R_err=float(np.sqrt(cov[0, 0])), angle=angle, angle_err=float(np.sqrt(cov[1, 1])),
        center=(float(center[0]), float(center[1])), plane=tuple(float(v) for v in plane),
        elevation=h - _plane(plane, x, y), d=d_all, s=s_all, substrate=spread(sub),
        cell=spread(cell), middle=spread(middle), arc=spread(arc), crest=crest,
        half_length=float(half), residual_sd=sd)
