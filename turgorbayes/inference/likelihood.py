"""Pointwise log-likelihood of the cells, latent bulged-cell pressures integrated out.

:class:`CellLikelihood` is the one engine of both ``fit`` (the baseline) and ``criticize``
(model extensions, through a :class:`turgorbayes.inference.context.LikelihoodContext`): each
bulged cell's latent ``ln P`` is integrated by adaptive Gauss-Hermite quadrature (Liu & Pierce
1994), intact cells sit at ``P_phys``. Observation model, latent prior, quadrature and its
measured accuracy and speed: docs/statistics.md; the extensions' quadrature strategy (the
switch to a dense rule): docs/effects.md, "The extended likelihood". The extensions' path is
:class:`turgorbayes.inference.context_likelihood.ContextPath`, mixed into :class:`CellLikelihood`:
the two paths share the node, centring and reduction machinery of one engine; the rules are in
:mod:`turgorbayes.inference.quadrature`.
"""


import numpy as np

from turgorbayes.inference.context_likelihood import ContextPath
from turgorbayes.inference.observations import (
    LOG_2PI,
    bulge_sd,
    gaussian_logpdf,
    latent_log_density,
    latent_prior,
    stiffness_sd,
)
from turgorbayes.inference.population import logsumexp
from turgorbayes.inference.pressure_grid import LogPressureGrid
from turgorbayes.inference.quadrature import hermite_rule, weighted_mean_pressure
from turgorbayes.inference.reading_correlation import (
    bivariate_logpdf,
    cell_correlations,
    centre_terms,
    known_rho,
)
from turgorbayes.physics import forward
from turgorbayes.physics.parameters import P0

__all__ = ["DEFAULT_NODES", "GRID_STEP", "CellLikelihood"]

#: Adaptive Gauss-Hermite nodes per bulged cell (error < 1e-5 per cell against dense
#: quadrature with the shipped table, tests/inference/test_likelihood.py).
DEFAULT_NODES = 8
#: Spacing of the per-walker interpolation grid in ln P.
GRID_STEP = 0.1


class CellLikelihood(ContextPath):
    """Pointwise log-likelihood of every cell for given wall parameters (docs/statistics.md).

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
        ``ln P_i``, docs/statistics.md); False puts them on the bulge estimate alone.

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

    def __init__(self, obs, surrogate, n_nodes=DEFAULT_NODES, P0=P0, grid_step=GRID_STEP,
                 adapt=True):
        self.obs = obs
        self.surrogate = surrogate
        self.n_nodes = int(n_nodes)
        self.P0 = float(P0)
        self.grid_step = grid_step
        self.adapt = bool(adapt)
        self.z, self.log_w = hermite_rule(n_nodes)
        b, i = obs.bulged, obs.intact
        # the readings and their errors' correlation (NaN: unknown; docs/statistics.md,
        # "Correlated readings"); the baseline's path reads unknown as 0
        rho = cell_correlations(obs)
        cols = (obs.R_c, obs.R_c_err, obs.k_c, obs.k_c_err, rho)
        self._bulged_obs = tuple(a[b][:, None] for a in cols)
        self._intact_obs = tuple(a[i] for a in cols)
        self._bulged_rho, self._intact_rho = known_rho(rho[b][:, None]), known_rho(rho[i][:, None])

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

    def _centre(self, model, mu, s, shape):
        """Mean and sd of the linearized conditional posterior of ``ln P_i`` (adaptive GH).

        Gauss-Newton: the model is linearized in ``ln P`` at the current centre (first the
        bulge estimate), which makes the integrand Gaussian; its mean becomes the next
        centre (:attr:`n_adapt` iterations).
        """
        m = np.broadcast_to(mu, shape).copy()
        v = np.broadcast_to(s**2, shape).copy()
        if not self.adapt:
            return m, np.sqrt(v)
        R_obs, R_err, k_obs, k_err = self._bulged_obs[:4]
        rel, rho = k_err / k_obs, self._bulged_rho
        for _ in range(self.n_adapt):
            lnR, dlnR, lnk, dlnk = model(m[..., None])
            R, ratio = np.exp(lnR[..., 0]), k_obs / np.exp(lnk[..., 0])
            R1, dlnk = R * dlnR[..., 0], dlnk[..., 0]
            # k residual (k_obs/k - 1)/rel, slope J_k = -(k_obs/k) dlnk/rel; the density's
            # -ln sd = -ln(rel k) adds the constant gradient -dlnk
            J_k = ratio * dlnk / rel
            if rho is None:
                prec = 1 / s**2 + (R1 / R_err) ** 2 + J_k**2
                num = (mu / s**2 + R1 * (R_obs - R + R1 * m) / R_err**2
                       + J_k * (J_k * m + (ratio - 1) / rel) - dlnk)
            else:  # correlated readings
                p, q = centre_terms(R1 / R_err, (R_obs - R + R1 * m) / R_err, J_k,
                                    J_k * m + (ratio - 1) / rel, rho)
                prec, num = 1 / s**2 + p, mu / s**2 + q - dlnk
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
        m, sd = self._centre(lambda lp: self._model(params, lp, grid), mu, s, shape)
        log_P = m[..., None] + sd[..., None] * self.z  # (W, nb, M, n)
        # importance weights: bulge x latent prior over the proposal N(m, sd) at the nodes
        log_w = (self.log_w + 0.5 * self.z**2 + 0.5 * LOG_2PI + np.log(sd[..., None])
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
        _, total = self._bulged_integrand(gamma, E0t, R0, extra_log_sd, aux_log_w, obs_logpdf,
                                          grid)
        return logsumexp(total, axis=-1)

    def _bulged_integrand(self, gamma, E0t, R0, extra_log_sd=0.0, aux_log_w=None,
                          obs_logpdf=None, grid=None):
        """Nodes ``ln P`` and log integrand at them (log weights included), ``(W, nb, M n)``."""
        log_P, log_w, R, k = self._bulged_nodes(gamma, E0t, R0, extra_log_sd, aux_log_w, grid)
        R_obs, R_err, k_obs, k_err = (a[..., None] for a in self._bulged_obs[:4])
        rho = None if self._bulged_rho is None else self._bulged_rho[..., None]
        f = self._obs_logpdf(obs_logpdf, R, k, R_obs, R_err, k_obs, k_err, rho) + log_w
        if aux_log_w is not None:
            f = f + np.asarray(aux_log_w, float)[..., None]
        shape = f.shape[:2] + (-1,)
        return np.broadcast_to(log_P, f.shape).reshape(shape), f.reshape(shape)

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
    def _obs_logpdf(fn, R, k, R_obs, R_err, k_obs, k_err, rho=None):
        if fn is not None:
            return fn(R, k, R_obs, R_err, k_obs, k_err)
        if rho is not None:  # correlated readings (docs/statistics.md, "Correlated readings")
            return bivariate_logpdf(R_obs, R, R_err, k_obs, k, k_err, rho)
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
        R_obs, R_err, k_obs, k_err = (a[:, None] for a in self._intact_obs[:4])
        f = self._obs_logpdf(obs_logpdf, R, k, R_obs, R_err, k_obs, k_err, self._intact_rho)
        f = np.broadcast_to(f, f.shape[:1] + (R_obs.shape[0],) + f.shape[2:])
        if aux_log_w is None:
            return f[..., 0] if f.shape[-1] == 1 else logsumexp(f - np.log(f.shape[-1]), -1)
        return logsumexp(f + np.asarray(aux_log_w, float), axis=-1)

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
        return weighted_mean_pressure(*self._bulged_integrand(g, e, r, extra_log_sd))
