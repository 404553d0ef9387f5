"""What a model extension may change in the per-cell likelihood: the likelihood context.

An effect (:mod:`turgorbayes.effects`) edits a :class:`LikelihoodContext`: per-group wall
parameters with variants and their log weights, extra scatter of the bulge pressures, the
density of a cell's observables and the wall model.
:meth:`turgorbayes.inference.likelihood.CellLikelihood.pointwise_context` evaluates it
(docs/effects.md).
"""

import numpy as np

from turgorbayes.inference.observations import normal_log_density, stiffness_sd
from turgorbayes.inference.population import logsumexp
from turgorbayes.inference.reading_correlation import (
    bivariate_logpdf,
    cell_rho,
    conditional_stiffness,
    readings,
)
from turgorbayes.physics import forward

__all__ = [
    "LikelihoodContext",
    "apply_effects",
    "average_variants",
    "baseline_radius_and_stiffness",
    "default_cell_logpdf",
    "density_first",
    "gaussian_R_logpdf",
    "gaussian_k_logpdf",
    "reading_logpdf",
    "walker_column",
]


def walker_column(a, ndim):
    """A per-walker array ``(W,)`` reshaped to ``(W, 1, ..., 1)`` with ``ndim`` axes."""
    a = np.asarray(a, float)
    return a.reshape(a.shape[:1] + (1,) * (ndim - 1))


def density_first(effects):
    """``effects`` (:class:`turgorbayes.effects.Effect` objects) in the order they edit a
    context: one that replaces the stiffness density (``replaces_k_density``) first, the others
    in their order, since they wrap or corrupt what it gives (in the likelihood and in
    replicated data alike)."""
    return sorted(effects, key=lambda e: not e.replaces_k_density)


def apply_effects(ctx, effects, v, skip=()):
    """``ctx`` edited by ``effects`` in :func:`density_first` order for physical values ``v``
    (dict of ``(W,)``), the effects named in ``skip`` left out (the gross-error screen's
    interface of a model); returns ``ctx``."""
    for e in density_first(effects):
        if e.name not in skip:
            e.apply(ctx, v)
    return ctx


def gaussian_k_logpdf(k_obs, k, k_err):
    """``ln N(k_obs; k, sd)``, ``sd = (k_err/k_obs) k`` (the baseline's stiffness density,
    relative error: :func:`turgorbayes.inference.observations.stiffness_sd`; NaN where ``k``
    is NaN)."""
    return normal_log_density(np.asarray(np.subtract(k_obs, k)),
                              stiffness_sd(k, k_obs, k_err))


def gaussian_R_logpdf(R_obs, R, R_err):
    """``ln N(R_obs; R, R_err)`` (the baseline's radius density; NaN where ``R`` is NaN)."""
    return normal_log_density(np.asarray(np.subtract(R_obs, R)), R_err)


def baseline_radius_and_stiffness(P, walls, P0, surrogate):
    """The baseline wall model (:func:`turgorbayes.physics.forward.cell_radius_and_stiffness`), at
    the walls' own FE settings where they carry any (:func:`turgorbayes.physics.forward.fe_settings`)."""
    return forward.cell_radius_and_stiffness(P, walls["gamma"], walls["E0t"], walls["R0"], P0,
                                             surrogate, forward.fe_settings(walls))


def default_cell_logpdf(ctx, lnR, lnk, obs, log_w):
    """Densities of ``R_c`` and ``k_c``, averaged over the wall variants.

    .. math:: \\ln \\sum_v w_v\\, p_R(R_{obs} \\mid R_v)\\, p_k(k_{obs} \\mid k_v, R_{obs})

    Independent readings, unless a cell's errors are correlated (:meth:`LikelihoodContext.rho`):
    then :func:`reading_logpdf`.

    Parameters
    ----------
    lnR, lnk : ndarray (W, V, n, K)
    obs : tuple of ndarray (n, 1)
        ``R_obs, R_err, k_obs, k_err`` [m, m, N/m, N/m] and optionally the cells' known error
        correlations (NaN: unknown).
    log_w : ndarray (W, V) or None
        Log weights of the variants (None: a single variant).

    Returns
    -------
    ndarray (W, n, K)
    """
    R_obs, R_err, k_obs, k_err, rho = readings(obs)
    with np.errstate(over="ignore", invalid="ignore"):
        f = reading_logpdf(ctx, R_obs, np.exp(lnR), R_err, k_obs, np.exp(lnk), k_err,
                           ctx.rho(rho, lnR.ndim))
    return average_variants(f, log_w)


def reading_logpdf(ctx, R_obs, R, R_err, k_obs, k, k_err, rho):
    """Log density of a cell's two readings under the context's densities.

    ``rho`` None: ``R_logpdf + k_logpdf`` (independent readings). Otherwise the readings'
    Gaussian measurement errors are correlated (docs/statistics.md, "Correlated readings"):
    the baseline's densities give the bivariate normal; the radius' density times the
    stiffness' given the radius' residual
    (:func:`~turgorbayes.inference.reading_correlation.conditional_stiffness`) otherwise. An
    effect's mixture (a density with ``good_branch``: gross errors, bad curves) conditions only
    its branch of correctly read values, so each reading stays a gross error with its own
    probability; another stiffness law (Student-t) describes the part of the stiffness error
    independent of the radius'. A radius density without a Gaussian core keeps the readings
    independent.
    """
    if rho is None or _core(ctx.R_logpdf) is not gaussian_R_logpdf:
        return ctx.R_logpdf(R_obs, R, R_err) + ctx.k_logpdf(k_obs, k, k_err)
    if ctx.R_logpdf is gaussian_R_logpdf and ctx.k_logpdf is gaussian_k_logpdf:
        return bivariate_logpdf(R_obs, R, R_err, k_obs, k, k_err, rho)
    k_cond, k_err_cond = conditional_stiffness(R_obs, R, R_err, k_obs, k, k_err, rho)
    given = _given_radius(ctx.k_logpdf, k_obs, k_cond, k_err_cond, k, k_err)
    if ctx.R_logpdf is gaussian_R_logpdf:
        return ctx.R_logpdf(R_obs, R, R_err) + given
    good = ctx.R_logpdf.good_branch(R_obs, R, R_err)  # the radius read correctly
    rest = _log_minus(ctx.R_logpdf(R_obs, R, R_err), good)
    return np.logaddexp(good + given, rest + ctx.k_logpdf(k_obs, k, k_err))


def _core(density):
    """The innermost component of a density that wraps a ``good`` one (a mixture's)."""
    while hasattr(density, "good"):
        density = density.good
    return density


def _given_radius(density, k_obs, k_cond, k_err_cond, k, k_err):
    """``ln p(k_obs | the radius' Gaussian residual)``: a mixture's good branch at the
    conditional stiffness, its other branches as they are; any other density at the
    conditional stiffness."""
    if not hasattr(density, "good_branch"):
        return density(k_obs, k_cond, k_err_cond)
    good = density.good_branch(k_obs, k, k_err)
    rest = _log_minus(density(k_obs, k, k_err), good)
    return np.logaddexp(density.good_branch(k_obs, k_cond, k_err_cond), rest)


def _log_minus(a, b):
    """``ln(e^a - e^b)`` for ``b <= a`` (rounding above ``a`` counts as equal: ``-inf``)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return a + np.log1p(-np.exp(np.minimum(b - a, 0.0)))


def average_variants(f, log_w):
    """``ln sum_v w_v exp(f_v)``: a cell density ``f (W, V, n, K)`` averaged over the wall
    variants with log weights ``log_w (W, V)`` (a single variant: ``f[:, 0]``; NaN: -inf)."""
    if f.shape[1] == 1:
        return f[:, 0]
    f = np.where(np.isnan(f), -np.inf, f)
    return logsumexp(f + log_w[:, :, None, None], axis=1)


class LikelihoodContext:
    """What an effect may change in the likelihood, for ``W`` walkers.

    Attributes
    ----------
    walls : dict
        ``{"bulged": {...}, "intact": {...}}``: wall parameters per group, arrays ``(W, V)``
        over ``V`` variants (1 in the baseline).
    log_w : dict
        Log weights ``(W, V)`` of the variants per group (``None``: a single variant).
    extra_log_sd : ndarray (W,)
        Extra scatter added in quadrature to every bulged cell's ``s_i``.
    R_logpdf, k_logpdf : callable
        ``(obs, pred, err) -> log density`` of one observable.
    cell_logpdf : callable
        ``(ctx, lnR, lnk, obs, log_w) -> (W, n, K)``: log density of a cell's observables given
        the model's ``ln R_c``, ``ln k_c`` of shape ``(W, V, n, K)`` (K pressure nodes),
        ``obs = (R_obs, R_err, k_obs, k_err)`` of shape ``(n, 1)`` and the variants' log
        weights (:func:`default_cell_logpdf`).
    cell_logpdf_by_group : dict
        ``{"bulged"|"intact": cell_logpdf}``: a group's own cell density, used instead of
        :attr:`cell_logpdf` for that group (:meth:`cell_logpdf_of`; empty: none).
    radius_and_stiffness : callable
        ``(P, walls, P0, surrogate) -> (R_c, k_c)``, broadcasting.
    values : dict
        Per-walker values ``(W,)`` of every parameter (for effects that need each other's).
    bulge_outlier : tuple or None
        ``(log_f, sd)``: with probability ``exp(log_f)`` ``(W,)`` a bulged cell's bulge reading
        is a gross error, ``ln P_hat ~ N(ln P, sd)`` instead of ``N(ln P, s_i)`` (None: never;
        :mod:`turgorbayes.effects.outliers`).
    log_k_scale : ndarray (W, n_cells) or None
        ``ln c_i``: every stiffness reading of cell ``i`` (``k_c``, ``k_b``) is ``c_i`` times the
        true one (a cantilever's calibration error, :mod:`turgorbayes.effects.calibration`). A
        bulged cell's latent pressure is then the apparent (bulge-derived) one: the wall model
        sees ``P / c_i`` and its ``k_c`` is multiplied by ``c_i``. None: no scale.
    latent_log_pdf : callable or None
        ``log_P (W, n, K) -> ln g(log_P)`` [per unit ln P, broadcast]: a population density
        of the bulged cells' true ``ln P`` with per-walker parameters (a hierarchical
        population, :mod:`turgorbayes.effects.pressure_range`), used instead of the data's
        plug-in population, which then only centres the quadrature and bounds its windows
        (its support reaches 4 bulge sds beyond the extreme estimates). None: the plug-in.
    intact_log_sd : ndarray (W,) or None
        Cell-to-cell spread of the intact cells' true ``ln P`` about ``ln P_phys``
        (:mod:`turgorbayes.effects.turgor_spread`): each intact cell's density is integrated
        over its own ``ln P_i ~ N(ln P_phys, intact_log_sd)``. None: every intact cell at
        ``P_phys``.
    intact_log_P : ndarray (W, n_intact) or None
        Each intact cell's own ``ln P`` [ln Pa] (the centre of its spread where
        :attr:`intact_log_sd` is set), e.g. its medium level's turgor in an osmotic series
        (:class:`turgorbayes.effects.series.SeriesModel`; effects such as
        :mod:`turgorbayes.effects.osmoadaptation` move it). None: every intact cell at
        ``P_phys``, the baseline's path bit for bit.
    reading_rho : ndarray (W,) or None
        Correlation of the R_c and k_c errors of every cell whose own is not known (the
        ``rho_R_c_k_c`` column; :mod:`turgorbayes.effects.correlated_errors`). None: those
        cells' readings are independent.
    """

    def __init__(self, base, values):
        W = len(base["gamma"])
        self.W = W
        wall = {k: np.asarray(base[k], float)[:, None] for k in ("gamma", "E0t", "R0")}
        self.walls = {"bulged": dict(wall), "intact": dict(wall)}
        self.log_w = {"bulged": None, "intact": None}
        self.extra_log_sd = np.zeros(W)
        self.R_logpdf = gaussian_R_logpdf
        self.k_logpdf = gaussian_k_logpdf
        self.cell_logpdf = default_cell_logpdf
        self.cell_logpdf_by_group = {}
        self.radius_and_stiffness = baseline_radius_and_stiffness
        self.values = values
        self.bulge_outlier = None
        self.log_k_scale = None
        self.latent_log_pdf = None
        self.intact_log_sd = None
        self.intact_log_P = None
        self.reading_rho = None

    def add_variants(self, group, update, log_w):
        """Expand a group's walls by ``Q`` new variants (outer product with existing ones).

        Parameters
        ----------
        group : str
        update : callable
            ``(walls with a trailing variant axis of length V*Q, q index array) -> walls``.
        log_w : ndarray (W|1, Q)
            Log weights of the new variants.
        """
        walls = self.walls[group]
        V = next(iter(walls.values())).shape[1]
        Q = np.shape(log_w)[-1]
        walls = {k: np.repeat(np.broadcast_to(a, (self.W, V)), Q, axis=1) for k, a in walls.items()}
        q = np.tile(np.arange(Q), V)
        self.walls[group] = update(walls, q)
        lw = np.broadcast_to(np.asarray(log_w, float), (self.W, Q))
        old = self.log_w[group]
        old = np.zeros((self.W, V)) if old is None else old
        self.log_w[group] = np.repeat(old, Q, axis=1) + np.tile(lw, (1, V))

    # -- what the engine asks ------------------------------------------------------------
    def n_variants(self, group):
        """Number ``V`` of wall variants of a group."""
        return next(iter(self.walls[group].values())).shape[1]

    def gaussian(self):
        """True if the cell density is the baseline's independent Gaussians."""
        return (self.cell_logpdf is default_cell_logpdf and self.R_logpdf is gaussian_R_logpdf
                and self.k_logpdf is gaussian_k_logpdf and not self.cell_logpdf_by_group
                and self.reading_rho is None)

    def rho(self, rho_cells, ndim):
        """The error correlation of the cells whose known ones are ``rho_cells`` (NaN:
        unknown, None: none known): theirs, else :attr:`reading_rho`; None when all are 0
        (:func:`~turgorbayes.inference.reading_correlation.cell_rho`)."""
        return cell_rho(rho_cells, self.reading_rho, ndim)

    def cell_logpdf_of(self, group):
        """The cell density of ``group`` (its own if an effect set one, else :attr:`cell_logpdf`)."""
        return self.cell_logpdf_by_group.get(group, self.cell_logpdf)

    def shared_walls(self, group):
        """``(gamma, E0t, R0)`` as ``(W,)`` arrays if the group has one baseline wall per
        walker (no variants, baseline wall model), else None."""
        walls = self.walls[group]
        if (self.radius_and_stiffness is not baseline_radius_and_stiffness
                or set(walls) != {"gamma", "E0t", "R0"} or self.n_variants(group) != 1):
            return None
        return tuple(np.broadcast_to(walls[k], (self.W, 1))[:, 0] for k in ("gamma", "E0t", "R0"))

    def intact_spread(self):
        """:attr:`intact_log_sd` as ``(W,)``, or None when it is unset or zero for every
        walker (then the intact cells sit at ``P_phys``, exactly the baseline)."""
        if self.intact_log_sd is None:
            return None
        tau = np.broadcast_to(np.asarray(self.intact_log_sd, float), (self.W,))
        return tau if np.any(tau) else None

    def intact_log_pressure(self, P_phys):
        """The intact cells' ``ln P`` [ln Pa]: :attr:`intact_log_P` ``(W, n_intact)``, or
        ``ln P_phys`` as a column ``(W, 1)`` when it is None."""
        if self.intact_log_P is None:
            return np.log(np.asarray(P_phys, float))[:, None]
        return np.asarray(self.intact_log_P, float)

    def extra_sd(self):
        """:attr:`extra_log_sd`, or 0.0 when it is zero for every walker (the baseline)."""
        extra = np.asarray(self.extra_log_sd, float)
        return extra if np.any(extra) else 0.0
