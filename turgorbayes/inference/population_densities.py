"""The population densities of the latent ``ln P`` that are given, not deconvolved: flat
(:class:`FlatPopulation`), normal (:class:`NormalPopulation`) and on a grid
(:class:`GridPopulation`), with the one interface the likelihood uses (``log_pdf``,
``moments``, ``sample_posterior``, each taking ``extra_log_sd``). The population deconvolved
from the bulge estimates is :mod:`turgorbayes.inference.population`.
"""

from dataclasses import dataclass

import numpy as np
from scipy import interpolate, special

__all__ = ["LOG_2PI", "MIN_POPULATION_SD", "FlatPopulation", "GridPopulation",
           "NormalPopulation", "along_walkers", "logsumexp", "no_extra_scatter"]

#: Smallest sd of a normal population estimated from the bulge estimates [-].
MIN_POPULATION_SD = 0.1

#: ``ln 2 pi``, the one copy used by the likelihood code.
LOG_2PI = np.log(2 * np.pi)


def logsumexp(a, axis):
    """``ln sum exp(a)`` along ``axis`` in a fixed summation order.

    The likelihood uses this instead of :func:`scipy.special.logsumexp`, whose algorithm
    changed in scipy 1.15 (the maximum's term is taken out and added by ``log1p``): the
    results differ in the last bits, which the MCMC chain amplifies into a different chain.
    With one fixed formula a fit is reproducible bit for bit across scipy versions.
    """
    m = np.max(a, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore"):
        return np.log(np.sum(np.exp(a - m), axis=axis)) + np.squeeze(m, axis=axis)


def no_extra_scatter(extra_log_sd):
    """True for the baseline: a scalar extra scatter ``extra_log_sd`` [-] of exactly 0."""
    return np.ndim(extra_log_sd) == 0 and float(extra_log_sd) == 0.0


def along_walkers(a, ndim):
    """``a`` (``()`` or ``(W,)``) shaped to broadcast along the first of ``ndim`` axes."""
    a = np.asarray(a)
    return a if a.ndim == 0 else a.reshape((-1,) + (1,) * (max(int(ndim), 1) - 1))


@dataclass(frozen=True)
class FlatPopulation:
    """A uniform density of ``ln P`` on ``[lo, hi]`` (the "functional" treatment).

    Every population has the methods :meth:`log_pdf`, :meth:`moments` and
    :meth:`sample_posterior` used by :mod:`turgorbayes.inference.likelihood`.

    Attributes
    ----------
    lo, hi : float [ln Pa]
    """

    lo: float
    hi: float

    @property
    def support(self):
        """``(lo, hi)`` [ln Pa]: where the density is positive."""
        return (self.lo, self.hi)

    def log_pdf(self, x, extra_log_sd=0.0):
        """``-ln(hi - lo)`` inside the support, ``-inf`` outside (``extra_log_sd`` ignored:
        the support was not estimated from the bulge estimates)."""
        x = np.asarray(x, float)
        return np.where((x >= self.lo) & (x <= self.hi), -np.log(self.hi - self.lo), -np.inf)

    def moments(self, log_P_hat, sd, extra_log_sd=0.0):
        """``ln P_hat``, ``sd`` and ``-ln(hi - lo)``: the bulge factor alone (support ignored).

        ``sd`` is the bulge's whole sd (extra scatter included); ``extra_log_sd`` is ignored.
        """
        log_P_hat, sd = np.broadcast_arrays(np.asarray(log_P_hat, float), np.asarray(sd, float))
        return log_P_hat, sd, np.full(sd.shape, -np.log(self.hi - self.lo))

    def sample_posterior(self, log_P_hat, sd, rng, extra_log_sd=0.0):
        """``ln P_hat + sd * N(0, 1)``, one draw per element."""
        centre, sd, _ = self.moments(log_P_hat, sd)
        return centre + sd * rng.standard_normal(centre.shape)


@dataclass(frozen=True)
class NormalPopulation:
    """A normal density ``N(mu, tau)`` of ``ln P``.

    Attributes
    ----------
    mu : float [ln Pa]
    tau : float [-]
        The sd with no extra scatter of the bulge estimates.
    floor : float or None [-]
        None: a known population (independent of the extra scatter). A float: ``tau`` was
        estimated from the bulge estimates by moments, so an extra scatter ``sigma`` of them is
        part of it; the population then has sd ``sqrt(max(tau^2 - sigma^2, floor^2))``
        (:mod:`turgorbayes.inference.population`, "Extra scatter"; the floor is at most
        ``tau``).
    """

    mu: float
    tau: float
    floor: float | None = None

    def __iter__(self):  # ``mu, tau = population``
        return iter((self.mu, self.tau))

    @property
    def support(self):
        """``(-inf, inf)``: where the density is positive."""
        return (-np.inf, np.inf)

    def sd_at(self, extra_log_sd=0.0, ndim=1):
        """The population sd [-] at an extra scatter ``()`` or ``(W,)`` (class docstring),
        shaped to broadcast along the first of ``ndim`` axes."""
        if self.floor is None or no_extra_scatter(extra_log_sd):
            return self.tau
        floor = min(self.floor, self.tau)
        extra = along_walkers(np.asarray(extra_log_sd, float), ndim)
        return np.sqrt(np.maximum(self.tau**2 - extra**2, floor**2))

    def log_pdf(self, x, extra_log_sd=0.0):
        """``ln N(x; mu, tau)`` [per unit ln P], ``tau`` at the extra scatter."""
        x = np.asarray(x, float)
        tau = self.sd_at(extra_log_sd, x.ndim)
        z = (x - self.mu) / tau
        return -0.5 * (z * z + LOG_2PI) - np.log(tau)

    def moments(self, log_P_hat, sd, extra_log_sd=0.0):
        """Mean and sd of the Gaussian posterior of ``ln P`` and ``ln N(ln P_hat; mu, tot)``.

        The product ``N(ln P_hat; x, sd) N(x; mu, tau)`` is
        ``N(ln P_hat; mu, sqrt(sd^2 + tau^2)) N(x; c, sigma)`` (docs/statistics.md); ``sd``
        is the bulge's whole sd, ``tau`` the population's at ``extra_log_sd``.
        """
        lp, s2 = np.asarray(log_P_hat, float), np.asarray(sd, float) ** 2
        tau2 = self.sd_at(extra_log_sd, max(lp.ndim, s2.ndim)) ** 2
        tot = s2 + tau2
        centre = (tau2 * lp + s2 * self.mu) / tot
        log_norm = -0.5 * ((lp - self.mu) ** 2 / tot + LOG_2PI + np.log(tot))
        return centre, np.sqrt(s2 * tau2 / tot), log_norm

    def sample_posterior(self, log_P_hat, sd, rng, extra_log_sd=0.0):
        centre, sd, _ = self.moments(log_P_hat, sd, extra_log_sd)
        centre, sd = np.broadcast_arrays(centre, sd)
        return centre + sd * rng.standard_normal(centre.shape)


@dataclass(frozen=True)
class GridPopulation:
    """A density of ``ln P`` on a uniform grid, independent of the extra scatter.

    Attributes
    ----------
    grid : ndarray (m,) [ln Pa]
        Uniformly spaced.
    log_mass : ndarray (m,)
        ``ln g_j``, probabilities summing to 1.
    """

    grid: np.ndarray
    log_mass: np.ndarray

    @property
    def step(self):
        return float(self.grid[1] - self.grid[0])

    @property
    def support(self):
        """``(grid[0], grid[-1])`` [ln Pa]: where the density is positive."""
        return (float(self.grid[0]), float(self.grid[-1]))

    def __post_init__(self):
        # ln g between grid points: a cubic spline (smooth, so the likelihood's Gauss-Hermite
        # rule sees no kinks); the deconvolved ln g is itself a cubic spline on coarser knots
        object.__setattr__(self, "_spline", interpolate.CubicSpline(
            self.grid, self.log_mass - np.log(self.step)))

    def log_pdf(self, x, extra_log_sd=0.0):
        """``ln g(x)`` [per unit ln P], cubic in ``ln g`` between grid points, -inf outside
        (``extra_log_sd`` ignored: a known population)."""
        x = np.asarray(x, float)
        inside = (x >= self.grid[0]) & (x <= self.grid[-1])
        return np.where(inside, self._spline(np.clip(x, self.grid[0], self.grid[-1])), -np.inf)

    def log_mass_at(self, extra_log_sd=0.0, ndim=1):
        """``ln g_j`` ``(m,)`` on :attr:`grid` (the same at every extra scatter)."""
        return self.log_mass

    def posterior(self, log_P_hat, sd, extra_log_sd=0.0):
        """Posterior of ``ln P`` given ``ln P_hat ~ N(ln P, sd)`` on the grid.

        Parameters
        ----------
        log_P_hat, sd : array_like, broadcastable to a common shape ``S``
            ``sd`` is the bulge's whole sd (extra scatter included).
        extra_log_sd : float or ndarray (W,)
            Ignored here (:class:`DeconvolvedPopulation` uses it).

        Returns
        -------
        log_p : ndarray ``S + (m,)``
            Log posterior masses on :attr:`grid`.
        log_norm : ndarray ``S``
            ``ln sum_j g_j N(ln P_hat; theta_j, sd)``, the marginal density of ``ln P_hat``.
        """
        log_P_hat, sd = np.broadcast_arrays(np.asarray(log_P_hat, float),
                                            np.asarray(sd, float))
        z = (log_P_hat[..., None] - self.grid) / sd[..., None]
        log_mass = self.log_mass_at(extra_log_sd, sd.ndim + 1)
        a = log_mass - 0.5 * (z * z + LOG_2PI) - np.log(sd)[..., None]
        log_norm = special.logsumexp(a, axis=-1)
        return a - log_norm[..., None], log_norm

    def moments(self, log_P_hat, sd, extra_log_sd=0.0):
        """Mean, sd (at least ``step/sqrt(12)``) and ``log_norm`` of :meth:`posterior`."""
        log_p, log_norm = self.posterior(log_P_hat, sd, extra_log_sd)
        p = np.exp(log_p)
        mean = p @ self.grid
        var = p @ self.grid**2 - mean**2  # grid sums of a smooth density: no Sheppard term
        return mean, np.sqrt(np.maximum(var, self.step**2 / 12)), log_norm

    def sample_posterior(self, log_P_hat, sd, rng, extra_log_sd=0.0):
        """One draw of ``ln P`` per element of the posterior (uniform within the grid cell,
        which adds ``step^2/12`` to the variance: 5e-5 for the default grid over 1-25 kPa).

        Where every draw (first axis) has the same ``log_P_hat``, ``sd`` and extra scatter
        (the same cells for every draw, e.g. the predictive checks of a model without extra
        scatter), the posterior is computed for the first draw only: each element's posterior
        depends on its own inputs alone, so this is the same as computing it for every draw.
        """
        log_P_hat, sd = np.broadcast_arrays(np.asarray(log_P_hat, float),
                                            np.asarray(sd, float))
        log_p, _ = self.posterior(*_first_draw_if_repeated(log_P_hat, sd, extra_log_sd))
        cdf = np.broadcast_to(np.cumsum(np.exp(log_p), axis=-1), sd.shape + log_p.shape[-1:])
        u = rng.random(cdf.shape[:-1])
        j = np.minimum(np.sum(cdf < u[..., None] * cdf[..., -1:], axis=-1), self.grid.size - 1)
        return self.grid[j] + self.step * (rng.random(j.shape) - 0.5)


def _first_draw_if_repeated(log_P_hat, sd, extra_log_sd):
    """``(log_P_hat, sd, extra_log_sd)`` (the first two of one shape, draws along the first
    axis; the extra scatter a number or one per draw) cut to the first draw when every draw
    has exactly the same values, else as given."""
    extra = np.asarray(extra_log_sd, float)
    if (sd.ndim == 0 or sd.shape[0] < 2 or (extra.ndim and not np.all(extra == extra[0]))
            or not all(np.array_equal(a, np.broadcast_to(a[:1], a.shape)) for a in (log_P_hat, sd))):
        return log_P_hat, sd, extra_log_sd
    return log_P_hat[:1], sd[:1], extra[:1] if extra.ndim else extra_log_sd
