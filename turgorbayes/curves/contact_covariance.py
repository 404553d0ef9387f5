r"""One contact point, one covariance: the correlation of a force map's R_c and k_c errors.

A crest curve's contact point is a pixel of the height map the radius is fitted to and the
start of the indentation its stiffness is read at: found late, it lowers the pixel (a smaller
``R_c``) and shortens the indentation (a larger ``k``). To first order (docs/curves.md,
Correlated readings),

.. math::

    \mathrm{Cov}(R_c, k_c) = -\frac{1}{n}\sum_{j\in\text{crest}} g_j\,
        \frac{\partial k_j}{\partial z_{0,j}}\,\sigma_{H,j}\,\sigma_{z_0,j},

with :math:`g_j = \partial R/\partial h_j` the arc fit's gain of pixel ``j``
(:func:`radius_gain`), ``n`` the accepted crest curves (their plain mean is ``k_c``), and
:math:`\sigma_{H,j}`, :math:`\sigma_{z_0,j}` the contact errors of the curve's two contact
fits (the height map's and the reduction's, taken to move together). The correlation is this
over the errors written, whose radius error holds the height calibration too: that part is
taken as independent of ``k_c`` (its effects on ``k_c``, through the reading depth
``R_c/20`` and the piezo's travel scale, are not in ``k_c``'s error either).
"""

import math

import numpy as np

__all__ = ["contact_covariance", "map_error_correlation", "radius_gain"]


def radius_gain(section):
    r""":math:`g_j = \partial R/\partial h_j` of every pixel of a map: how much the fitted radius
    moves per unit of a pixel's height (0 off the arc).

    The arc fit (:func:`turgorbayes.curves.crosssection.fit_arc`) is least squares in the
    radius, the axis' angle and its offset across itself; linearized at the solution the
    parameters move by :math:`(J^TJ)^{-1}J^T\,\delta h`, and ``g`` is its first row, with

    .. math:: J_j = \Bigl(1 + \frac{R}{w_j},\ \frac{d_j s_j}{w_j},\ \frac{d_j}{w_j}\Bigr),
              \qquad w_j = \sqrt{R^2 - d_j^2}

    (:math:`h = R + w` at signed distance ``d`` from the axis and position ``s`` along it:
    :math:`\partial d/\partial\theta = -s`, :math:`\partial d/\partial\,\mathrm{offset} = -1`).

    Parameters
    ----------
    section : turgorbayes.curves.crosssection.CrossSection

    Returns
    -------
    ndarray (n_pixels,) [-]
    """
    arc = np.asarray(section.arc, bool)
    d, s, R = section.d[arc], section.s[arc], section.R
    w = np.sqrt(R * R - d * d)
    J = np.column_stack([1 + R / w, d * s / w, d / w])
    gain = np.zeros(arc.size)
    gain[arc] = np.linalg.pinv(J)[0]
    return gain


def map_error_correlation(pixels, section, crest, R_err, k_err):
    """The correlation of a force map's R_c and k_c errors (module docstring).

    Parameters
    ----------
    pixels : turgorbayes.curves.forcemap.MapPixels
    section : turgorbayes.curves.crosssection.CrossSection
    crest : sequence of turgorbayes.curves.reduce.CurveResult
        The crest curves, in the order of ``numpy.flatnonzero(section.crest)``.
    R_err : float [m]
        The radius error written.
    k_err : float [N/m]
        The combined crest stiffness' error.

    Returns
    -------
    rho : float
        In (-1, 1); NaN when it cannot be computed (no accepted crest curve, a non-finite
        term) or the errors written cannot hold it (``|Cov| >= R_err k_err``).
    """
    if not (R_err > 0 and k_err > 0):
        return math.nan
    rho = contact_covariance(pixels, section, crest) / (R_err * k_err)
    return float(rho) if np.isfinite(rho) and abs(rho) < 1 else math.nan


def contact_covariance(pixels, section, crest):
    """The contact points' share of ``Cov(R_c, k_c)`` [m N/m] (the module docstring's sum);
    NaN without an accepted crest curve. Arguments as in :func:`map_error_correlation`."""
    index = np.flatnonzero(section.crest)
    ok = [(j, r) for j, r in zip(index, crest, strict=True) if r.accepted]
    if not ok:
        return math.nan
    gain = radius_gain(section)
    return -sum(gain[j] * r.dk_dz0 * pixels.height_err[j] * r.contact_err
                for j, r in ok) / len(ok)
