"""The likelihood of a model extension: :class:`ContextPath`, the part of
:class:`turgorbayes.inference.likelihood.CellLikelihood` that evaluates a
:class:`turgorbayes.inference.context.LikelihoodContext` (an effect's wall variants, extra
scatter, densities and wall models): more Gauss-Hermite nodes with Newton-refined centres, and
a dense composite rule where that rule cannot be trusted (docs/effects.md, "The extended
likelihood"). It shares the baseline's node, centring and reduction machinery through the
class it is mixed into.
"""


import numpy as np

from turgorbayes.inference.context import baseline_radius_and_stiffness
from turgorbayes.inference.observations import (
    LOG_2PI,
    LOG_P_LATENT,
    bulge_sd,
    gaussian_logpdf,
    latent_log_density,
)
from turgorbayes.inference.population import logsumexp
from turgorbayes.inference.pressure_grid import LogPressureGrid, WallGrid
from turgorbayes.inference.quadrature import composite_legendre, hermite_rule, weighted_mean_pressure

__all__ = ["ContextPath"]


class ContextPath:
    """The extensions' path of :class:`~turgorbayes.inference.likelihood.CellLikelihood`
    (module docstring); a mixin: it uses the baseline's ``_centre``, ``_model``,
    ``shared_grid``, ``intact`` and the observations of the class it is mixed into."""

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
            return weighted_mean_pressure(
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
        if ctx.log_k_scale is None:  # every cell the same nodes: the walls once for all
            model = _first_cell_walls(model)
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
        """Intact cells, ``(W, n_intact)``: at ``P_phys``, or each at its own pressure where the
        context gives one (``ctx.intact_log_P``, e.g. its level's turgor in an osmotic series),
        and, where an effect spreads their pressures (``ctx.intact_log_sd``), each integrated
        over its own ``ln P_i ~ N(centre_i, tau)`` by :meth:`_intact_nodes`'s dense rule."""
        shared = ctx.shared_walls("intact")
        tau = ctx.intact_spread()
        if (ctx.gaussian() and shared is not None and ctx.log_k_scale is None
                and tau is None and ctx.intact_log_P is None):
            return self.intact(*shared, P_phys, grid=grid)
        centre, model = self._intact_centres(ctx, P_phys)
        if tau is None:
            return self._intact_density(ctx, *model(centre))[..., 0]
        eta, log_w = self._intact_nodes(ctx, model, centre, tau)
        size = ctx.W * ctx.n_variants("intact") * len(self._intact_obs[0])
        step = max(1, self.dense_chunk // size)
        parts = [logsumexp(self._intact_density(ctx, *model(centre + tau[:, None, None]
                                                            * eta[c])) + log_w[c], axis=-1)
                 for c in (slice(j, j + step) for j in range(0, eta.size, step))]
        return logsumexp(np.stack(parts, axis=-1), axis=-1)

    def _intact_centres(self, ctx, P_phys):
        """The intact cells' distinct centres ``ln P`` ``(W, L, 1)`` [ln Pa] and the wall model
        ``log_P (W, L, K) -> (ln R_c, ln k_c) (W, V, n_intact|1, K)`` that evaluates the walls
        once per distinct centre and gives every cell its own (``ln P_phys``, ``L = 1``, for
        all of them when ``ctx.intact_log_P`` is None; one per medium level in a series)."""
        direct = self._context_model(ctx, "intact", None)  # W x L x K points: direct
        if ctx.intact_log_P is None:
            return np.log(P_phys)[:, None, None], direct
        log_P = np.broadcast_to(np.asarray(ctx.intact_log_P, float),
                                (ctx.W, self.obs.intact.size))
        centres, inverse = np.unique(log_P, axis=1, return_inverse=True)
        inverse = np.reshape(inverse, -1)

        def model(x):
            lnR, lnk = direct(x)
            return lnR[:, :, inverse], lnk[:, :, inverse]
        return centres[..., None], model

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

    def _intact_nodes(self, ctx, model, centre, tau):
        r"""Nodes ``eta (K,)`` shared by every walker and intact cell and log weights ``(K,)``
        of the intact cells' rule: composite 6-point Gauss-Legendre over
        ``[-intact_eta_max, intact_eta_max]`` times the N(0, 1) density, normalized.

        The panels are narrower than :attr:`intact_panel_sds` widths of the narrowest cell's
        likelihood in ``eta``, :math:`1/(\tau J)`, with
        :math:`J^2 = (\partial_{\ln P}\ln R_c\,R_{obs}/R_{err})^2 + (\partial_{\ln P}\ln k_c\,
        k_{obs}/k_{err})^2` at each cell's centre ``centre`` ``(W, L, 1)`` (the largest over
        walkers, variants and cells).
        """
        d = 1e-3
        lnR, lnk = model(centre + np.array([-d, d]))  # (W, V, n|1, 2)
        R_obs, R_err, k_obs, k_err = self._intact_obs[:4]
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


def _first_cell_walls(model):
    """``model`` for nodes ``log_P (W, n, K)`` that are the same for every cell (the gross-error
    branch's, without a stiffness scale per cell): the walls evaluated at the first cell's
    nodes only and copied to all ``n`` (the same values as evaluating them ``n`` times)."""
    def shared(log_P, cells=None):
        lnR, lnk = model(log_P[:, :1], cells)
        shape = lnR.shape[:2] + log_P.shape[1:]
        return (np.ascontiguousarray(np.broadcast_to(lnR, shape)),
                np.ascontiguousarray(np.broadcast_to(lnk, shape)))
    return shared


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
