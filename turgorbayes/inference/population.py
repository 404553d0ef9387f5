r"""Deconvolved population of the bulged cells' true pressures (empirical Bayes g-modeling).

Why
---
Each bulged cell's true ``ln P_i`` is latent and seen through its bulge, ``ln P_hat_i ~
N(ln P_i, s_i)`` (:mod:`turgorbayes.inference.likelihood`). A flat prior per cell (the "functional"
treatment) is inconsistent when the cell model is nonlinear in ``ln P``: the integrated
likelihood smears the model over ``N(ln P_hat_i, s_i)`` around an estimate that is itself
``s_i`` off, so the curvature of ``k_c(ln P)`` is counted twice and ``gamma``, ``R0``,
``P_phys`` come out biased by about one posterior sd at 10x the paper's cell count
(``studies/calibration_bias.py``). The consistent ("structural") treatment gives the true
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
sds, grows like the square root of the cell count (``studies/calibration_score.py``;
docs/validation.md, "Calibration as experiments grow").
The continuous density used by the likelihood is ``ln g`` interpolated by a cubic spline
between grid points and divided by the spacing (so it integrates to 1); it is ``-inf`` outside the
grid. The likelihood holds the estimate fixed (a plug-in, empirical-Bayes prior); ``fit``
carries its estimation noise into the posterior afterwards
(:mod:`turgorbayes.inference.population_noise`). Measured
(``studies/latent_population_cost.py``; docs/validation.md, "Over designs and truths"): a
fit with the *true* population differs from the plug-in's on the hard-edged log-uniform
design, by a shift of the same sign in every data set (``gamma``'s z: -0.28 at 10x, -0.64 at
20x the paper's cells; 0.07-0.15 sd RMS on a smooth lognormal design). That shift is not the
spline rounding the edges off: the hierarchical population with free, sharp edges sampled with
the wall parameters (:mod:`turgorbayes.effects.pressure_range`) gives the plug-in's z-scores
(10x: -0.06 +- 0.04 from them, against -0.39 +- 0.04 for the true population). It is the
value of knowing where the edges are: moving the true population's edges 0.015 in ``ln P``
inward moves ``gamma``'s z by +0.24 at 10x, and every population estimated from the bulges
places them about that far off. The estimate's own noise adds 0.26 sd at 10x and 0.33 sd at
20x (refits with a population deconvolved from an independent data set's bulges), which a
posterior with the population held fixed does not carry: with a 1.8 % per-cell sandwich
excess it accounts for the spread of ``gamma``'s z on the hard-edged design at 20x (1.08 over
300 data sets, 90 % intervals covering 85 %; 88 % with the noise carried; docs/validation.md).

Extra scatter of the bulge estimates (a family of populations)
--------------------------------------------------------------
An effect may say that the bulge estimates scatter more than reported,
``ln P_hat_i ~ N(ln P_i, sqrt(s_i^2 + sigma^2))`` with ``sigma`` fitted (``extra_log_sd``, e.g.
:mod:`turgorbayes.effects.pressure_error`). A ``g`` deconvolved with ``s_i`` alone has that
scatter in it already, so widening the bulge's sd as well would count it twice (the model's
marginal of ``ln P_hat`` is then ``g_true`` smeared by ``s^2 + 2 sigma^2``). The population
estimated from the data is therefore a function of ``sigma``: :class:`DeconvolvedPopulation`
deconvolves with noise ``sqrt(s_i^2 + sigma_k^2)`` at the rows ``sigma_k`` of
:data:`SIGMA_GRID` (all on the grid of the ``sigma = 0`` member, so every member has one
support), and between two rows uses the mixture ``(1 - t) g_k + t g_{k+1}`` (normalized, like
both members). The ``sigma = 0`` member is exactly :func:`deconvolve`'s estimate, so the baseline
is unchanged. The normal population estimated by moments
(:class:`NormalPopulation` with a ``floor``) likewise shrinks: ``tau^2 -> max(tau^2 - sigma^2,
floor^2)``. A population that was not estimated from the bulge estimates (:class:`FlatPopulation`,
a :class:`GridPopulation` or :class:`NormalPopulation` given as known) does not depend on
``sigma``.

Every population's ``log_pdf``, ``moments`` (and ``posterior``) and ``sample_posterior`` take
``extra_log_sd``: a float, or an array ``(W,)`` (one value per walker) that runs along the
first axis of the evaluation points.

This module is the deconvolution; the given densities are
:mod:`turgorbayes.inference.population_densities` and the log-uniform boxes
:mod:`turgorbayes.inference.population_box`, both re-exported here.
"""

import dataclasses
import functools
from dataclasses import dataclass

import numpy as np
from scipy import interpolate, optimize, special

from turgorbayes.inference.population_box import BOX_STEP, RAMP, fitted_box, ramped_box
from turgorbayes.inference.population_densities import (
    LOG_2PI,
    MIN_POPULATION_SD,
    FlatPopulation,
    GridPopulation,
    NormalPopulation,
    along_walkers,
    logsumexp,
    no_extra_scatter,
)

__all__ = ["BOX_STEP", "DF", "GRID_PAD_SD", "LOG_2PI", "MAX_DF", "MIN_POPULATION_SD", "N_GRID",
           "PENALTY", "REFERENCE_CELLS", "SIGMA_GRID", "DeconvolvedPopulation", "FlatPopulation",
           "GridPopulation", "NormalPopulation", "RAMP", "deconvolve", "deconvolve_family",
           "fitted_box", "logsumexp", "ramped_box", "spline_functions"]

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

#: Rows ``sigma_k`` [-] of the extra scatter of ``ln P_hat`` at which :class:`DeconvolvedPopulation`
#: deconvolves (module docstring). Spacing 0.05: at mid-row the mixture of the two rows and the
#: population deconvolved there directly give marginal log-likelihoods of the paper's 72
#: estimates within 0.018 nats (0.005 at spacing 0.025, 0.065 at 0.1, 0.18 at 0.2; error ~
#: spacing^2; studies/pressure_error_double_counting.py). The last row is far in the tail of
#: the ``HalfNormal(0.25)`` prior of ``sigma_P`` (``P(sigma_P > 1) = 6e-5``); beyond it the last
#: member is used. The 20 rows beyond 0 are deconvolved once, on first use (0.5 s CPU at 72
#: cells).
SIGMA_GRID = np.round(np.arange(0.0, 1.0 + 1e-9, 0.05), 10)


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


def deconvolve(log_P_hat, sd, n_grid=N_GRID, df=None, penalty=PENALTY, grid=None):
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
    grid : ndarray (m,), optional [ln Pa]
        Uniform grid of the density (default: ``n_grid`` points over the estimates
        +- :data:`GRID_PAD_SD` largest ``sd``).

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
    if grid is None:
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


@dataclass(frozen=True, eq=False)
class DeconvolvedPopulation(GridPopulation):
    """The population deconvolved from the bulge estimates, as a function of their extra
    scatter ``sigma`` (module docstring, "Extra scatter").

    As a :class:`GridPopulation` it is the ``sigma = 0`` member (:func:`deconvolve`'s estimate);
    at ``extra_log_sd = sigma`` it is the mixture of the members at the two rows of
    :attr:`sigmas` around ``sigma`` (deconvolved on first use, on the same grid).

    Attributes
    ----------
    grid, log_mass : ndarray (m,)
        The ``sigma = 0`` member (:class:`GridPopulation`).
    log_P_hat, sd : ndarray (n,) [ln Pa, -]
        The bulge estimates and their reported sds it was deconvolved from.
    sigmas : ndarray (K,) [-]
        Increasing rows of the extra scatter, the first 0 (default :data:`SIGMA_GRID`).
    df : int
        B-spline functions of every member.
    penalty : float
        Efron's ``c0`` of every member.
    """

    log_P_hat: np.ndarray = None
    sd: np.ndarray = None
    sigmas: np.ndarray = dataclasses.field(default_factory=lambda: SIGMA_GRID.copy())
    df: int = DF
    penalty: float = PENALTY

    @functools.cached_property
    def rows(self):
        """``ln g_j`` of every member, ``(K, m)``: row ``k`` deconvolved with noise
        ``sqrt(sd^2 + sigmas[k]^2)`` on :attr:`grid` (row 0 is :attr:`log_mass`)."""
        out = [self.log_mass]
        for sigma in self.sigmas[1:]:
            member = deconvolve(self.log_P_hat, np.hypot(self.sd, sigma), df=self.df,
                                penalty=self.penalty, grid=self.grid)
            out.append(member.log_mass)
        return np.array(out)

    @functools.cached_property
    def _coefficients(self):
        """Cubic-spline coefficients of every member's ``ln g(x)``, ``(K (m - 1), 4)``: row
        ``k (m - 1) + i`` holds member ``k``'s cubic on grid interval ``i`` (highest power
        first), so one gather fetches a point's four coefficients."""
        log_density = (self.rows - np.log(self.step)).T  # (m, K)
        c = interpolate.CubicSpline(self.grid, log_density, axis=0).c  # (4, m - 1, K)
        return np.ascontiguousarray(c.transpose(2, 1, 0).reshape(-1, 4))

    def member(self, extra_log_sd, ndim=1):
        """Rows ``k`` and mixture weights ``t`` of ``(1 - t) g_k + t g_{k+1}`` at an extra
        scatter ``()`` or ``(W,)`` [-], shaped to broadcast along the first of ``ndim`` axes
        (beyond the last row: the last member)."""
        extra = np.asarray(extra_log_sd, float)
        k = np.clip(np.searchsorted(self.sigmas, extra, side="right") - 1, 0, self.sigmas.size - 2)
        t = np.clip((extra - self.sigmas[k]) / (self.sigmas[k + 1] - self.sigmas[k]), 0.0, 1.0)
        return along_walkers(k, ndim), along_walkers(t, ndim)

    def log_mass_at(self, extra_log_sd=0.0, ndim=1):
        """``ln g_j`` on :attr:`grid` at the extra scatter: ``(m,)`` for a float,
        ``(W, 1, ..., m)`` with ``ndim`` axes for ``(W,)``."""
        if no_extra_scatter(extra_log_sd):
            return self.log_mass
        k, t = self.member(extra_log_sd, ndim - 1)
        return _mix(self.rows[k], self.rows[k + 1], t[..., None])

    def log_pdf(self, x, extra_log_sd=0.0):
        """``ln g(x)`` [per unit ln P] at the extra scatter (the mixture of two members' cubic
        ``ln g``), ``-inf`` outside :attr:`grid`."""
        if no_extra_scatter(extra_log_sd):
            return super().log_pdf(x)
        x = np.asarray(x, float)
        k, t = self.member(extra_log_sd, x.ndim)
        n = self.grid.size - 1
        xc = np.clip(x, self.grid[0], self.grid[-1])
        i = np.clip(np.floor((xc - self.grid[0]) / self.step).astype(np.intp), 0, n - 1)
        dx = xc - self.grid[i]

        def spline(rows):
            c = self._coefficients[rows * n + i]  # (..., 4)
            return ((c[..., 0] * dx + c[..., 1]) * dx + c[..., 2]) * dx + c[..., 3]

        inside = (x >= self.grid[0]) & (x <= self.grid[-1])
        return np.where(inside, _mix(spline(k), spline(k + 1), t), -np.inf)

    def moments(self, log_P_hat, sd, extra_log_sd=0.0):
        """Mean, sd (at least ``step/sqrt(12)``) and ``log_norm`` of :meth:`posterior` at the
        extra scatter (the baseline's arithmetic at exactly 0, one exponential pass else)."""
        if no_extra_scatter(extra_log_sd):
            return super().moments(log_P_hat, sd)
        log_P_hat, sd = np.broadcast_arrays(np.asarray(log_P_hat, float),
                                            np.asarray(sd, float))
        z = (log_P_hat[..., None] - self.grid) / sd[..., None]
        a = self.log_mass_at(extra_log_sd, sd.ndim + 1) - 0.5 * z * z
        top = np.max(a, axis=-1, keepdims=True)
        e = np.exp(a - top)
        total = np.sum(e, axis=-1)
        mean = (e @ self.grid) / total
        var = (e @ self.grid**2) / total - mean**2
        log_norm = np.log(total) + top[..., 0] - 0.5 * LOG_2PI - np.log(sd)
        return mean, np.sqrt(np.maximum(var, self.step**2 / 12)), log_norm


def _mix(log_a, log_b, t):
    """``ln((1 - t) e^log_a + t e^log_b)`` elementwise, exact at ``t = 0`` and ``t = 1``."""
    with np.errstate(divide="ignore"):
        return np.logaddexp(np.log1p(-t) + log_a, np.log(t) + log_b)


def deconvolve_family(log_P_hat, sd, sigmas=SIGMA_GRID, n_grid=N_GRID, df=None, penalty=PENALTY,
                      grid=None):
    """:func:`deconvolve` as a function of the extra scatter of the estimates.

    Parameters
    ----------
    log_P_hat : array_like (n,) [ln Pa]
    sd : array_like (n,) [-]
        Reported sds ``s_i`` (no extra scatter).
    sigmas : array_like (K,) [-]
        Increasing rows of the extra scatter, starting at 0.
    n_grid, df, penalty, grid
        As in :func:`deconvolve`.

    Returns
    -------
    DeconvolvedPopulation
        Its ``sigma = 0`` member is ``deconvolve(log_P_hat, sd, n_grid, df, penalty, grid)``
        bit for bit; the other members are deconvolved on first use.
    """
    x, s = np.asarray(log_P_hat, float), np.asarray(sd, float)
    sigmas = np.asarray(sigmas, float)
    if sigmas.ndim != 1 or sigmas.size < 2 or sigmas[0] != 0 or np.any(np.diff(sigmas) <= 0):
        raise ValueError("the rows of the extra scatter must increase from 0 (at least 2)")
    df = spline_functions(x.size) if df is None else int(df)
    base = deconvolve(x, s, n_grid=n_grid, df=df, penalty=penalty, grid=grid)
    return DeconvolvedPopulation(grid=base.grid, log_mass=base.log_mass, log_P_hat=x, sd=s,
                                 sigmas=sigmas, df=df, penalty=penalty)
