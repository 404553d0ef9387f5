"""Pointwise log-likelihood of the cells, latent bulged-cell pressures integrated out.

:class:`CellLikelihood` is the one engine of both ``fit`` (the baseline) and ``criticize``
(model extensions, through a :class:`turgorbayes.inference.context.LikelihoodContext`): each
bulged cell's latent ``ln P`` is integrated by adaptive Gauss-Hermite quadrature (Liu & Pierce
1994), intact cells sit at ``P_phys``. Observation model, latent prior, quadrature and its
measured accuracy and speed: docs/statistics.md; the extensions' quadrature strategy (the
switch to a dense rule): docs/effects.md, "The extended likelihood". About 620 lines, kept in
one module on purpose: the baseline's path and the extensions' path share the node, centring
and reduction machinery of one engine.
"""

import functools

import numpy as np

from turgorbayes.inference.context import baseline_radius_and_stiffness
from turgorbayes.inference.observations import (
    DEFAULT_LATENT,
    LATENT_PRIORS,
    LOG_2PI,
    LOG_P_LATENT,
    MIN_POPULATION_SD,
    CellObservations,
    bulge_log_pressure,
    bulge_sd,
    gaussian_logpdf,
    latent_log_density,
    latent_prior,
    observations_from_cells,
    population_prior,
    sample_latent,
    stiffness_sd,
)
from turgorbayes.inference.population import logsumexp
from turgorbayes.inference.pressure_grid import LogPressureGrid, WallGrid
from turgorbayes.physics import forward
from turgorbayes.physics.parameters import P0

__all__ = [
    "DEFAULT_LATENT",
    "DEFAULT_NODES",
    "GRID_STEP",
    "LATENT_PRIORS",
    "LOG_P_LATENT",
    "MIN_POPULATION_SD",
    "CellLikelihood",
    "CellObservations",
    "LogPressureGrid",
    "bulge_log_pressure",
    "bulge_sd",
    "composite_legendre",
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
#: quadrature with the shipped table, tests/inference/test_likelihood.py).
DEFAULT_NODES = 8
#: Spacing of the per-walker interpolation grid in ln P.
GRID_STEP = 0.1


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
    return _hermite_rule(int(n))


@functools.lru_cache(maxsize=32)
def _hermite_rule(n):
    """:func:`hermite_rule`, computed once per ``n`` (read-only arrays: the likelihood asks for
    the same few rules at every evaluation)."""
    x, w = np.polynomial.hermite.hermgauss(n)
    return _read_only(np.sqrt(2.0) * x), _read_only(np.log(w) - 0.5 * np.log(np.pi))


def _read_only(a):
    a.flags.writeable = False
    return a


class CellLikelihood:
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
        R_obs, R_err, k_obs, k_err = self._bulged_obs
        rel = k_err / k_obs
        for _ in range(self.n_adapt):
            lnR, dlnR, lnk, dlnk = model(m[..., None])
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
        R_obs, R_err, k_obs, k_err = (a[..., None] for a in self._bulged_obs)
        f = self._obs_logpdf(obs_logpdf, R, k, R_obs, R_err, k_obs, k_err) + log_w
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
        return _weighted_mean_pressure(*self._bulged_integrand(g, e, r, extra_log_sd))

    # ------------------------------------------------------------------ model extensions
    #: Newton steps on the full log integrand after the Gauss-Newton centre (contexts other
    #: than the baseline).
    n_newton = 2
    #: Gauss-Hermite nodes per bulged cell for contexts other than the baseline (checked
    #: against the 8-node rule at the same centre).
    context_nodes = 16

    def pointwise_context(self, ctx, P_phys):
        """Pointwise log-likelihood ``(W, n_cells)`` of a likelihood context.

        Parameters
        ----------
        ctx : turgorbayes.inference.context.LikelihoodContext
            Walls, variants, extra bulge scatter, cell density and wall model (as edited by
            the effects).
        P_phys : array_like (W,) [Pa]

        Notes
        -----
        A context without effects takes exactly the path of :meth:`pointwise`. Any other
        context is integrated by :meth:`_context_bulged`: every wall (walker x variant) of any
        wall model on a :class:`turgorbayes.inference.pressure_grid.WallGrid`, 16-node adaptive
        Gauss-Hermite, and a dense rule for the cells where that rule is not to be trusted.
        """
        p = np.atleast_1d(np.asarray(P_phys, float))
        if not self.obs.bulged.size:  # intact cells only (a condition without bulges)
            return self.assemble(np.empty((ctx.W, 0)), self._context_intact(ctx, p, None))
        if self._plain(ctx):
            grid, same = self._context_grid(ctx, p)
            bulged = self.bulged(*ctx.shared_walls("bulged"), grid=grid)
            return self.assemble(bulged, self._context_intact(ctx, p, grid if same else None))
        bulged = self._context_bulged(ctx)
        return self.assemble(bulged, self._context_intact(ctx, p, None))

    def latent_pressure_mean_context(self, ctx):
        """``E[P_i | data_i, theta]`` ``(W, n_bulged)`` [Pa] under a likelihood context."""
        if not self.obs.bulged.size:
            return np.empty((ctx.W, 0))
        if self._plain(ctx):
            grid, _ = self._context_grid(ctx, None)
            return _weighted_mean_pressure(
                *self._bulged_integrand(*ctx.shared_walls("bulged"), grid=grid))
        return np.exp(self._context_bulged(ctx, moment=1) - self._context_bulged(ctx))

    @staticmethod
    def _plain(ctx):
        """True if the bulged cells' part of the context is the baseline's (the same walls as
        the intact cells, baseline wall model and cell density, no extra scatter)."""
        shared, intact = ctx.shared_walls("bulged"), ctx.shared_walls("intact")
        return (ctx.gaussian() and shared is not None and intact is not None
                and ctx.bulge_outlier is None and ctx.log_k_scale is None
                and ctx.latent_log_pdf is None
                and np.ndim(ctx.extra_sd()) == 0
                and all(np.array_equal(a, b) for a, b in zip(shared, intact, strict=True)))

    def _context_grid(self, ctx, P_phys):
        """The bulged cells' :class:`LogPressureGrid` (None without shared walls) and whether
        the intact cells share it (same walls, grid covering ``P_phys``)."""
        shared = ctx.shared_walls("bulged")
        if shared is None or not self.grid_step:
            return None, False
        intact = ctx.shared_walls("intact")
        same = (P_phys is not None and intact is not None
                and all(np.array_equal(a, b) for a, b in zip(shared, intact, strict=True)))
        grid = self.shared_grid(*shared, extra_log_sd=ctx.extra_sd(),
                                P_phys=P_phys if same else None)
        return grid, same

    #: Half-width, in bulge sds, of a cell's window for the dense rule (and the grid's reach),
    #: cut to the latent prior's support.
    DENSE_SIGMA = 8.0
    #: Panels x nodes of the dense composite Gauss-Legendre rule over a cell's window.
    dense_panels, dense_order = 8, 6
    #: At most this many panels (when the integrand is much narrower than the window).
    max_panels = 24
    #: Widest panel, in adaptive sds of the integrand (6-point Gauss-Legendre on 3 sds of a
    #: Gaussian: relative error ~1e-7).
    panel_sds = 3.0
    #: Walkers x variants x cells x nodes evaluated at once by the dense rule (memory bound).
    dense_chunk = 2_000_000
    #: A cell takes the dense rule when the 8- and 16-node Gauss-Hermite rules differ by more.
    gh_check_tol = 1e-4
    #: Grid step in ln P for wall models other than the baseline's (tabulated point by point;
    #: 0.1 leaves interpolation errors up to 1.3e-4 per cell for the outer membrane, 0.05 1e-5).
    tabulated_step = 0.05

    def _wall_grid(self, ctx, group, lo, hi):
        """The :class:`WallGrid` of a group's walls ``(W, V)`` over ``[lo, hi]`` [ln Pa]."""
        V = ctx.n_variants(group)
        flat = {k: np.broadcast_to(a, (ctx.W, V)).ravel() for k, a in ctx.walls[group].items()}

        def point_model(log_P, rows):
            walls = {k: a[rows] for k, a in flat.items()}
            with np.errstate(all="ignore"):
                R, k = ctx.radius_and_stiffness(np.exp(log_P), walls, self.P0, self.surrogate)
                return np.log(R), np.log(k)

        table = None
        if ctx.radius_and_stiffness is baseline_radius_and_stiffness and set(flat) == {
                "gamma", "E0t", "R0"}:
            table = LogPressureGrid(lo, hi, self.grid_step, flat["gamma"], flat["E0t"],
                                    flat["R0"], self.P0, self.surrogate)
        step = self.grid_step if table is not None else min(self.grid_step, self.tabulated_step)
        return WallGrid(lo, hi, step, point_model, (ctx.W, V), table)

    def _context_model(self, ctx, group, grid):
        """``log_P (W, n, K) -> (ln R_c, ln k_c)`` of shape ``(W, V, n, K)`` for a group."""
        if grid is not None:
            return grid
        walls = {k: np.broadcast_to(a, (ctx.W, ctx.n_variants(group)))[:, :, None, None]
                 for k, a in ctx.walls[group].items()}

        def model(log_P):
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                R, k = ctx.radius_and_stiffness(np.exp(log_P)[:, None], walls, self.P0,
                                                self.surrogate)
                return np.log(R), np.log(k)
        return model

    def _context_log_density(self, ctx, model, log_P, cells=None, bulge_log_sd=None):
        """Log integrand of bulged cells at ``log_P (W, n, K)``: cell density x bulge x
        latent prior (``cells``: indices of the ``n`` cells, default all; ``bulge_log_sd``:
        the bulge's sd of ``ln P_hat`` instead of ``s_i``, e.g. a gross-error reading's;
        the latent prior is ``ctx.latent_log_pdf`` where an effect sets one)."""
        lnR, lnk = model(log_P, cells)
        obs = self._bulged_obs if cells is None else tuple(a[cells] for a in self._bulged_obs)
        f = ctx.cell_logpdf_of("bulged")(ctx, lnR, lnk, obs, ctx.log_w["bulged"])
        if cells is None and bulge_log_sd is None and ctx.latent_log_pdf is None:
            f = f + latent_log_density(self.obs, log_P, ctx.extra_sd())
        else:
            cells = slice(None) if cells is None else cells
            if bulge_log_sd is None:
                s = bulge_sd(self.obs, ctx.extra_sd())[:, cells]
            else:  # the same for every cell: (W|1, 1, 1)
                s = np.hypot(bulge_log_sd, np.reshape(ctx.extra_sd(), (-1, 1, 1)))
            log_g = (self.obs.population.log_pdf(log_P, ctx.extra_sd())
                     if ctx.latent_log_pdf is None else ctx.latent_log_pdf(log_P))
            f = f + gaussian_logpdf(self.obs.log_P_bulge[cells][:, None], log_P, s) + log_g
        f[np.isnan(f)] = -np.inf  # a fresh array either way
        return f

    def _context_bulged(self, ctx, moment=0):
        """``ln of the integral of P^moment x integrand`` over each bulged cell's latent
        ln P, ``(W, n_bulged)`` (``moment`` 0: the cell's log-likelihood; 1 over 0 gives the
        latent pressure's posterior mean).

        Adaptive Gauss-Hermite (16 nodes, Gauss-Newton then Newton centre) on a
        :class:`WallGrid`; a cell takes the dense rule (:meth:`_dense`) when its window
        ``c_i +- DENSE_SIGMA s_i`` (bulge sd, cut to the latent prior's support) leaves a wall's
        domain (the integrand is cut off there) or the 8- and 16-node rules differ by more than
        :attr:`gh_check_tol` (a shape no Gauss-Hermite rule follows, e.g. two modes). With a
        gross-error bulge reading in the context (``ctx.bulge_outlier``) that branch is
        integrated by the dense rule over the whole support (:meth:`_outlier_branch`) and
        mixed in.
        """
        def reduce(log_P, f):
            return logsumexp(f + moment * log_P if moment else f, axis=-1)

        extra = ctx.extra_sd()
        mu, s = self._latent_prior(extra)  # (W|1, nb, 1)
        sb = bulge_sd(self.obs, extra)
        # the window never leaves the latent prior's support (nor 100 Pa - 1 MPa): there the
        # integrand is zero, and a huge extra scatter (a proposal's tail) would otherwise ask
        # for a grid over hundreds of units of ln P
        sup_lo, sup_hi = self.obs.population.support
        sup_lo, sup_hi = max(sup_lo, LOG_P_LATENT[0]), min(sup_hi, LOG_P_LATENT[1])
        win_lo = np.clip(mu - self.DENSE_SIGMA * sb, sup_lo, sup_hi)
        win_hi = np.clip(mu + self.DENSE_SIGMA * sb, sup_lo, sup_hi)
        grid = None
        # ln c of the bulged cells (W, nb) or 0: the walls see ln P - ln c (apparent pressure)
        log_c = 0.0 if ctx.log_k_scale is None else ctx.log_k_scale[:, self.obs.bulged]
        if self.grid_step:
            reach = (self.MAX_SHIFT + np.max(np.abs(hermite_rule(self.context_nodes)[0])))
            lo = max(min(np.min(win_lo), np.min(mu - reach * sb)), sup_lo)
            hi = min(max(np.max(win_hi), np.max(mu + reach * sb)), sup_hi)
            if ctx.bulge_outlier is not None:
                lo, hi = sup_lo, sup_hi
            grid = self._wall_grid(ctx, "bulged", lo - np.max(log_c), hi - np.min(log_c))
        model = _per_cell(self._context_model(ctx, "bulged", grid),
                          None if ctx.log_k_scale is None else log_c)
        shape = (ctx.W, mu.shape[1], 1)
        m, sd = self._centre(_median_variant_slopes(model), mu, s, shape)
        m, sd = self._newton(ctx, model, m, sd, mu, s)
        rules = [self._gauss_hermite(ctx, model, m, sd, n) for n in (self.context_nodes, 8)]
        full = logsumexp(rules[0][1], -1)  # the 16-node rule's integral (moment 0: its reduce)
        out = reduce(*rules[0]) if moment else full
        with np.errstate(invalid="ignore"):
            diff = np.abs(full - logsumexp(rules[1][1], -1))
        bad = ~(diff <= self.gh_check_tol)  # also where both rules found nothing (inf - inf)
        dom_lo, dom_hi = np.full((ctx.W, 1, 1), -np.inf), np.full((ctx.W, 1, 1), np.inf)
        if grid is not None:  # the walls' domain, in each cell's apparent ln P
            dom_lo = grid.lo.reshape(ctx.W, -1).max(axis=1)[:, None, None] + _column(log_c)
            dom_hi = grid.hi.reshape(ctx.W, -1).min(axis=1)[:, None, None] + _column(log_c)
            cut_lo, cut_hi = np.maximum(win_lo, dom_lo), np.minimum(win_hi, dom_hi)
            # the walls' domain cuts the window (the prior's support is left to the 8/16 check)
            bad |= ((cut_lo > win_lo) | (cut_hi < win_hi))[..., 0]
            win_lo, win_hi = cut_lo, cut_hi
        cells = np.flatnonzero(bad.any(axis=0))
        if cells.size:
            lo, hi = (np.broadcast_to(a, shape)[:, cells] for a in (win_lo, win_hi))
            # panels no longer than the integrand's width (the adaptive sd) where it is flagged
            ratio = np.where(bad[:, cells, None], (hi - lo) / sd[:, cells], 0.0)
            panels = int(np.clip(np.ceil(np.max(ratio) / self.panel_sds), self.dense_panels,
                                 self.max_panels))
            dense = self._dense_cells(ctx, model, cells, lo, hi, panels, reduce)
            out[:, cells] = np.where(bad[:, cells], dense, out[:, cells])
        if ctx.bulge_outlier is None:
            return out
        lo = np.broadcast_to(np.maximum(sup_lo, dom_lo), shape)
        hi = np.broadcast_to(np.minimum(sup_hi, dom_hi), shape)
        return self._outlier_branch(ctx, model, out, lo, hi, reduce)

    #: Widest panel [ln Pa] of the dense rule over the whole support (a gross-error bulge
    #: reading's branch: the integrand is then as narrow as the cell's own R_c and k_c make it).
    outlier_panel = 0.3

    def _outlier_branch(self, ctx, model, out, lo, hi, reduce):
        """Mix ``out`` (the bulge read correctly) with the gross-error bulge branch
        (``ln P_hat ~ N(ln P, sd_out)``), integrated over ``[lo, hi]`` ``(W, nb, 1)``."""
        log_f, sd_out = ctx.bulge_outlier
        log_f = np.asarray(log_f, float)[:, None]
        cells = np.arange(out.shape[1])
        span = np.max(hi - lo)
        if not np.isfinite(span):
            raise FloatingPointError("the pressure support of the gross-error bulge branch is "
                                     f"not finite (widest {span}): the walkers left the domain")
        panels = max(self.dense_panels, int(np.ceil(span / self.outlier_panel)))
        broad = self._dense_cells(ctx, model, cells, lo, hi, panels, reduce, sd_out)
        with np.errstate(divide="ignore"):
            return np.logaddexp(np.log1p(-np.exp(log_f)) + out, log_f + broad)

    def _dense_cells(self, ctx, model, cells, lo, hi, panels, reduce, bulge_log_sd=None):
        """:meth:`_dense` over ``cells`` in chunks (memory bound :attr:`dense_chunk`)."""
        size = ctx.W * ctx.n_variants("bulged") * panels * self.dense_order
        step = max(1, self.dense_chunk // size)
        out = np.empty((ctx.W, cells.size))
        for j in range(0, cells.size, step):
            c = slice(j, j + step)
            out[:, c] = reduce(*self._dense(ctx, model, cells[c], lo[:, c], hi[:, c], panels,
                                            bulge_log_sd))
        return out

    def _gauss_hermite(self, ctx, model, m, sd, n):
        """Nodes ``ln P (W, nb, n)`` of the adaptive rule and the log integrand there."""
        z, log_w = hermite_rule(n)
        log_P = m + sd * z
        f = (self._context_log_density(ctx, model, log_P) + log_w + 0.5 * z**2
             + 0.5 * LOG_2PI + np.log(sd))
        return log_P, f

    def _dense(self, ctx, model, cells, lo, hi, panels, bulge_log_sd=None):
        """Composite Gauss-Legendre over ``[lo, hi]`` ``(W, n, 1)`` [ln Pa] for ``cells``.

        The window is the cell's ``c_i +- DENSE_SIGMA s_i`` cut to the walls' domain, so an
        integrand cut off where the model is undefined is integrated up to the cut
        (``bulge_log_sd``: see :meth:`_context_log_density`).
        """
        t, w = composite_legendre(panels, self.dense_order)
        width = np.maximum(hi - lo, 0.0)
        log_P = lo + width * t
        with np.errstate(divide="ignore"):
            log_w = np.log(w) + np.log(width)
        return log_P, self._context_log_density(ctx, model, log_P, cells, bulge_log_sd) + log_w

    def _newton(self, ctx, model, m, sd, mu, s):
        """Newton steps on the full log integrand (secant curvature over +-sd/2)."""
        for _ in range(self.n_newton):
            h = 0.5 * sd
            with np.errstate(invalid="ignore"):
                f = self._context_log_density(ctx, model, m + h * np.array([-1.0, 0.0, 1.0]))
                d1 = (f[..., 2] - f[..., 0]) / (2 * h[..., 0])
                d2 = (f[..., 2] - 2 * f[..., 1] + f[..., 0]) / h[..., 0] ** 2
            ok = np.isfinite(d1) & np.isfinite(d2) & (d2 < 0)
            d2 = np.where(ok, d2, -1.0)
            step = np.clip(-d1 / d2, -2 * sd[..., 0], 2 * sd[..., 0])
            new_m = np.clip(m[..., 0] + step, (mu - self.MAX_SHIFT * s)[..., 0],
                            (mu + self.MAX_SHIFT * s)[..., 0])
            new_sd = np.sqrt(np.minimum(-1 / d2, (s**2)[..., 0]))
            m = np.where(ok, new_m, m[..., 0])[..., None]
            sd = np.where(ok, new_sd, sd[..., 0])[..., None]
        return m, sd

    def _context_intact(self, ctx, P_phys, grid):
        """Intact cells, ``(W, n_intact)``: at ``P_phys``, or, where an effect spreads their
        pressures (``ctx.intact_log_sd``), each integrated over its own
        ``ln P_i ~ N(ln P_phys, tau)`` by :meth:`_intact_nodes`'s dense rule."""
        shared = ctx.shared_walls("intact")
        tau = ctx.intact_spread()
        if (ctx.gaussian() and shared is not None and ctx.log_k_scale is None
                and tau is None):
            return self.intact(*shared, P_phys, grid=grid)
        log_phys = np.log(P_phys)[:, None, None]  # (W, 1, 1)
        model = self._context_model(ctx, "intact", None)  # W x K points: direct
        if tau is None:
            return self._intact_density(ctx, *model(log_phys))[..., 0]
        eta, log_w = self._intact_nodes(ctx, model, log_phys, tau)
        size = ctx.W * ctx.n_variants("intact") * len(self._intact_obs[0])
        step = max(1, self.dense_chunk // size)
        parts = [logsumexp(self._intact_density(ctx, *model(log_phys + tau[:, None, None]
                                                             * eta[c])) + log_w[c], axis=-1)
                 for c in (slice(j, j + step) for j in range(0, eta.size, step))]
        return logsumexp(np.stack(parts, axis=-1), axis=-1)

    def _intact_density(self, ctx, lnR, lnk):
        """Log density ``(W, n_intact, K)`` of the intact cells' readings given the walls'
        ``ln R_c``, ``ln k_c`` ``(W, V, 1, K)`` at ``K`` pressures (NaN: -inf)."""
        if ctx.log_k_scale is not None:  # the readings, not the pressure, carry the scale
            lnk = lnk + ctx.log_k_scale[:, None, self.obs.intact, None]
        obs = tuple(a[:, None] for a in self._intact_obs)
        f = ctx.cell_logpdf_of("intact")(ctx, lnR, lnk, obs, ctx.log_w["intact"])
        return np.where(np.isnan(f), -np.inf, f)

    #: Half-width, in prior sds, of the intact cells' rule in ``eta`` (the prior's mass
    #: outside is 2e-9; the weights are normalized to the truncated normal).
    intact_eta_max = 6.0
    #: Fewest and most panels of the intact cells' rule in ``eta``.
    intact_panels = (8, 256)
    #: Widest panel of the intact cells' rule, in widths of the narrowest cell's likelihood
    #: in ``eta`` (measured against a dense reference at tau_P = 0.5: 3 widths leave 2.3e-6
    #: per cell, 2 widths 2.2e-8, 1.5 widths 3e-9).
    intact_panel_sds = 1.5

    def _intact_nodes(self, ctx, model, log_phys, tau):
        r"""Nodes ``eta (K,)`` shared by every walker and intact cell and log weights ``(K,)``
        of the intact cells' rule: composite 6-point Gauss-Legendre over
        ``[-intact_eta_max, intact_eta_max]`` times the N(0, 1) density, normalized.

        The panels are narrower than :attr:`intact_panel_sds` widths of the narrowest cell's
        likelihood in ``eta``, :math:`1/(\tau J)`, with
        :math:`J^2 = (\partial_{\ln P}\ln R_c\,R_{obs}/R_{err})^2 + (\partial_{\ln P}\ln k_c\,
        k_{obs}/k_{err})^2` at ``P_phys`` (the largest over walkers, variants and cells).
        """
        d = 1e-3
        lnR, lnk = model(log_phys + np.array([-d, d]))  # (W, V, 1, 2)
        R_obs, R_err, k_obs, k_err = self._intact_obs
        with np.errstate(invalid="ignore"):
            J = np.hypot((lnR[..., 1] - lnR[..., 0]) / (2 * d) * R_obs / R_err,
                         (lnk[..., 1] - lnk[..., 0]) / (2 * d) * k_obs / k_err)  # (W, V, n)
            need = np.nanmax(np.where(np.isfinite(J), J, np.nan), axis=(1, 2), initial=0.0)
        need = np.max(np.nan_to_num(tau * need))
        lo, hi = self.intact_panels
        half = self.intact_eta_max
        panels = int(np.clip(np.ceil(2 * half * need / self.intact_panel_sds), lo, hi))
        t, w = composite_legendre(panels, self.dense_order)
        eta = -half + 2 * half * t
        log_w = np.log(w * 2 * half) - 0.5 * (eta**2 + LOG_2PI)
        return eta, log_w - logsumexp(log_w, axis=0)


@functools.lru_cache(maxsize=512)
def composite_legendre(panels, order):
    """Composite Gauss-Legendre rule on [0, 1]: ``panels`` equal panels of ``order`` points;
    nodes and weights ``(panels * order,)``, the weights summing to 1 (computed once per
    ``(panels, order)``; read-only arrays)."""
    t, w = np.polynomial.legendre.leggauss(order)
    t = ((np.arange(panels)[:, None] + 0.5 * (t + 1)) / panels).ravel()
    return _read_only(t), _read_only(np.tile(w, panels) / (2 * panels))


def _per_cell(model, log_c):
    """``model(log_P, cells=None)``: the walls' ``(ln R_c, ln k_c)`` ``(W, V, n, K)`` at
    ``log_P (W, n, K)`` for the bulged cells ``cells`` (default all), with each cell's
    stiffness scale ``log_c (W, nb)`` (None: none): walls at ``ln P - ln c``, ``ln k + ln c``."""
    if log_c is None:
        return lambda log_P, cells=None: model(log_P)

    def scaled(log_P, cells=None):
        lc = (log_c if cells is None else log_c[:, cells])[..., None]  # (W, n, 1)
        lnR, lnk = model(log_P - lc)
        return lnR, lnk + lc[:, None]
    return scaled


def _column(log_c):
    """``log_c (W, nb)`` as ``(W, nb, 1)`` (a scalar stays a scalar)."""
    return log_c[..., None] if np.ndim(log_c) else log_c


def _median_variant_slopes(model, d=1e-3):
    """``ln R``, ``d ln R/d ln P``, ``ln k``, ``d ln k/d ln P`` of the middle wall variant
    (central differences, step ``d`` in ln P) at ``log_P (W, nb, 1, 1)``: the Gauss-Newton
    centre's linearization."""
    def slopes(log_P):
        x = log_P[..., 0]  # (W, nb, 1)
        lnR, lnk = model(x + d * np.array([0.0, 1.0, -1.0]))
        v = lnR.shape[1] // 2
        lnR, lnk = lnR[:, v], lnk[:, v]  # (W, nb, 3)
        return (lnR[..., :1, None], ((lnR[..., 1] - lnR[..., 2]) / (2 * d))[..., None, None],
                lnk[..., :1, None], ((lnk[..., 1] - lnk[..., 2]) / (2 * d))[..., None, None])
    return slopes


def _weighted_mean_pressure(log_P, f):
    """``sum exp(f) P / sum exp(f)`` over the last axis (nodes)."""
    return np.exp(logsumexp(f + log_P, axis=-1) - logsumexp(f, axis=-1))
