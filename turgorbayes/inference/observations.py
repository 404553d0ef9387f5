"""The cells' observations as the likelihood sees them, and the latent-pressure prior.

Bulge -> ``ln P_hat`` with its sd, the population prior of the latent pressures and the
stiffness error model (docs/statistics.md, "Observation model").
"""

import functools
from dataclasses import dataclass

import numpy as np

from turgorbayes.cells.correlation import ERROR_CORRELATION, error_correlation
from turgorbayes.errors import DataError
from turgorbayes.inference.population import (
    LOG_2PI,
    MIN_POPULATION_SD,
    FlatPopulation,
    NormalPopulation,
    deconvolve_family,
)
from turgorbayes.physics import bulge

__all__ = [
    "bulge_log_pressure",
    "bulge_sd",
    "CellObservations",
    "DEFAULT_LATENT",
    "DEFAULT_RELATIVE_ERRORS",
    "gaussian_logpdf",
    "in_place",
    "latent_log_density",
    "latent_population",
    "latent_prior",
    "normal_log_density",
    "LATENT_PRIORS",
    "LOG_2PI",
    "LOG_P_LATENT",
    "MIN_POPULATION_SD",
    "observations_from_cells",
    "population_prior",
    "RELATIVE_ERRORS",
    "sample_latent",
    "stiffness_sd",
]

#: Support (ln Pa) of the uniform prior on a bulged cell's latent ln P (``latent="flat"``).
LOG_P_LATENT = (np.log(1e2), np.log(1e6))
#: The latent-pressure priors :func:`observations_from_cells` knows: ``"deconvolved"`` (the
#: default), ``"population"`` (normal) or ``"flat"`` (docs/statistics.md).
LATENT_PRIORS = ("flat", "population", "deconvolved")
#: The default latent-pressure prior.
DEFAULT_LATENT = "deconvolved"
#: How the likelihood reads the reported errors of the quantities whose errors are relative
#: (k_c, k_b, R_b; docs/statistics.md, "Observation model"): ``"pooled"`` (the default) gives
#: every cell of a group (bulged, intact) the group's RMS relative error
#: ``sqrt(mean((dx/x_obs)^2))``; ``"reported"`` uses each cell's own ``dx/x_obs`` (the
#: published method's weights).
RELATIVE_ERRORS = ("pooled", "reported")
#: The default reading of the relative errors.
DEFAULT_RELATIVE_ERRORS = "pooled"


@dataclass(frozen=True)
class CellObservations:
    """What the likelihood needs from a :class:`turgorbayes.cells.table.CellData`, SI units.

    Attributes
    ----------
    is_bulged : ndarray of bool (n_cells,)
    R_c, R_c_err, k_c, k_c_err : ndarray (n_cells,) [m, m, N/m, N/m]
    log_P_bulge : ndarray (n_bulged,) [ln Pa]
        ``ln P_hat`` of each bulged cell (file order of the bulged cells).
    sd_log_P_bulge : ndarray (n_bulged,)
        ``s_i`` of the docs/statistics.md.
    bulged, intact : ndarray of int
        Indices of the two groups in file order.
    population : FlatPopulation, NormalPopulation or GridPopulation
        Latent-pressure population prior (:mod:`turgorbayes.inference.population`; all
        have ``log_pdf``, ``moments`` and ``sample_posterior``, each taking the extra scatter
        of ``ln P_hat``, which the populations estimated from the bulge estimates depend on:
        ``"deconvolved"`` gives a :class:`~turgorbayes.inference.population.DeconvolvedPopulation`).
    rho_R_k : ndarray (n_cells,) or None
        Correlation of each cell's R_c and k_c errors, NaN where not known (the optional
        ``rho_R_c_k_c`` column; docs/statistics.md, "Correlated readings"); None: no column.
    """

    is_bulged: np.ndarray
    R_c: np.ndarray
    R_c_err: np.ndarray
    k_c: np.ndarray
    k_c_err: np.ndarray
    log_P_bulge: np.ndarray
    sd_log_P_bulge: np.ndarray
    bulged: np.ndarray
    intact: np.ndarray
    population: object = FlatPopulation(*LOG_P_LATENT)
    rho_R_k: np.ndarray = None

    @property
    def n_cells(self):
        return self.is_bulged.size


def bulge_log_pressure(k_b, k_b_err, R_b, R_b_err, h_b, alpha=np.pi / 12):
    """``ln P_hat`` and its standard deviation ``s`` from bulge measurements.

    Parameters
    ----------
    k_b, k_b_err : array_like [N/m]
        Bulge secant stiffness and its standard error.
    R_b, R_b_err : array_like [m]
        Bulge radius and its standard error.
    h_b : array_like [m]
        Indentation depth at which k_b was read (exact).
    alpha : float [rad]
        Half-angle of the conical tip.

    Returns
    -------
    log_P : ndarray [ln Pa]
    sd : ndarray [-]
        See the docs/statistics.md (lognormal errors, R_b integrated out).
    """
    k_b, k_b_err, R_b, R_b_err, h_b = (np.asarray(v, float) for v in
                                        (k_b, k_b_err, R_b, R_b_err, h_b))
    log_P = np.log(bulge.pressure_from_bulge(k_b, R_b, h_b, alpha))
    x = h_b / R_b
    step = 1e-4  # central difference of ln r in ln x: truncation error ~1e-8
    eps = (np.log(bulge.reduced_stiffness(x * np.exp(step), alpha))
           - np.log(bulge.reduced_stiffness(x * np.exp(-step), alpha))) / (2 * step)
    sd = np.hypot(k_b_err / k_b, (1 - eps) * R_b_err / R_b)
    return log_P, sd


def _no_pressure_message(cells, b, alpha):
    """Which bulged cells have no bulge pressure, and why (for the error message)."""
    bad = []
    for i in b:
        try:
            lp, sd = bulge_log_pressure(cells.k_b[i], cells.k_b_err[i], cells.R_b[i],
                                        cells.R_b_err[i], cells.h_b[i], alpha)
            if not (np.isfinite(lp) and np.isfinite(sd)):
                bad.append(f"{cells.cell_id[i]} (no finite pressure)")
        except ValueError as err:
            bad.append(f"{cells.cell_id[i]} ({err})")
    shown = "; ".join(bad[:5]) + (f"; ... and {len(bad) - 5} more" if len(bad) > 5 else "")
    return (f"{len(bad)} bulged cell(s) have no pressure from the bulge model: {shown}. "
            "The depth h_b must be below (1 + cot alpha) R_b; remove or correct these cells")


def population_prior(log_P_hat, sd):
    """Empirical normal population ``(mu_P, tau_P)`` of the true ln P of the bulged cells.

    Method of moments (docs/statistics.md): ``mu_P = mean(ln P_hat)``,
    ``tau_P^2 = var(ln P_hat) - mean(s^2)``, floored at :data:`MIN_POPULATION_SD`. An extra
    scatter ``sigma`` of the estimates is part of that ``tau_P``: the population's sd at
    ``sigma`` is ``sqrt(max(tau_P^2 - sigma^2, MIN_POPULATION_SD^2))`` (its ``floor``).

    Parameters
    ----------
    log_P_hat : array_like (n,) [ln Pa]
    sd : array_like (n,) [-]

    Returns
    -------
    NormalPopulation, or FlatPopulation on :data:`LOG_P_LATENT` when fewer than 3 cells
    """
    log_P_hat, sd = np.asarray(log_P_hat, float), np.asarray(sd, float)
    if log_P_hat.size < 3:
        return FlatPopulation(*LOG_P_LATENT)
    tau2 = np.var(log_P_hat, ddof=1) - np.mean(sd**2)
    return NormalPopulation(float(np.mean(log_P_hat)),
                            float(max(np.sqrt(max(tau2, 0.0)), MIN_POPULATION_SD)),
                            floor=MIN_POPULATION_SD)


def bulge_sd(obs, extra_log_sd=0.0):
    """``s_i`` with an extra scatter of ``ln P_hat`` added in quadrature, ``(W|1, nb, 1)``.

    ``extra_log_sd`` is a float or an array ``(W,)`` (one value per walker).
    """
    s = obs.sd_log_P_bulge
    extra = np.asarray(extra_log_sd, float)
    if extra.ndim:
        return np.sqrt(s[None, :] ** 2 + extra[:, None] ** 2)[..., None]
    return np.sqrt(s**2 + float(extra) ** 2)[None, :, None]


def latent_prior(obs, extra_log_sd=0.0):
    """Gaussian in ln P of (bulge factor) x (population prior), per bulged cell.

    Exact for the flat and the normal population; for a deconvolved one the posterior's mean
    and sd on its grid (the quadrature then corrects with :func:`latent_log_density`).

    Parameters
    ----------
    obs : CellObservations
    extra_log_sd : float or ndarray (W,)
        Extra scatter of ``ln P_hat`` added to ``s_i`` in quadrature; the population is taken
        at it (a population estimated from the bulge estimates already holds that scatter).

    Returns
    -------
    centre, sd, log_norm : ndarray (W|1, n_bulged, 1)
        ``c_i``, ``sigma_i`` and the log of the constant factor (docs/statistics.md).
    """
    return obs.population.moments(obs.log_P_bulge[None, :, None], bulge_sd(obs, extra_log_sd),
                                  extra_log_sd)


def latent_log_density(obs, log_P, extra_log_sd=0.0):
    """``ln [N(ln P_hat_i; x, s_i) pi(x)]`` at ``x = log_P``, unnormalized posterior of ln P_i.

    Parameters
    ----------
    obs : CellObservations
    log_P : ndarray (W|1, n_bulged, ...) [ln Pa]
    extra_log_sd : float or ndarray (W,)

    Returns
    -------
    ndarray, the broadcast shape (``-inf`` outside the prior's support).
    """
    s = bulge_sd(obs, extra_log_sd)  # (W|1, nb, 1)
    log_P = np.asarray(log_P, float)
    lp = obs.log_P_bulge.reshape((1, -1) + (1,) * (log_P.ndim - 2))
    s = s.reshape(s.shape[:2] + (1,) * (log_P.ndim - 2))
    return in_place(np.add, gaussian_logpdf(lp, log_P, s),
                    obs.population.log_pdf(log_P, extra_log_sd))


def sample_latent(obs, rng, n_draws, extra_log_sd=0.0):
    """Draws ``(n_draws, n_bulged)`` of ln P_i from bulge x population (no cell data)."""
    shape = (n_draws, obs.bulged.size)
    s = np.broadcast_to(bulge_sd(obs, extra_log_sd)[..., 0], shape)
    return obs.population.sample_posterior(np.broadcast_to(obs.log_P_bulge, shape), s, rng,
                                           extra_log_sd)


def observations_from_cells(cells, alpha=np.pi / 12, latent=DEFAULT_LATENT,
                            relative_errors=DEFAULT_RELATIVE_ERRORS):
    """Build :class:`CellObservations` from a :class:`turgorbayes.cells.table.CellData`.

    ``latent``: one of :data:`LATENT_PRIORS`, the latent-pressure prior;
    ``relative_errors``: one of :data:`RELATIVE_ERRORS`.
    """
    if latent not in LATENT_PRIORS:
        raise ValueError(f"latent prior must be one of {', '.join(LATENT_PRIORS)}, got {latent!r}")
    if relative_errors not in RELATIVE_ERRORS:
        raise ValueError(f"relative_errors must be one of {', '.join(RELATIVE_ERRORS)}, "
                         f"got {relative_errors!r}")
    b = np.flatnonzero(cells.is_bulged)
    bulged = np.asarray(cells.is_bulged, bool)
    groups = (bulged, ~bulged) if relative_errors == "pooled" else ()
    k_b_err, R_b_err = (_relative_errors(getattr(cells, v), getattr(cells, v + "_err"), groups)
                        for v in ("k_b", "R_b"))
    try:
        log_P, sd = bulge_log_pressure(cells.k_b[b], k_b_err[b], cells.R_b[b], R_b_err[b],
                                       cells.h_b[b], alpha)
    except ValueError:
        log_P = sd = None
    if log_P is None or not (np.all(np.isfinite(log_P)) and np.all(np.isfinite(sd))):
        raise DataError(_no_pressure_message(cells, b, alpha), path=cells.path)
    return CellObservations(
        is_bulged=np.asarray(cells.is_bulged, bool), R_c=np.asarray(cells.R_c, float),
        R_c_err=np.asarray(cells.R_c_err, float), k_c=np.asarray(cells.k_c, float),
        k_c_err=_relative_errors(cells.k_c, cells.k_c_err, groups), log_P_bulge=log_P,
        sd_log_P_bulge=sd,
        bulged=b, intact=np.flatnonzero(~cells.is_bulged),
        population=latent_population(log_P, sd, latent),
        rho_R_k=error_correlation(cells) if ERROR_CORRELATION in cells.extra else None,
    )


def _relative_errors(value, err, groups):
    """Errors as the likelihood reads them: reported, or each group's RMS relative error.

    ``groups``: boolean masks (none: the reported errors). Why pooled: a cell's relative
    error computed from its own reading, ``dx/x_obs``, is correlated with that reading's noise
    whenever the lab's error bar does not scale with the reading (e.g. the standard error of a
    slope fit): cells read high get smaller relative errors and more weight, a bias of about
    twice the squared relative error per cell that adds up over cells (docs/validation.md,
    "Calibration as experiments grow"). NaN entries (intact cells' bulge columns) stay NaN.
    """
    value, err = np.asarray(value, float), np.asarray(err, float)
    rel = err / value
    for group in groups:
        ok = group & np.isfinite(rel)
        if ok.any():
            rel[ok] = np.sqrt(np.mean(rel[ok] ** 2))
    return rel * value


def latent_population(log_P, sd, latent):
    """The latent-pressure population of bulge estimates ``log_P`` with sds ``sd`` (one of
    :data:`LATENT_PRIORS`).

    The same estimates give the same population object: it is estimated once per process and
    data set (:func:`_estimated_population`), so the models of one data set (every candidate
    of a criticism, every leave-one-out refit) share it, and the members a
    :class:`~turgorbayes.inference.population.DeconvolvedPopulation` deconvolves on first
    use are deconvolved once. The estimate is deterministic: a shared one equals a fresh one.
    """
    x, s = np.asarray(log_P, float), np.asarray(sd, float)
    return _estimated_population(latent, x.tobytes(), x.shape, s.tobytes(), s.shape)


@functools.lru_cache(maxsize=16)
def _estimated_population(latent, x, x_shape, s, s_shape):
    """:func:`latent_population` of the estimates and sds given as bytes and shapes."""
    log_P = np.frombuffer(x).reshape(x_shape).copy()
    sd = np.frombuffer(s).reshape(s_shape).copy()
    if latent == "population":
        return population_prior(log_P, sd)
    if latent == "deconvolved" and log_P.size >= 3:
        return deconvolve_family(log_P, sd)
    return FlatPopulation(*LOG_P_LATENT)


def stiffness_sd(k, k_obs, k_err):
    """Model sd of a stiffness reading: the reported relative error times the model value.

    ``k_err / k_obs`` is the cell's relative error (docs/statistics.md, "Cell"); the sd of the
    reading is that fraction of the *model* stiffness ``k`` [N/m], so the reported error does
    not carry information about the cell's true pressure.
    """
    return (k_err / k_obs) * k


def gaussian_logpdf(x, mu, sd):
    """``ln N(x; mu, sd)`` elementwise (NaN ``mu`` gives ``-inf``).

    ``-0.5 (z^2 + ln 2 pi) - ln sd`` with ``z = (x - mu)/sd`` (:func:`normal_log_density`).
    """
    out = np.asarray(normal_log_density(np.asarray(np.subtract(x, mu)), sd))
    out[np.isnan(out)] = -np.inf
    return out


def normal_log_density(diff, sd):
    """``-0.5 ((diff/sd)^2 + ln 2 pi) - ln sd`` elementwise for a fresh array ``diff`` the
    caller gives up (e.g. ``x - mu``).

    The operations and their order are those of ``z = diff / sd; -0.5 * (z * z + LOG_2PI) -
    np.log(sd)``, so the values are the same bit for bit; in float64 they are computed in
    place in ``diff`` (:func:`in_place`), saving the temporaries of the full shape.
    """
    if diff.dtype != np.float64 or np.result_type(diff, sd) != np.float64:
        z = diff / sd
        return -0.5 * (z * z + LOG_2PI) - np.log(sd)
    z = in_place(np.divide, diff, sd)
    np.multiply(z, z, out=z)
    z += LOG_2PI
    z *= -0.5
    return in_place(np.subtract, z, np.log(sd))


def in_place(op, a, b, into=None):
    """``op(a, b)`` (a binary ufunc) written into ``into`` (default ``a``: a fresh array the
    caller gives up) when the result is float64 of its shape, else into a new array: the same
    values either way, without a temporary of the full shape where it fits."""
    into = a if into is None else into
    if (isinstance(into, np.ndarray) and into.dtype == np.float64
            and into.shape == np.broadcast_shapes(np.shape(a), np.shape(b))
            and np.result_type(a, b) == np.float64):
        return op(a, b, out=into)
    return op(a, b)

