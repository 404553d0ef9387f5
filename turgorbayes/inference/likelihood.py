r"""Pointwise log-likelihood of the cells, latent bulged-cell pressures integrated out.

Observation model (per cell; the unit of model comparison is one cell, 114 points)
-------------------------------------------------------------------------------------
**Bulge -> pressure.** A bulged cell's true pressure ``P_i`` is latent. Its bulge gives
(SCIENCE.md section 2) ``k_b = r(h_b/R_b) P_i R_b`` with ``r = k_b/(P R_b)`` the reduced
secant stiffness (:func:`turgorbayes.bulge.reduced_stiffness`). Measurement errors are taken
multiplicative (lognormal): ``ln k_b^obs ~ N(ln k_b, (dk_b/k_b)^2)`` and
``ln R_b^obs ~ N(ln R_b, (dR_b/R_b)^2)``; the depth ``h_b`` is read from the piezo and taken
as exact. With a flat prior on the true ``ln R_b`` (a nuisance of no interest) and ``ln r``
linearized in ``ln(h_b/R_b)`` around the observed value (``epsilon = d ln r/d ln(h/R_b)``,
~0.2 in the paper's range, so the neglected curvature is second order in dR_b/R_b), the true
``R_b`` integrates out analytically and the bulge-derived pressure
``P_hat_i = k_b^obs/(r(h_b/R_b^obs) R_b^obs)`` obeys

.. math::

    \ln \hat P_i \sim N\!\left(\ln P_i,\; s_i^2\right),\qquad
    s_i^2 = \left(\frac{\delta k_b}{k_b}\right)^2
          + (1-\epsilon_i)^2\left(\frac{\delta R_b}{R_b}\right)^2 .

The ``(1 - epsilon)`` factor is the h_b dependence: a larger true ``R_b`` lowers
``h_b/R_b`` and with it ``r``, partly cancelling the explicit ``1/R_b``.

**Prior of the latent pressures.** By default (:data:`LATENT_PRIOR` = ``"deconvolved"``) the
true ``ln P_i`` of the bulged cells share a population density ``g`` estimated from the bulge
estimates themselves by Efron's deconvolution (:mod:`turgorbayes.inference.population`; empirical
Bayes, no shape assumed beyond smoothness): the "structural" errors-in-variables treatment,
which is consistent. Each cell's integral then runs against ``N(ln P_hat_i; x, s_i) g(x)``.
The alternatives are a normal population ``"population"`` and a flat prior per cell
``"flat"`` (uniform over ``[ln 0.1 kPa, ln 1000 kPa]``, :data:`LOG_P_LATENT`; the
"functional" treatment, the only one before version 0.2).

Measured (``benchmarks/calibration_bias.py``: posterior mode and Laplace sd of 20 data sets
with 10x the paper's 72 + 42 cells, simulated at the paper's values with bulge pressures
log-uniform over 1-25 kPa; mean ``z = (mode - truth)/sd``, a bias grows like sqrt(cells)):

==============  =======  =======  =======  =======
latent prior    gamma    E0t      R0       P_phys
==============  =======  =======  =======  =======
deconvolved     -0.02    -0.04    -0.13    -0.03
flat            -1.75    +1.15    -0.99    +0.96
==============  =======  =======  =======  =======

(sd of z 0.8-1.0 in both.) At the paper's size (400 data sets) the deconvolved prior gives
mean z -0.28 / +0.15 / -0.24 / +0.23, sd of z 0.99-1.04, and its 90 % intervals cover the
truth in 84.8 / 90.5 / 89.0 / 89.5 % of the data sets: a small-sample shift of the mode that
shrinks with the cell count (-0.19 / +0.12 / -0.06 / +0.14 at 5x). The flat prior smears
the nonlinear cell model over the bulge error around an estimate that is itself a bulge
error off, so the curvature of ``k_c(ln P)`` is counted twice; its bias is ``sqrt(10)``
times smaller at the paper's size but still visible
in coverage. (Before the stiffness errors were made relative, see "Cell", the structural
priors looked biased too, in the other direction: that was the synthetic data's reported
``dk_c``, proportional to each cell's *true* stiffness, leaking the latent pressure.)

The normal population ``N(mu_P, tau_P^2)`` is set from the data (:func:`population_prior`:
``mu_P`` the mean of the ``ln P_hat_i``, ``tau_P^2 = var(ln P_hat) - mean(s_i^2)``, at least
:data:`MIN_POPULATION_SD`). The product of the bulge factor and the normal population is again
Gaussian in ``ln P_i``,

.. math::

    N(\ln\hat P_i; x, s_i)\,N(x; \mu_P, \tau_P)
        = N(\ln\hat P_i; \mu_P, \sqrt{s_i^2+\tau_P^2})\; N(x; c_i, \sigma_i),\qquad
    c_i = \frac{\tau_P^2 \ln\hat P_i + s_i^2\mu_P}{s_i^2+\tau_P^2},\;
    \sigma_i = \frac{s_i\tau_P}{\sqrt{s_i^2+\tau_P^2}},

so the quadrature below centres on ``N(c_i, sigma_i)`` and the first factor is a per-cell
constant (:func:`latent_prior`; for the flat prior ``c_i = ln P_hat_i``, ``sigma_i = s_i`` and
the constant is ``-ln L``; for the deconvolved ``g``, ``c_i`` and ``sigma_i`` are the mean and
sd of ``N(ln P_hat_i; x, s_i) g(x)`` on its grid). The nodes' weights always carry the exact
``N(ln P_hat_i; x, s_i) pi(x)`` (:func:`latent_log_density`), so the Gaussian is only the
proposal.

**Cell.** ``R_c^obs ~ N(R_c(P), dR_c^2)`` and ``k_c^obs ~ N(k_c(P), (rho_i k_c(P))^2)``
independently, with the forward model of :mod:`turgorbayes.forward`; intact cells sit at
``P = P_phys``. The radius error ``dR_c`` is the reported one (absolute: a contact-point
error). The stiffness error is *relative*: ``rho_i = dk_c/k_c^obs`` from the reported values,
applied to the model stiffness (:func:`stiffness_sd`). Why not the reported ``dk_c`` as a
fixed sd: a stiffness error scales with the stiffness (cantilever calibration, slope fit), so
a bulged cell's ``dk_c`` is proportional to its own, unknown, ``k_c(P_i)`` and tells the
likelihood about the latent pressure in a way a fixed-sd Gaussian ignores. Measured on cells
drawn exactly from the model (``benchmarks/calibration_bias.py``, 20,000 bulged cells): a
fixed sd equal to ``rho x`` the *true* k_c made the mean score of E0t at the truth 8.5
standard errors from zero; with the relative error it is within 1.6.

**Pointwise log-likelihood.** For a bulged cell, the density of ``(R_c, k_c, ln P_hat)``:

.. math::

    \ell_i(\theta) = \ln \int N(\ln\hat P_i; \ln P, s_i)\,\pi(\ln P)\,
        N(R_{c,i}; R_c(P), \delta R_{c,i})\,N(k_{c,i}; k_c(P), \delta k_{c,i})\; d\ln P

(``pi`` the latent prior above: ``g`` for the deconvolved one, ``1/L`` for the flat one,
``L`` the width of :data:`LOG_P_LATENT` in ln P; ``delta k_c,i`` is the relative error times
the model ``k_c(P)``, see "Cell"). For an intact cell
``ell_i = ln N(R_c) + ln N(k_c)`` at ``P_phys``. Forward-model values that are undefined
(NaN) contribute zero density (the model puts no mass there); a cell with no defined node
has ``-inf``.

Quadrature (adaptive Gauss-Hermite, Liu & Pierce 1994)
------------------------------------------------------
The cell's own k_c pins its pressure about as tightly as the bulge does (k_c ~ P^0.6 with
12 % errors vs a 10-15 % bulge error), so the integrand is narrower than, and offset from,
the bulge factor; plain Gauss-Hermite around ``ln P_hat`` needs > 16 nodes for 1e-3. Instead
the model is linearized in ``ln P`` (two Gauss-Newton steps from ``ln P_hat``), which makes
the integrand Gaussian with mean ``m_i`` and sd ``v_i``; the nodes ``m_i + v_i z_j`` carry
the weights ``w_j N(ln P_hat; x_j, s_i) pi(x_j)/N(x_j; m_i, v_i)``. With :data:`DEFAULT_NODES`
nodes the log-likelihood of every cell agrees with dense brute-force quadrature to < 1e-4
(tests/test_likelihood.py). The centre may move at most ``MAX_SHIFT`` bulge sds.

Speed
-----
When the wall parameters are shared by all cells (the baseline), each walker's wall is
tabulated once per call on a uniform grid in ``ln P`` (spacing :data:`GRID_STEP`), with no
root search (:class:`LogPressureGrid`), and ``ln R_c``, ``ln k_c`` at the quadrature nodes
and at ``P_phys`` are 4-point Lagrange (cubic) interpolations: error < 1e-6 in the
log-likelihood (tests), and walkers x cells x nodes cost a few gathers. Per-cell
parameter arrays (model extensions) are evaluated directly.
"""

from dataclasses import dataclass

import numpy as np

from turgorbayes import bulge, forward
from turgorbayes.errors import DataError
from turgorbayes.inference.population import GridPopulation, deconvolve

__all__ = [
    "DEFAULT_NODES",
    "GRID_STEP",
    "LogPressureGrid",
    "LATENT_PRIOR",
    "LATENT_PRIORS",
    "LOG_P_LATENT",
    "MIN_POPULATION_SD",
    "CellLikelihood",
    "CellObservations",
    "bulge_sd",
    "gaussian_logpdf",
    "hermite_rule",
    "latent_log_density",
    "latent_prior",
    "observations_from_cells",
    "population_prior",
    "sample_latent",
    "stiffness_sd",
]

#: Adaptive Gauss-Hermite nodes per bulged cell (error < 1e-5 per cell against dense
#: quadrature with the shipped table, tests/test_likelihood.py).
DEFAULT_NODES = 8
#: Spacing of the per-walker interpolation grid in ln P.
GRID_STEP = 0.1
#: Support (ln Pa) of the uniform prior on a bulged cell's latent ln P (``LATENT_PRIOR = "flat"``).
LOG_P_LATENT = (np.log(1e2), np.log(1e6))
#: Prior of the latent pressures: ``"deconvolved"`` (default), ``"population"`` (normal) or
#: ``"flat"`` (module docstring).
LATENT_PRIOR = "deconvolved"
#: The latent-pressure priors :func:`observations_from_cells` knows.
LATENT_PRIORS = ("flat", "population", "deconvolved")
#: Smallest population sd of ln P (when the bulge pressures hardly spread beyond their noise).
MIN_POPULATION_SD = 0.1

_LOG_2PI = np.log(2 * np.pi)


@dataclass(frozen=True)
class CellObservations:
    """What the likelihood needs from a :class:`turgorbayes.io.CellData`, SI units.

    Attributes
    ----------
    is_bulged : ndarray of bool (n_cells,)
    R_c, R_c_err, k_c, k_c_err : ndarray (n_cells,) [m, m, N/m, N/m]
    log_P_bulge : ndarray (n_bulged,) [ln Pa]
        ``ln P_hat`` of each bulged cell (file order of the bulged cells).
    sd_log_P_bulge : ndarray (n_bulged,)
        ``s_i`` of the module docstring.
    bulged, intact : ndarray of int
        Indices of the two groups in file order.
    population : tuple, GridPopulation or None
        Latent-pressure population prior: ``(mu_P, tau_P)`` of a normal one [ln Pa, -], a
        deconvolved :class:`turgorbayes.inference.population.GridPopulation`, or None (flat).
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
    population: object = None

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
        See the module docstring (lognormal errors, R_b integrated out).
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

    Method of moments (module docstring): ``mu_P = mean(ln P_hat)``,
    ``tau_P^2 = var(ln P_hat) - mean(s^2)``, floored at :data:`MIN_POPULATION_SD`.

    Parameters
    ----------
    log_P_hat : array_like (n,) [ln Pa]
    sd : array_like (n,) [-]

    Returns
    -------
    tuple of float, or None when fewer than 3 cells (then the prior is flat)
    """
    log_P_hat, sd = np.asarray(log_P_hat, float), np.asarray(sd, float)
    if log_P_hat.size < 3:
        return None
    tau2 = np.var(log_P_hat, ddof=1) - np.mean(sd**2)
    return float(np.mean(log_P_hat)), float(max(np.sqrt(max(tau2, 0.0)), MIN_POPULATION_SD))


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

    Exact for the flat and the normal population; for a deconvolved population
    (:class:`turgorbayes.inference.population.GridPopulation`) the posterior's mean and sd on its grid
    (the quadrature then corrects with :func:`latent_log_density`).

    Parameters
    ----------
    obs : CellObservations
    extra_log_sd : float or ndarray (W,)
        Extra scatter of ``ln P_hat`` added to ``s_i`` in quadrature.

    Returns
    -------
    centre, sd, log_norm : ndarray (W|1, n_bulged, 1)
        ``c_i``, ``sigma_i`` and the log of the constant factor of the module docstring
        (``-ln L`` for the flat prior, whose ``c_i, sigma_i`` are ``ln P_hat_i, s_i``).
    """
    s2 = bulge_sd(obs, extra_log_sd) ** 2
    lp = obs.log_P_bulge[None, :, None]
    if obs.population is None:
        return (np.broadcast_to(lp, s2.shape), np.sqrt(s2),
                np.full(s2.shape, -np.log(LOG_P_LATENT[1] - LOG_P_LATENT[0])))
    if isinstance(obs.population, GridPopulation):
        return obs.population.moments(lp, np.sqrt(s2))
    mu, tau = obs.population
    tot = s2 + tau**2
    centre = (tau**2 * lp + s2 * mu) / tot
    return centre, np.sqrt(s2 * tau**2 / tot), -0.5 * ((lp - mu) ** 2 / tot + _LOG_2PI
                                                        + np.log(tot))


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
    out = gaussian_logpdf(lp, log_P, s)
    pop = obs.population
    if pop is None:
        inside = (log_P >= LOG_P_LATENT[0]) & (log_P <= LOG_P_LATENT[1])
        return np.where(inside, out - np.log(LOG_P_LATENT[1] - LOG_P_LATENT[0]), -np.inf)
    if isinstance(pop, GridPopulation):
        return out + pop.log_pdf(log_P)
    return out + gaussian_logpdf(log_P, pop[0], pop[1])


def sample_latent(obs, rng, n_draws, extra_log_sd=0.0):
    """Draws ``(n_draws, n_bulged)`` of ln P_i from bulge x population (no cell data)."""
    shape = (n_draws, obs.bulged.size)
    if isinstance(obs.population, GridPopulation):
        s = np.broadcast_to(bulge_sd(obs, extra_log_sd)[..., 0], shape)
        return obs.population.sample_posterior(np.broadcast_to(obs.log_P_bulge, shape), s, rng)
    centre, sd, _ = latent_prior(obs, extra_log_sd)
    return centre[..., 0] + sd[..., 0] * rng.standard_normal(shape)


def observations_from_cells(cells, alpha=np.pi / 12, latent=None):
    """Build :class:`CellObservations` from a :class:`turgorbayes.io.CellData`.

    ``latent``: one of :data:`LATENT_PRIORS`, the latent-pressure prior (default
    :data:`LATENT_PRIOR`).
    """
    b = np.flatnonzero(cells.is_bulged)
    try:
        log_P, sd = bulge_log_pressure(cells.k_b[b], cells.k_b_err[b], cells.R_b[b],
                                       cells.R_b_err[b], cells.h_b[b], alpha)
    except ValueError:
        log_P = sd = None
    if log_P is None or not (np.all(np.isfinite(log_P)) and np.all(np.isfinite(sd))):
        raise DataError(_no_pressure_message(cells, b, alpha), path=cells.path)
    return CellObservations(
        is_bulged=np.asarray(cells.is_bulged, bool), R_c=np.asarray(cells.R_c, float),
        R_c_err=np.asarray(cells.R_c_err, float), k_c=np.asarray(cells.k_c, float),
        k_c_err=np.asarray(cells.k_c_err, float), log_P_bulge=log_P, sd_log_P_bulge=sd,
        bulged=b, intact=np.flatnonzero(~cells.is_bulged),
        population=_population(log_P, sd, LATENT_PRIOR if latent is None else latent),
    )


def _population(log_P, sd, latent):
    if latent not in LATENT_PRIORS:
        raise ValueError(f"latent prior must be one of {', '.join(LATENT_PRIORS)}, got {latent!r}")
    if latent == "population":
        return population_prior(log_P, sd)
    if latent == "deconvolved":
        return deconvolve(log_P, sd) if log_P.size >= 3 else None
    return None


def hermite_rule(n):
    """Gauss-Hermite rule for expectations under a standard normal.

    Returns
    -------
    z : ndarray (n,)
        Nodes ``sqrt(2) x_j``.
    log_w : ndarray (n,)
        ``ln(w_j / sqrt(pi))`` (the weights sum to 1).
    """
    if int(n) != n or n < 1:
        raise ValueError(f"number of quadrature nodes must be a positive integer, got {n!r}")
    x, w = np.polynomial.hermite.hermgauss(int(n))
    return np.sqrt(2.0) * x, np.log(w) - 0.5 * np.log(np.pi)


def stiffness_sd(k, k_obs, k_err):
    """Model sd of a stiffness reading: the reported relative error times the model value.

    ``k_err / k_obs`` is the cell's relative error (module docstring, "Cell"); the sd of the
    reading is that fraction of the *model* stiffness ``k`` [N/m], so the reported error does
    not carry information about the cell's true pressure.
    """
    return (k_err / k_obs) * k


def gaussian_logpdf(x, mu, sd):
    """``ln N(x; mu, sd)`` elementwise (NaN ``mu`` gives ``-inf``)."""
    z = (x - mu) / sd
    out = -0.5 * (z * z + _LOG_2PI) - np.log(sd)
    return np.where(np.isnan(out), -np.inf, out)


def _logsumexp(a, axis):
    m = np.max(a, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        return np.log(np.sum(np.exp(a - m), axis=axis)) + np.squeeze(m, axis=axis)


def _lagrange4_weights(pos, n_grid, slope=False):
    """Cubic Lagrange weights (and their derivatives if ``slope``) at grid positions."""
    i = np.clip(pos.astype(np.intp), 1, n_grid - 3)  # floor for pos >= 0; clipped anyway
    t = pos - i
    tm1, tm2, tp1 = t - 1, t - 2, t + 1
    a, b = t * tm1, tp1 * tm2
    w = (a * tm2 * (-1 / 6), b * tm1 * 0.5, b * t * (-0.5), a * tp1 * (1 / 6))
    if not slope:
        return i, w, None
    t2 = t * t
    dw = (-(3 * t2 - 6 * t + 2) / 6, (3 * t2 - 4 * t - 1) / 2,
          -(3 * t2 - 2 * t - 2) / 2, (3 * t2 - 1) / 6)
    return i, w, dw


def _hermite(t, delta, y0, y1, m0, m1, slope):
    """Cubic Hermite interpolant on ``[x0, x0 + delta]`` (and its derivative in x)."""
    t2, t3 = t * t, t * t * t
    val = ((2 * t3 - 3 * t2 + 1) * y0 + (t3 - 2 * t2 + t) * delta * m0
           + (3 * t2 - 2 * t3) * y1 + (t3 - t2) * delta * m1)
    if not slope:
        return val, None
    der = ((6 * t2 - 6 * t) * (y0 - y1) / delta + (3 * t2 - 4 * t + 1) * m0
           + (3 * t2 - 2 * t) * m1)
    return val, der


class LogPressureGrid:
    """Each walker's ``ln R_c`` and ``ln k_c`` on a uniform grid in ``ln P``.

    Lookups are 4-point Lagrange (cubic) interpolation in ``ln P`` (one gather per table
    and stencil point). Building the table needs the radius at every grid pressure; it is
    found without a general root search: the pressure is explicit along
    ``s = ln(R_c/R0)`` (:func:`turgorbayes.forward.pressure_on_branch`), so a second table
    at equally spaced ``s`` (only its two end radii come from Newton) gives every grid
    point's ``s`` by cubic Hermite interpolation with exact slopes, and two Newton steps
    on the explicit law polish it to machine precision. Pressures beyond the largest one
    the wall can bear give NaN.

    Parameters
    ----------
    lo, hi : float [ln Pa]
        Range of the query pressures (the grid adds guard points).
    step : float
        Spacing in ``ln P``.
    gamma, E0t, R0 : ndarray (W,)
    P0 : float [Pa]
    surrogate : Surrogate
    """

    _ROW = 1e4  # row offset in ln P for the flat searchsorted (ln P spans << 1e4)

    def __init__(self, lo, hi, step, gamma, E0t, R0, P0, surrogate):
        self.h = float(step)
        n = int(np.ceil((hi - lo) / step)) + 4
        self.g0 = lo - 1.5 * step
        grid = self.g0 + step * np.arange(n)
        g, e, r = gamma[:, None], E0t[:, None], R0[:, None]
        s = _log_radius_on_grid(grid, g, e, r, P0)
        k = forward.stiffness_at_radius(np.exp(grid), r * np.exp(s), g, e, r, P0, surrogate)
        with np.errstate(divide="ignore", invalid="ignore"):
            # flat (W * n,) tables: a 1-D np.take is the fastest gather
            self.values = ((np.log(r) + s).ravel(), np.log(k).ravel())
        self.shape = s.shape

    def __call__(self, log_P, walker_axis=False, slope=False):
        """Interpolated ``(ln R_c, ln k_c)`` (and slopes ``d/d ln P`` if ``slope``).

        ``log_P`` is ``(Q...)`` (shared by all walkers) or ``(W, Q...)`` with
        ``walker_axis``; results are ``(W, Q...)``. With ``slope`` the order is
        ``(ln R_c, d ln R_c, ln k_c, d ln k_c)``.
        """
        W, G = self.shape
        log_P = np.asarray(log_P, float)
        i, w, dw = _lagrange4_weights((log_P - self.g0) / self.h, G, slope)
        if walker_axis:
            flat = i + (G * np.arange(W)).reshape((W,) + (1,) * (i.ndim - 1))
        else:
            flat = i[None] + (G * np.arange(W)).reshape((W,) + (1,) * i.ndim)
        out = []
        for table in self.values:
            val = der = 0.0
            for k in range(4):
                v = np.take(table, flat + (k - 1))
                val = val + w[k] * v
                if slope:
                    der = der + dw[k] * v
            out += [val, der / self.h] if slope else [val]
        return tuple(out)


_S_SCAN = np.linspace(-3.0, 3.0, 121)  # coarse ln(R_c/R0) scan for the table's end radii


def _end_radii(lo, hi, g, e, r, P0):
    """``s`` bracketing ``[lo, hi]`` in ln P per walker, from one explicit coarse scan."""
    s_end, log_p_max = forward.branch_end(g, e, r, P0)
    cap = np.where(np.isfinite(s_end), s_end, np.inf)
    scan = np.minimum(_S_SCAN, cap - 1e-9 * np.maximum(np.abs(cap), 1.0))  # (W, K)
    x, _ = forward.pressure_on_branch(scan, g, e, r, P0)
    below = np.where(np.isfinite(x) & (x <= lo), scan, -np.inf).max(axis=1, keepdims=True)
    above = np.where(np.isfinite(x) & (x >= hi), scan, np.inf).min(axis=1, keepdims=True)
    s_lo = np.where(np.isfinite(below), below, _S_SCAN[0])
    # an unreachable (or off-scan) top: tabulate up to just short of the branch end
    top = np.minimum(cap, _S_SCAN[-1])
    s_hi = np.where(np.isfinite(above), above, s_lo + 0.999 * (top - s_lo))
    return s_lo, s_hi, log_p_max


def _log_radius_on_grid(grid, g, e, r, P0, n_polish=2):
    """``s = ln(R_c/R0)`` at the pressures ``exp(grid)`` (shared) for walkers ``(W, 1)``."""
    W, n = g.shape[0], grid.size
    s_lo, s_hi, log_p_max = _end_radii(grid[0], grid[-1], g, e, r, P0)
    s_tab = s_lo + (s_hi - s_lo) * np.linspace(0.0, 1.0, n)
    x_tab, m_tab = forward.pressure_on_branch(s_tab, g, e, r, P0)
    bad = ~np.isfinite(x_tab).all(axis=1)
    x_tab[bad] = np.arange(n) * 1e-3 - 1e3  # invalid walker: keep the rows sorted
    rows = (x_tab + LogPressureGrid._ROW * np.arange(W)[:, None]).ravel()
    base = n * np.arange(W)[:, None]
    q = np.broadcast_to(grid, (W, n))
    j = np.searchsorted(rows, q + LogPressureGrid._ROW * np.arange(W)[:, None]) - 1
    j = np.clip(j - base, 0, n - 2)
    x0, x1 = np.take_along_axis(x_tab, j, 1), np.take_along_axis(x_tab, j + 1, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        m0 = 1 / np.take_along_axis(m_tab, j, 1)
        m1 = 1 / np.take_along_axis(m_tab, j + 1, 1)
        s, _ = _hermite((q - x0) / (x1 - x0), x1 - x0, np.take_along_axis(s_tab, j, 1),
                        np.take_along_axis(s_tab, j + 1, 1), m0, m1, False)
        for _ in range(n_polish):
            x, m = forward.pressure_on_branch(s, g, e, r, P0)
            s = s + (q - x) / m
    # on the table (not beyond the scan) and below the pressure maximum
    reachable = (q < log_p_max) & (q >= x_tab[:, :1]) & (q <= x_tab[:, -1:]) & ~bad[:, None]
    return np.where(reachable, s, np.nan)


class CellLikelihood:
    """Pointwise log-likelihood of every cell for given wall parameters (module docstring).

    Parameters
    ----------
    obs : CellObservations
    surrogate : turgorbayes.surrogate.Surrogate
        The k/(PR) table.
    n_nodes : int
        Gauss-Hermite nodes per bulged cell.
    P0 : float [Pa]
        Reference pressure of the wall law.
    grid_step : float or None
        Spacing in ln P of the interpolation grid (None: evaluate every node directly).
    adapt : bool
        Adaptive quadrature (nodes centred on the linearized conditional posterior of
        ``ln P_i``, module docstring); False puts them on the bulge estimate alone.

    Notes
    -----
    Parameter arrays (``gamma``, ``E0t``, ``R0``) may be of shape ``(W,)`` (one value per
    walker, shared by all cells of the group) or broadcastable to ``(W, n_group, M)``:
    per-cell values, with an optional trailing axis ``M`` of auxiliary quadrature nodes
    whose log weights ``aux_log_w`` (broadcastable to ``(W, n_group, M)``) are integrated
    over together with the latent pressure (e.g. a per-cell R0 spread).
    """

    #: The adaptive centre may move at most this many bulge sds away from ln P_hat.
    MAX_SHIFT = 4.0
    #: Gauss-Newton iterations of the adaptive centre.
    n_adapt = 2

    def __init__(self, obs, surrogate, n_nodes=DEFAULT_NODES, P0=5e3, grid_step=GRID_STEP,
                 adapt=True):
        self.obs = obs
        self.surrogate = surrogate
        self.n_nodes = int(n_nodes)
        self.P0 = float(P0)
        self.grid_step = grid_step
        self.adapt = bool(adapt)
        self.z, self.log_w = hermite_rule(n_nodes)
        b, i = obs.bulged, obs.intact
        self._bulged_obs = tuple(a[b][:, None] for a in (obs.R_c, obs.R_c_err, obs.k_c,
                                                                obs.k_c_err))
        self._intact_obs = tuple(a[i] for a in (obs.R_c, obs.R_c_err, obs.k_c, obs.k_c_err))

    # ------------------------------------------------------------------ forward model
    def forward(self, log_P, gamma, E0t, R0, walker_axis=False):
        """``(R_c, k_c)`` at ``exp(log_P)`` for per-walker parameters ``(W,)``.

        ``log_P`` is ``(Q...)`` (the same points for every walker) or, with
        ``walker_axis=True``, ``(W, Q...)``. Returns arrays ``(W, Q...)``. Uses the
        interpolation grid when there are many more points than walkers.
        """
        gamma, E0t, R0 = (np.atleast_1d(np.asarray(v, float)) for v in (gamma, E0t, R0))
        log_P = np.asarray(log_P, float)
        n_points = log_P[0].size if walker_axis else log_P.size
        if self.grid_step and n_points > 64:
            grid = LogPressureGrid(np.min(log_P), np.max(log_P), self.grid_step, gamma, E0t,
                                   R0, self.P0, self.surrogate)
            log_R, log_k = grid(log_P, walker_axis)
            return np.exp(log_R), np.exp(log_k)
        extra = log_P.ndim - 1 if walker_axis else log_P.ndim
        expand = (slice(None),) + (None,) * extra
        return forward.cell_radius_and_stiffness(
            np.exp(log_P), gamma[expand], E0t[expand], R0[expand], self.P0, self.surrogate)

    # ------------------------------------------------------------------ bulged cells
    def _model(self, params, log_P, grid):
        """``(ln R, ln k)`` at ``log_P (W, nb, M, n)`` and slopes if ``n`` is 1."""
        slope = log_P.shape[-1] == 1
        if grid is not None:
            out = grid(log_P.reshape(log_P.shape[0], -1), walker_axis=True, slope=slope)
            return tuple(o.reshape(log_P.shape) for o in out)
        g, e, r = params  # (W, nb|1, M|1, 1)

        def at(lp):
            R, k = forward.cell_radius_and_stiffness(np.exp(lp), g, e, r, self.P0,
                                                     self.surrogate)
            with np.errstate(divide="ignore", invalid="ignore"):
                return np.log(R), np.log(k)

        lnR, lnk = at(log_P)
        if not slope:
            return lnR, lnk
        d = 1e-3  # central difference in ln P: error ~1e-7 relative in the slope
        (R_hi, k_hi), (R_lo, k_lo) = at(log_P + d), at(log_P - d)
        return lnR, (R_hi - R_lo) / (2 * d), lnk, (k_hi - k_lo) / (2 * d)

    def _centre(self, params, grid, mu, s, shape):
        """Mean and sd of the linearized conditional posterior of ``ln P_i`` (adaptive GH).

        Gauss-Newton: the model is linearized in ``ln P`` at the current centre (first the
        bulge estimate), which makes the integrand Gaussian; its mean becomes the next
        centre (:attr:`n_adapt` iterations).
        """
        m = np.broadcast_to(mu, shape).copy()
        v = np.broadcast_to(s**2, shape).copy()
        if not self.adapt:
            return m, np.sqrt(v)
        R_obs, R_err, k_obs, k_err = self._bulged_obs
        rel = k_err / k_obs
        for _ in range(self.n_adapt):
            lnR, dlnR, lnk, dlnk = self._model(params, m[..., None], grid)
            R, ratio = np.exp(lnR[..., 0]), k_obs / np.exp(lnk[..., 0])
            R1, dlnk = R * dlnR[..., 0], dlnk[..., 0]
            # k residual (k_obs/k - 1)/rel, slope J_k = -(k_obs/k) dlnk/rel; the density's
            # -ln sd = -ln(rel k) adds the constant gradient -dlnk
            J_k = ratio * dlnk / rel
            prec = 1 / s**2 + (R1 / R_err) ** 2 + J_k**2
            num = (mu / s**2 + R1 * (R_obs - R + R1 * m) / R_err**2
                   + J_k * (J_k * m + (ratio - 1) / rel) - dlnk)
            new_m = np.clip(num / prec, mu - self.MAX_SHIFT * s, mu + self.MAX_SHIFT * s)
            new_v = np.minimum(1 / prec, s**2)
            ok = np.isfinite(new_m) & np.isfinite(new_v)
            m, v = np.where(ok, new_m, m), np.where(ok, new_v, v)
        return m, np.sqrt(v)

    def shared_grid(self, gamma, E0t, R0, extra_log_sd=0.0, P_phys=None):
        """The :class:`LogPressureGrid` of per-walker parameters ``(W,)``.

        It covers every quadrature node the bulged cells can use (the bulge estimates
        +- (MAX_SHIFT + largest node) bulge sds) and, if given, ``P_phys (W,)`` [Pa].
        """
        s = bulge_sd(self.obs, extra_log_sd)
        mu = self.obs.log_P_bulge
        reach = (self.MAX_SHIFT + np.max(np.abs(self.z))) * np.max(s)
        lo, hi = np.min(mu) - reach, np.max(mu) + reach
        if P_phys is not None:
            log_phys = np.log(np.asarray(P_phys, float))
            lo, hi = min(lo, np.min(log_phys)), max(hi, np.max(log_phys))
        return LogPressureGrid(lo, hi, self.grid_step or GRID_STEP,
                               *(np.atleast_1d(np.asarray(v, float)) for v in (gamma, E0t, R0)),
                               self.P0, self.surrogate)

    def _bulged_nodes(self, gamma, E0t, R0, extra_log_sd, aux, grid=None):
        """Nodes ``ln P (W, nb, M, n)``, their log weights and the model there.

        The weights integrate against the latent prior :func:`latent_prior` (Gaussian
        ``N(c_i, sigma_i)``; its constant factor is added in :meth:`bulged`).
        """
        mu, s = self._latent_prior(extra_log_sd)  # (W|1, nb, 1)
        gamma, E0t, R0 = (np.atleast_1d(np.asarray(v, float)) for v in (gamma, E0t, R0))
        shared = aux is None and all(v.ndim == 1 for v in (gamma, E0t, R0))
        W = gamma.shape[0]
        if shared and (self.grid_step or grid is not None):
            params, M = None, 1
            grid = grid if grid is not None else self.shared_grid(gamma, E0t, R0, extra_log_sd)
        else:
            params = tuple(self._cell_axis(v) for v in (gamma, E0t, R0))
            grid = None
            M = max(np.shape(p)[2] for p in params)
        shape = (W, mu.shape[1], M)
        m, sd = self._centre(params, grid, mu, s, shape)
        log_P = m[..., None] + sd[..., None] * self.z  # (W, nb, M, n)
        # importance weights: bulge x latent prior over the proposal N(m, sd) at the nodes
        log_w = (self.log_w + 0.5 * self.z**2 + 0.5 * _LOG_2PI + np.log(sd[..., None])
                 + latent_log_density(self.obs, log_P, extra_log_sd))
        lnR, lnk = self._model(params, log_P, grid)
        return log_P, log_w, np.exp(lnR), np.exp(lnk)

    def bulged(self, gamma, E0t, R0, extra_log_sd=0.0, aux_log_w=None, obs_logpdf=None,
               grid=None):
        """Pointwise log-likelihood of the bulged cells, ``(W, n_bulged)``.

        Parameters
        ----------
        gamma, E0t, R0 : array_like
            ``(W,)`` or broadcastable to ``(W, n_bulged, M)`` (class Notes).
        extra_log_sd : float or ndarray (W,)
            Extra scatter of ``ln P_hat`` (0 in the baseline).
        aux_log_w : array_like, optional
            Log weights of the auxiliary axis M, broadcastable to ``(W, n_bulged, M)``.
        obs_logpdf : callable, optional
            ``(R_pred, k_pred, R_obs, R_err, k_obs, k_err) -> log density`` replacing the
            independent Gaussians (e.g. a mixture for corrupted curves). Consider
            ``adapt=False`` then, since the adaptive centre assumes Gaussian errors.
        grid : LogPressureGrid, optional
            Prebuilt by :meth:`shared_grid` (per-walker parameters only).
        """
        _, log_w, R, k = self._bulged_nodes(gamma, E0t, R0, extra_log_sd, aux_log_w, grid)
        R_obs, R_err, k_obs, k_err = (a[..., None] for a in self._bulged_obs)
        f = self._obs_logpdf(obs_logpdf, R, k, R_obs, R_err, k_obs, k_err) + log_w
        if aux_log_w is not None:
            f = f + np.asarray(aux_log_w, float)[..., None]
        total = f.reshape(f.shape[0], f.shape[1], -1)
        return _logsumexp(total, axis=-1)

    def _latent_prior(self, extra_log_sd):
        """``c_i, sigma_i`` of :func:`latent_prior`, cached for the baseline (no extra sd)."""
        if np.ndim(extra_log_sd) == 0 and float(extra_log_sd) == 0.0:
            if getattr(self, "_latent0", None) is None or self._latent0[0] is not self.obs:
                self._latent0 = (self.obs, latent_prior(self.obs)[:2])
            return self._latent0[1]
        return latent_prior(self.obs, extra_log_sd)[:2]

    @staticmethod
    def _cell_axis(v):
        """Parameter ``(W,)`` -> ``(W,1,1,1)``; ``(W, n)`` or ``(W, n, M)`` -> ``(W, n, M, 1)``."""
        v = np.asarray(v, float)
        if v.ndim == 1:
            return v[:, None, None, None]
        v = v if v.ndim == 3 else v[..., None]
        return v[..., None]

    @staticmethod
    def _obs_logpdf(fn, R, k, R_obs, R_err, k_obs, k_err):
        if fn is not None:
            return fn(R, k, R_obs, R_err, k_obs, k_err)
        return gaussian_logpdf(R_obs, R, R_err) + gaussian_logpdf(k_obs, k,
                                                                  stiffness_sd(k, k_obs, k_err))

    # ------------------------------------------------------------------ intact cells
    def intact(self, gamma, E0t, R0, P_phys, aux_log_w=None, obs_logpdf=None, grid=None):
        """Pointwise log-likelihood of the intact cells at ``P_phys``, ``(W, n_intact)``.

        Parameter shapes as in :meth:`bulged`; ``P_phys`` is ``(W,)`` [Pa]. Without
        ``aux_log_w`` an auxiliary axis M is averaged with equal weights. A ``grid``
        (:meth:`shared_grid` covering ``P_phys``) replaces the direct evaluation for
        per-walker parameters.
        """
        log_phys = np.log(np.asarray(P_phys, float))
        if grid is not None:
            log_R, log_k = grid(log_phys[:, None, None], walker_axis=True)
            R, k = np.exp(log_R), np.exp(log_k)
        else:
            params = []
            for v in (gamma, E0t, R0):
                v = np.atleast_1d(np.asarray(v, float))
                params.append(v[:, None, None] if v.ndim == 1 else
                              (v if v.ndim == 3 else v[..., None]))
            R, k = forward.cell_radius_and_stiffness(np.exp(log_phys)[:, None, None], *params,
                                                     self.P0, self.surrogate)
        R_obs, R_err, k_obs, k_err = (a[:, None] for a in self._intact_obs)
        f = self._obs_logpdf(obs_logpdf, R, k, R_obs, R_err, k_obs, k_err)
        f = np.broadcast_to(f, f.shape[:1] + (R_obs.shape[0],) + f.shape[2:])
        if aux_log_w is None:
            return f[..., 0] if f.shape[-1] == 1 else _logsumexp(f - np.log(f.shape[-1]), -1)
        return _logsumexp(f + np.asarray(aux_log_w, float), axis=-1)

    # ------------------------------------------------------------------ all cells
    def assemble(self, bulged, intact):
        """Pointwise arrays of the two groups -> ``(W, n_cells)`` in file order."""
        out = np.empty((bulged.shape[0], self.obs.n_cells))
        out[:, self.obs.bulged] = bulged
        out[:, self.obs.intact] = intact
        return out

    def pointwise(self, gamma, E0t, R0, P_phys):
        """Baseline pointwise log-likelihood ``(W, n_cells)`` for per-walker parameters.

        Parameters
        ----------
        gamma : array_like (W,) [-]
        E0t : array_like (W,) [N/m]
        R0 : array_like (W,) [m]
        P_phys : array_like (W,) [Pa]
        """
        g, e, r, p = (np.atleast_1d(np.asarray(v, float)) for v in (gamma, E0t, R0, P_phys))
        grid = self.shared_grid(g, e, r, P_phys=p) if self.grid_step else None
        return self.assemble(self.bulged(g, e, r, grid=grid),
                             self.intact(g, e, r, p, grid=grid))

    def latent_pressure_mean(self, gamma, E0t, R0, extra_log_sd=0.0):
        """``E[P_i | data_i, theta]`` of each bulged cell, ``(W, n_bulged)`` [Pa].

        Same quadrature as :meth:`bulged` (a Rao-Blackwellized estimate of the latent
        pressure, used for plots).
        """
        g, e, r = (np.atleast_1d(np.asarray(v, float)) for v in (gamma, E0t, R0))
        log_P, log_w, R, k = self._bulged_nodes(g, e, r, extra_log_sd, None)
        R_obs, R_err, k_obs, k_err = (a[..., None] for a in self._bulged_obs)
        f = self._obs_logpdf(None, R, k, R_obs, R_err, k_obs, k_err) + log_w
        f, log_P = f.reshape(f.shape[0], f.shape[1], -1), log_P.reshape(f.shape[0],
                                                                         f.shape[1], -1)
        return np.exp(_logsumexp(f + log_P, axis=-1) - _logsumexp(f, axis=-1))
