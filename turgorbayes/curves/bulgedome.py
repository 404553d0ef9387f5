r"""A membrane bulge on a force map's height map (docs/curves.md, Bulges on force maps).

Rule: the cell's cylinder is fitted (:func:`turgorbayes.curves.crosssection.cross_section`);
the bulge is the largest 8-connected group of pixels over the cell's upper surface (within
``arc_fraction R`` of its axis segment) rising more than ``max(min_height_sd x sd, min_height
x R)`` above the fitted cell surface (``sd``: robust scatter of the arc's residuals). The cell
is fitted again without the dome and a one-pixel margin round it, the dome found again, and a
sphere

.. math:: h(x, y) = z_0 + \sqrt{R_b^2 - (x - x_0)^2 - (y - y_0)^2}

fitted to its pixels gives the apex ``(x_0, y_0)``, its height and ``R_b``. The apex curves
are the dome's pixels within ``apex_fraction R_b`` of the apex (else the one nearest it).
"""

from dataclasses import dataclass

import numpy as np
from scipy import ndimage, optimize

from turgorbayes.curves.crosssection import DEFAULT_SECTION, axis_coordinates, cross_section, largest_component
from turgorbayes.curves.qc import CurveRejected

__all__ = ["DEFAULT_BULGE", "BulgeDome", "BulgeSettings", "cell_section", "cell_surface",
           "find_dome", "fit_cap"]


@dataclass(frozen=True)
class BulgeSettings:
    """How a bulge is found on a height map (dimensionless).

    Attributes
    ----------
    min_height_sd : float [-]
        A dome pixel rises above the fitted cell surface by more than this many robust sds
        of the arc fit's residuals ...
    min_height : float [-]
        ... and by more than this fraction of ``R_c`` (0.03: 13.5 nm on a 450 nm cell; a
        20 nm tip's dilation moves the upper surface by 3 nm).
    min_dome_pixels : int
        Fewest dome pixels (the sphere has 4 parameters).
    fit_fraction : float [-]
        The sphere is refitted to the dome pixels within ``fit_fraction R_b`` of its apex
        (its smooth upper part, as the cylinder's arc).
    apex_fraction : float [-]
        Apex curves: dome pixels within ``apex_fraction R_b`` of the apex (surface less than
        ``1 - sqrt(1 - 0.35^2)`` = 6.3 % of ``R_b`` below it, slope <= 20.5 deg).
    max_refits : int
        The cell is refitted without the pixels more than ``min_height R_c`` above its last
        fit (their largest group and a one-pixel margin) until that set is stable, at most
        this many times.
    """

    min_height_sd: float = 10.0
    min_height: float = 0.03
    min_dome_pixels: int = 6
    fit_fraction: float = 0.8
    apex_fraction: float = 0.35
    max_refits: int = 5


#: The documented defaults.
DEFAULT_BULGE = BulgeSettings()


@dataclass(frozen=True)
class BulgeDome:
    """A bulge found on a map (SI units; per-pixel arrays in the map's curve order).

    Attributes
    ----------
    residual : ndarray [m]
        Height above the fitted cell surface (NaN without a contact).
    threshold : float [m]
        A dome pixel's least residual.
    dome, fitted, apex : ndarray of bool
        Dome pixels, those of the sphere's last fit, the apex curves.
    apex_x, apex_y, apex_xy_err : float [m]
        The sphere's apex in the plane and the larger sd of the two.
    apex_height : float [m]
        Apex height above the substrate.
    dome_height : float [m]
        Apex above the cell's fitted surface there.
    R_b, R_b_err : float [m]
        Sphere radius and its sd (covariance scaled by the residual variance).
    residual_sd : float [m]
        Scatter of the sphere fit's residuals.
    apex_distance : ndarray [m]
        Distance of every pixel from the apex in the plane.
    """

    residual: np.ndarray
    threshold: float
    dome: np.ndarray
    fitted: np.ndarray
    apex: np.ndarray
    apex_x: float
    apex_y: float
    apex_xy_err: float
    apex_height: float
    dome_height: float
    R_b: float
    R_b_err: float
    residual_sd: float
    apex_distance: np.ndarray

    @property
    def apex_index(self):
        """Pixel indices of the apex curves, nearest the apex first."""
        idx = np.flatnonzero(self.apex)
        return idx[np.argsort(self.apex_distance[idx], kind="stable")]


def cell_surface(section, x, y):
    """Height [m] of the fitted cell (a spherocylinder of the section's radius, axis and length)
    above the substrate, and the distance [m] from its axis segment.

    Parameters
    ----------
    section : turgorbayes.curves.crosssection.CrossSection
    x, y : ndarray [m]

    Returns
    -------
    height, rho : ndarray [m]
    """
    s, d = axis_coordinates(x, y, section.center, section.angle)
    half = max(section.half_length - section.R, 0.0)
    rho = np.hypot(np.maximum(np.abs(s) - half, 0.0), d)
    inside = rho < section.R
    return np.where(inside, section.R + np.sqrt(np.where(inside, section.R**2 - rho**2, 0.0)),
                    0.0), rho


def _threshold(section, residual, settings):
    sd = 1.4826 * float(np.median(np.abs(residual[section.arc])))
    return max(settings.min_height_sd * sd, settings.min_height * section.R)


def _dome_mask(pixels, section, settings, section_settings):
    """(residual, threshold, dome mask or None)."""
    model, rho = cell_surface(section, pixels.x, pixels.y)
    residual = section.elevation - model
    threshold = _threshold(section, residual, settings)
    upper = rho <= section_settings.arc_fraction * section.R
    raised = np.isfinite(residual) & upper & (residual > threshold)
    if raised.sum() < settings.min_dome_pixels:
        return residual, threshold, None
    dome = largest_component(raised, pixels.ix, pixels.iy)
    return residual, threshold, dome if dome.sum() >= settings.min_dome_pixels else None


def _margin(mask, ix, iy):
    """``mask`` grown by one pixel (8 neighbours) on the grid."""
    grid = np.zeros((ix.max() + 1, iy.max() + 1), bool)
    grid[ix[mask], iy[mask]] = True
    return ndimage.binary_dilation(grid, structure=np.ones((3, 3)))[ix, iy]


def _section(pixels, settings, exclude=None):
    return cross_section(pixels.x, pixels.y, pixels.height, pixels.ix, pixels.iy, pixels.pitch,
                         settings, exclude=exclude)


def cell_section(pixels, section_settings=DEFAULT_SECTION, settings=DEFAULT_BULGE):
    """The cell's cross-section with a bulge (if any) left out of the arc and the crest.

    Parameters
    ----------
    pixels : turgorbayes.curves.forcemap.MapPixels
    section_settings : SectionSettings
    settings : BulgeSettings

    Returns
    -------
    section : CrossSection
    found : (residual, threshold, dome) or None
        The dome of the refitted cell (None: no dome on the first fit).

    Raises
    ------
    CurveRejected
        The cross-section's statuses.
    """
    section, exclude = _section(pixels, section_settings), None
    for _ in range(settings.max_refits):
        raised = _raised(pixels, section, settings.min_height * section.R, section_settings)
        if raised.sum() < settings.min_dome_pixels:
            break
        grown = _margin(largest_component(raised, pixels.ix, pixels.iy), pixels.ix, pixels.iy)
        if exclude is not None and np.array_equal(grown, exclude):
            break
        exclude = grown
        section = _section(pixels, section_settings, exclude)
    if exclude is None:
        return section, None
    return section, _dome_mask(pixels, section, settings, section_settings)


def _raised(pixels, section, threshold, section_settings):
    """Pixels over the cell's upper surface more than ``threshold`` [m] above its fit."""
    model, rho = cell_surface(section, pixels.x, pixels.y)
    residual = section.elevation - model
    upper = rho <= section_settings.arc_fraction * section.R
    return np.isfinite(residual) & upper & (residual > threshold)


def _sphere_fit(x, y, h, start):
    """Least squares of ``z0 + sqrt(R^2 - rho^2)`` (``z0`` outside the sphere); (params, cov, sd)."""
    scale = start[3]

    def resid(p):
        x0, y0, z0, R = p * scale
        inside = np.maximum(R * R - (x - x0) ** 2 - (y - y0) ** 2, 0.0)
        return (z0 + np.sqrt(inside) - h) / scale

    fit = optimize.least_squares(resid, np.asarray(start) / scale)
    dof = max(h.size - 4, 1)
    var = 2 * fit.cost / dof
    cov = np.linalg.pinv(fit.jac.T @ fit.jac) * var * scale**2
    if not (fit.success and np.all(np.isfinite(fit.x)) and fit.x[3] > 0):
        raise CurveRejected("bulge_fit_failed", f"sphere fit: {fit.message}")
    return fit.x * scale, cov, float(np.sqrt(var) * scale)


def _algebraic_sphere(x, y, h):
    """Centre and radius [m] of the sphere ``x^2 + y^2 + h^2 + D x + E y + F h + G = 0`` fitted
    linearly to points on it: the start of the geometric fit (exact without noise)."""
    scale = float(np.ptp(h)) or 1.0
    u, v, w = x / scale, y / scale, h / scale
    A = np.column_stack([u, v, w, np.ones_like(u)])
    D, E, F, G = np.linalg.lstsq(A, -(u * u + v * v + w * w), rcond=None)[0]
    centre = -0.5 * np.array([D, E, F])
    R = np.sqrt(max(centre @ centre - G, 0.0))
    return [*(centre * scale), R * scale]


def fit_cap(pixels, section, dome, settings=DEFAULT_BULGE):
    """Sphere fitted to the dome's heights above the substrate: apex, its height and ``R_b``.

    Fitted to every dome pixel, then to those within ``fit_fraction R_b`` of the apex (if at
    least ``min_dome_pixels``).

    Returns
    -------
    params : ndarray
        ``x0, y0, z0, R_b`` [m].
    cov : ndarray, shape (4, 4)
    residual_sd : float [m]
    fitted : ndarray of bool

    Raises
    ------
    CurveRejected
        ``bulge_fit_failed``: no convergence, or an apex outside the dome or ``R_b`` larger
        than the map.
    """
    x, y, h = pixels.x, pixels.y, section.elevation
    params, cov, sd = _sphere_fit(x[dome], y[dome], h[dome], _algebraic_sphere(x[dome], y[dome], h[dome]))
    fitted = dome
    near = dome & (np.hypot(x - params[0], y - params[1]) <= settings.fit_fraction * params[3])
    if near.sum() >= settings.min_dome_pixels and near.sum() < dome.sum():
        params, cov, sd = _sphere_fit(x[near], y[near], h[near], params)
        fitted = near
    _check_cap(params, x, y, dome, pixels.pitch)
    return params, cov, sd, fitted


def _check_cap(params, x, y, dome, pitch):
    lo, hi = np.array([x[dome].min(), y[dome].min()]) - pitch, np.array([x[dome].max(), y[dome].max()]) + pitch
    if not (np.all(params[:2] >= lo) and np.all(params[:2] <= hi)):
        raise CurveRejected("bulge_fit_failed", f"sphere's apex ({params[0] * 1e9:.0f}, "
                            f"{params[1] * 1e9:.0f}) nm is outside the dome")
    if not params[3] < max(np.ptp(x), np.ptp(y)):
        raise CurveRejected("bulge_fit_failed", f"fitted R_b {params[3] * 1e9:.0f} nm is larger "
                            "than the map")


def find_dome(pixels, section, found, settings=DEFAULT_BULGE):
    """The bulge on a map whose cell is fitted (module docstring).

    Parameters
    ----------
    pixels : MapPixels
    section : CrossSection
        The cell fitted without the dome (:func:`cell_section`).
    found : (residual, threshold, dome) or None
        :func:`cell_section`'s second return.
    settings : BulgeSettings

    Returns
    -------
    BulgeDome

    Raises
    ------
    CurveRejected
        ``no_bulge`` (no dome of ``min_dome_pixels`` rises above the threshold) or
        ``bulge_fit_failed``.
    """
    if found is None or found[2] is None:
        raise CurveRejected("no_bulge", _no_bulge_detail(pixels, section, found, settings))
    residual, threshold, dome = found
    (x0, y0, z0, R_b), cov, sd, fitted = fit_cap(pixels, section, dome, settings)
    distance = np.hypot(pixels.x - x0, pixels.y - y0)
    apex = dome & (distance <= settings.apex_fraction * R_b)
    if not apex.any():
        apex = np.zeros(dome.size, bool)
        apex[np.flatnonzero(dome)[np.argmin(distance[dome])]] = True
    model, _ = cell_surface(section, np.array([x0]), np.array([y0]))
    return BulgeDome(residual=residual, threshold=threshold, dome=dome, fitted=fitted, apex=apex,
                     apex_x=float(x0), apex_y=float(y0),
                     apex_xy_err=float(np.sqrt(max(cov[0, 0], cov[1, 1]))),
                     apex_height=float(z0 + R_b), dome_height=float(z0 + R_b - model[0]),
                     R_b=float(R_b), R_b_err=float(np.sqrt(cov[3, 3])), residual_sd=sd,
                     apex_distance=distance)


def _no_bulge_detail(pixels, section, found, settings):
    if found is None:
        model, _ = cell_surface(section, pixels.x, pixels.y)
        residual = section.elevation - model
        threshold = _threshold(section, residual, settings)
    else:
        residual, threshold = found[0], found[1]
    top = np.nanmax(np.where(section.cell, residual, np.nan))
    return (f"no bulge: no {settings.min_dome_pixels} connected pixels over the cell rise more "
            f"than {threshold * 1e9:.3g} nm above its fitted cylinder (highest "
            f"{top * 1e9:.3g} nm)")
