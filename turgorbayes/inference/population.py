r"""Deconvolved population of the bulged cells' true pressures (empirical Bayes g-modeling).

Why
---
Each bulged cell's true ``ln P_i`` is latent and seen through its bulge, ``ln P_hat_i ~
N(ln P_i, s_i)`` (:mod:`turgorbayes.inference.likelihood`). A flat prior per cell (the "functional"
treatment) is inconsistent when the cell model is nonlinear in ``ln P``: the integrated
likelihood smears the model over ``N(ln P_hat_i, s_i)`` around an estimate that is itself
``s_i`` off, so the curvature of ``k_c(ln P)`` is counted twice and ``gamma``, ``R0``,
``P_phys`` come out biased by about one posterior sd at 10x the paper's cell count
(``benchmarks/calibration_bias.py``). The consistent ("structural") treatment gives the true
pressures a population density ``g`` and integrates against ``N(ln P_hat_i; x, s_i) g(x)``.
A normal ``g`` is the wrong shape for the experiment's pressures (bulges are induced over a
wide, flat range) and over-corrects; so ``g`` is estimated from the ``ln P_hat_i``
themselves, without a shape assumption.

Method (Efron, "Empirical Bayes deconvolution estimates", Biometrika 103, 1, 2016)
----------------------------------------------------------------------------------
``g`` lives on a grid ``theta_1..theta_m`` (:data:`N_GRID` points spanning the bulge
estimates +- :data:`GRID_PAD_SD` of the largest ``s_i``) as probabilities
``g_j = exp(Q_j alpha) / sum_l exp(Q_l alpha)`` with ``Q`` a cubic B-spline basis of
:func:`spline_functions` ``(n)`` functions: :data:`DF` at the paper's 72 bulged cells, growing
like ``n^(1/3)`` up to :data:`MAX_DF` (a sieve: the family grows with the data, so the
estimate converges to the true population and the wall parameters stay consistent).
``alpha`` maximizes the marginal log-likelihood of the bulge estimates
minus Efron's penalty ``c0 ||alpha||``:

.. math::

    \ell(\alpha) = \sum_i \ln \sum_j g_j(\alpha)\, N(\ln\hat P_i; \theta_j, s_i)
                  - c_0 \lVert\alpha\rVert_2 .

Features of ``g`` narrower than about (range of the estimates)/(number of functions) are
smoothed out (tests/inference/test_population.py recovers a log-uniform and a two-group
population).

Why the family grows: with a fixed number of functions the estimate converges to the best
*smooth* approximation of ``g``, not to ``g``. For a hard-edged population (pressures
log-uniform over 1-25 kPa, the synthetic design) that smoothing is small per cell but the
same in every cell, so it adds up: the asymptotic bias of the wall parameters, in posterior
sds, grows like the square root of the cell count (``benchmarks/calibration_score.py``;
docs/validation.md, "Calibration as experiments grow").
The continuous density used by the likelihood is ``ln g`` interpolated by a cubic spline
between grid points and divided by the spacing (so it integrates to 1); it is ``-inf`` outside the
grid. The estimate ignores its own uncertainty (a plug-in, empirical-Bayes prior); its measured
cost is in docs/validation.md.
"""

from dataclasses import dataclass

import numpy as np
from scipy import interpolate, optimize, special

__all__ = ["DF", "GRID_PAD_SD", "LOG_2PI", "MAX_DF", "N_GRID", "PENALTY", "REFERENCE_CELLS",
           "FlatPopulation", "GridPopulation", "NormalPopulation", "deconvolve", "logsumexp",
           "spline_functions"]

#: Grid points of the population density.
N_GRID = 200
#: The grid extends this many (largest) bulge sds beyond the smallest and largest estimate.
GRID_PAD_SD = 4.0
#: Number of cubic B-spline functions of ``ln g`` at :data:`REFERENCE_CELLS` bulged cells.
DF = 7
#: The paper's number of bulged cells, where :func:`spline_functions` gives :data:`DF`.
REFERENCE_CELLS = 72
#: Largest number of B-spline functions (knots stay >= 5 grid points apart).
MAX_DF = 40
#: Efron's penalty ``c0`` on ``||alpha||``.
PENALTY = 1.0

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

    def log_pdf(self, x):
        """``-ln(hi - lo)`` inside the support, ``-inf`` outside."""
        x = np.asarray(x, float)
        return np.where((x >= self.lo) & (x <= self.hi), -np.log(self.hi - self.lo), -np.inf)

    def moments(self, log_P_hat, sd):
        """``ln P_hat``, ``sd`` and ``-ln(hi - lo)``: the bulge factor alone (support ignored)."""
        log_P_hat, sd = np.broadcast_arrays(np.asarray(log_P_hat, float), np.asarray(sd, float))
        return log_P_hat, sd, np.full(sd.shape, -np.log(self.hi - self.lo))

    def sample_posterior(self, log_P_hat, sd, rng):
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
    """

    mu: float
    tau: float

    def __iter__(self):  # ``mu, tau = population``
        return iter((self.mu, self.tau))

    @property
    def support(self):
        """``(-inf, inf)``: where the density is positive."""
        return (-np.inf, np.inf)

    def log_pdf(self, x):
        z = (np.asarray(x, float) - self.mu) / self.tau
        return -0.5 * (z * z + LOG_2PI) - np.log(self.tau)

    def moments(self, log_P_hat, sd):
        """Mean and sd of the Gaussian posterior of ``ln P`` and ``ln N(ln P_hat; mu, tot)``.

        The product ``N(ln P_hat; x, sd) N(x; mu, tau)`` is
        ``N(ln P_hat; mu, sqrt(sd^2 + tau^2)) N(x; c, sigma)`` (docs/statistics.md).
        """
        lp, s2, tau2 = np.asarray(log_P_hat, float), np.asarray(sd, float) ** 2, self.tau**2
        tot = s2 + tau2
        centre = (tau2 * lp + s2 * self.mu) / tot
        log_norm = -0.5 * ((lp - self.mu) ** 2 / tot + LOG_2PI + np.log(tot))
        return centre, np.sqrt(s2 * tau2 / tot), log_norm

    def sample_posterior(self, log_P_hat, sd, rng):
        centre, sd, _ = self.moments(log_P_hat, sd)
        centre, sd = np.broadcast_arrays(centre, sd)
        return centre + sd * rng.standard_normal(centre.shape)


@dataclass(frozen=True)
class GridPopulation:
    """A density of ``ln P`` on a uniform grid.

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

    def log_pdf(self, x):
        """``ln g(x)`` [per unit ln P], cubic in ``ln g`` between grid points, -inf outside."""
        x = np.asarray(x, float)
        inside = (x >= self.grid[0]) & (x <= self.grid[-1])
        return np.where(inside, self._spline(np.clip(x, self.grid[0], self.grid[-1])), -np.inf)

    def posterior(self, log_P_hat, sd):
        """Posterior of ``ln P`` given ``ln P_hat ~ N(ln P, sd)`` on the grid.

        Parameters
        ----------
        log_P_hat, sd : array_like, broadcastable to a common shape ``S``

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
        a = self.log_mass - 0.5 * (z * z + LOG_2PI) - np.log(sd)[..., None]
        log_norm = special.logsumexp(a, axis=-1)
        return a - log_norm[..., None], log_norm

    def moments(self, log_P_hat, sd):
        """Mean, sd (at least ``step/sqrt(12)``) and ``log_norm`` of :meth:`posterior`."""
        log_p, log_norm = self.posterior(log_P_hat, sd)
        p = np.exp(log_p)
        mean = p @ self.grid
        var = p @ self.grid**2 - mean**2  # grid sums of a smooth density: no Sheppard term
        return mean, np.sqrt(np.maximum(var, self.step**2 / 12)), log_norm

    def sample_posterior(self, log_P_hat, sd, rng):
        """One draw of ``ln P`` per element of the posterior (uniform within the grid cell,
        which adds ``step^2/12`` to the variance: 5e-5 for the default grid over 1-25 kPa)."""
        log_p, _ = self.posterior(log_P_hat, sd)
        cdf = np.cumsum(np.exp(log_p), axis=-1)
        u = rng.random(cdf.shape[:-1])
        j = np.minimum(np.sum(cdf < u[..., None] * cdf[..., -1:], axis=-1), self.grid.size - 1)
        return self.grid[j] + self.step * (rng.random(j.shape) - 0.5)


def spline_functions(n_cells):
    """Number of B-spline functions of ``ln g`` for ``n_cells`` bulge estimates (a sieve).

    ``DF * (n / REFERENCE_CELLS)^(1/3)`` rounded, at least :data:`DF`, at most :data:`MAX_DF`:
    7 at the paper's 72 cells, 15 at 10x, 19 at 20x, 32 at 100x (module docstring).
    """
    grow = DF * (max(int(n_cells), 1) / REFERENCE_CELLS) ** (1 / 3)
    return int(min(MAX_DF, max(DF, round(grow))))


def _basis(grid, df):
    """Cubic B-spline basis ``(m, df)`` on the grid, columns centred (Efron's ``Q``)."""
    k = 3
    inner = np.linspace(grid[0], grid[-1], df - k + 1)
    knots = np.concatenate([[grid[0]] * k, inner, [grid[-1]] * k])
    Q = interpolate.BSpline.design_matrix(grid, knots, k).toarray()
    return Q - Q.mean(axis=0)


def deconvolve(log_P_hat, sd, n_grid=N_GRID, df=None, penalty=PENALTY):
    """Estimate the population density of the true ``ln P`` (module docstring).

    Parameters
    ----------
    log_P_hat : array_like (n,) [ln Pa]
        Bulge estimates.
    sd : array_like (n,) [-]
        Their standard deviations ``s_i``.
    n_grid : int
        Grid points of the density.
    df : int, optional
        Number of B-spline functions; default :func:`spline_functions` ``(n)``.
    penalty : float
        Efron's ``c0``.

    Returns
    -------
    GridPopulation

    Raises
    ------
    ValueError
        Fewer than 3 cells, non-finite input, or the optimizer fails.
    """
    x, s = np.asarray(log_P_hat, float), np.asarray(sd, float)
    if x.size < 3 or not (np.all(np.isfinite(x)) and np.all(np.isfinite(s)) and np.all(s > 0)):
        raise ValueError("deconvolution needs at least 3 bulge estimates with finite values "
                         "and positive sds")
    df = spline_functions(x.size) if df is None else df
    pad = GRID_PAD_SD * np.max(s)
    grid = np.linspace(x.min() - pad, x.max() + pad, int(n_grid))
    Q = _basis(grid, int(df))
    log_kernel = -0.5 * (((x[:, None] - grid) / s[:, None]) ** 2 + LOG_2PI) - np.log(s)[:, None]

    def objective(alpha):
        # -l(alpha) and its gradient -Q^T (sum_i p_i - n g) + c0 alpha/||alpha|| (Efron 2016)
        log_g = Q @ alpha - special.logsumexp(Q @ alpha)
        a = log_kernel + log_g
        log_f = special.logsumexp(a, axis=1)
        post = np.exp(a - log_f[:, None]).sum(axis=0)  # sum_i p_ij
        norm = np.sqrt(alpha @ alpha + 1e-12)
        grad = -Q.T @ (post - x.size * np.exp(log_g)) + penalty * alpha / norm
        return -np.sum(log_f) + penalty * norm, grad

    res = optimize.minimize(objective, np.zeros(Q.shape[1]), jac=True, method="BFGS")
    if not np.all(np.isfinite(res.x)):
        raise ValueError(f"population deconvolution failed: {res.message}")
    log_g = Q @ res.x
    return GridPopulation(grid=grid, log_mass=log_g - special.logsumexp(log_g))
