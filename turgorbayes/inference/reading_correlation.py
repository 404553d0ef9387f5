r"""A cell's two readings with correlated errors: the bivariate normal observation model.

One contact point sets both readings of a force map's cell, so their errors are correlated
(the ``rho_R_c_k_c`` column, :mod:`turgorbayes.cells.correlation`; where it is not known, the
``correlated_errors`` effect's one correlation). With the baseline's radius error
:math:`\sigma_R` and relative stiffness error :math:`\sigma_k = r\,k` (``r = k_err/k_obs``,
:func:`turgorbayes.inference.observations.stiffness_sd`), the readings are

.. math::

    (R_{obs}, k_{obs}) \sim N_2\!\left((R, k),
    \begin{pmatrix}\sigma_R^2 & \rho\,\sigma_R\sigma_k\\ \rho\,\sigma_R\sigma_k & \sigma_k^2
    \end{pmatrix}\right),

computed as the radius' density times the stiffness' given the radius,
:math:`N(R_{obs}; R, \sigma_R)\,N\bigl(k_{obs};\ k\,(1 + \rho\,r\,e_R),\ \sigma_k\sqrt{1-\rho^2}\bigr)`,
:math:`e_R = (R_{obs} - R)/\sigma_R` (docs/statistics.md, "Correlated readings").
"""

import warnings

import numpy as np

from turgorbayes.inference.observations import gaussian_logpdf

__all__ = [
    "CorrelationLostWarning",
    "bivariate_logpdf",
    "cell_correlations",
    "cell_rho",
    "centre_terms",
    "conditional_stiffness",
    "correlated_normals",
    "known_rho",
    "readings",
]


def cell_correlations(obs):
    """The known error correlations of ``obs``' cells (a
    :class:`~turgorbayes.inference.observations.CellObservations`), NaN where unknown.

    Observations subset by a path that does not know the field carry the whole data set's
    correlations (today the per-condition observations of
    :mod:`turgorbayes.inference.conditions`): their cells cannot be matched, so they are read
    as unknown, with a warning (never silently).
    """
    rho = obs.rho_R_k
    if rho is None:
        return np.full(obs.n_cells, np.nan)
    if np.shape(rho) != (obs.n_cells,):
        warnings.warn(f"the error correlations ({np.size(rho)}) do not match these "
                      f"observations' {obs.n_cells} cells (a subset that did not carry them, "
                      "e.g. one condition of several): their readings are taken as "
                      "independent", CorrelationLostWarning, stacklevel=3)
        return np.full(obs.n_cells, np.nan)
    return np.asarray(rho, float)


class CorrelationLostWarning(UserWarning):
    """Observations whose cells' error correlations could not be matched (read as unknown)."""


def readings(obs):
    """``(R_obs, R_err, k_obs, k_err, rho)`` of a cell-readings tuple of four (``rho`` None) or
    five (``rho``: the cells' known correlations, NaN where unknown)."""
    return (*obs[:4], obs[4] if len(obs) > 4 else None)


def known_rho(rho):
    """``rho`` with unknown entries (NaN) at 0, or None when every entry is 0 or unknown (the
    readings are then independent, the baseline's path exactly)."""
    if rho is None:
        return None
    rho = np.nan_to_num(np.asarray(rho, float), nan=0.0)
    return rho if np.any(rho) else None


def cell_rho(rho_cells, rho_walkers, ndim):
    """The correlation of each cell's readings: its own where known, else the walkers'.

    Parameters
    ----------
    rho_cells : ndarray or None
        Known correlations of the cells (NaN: unknown), broadcastable to the cell axis.
    rho_walkers : ndarray (W,) or None
        One correlation per walker for the cells without a known one (an effect's parameter).
    ndim : int
        Number of axes of the densities (walkers first).

    Returns
    -------
    ndarray or None
        Broadcastable to the densities; None when every cell's correlation is 0.
    """
    if rho_walkers is None:
        return known_rho(rho_cells)
    w = np.asarray(rho_walkers, float)
    w = w.reshape(w.shape[:1] + (1,) * (ndim - 1))
    if rho_cells is None:
        return w
    return np.where(np.isnan(rho_cells), w, rho_cells)


def conditional_stiffness(R_obs, R, R_err, k_obs, k, k_err, rho):
    r"""Model stiffness and reported error of ``k``'s density given the radius reading.

    The bivariate normal's conditional: mean :math:`k\,(1 + \rho\,r\,e_R)` and sd
    :math:`r\,k\sqrt{1-\rho^2}`, with :math:`r = k_{err}/k_{obs}` and
    :math:`e_R = (R_{obs} - R)/R_{err}`, written as the arguments ``(k', k_err')`` of a
    stiffness density of the baseline's form, whose sd is ``(k_err'/k_obs) k'``.

    Parameters
    ----------
    R_obs, R, R_err : array_like [m]
    k_obs, k, k_err : array_like [N/m]
    rho : array_like

    Returns
    -------
    k_cond, k_err_cond : ndarray [N/m]
    """
    factor = 1 + rho * (k_err / k_obs) * (R_obs - R) / R_err
    return k * factor, k_err * np.sqrt(1 - rho * rho) / factor


def bivariate_logpdf(R_obs, R, R_err, k_obs, k, k_err, rho):
    """``ln N_2((R_obs, k_obs); (R, k), Sigma)`` (module docstring), elementwise; ``-inf``
    where ``R`` or ``k`` is NaN."""
    rel = k_err / k_obs
    e_R = (R_obs - R) / R_err
    mean = k * (1 + rho * rel * e_R)
    return (gaussian_logpdf(R_obs, R, R_err)
            + gaussian_logpdf(k_obs, mean, rel * k * np.sqrt(1 - rho * rho)))


def centre_terms(a_R, b_R, a_k, b_k, rho):
    r"""The readings' terms of a Gauss-Newton step for a cell's latent ``ln P``.

    With the standardized residuals linearized in ``x = ln P``, :math:`e_R = b_R - a_R x` and
    :math:`e_k = b_k - a_k x`, the readings contribute
    :math:`\tfrac12(e_R^2 - 2\rho e_Re_k + e_k^2)/(1-\rho^2)` to the negative log density, so
    the step's precision and numerator gain

    .. math:: \frac{a_R^2 - 2\rho a_Ra_k + a_k^2}{1-\rho^2},\qquad
              \frac{a_Rb_R - \rho(a_Rb_k + a_kb_R) + a_kb_k}{1-\rho^2}

    (at :math:`\rho = 0` the baseline's :math:`a_R^2 + a_k^2` and :math:`a_Rb_R + a_kb_k`).

    Returns
    -------
    precision, numerator : ndarray
    """
    d = 1 - rho * rho
    return ((a_R * a_R - 2 * rho * a_R * a_k + a_k * a_k) / d,
            (a_R * b_R - rho * (a_R * b_k + a_k * b_R) + a_k * b_k) / d)


def correlated_normals(rng, shape, rho):
    """Standard normal errors ``(z_R, z_k)`` of ``shape`` with correlation ``rho`` (None: 0).

    ``z_R`` and an independent draw are taken from ``rng`` in that order (the order in which
    the replicates without correlation draw them, so those are unchanged);
    ``z_k = rho z_R + sqrt(1 - rho^2) z``.
    """
    z_R = rng.standard_normal(shape)
    z = rng.standard_normal(shape)
    if rho is None:
        return z_R, z
    return z_R, rho * z_R + np.sqrt(1 - rho * rho) * z
