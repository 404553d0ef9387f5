r"""Model extensions ("effects") of the baseline fit, one physical or statistical cause each.

Each effect (one module each: :mod:`~turgorbayes.effects.radius_spread`,
:mod:`~turgorbayes.effects.pressure_error`, :mod:`~turgorbayes.effects.bad_curves`,
:mod:`~turgorbayes.effects.wall_softening`, :mod:`~turgorbayes.effects.outer_membrane`) is an
:class:`Effect` with the same interface:

* **parameters and priors**: :attr:`Effect.parameters` (:class:`turgorbayes.inference.models.Parameter`),
  the one measuring its size (:attr:`Effect.size_parameter`, with the value
  :attr:`Effect.null_value` at which the baseline is recovered) and a realistic size for tests;
* **how the likelihood changes**: :meth:`Effect.apply` edits a :class:`LikelihoodContext`
  (per-group wall parameters and their variants, extra scatter of the bulge pressures, the
  density of a cell's observables, the wall model);
* **how data are generated with it** (``turgorbayes simulate --effect NAME --effect-size X``
  and posterior predictive replicates): :meth:`Effect.cell_walls` (per-cell wall parameters),
  :meth:`Effect.log_pressure_sd` (extra scatter of bulge-derived pressures) and
  :meth:`Effect.observe_k` (corruption of the stiffness readings); :meth:`Effect.injection`
  wraps them for :func:`turgorbayes.synthetic.simulate_cells`.

Because every effect only edits the shared context, any set of effects combines without code
per pair: :class:`ExtendedModel` applies them in order.

The extended likelihood (same 114 per-cell points as the baseline)
-----------------------------------------------------------------
For a bulged cell with bulge-derived pressure :math:`\hat P_i` (sd :math:`s_i` of
:mod:`turgorbayes.inference.likelihood`) and observables :math:`y_i = (R_{c,i}, k_{c,i})`,

.. math::

    \ell_i(\theta) = \ln \int \pi(x)\, N\!\left(\ln\hat P_i;\, x,\, \sqrt{s_i^2 + \sigma_P^2}\right)
        \sum_v w_v\, p(y_i \mid x, \theta, v)\, dx,

with :math:`x = \ln P` the latent log pressure (:math:`\pi` its population prior
:math:`N(\mu_P, \tau_P)`, as in the baseline, :mod:`turgorbayes.inference.likelihood`), :math:`\sigma_P` an
extra scatter (0 unless ``pressure_error``) and :math:`v` the
variants of the wall parameters an effect may introduce. The integral over :math:`x` is the
trapezoidal rule on a uniform grid (step :data:`GRID_STEP` = 0.05) over
:math:`\ln\hat P_i \pm 6\sqrt{s_i^2+\sigma_P^2}`: for an integrand that is smooth and decays
like a Gaussian of width :math:`w` the rule's relative error is about
:math:`2e^{-2\pi^2 w^2/h^2}` (Trefethen & Weideman, SIAM Rev. 56, 385, 2014), below 1e-8 for the
narrowest widths met here (:math:`w \ge 0.05`). The forward model is evaluated per walker on a
grid of twice the step and refined by 4-point cubic midpoint interpolation (error
:math:`\frac{3}{128}h^4 f^{(4)}`, below 1e-7 for the smooth :math:`\ln R_c(\ln P)`,
:math:`\ln k_c(\ln P)`), so walkers x cells x nodes cost one gather. Intact cells sit at
``P_phys``. Without effects this is the baseline likelihood of :mod:`turgorbayes.inference.likelihood`
evaluated by a different quadrature (tests compare the two).
"""

from dataclasses import dataclass, field

import numpy as np

from turgorbayes import forward
from turgorbayes.inference import models
from turgorbayes.inference.likelihood import LOG_P_LATENT, latent_log_density, sample_latent, stiffness_sd

__all__ = [
    "EFFECTS",
    "GRID_STEP",
    "N_SIGMA",
    "Effect",
    "ExtendedModel",
    "Injection",
    "LikelihoodContext",
    "SqrtCoordinate",
    "baseline_radius_and_stiffness",
    "default_cell_logpdf",
    "effect_names",
    "gaussian_R_logpdf",
    "gaussian_k_logpdf",
    "get_effect",
    "model_name",
    "parse_model_name",
    "register_effect",
    "walker_column",
]

#: Step of the trapezoidal rule in ln P.
GRID_STEP = 0.05
#: Half-width of each bulged cell's integration window, in prior sds of ln P.
N_SIGMA = 6.0
_LOG_2PI = np.log(2 * np.pi)

#: Effect name -> :class:`Effect` instance (filled by the effect modules on import).
EFFECTS = {}


def register_effect(effect):
    """Add an :class:`Effect` instance to :data:`EFFECTS` under its ``name``."""
    if not isinstance(effect, Effect):
        raise TypeError(f"register_effect needs an Effect instance, got {type(effect).__name__}")
    EFFECTS[effect.name] = effect
    return effect


def effect_names():
    """Names of the registered effects, in registration order."""
    return list(EFFECTS)


def get_effect(name):
    """The registered :class:`Effect` called ``name``."""
    try:
        return EFFECTS[name]
    except KeyError:
        raise ValueError(f"unknown effect {name!r}; known effects: {', '.join(EFFECTS)}") from None


def model_name(effects):
    """Name of the model with these effects: ``"baseline"`` or ``"radius_spread+bad_curves"``."""
    names = [e if isinstance(e, str) else e.name for e in effects]
    return "+".join(names) if names else "baseline"


def parse_model_name(name):
    """Effect names of a model name (inverse of :func:`model_name`)."""
    if name == "baseline":
        return []
    names = name.split("+")
    for n in names:
        get_effect(n)
    return names


def walker_column(a, ndim):
    """A per-walker array ``(W,)`` reshaped to ``(W, 1, ..., 1)`` with ``ndim`` axes."""
    a = np.asarray(a, float)
    return a.reshape(a.shape[:1] + (1,) * (ndim - 1))


# ---------------------------------------------------------------------------------- priors
@dataclass(frozen=True)
class SqrtCoordinate:
    r"""An effect-size prior sampled as :math:`u = \sqrt{x}` instead of its own coordinate.

    The prior on ``x`` is unchanged (``base``: a :class:`turgorbayes.inference.priors.HalfNormal` or
    :class:`turgorbayes.inference.priors.Beta`). Why: the sizes of these effects have their null value at
    the boundary ``x = 0``; in ``ln x`` the posterior of data without the effect has a long
    exponential left tail along which the other parameters drift back to their baseline values
    (a curved, skewed shape that neither a Laplace approximation nor an importance proposal
    follows), while in :math:`\sqrt{x}` the density
    :math:`p_u(u) = 2u\,p_x(u^2)` is unimodal with an interior mode and light tails.

    Parameters
    ----------
    base : HalfNormal or Beta
    """

    base: object

    def _log_px(self, x):
        base = self.base
        with np.errstate(divide="ignore", invalid="ignore"):
            log_jac = np.log(x) + (np.log1p(-x) if hasattr(base, "a") else 0.0)
            return base.log_density_u(base.to_u(x)) - log_jac

    def to_physical(self, u):
        return np.asarray(u, float) ** 2

    def to_u(self, x):
        return np.sqrt(np.asarray(x, float))

    def log_density_u(self, u):
        u = np.asarray(u, float)
        upper = 1.0 if hasattr(self.base, "a") else np.inf
        ok = (u > 0) & (u * u < upper)
        x = np.where(ok, u * u, 0.5)
        return np.where(ok, self._log_px(x) + np.log(2 * np.where(ok, u, 1.0)), -np.inf)

    def sample(self, rng, size=None):
        return self.base.sample(rng, size)

    def describe(self, unit="", factor=1.0):
        return self.base.describe(unit, factor) + " (sampled as sqrt)"


# ---------------------------------------------------------------------------------- effects
class Effect:
    """Base class of a model extension (module docstring). Subclasses set the attributes.

    Attributes
    ----------
    name : str
        Registry name (also the module name).
    parameters : tuple of turgorbayes.inference.models.Parameter
        Extra global parameters and their priors.
    size_parameter : str
        The parameter that measures the effect's size.
    null_value : float
        Its value at which the model is the baseline.
    realistic_size : float
        A realistic size (SI) used by the hidden-effect tests and the power study.
    realistic_size_reason : str
        Why that size is realistic.
    start : dict
        Starting values (SI) of the extra parameters for the optimizer.
    cause : str
        One sentence a biologist understands, used when the effect is selected.
    """

    name = ""
    parameters = ()
    size_parameter = ""
    null_value = 0.0
    realistic_size = 0.0
    realistic_size_reason = ""
    start = {}
    cause = ""

    # -- likelihood -------------------------------------------------------------------------
    def apply(self, ctx, v):
        """Edit the :class:`LikelihoodContext` for per-walker values ``v`` (dict of ``(W,)``)."""

    # -- generative model -------------------------------------------------------------------
    def cell_walls(self, walls, v, is_bulged, rng):
        """Per-cell wall parameters with the effect (``rng`` None: the median cell).

        Parameters
        ----------
        walls : dict of ndarray
            ``gamma``, ``E0t`` [N/m], ``R0`` [m] (and any effect's, e.g. ``Y_om``), arrays
            broadcastable to ``(..., n_cells)``.
        v : dict
            This effect's parameter values, scalars or arrays broadcastable to ``(..., 1)``.
        is_bulged : ndarray of bool (n_cells,)
        rng : numpy.random.Generator or None

        Returns
        -------
        dict of ndarray
        """
        return walls

    def log_pressure_sd(self, v):
        """Extra scatter of the bulge-derived ``ln P`` (0 unless the effect adds one)."""
        return 0.0

    def observe_k(self, k_obs, k_true, v, is_cell, rng):
        """Stiffness readings after the effect (default unchanged).

        Parameters
        ----------
        k_obs : ndarray [N/m]
            Readings with the ordinary measurement noise.
        k_true : ndarray [N/m]
            Noise-free stiffness of the same cells.
        v : dict
            Parameter values, broadcastable to ``k_obs``.
        is_cell : ndarray of bool
            Which entries are real cells (all True in practice).
        rng : numpy.random.Generator
        """
        return k_obs

    def radius_and_stiffness(self, P, walls, P0, surrogate):
        """Wall model of the effect, or None to keep :func:`turgorbayes.forward.cell_radius_and_stiffness`."""
        return None

    def injection(self, size):
        """The effect at ``size`` as an injection for :func:`turgorbayes.synthetic.simulate_cells`."""
        return Injection(self, float(size))

    def values_for_size(self, size):
        """All extra parameters (SI) when the size parameter is ``size`` (others at defaults)."""
        return {self.size_parameter: float(size)}

    def __repr__(self):
        return f"<effect {self.name}>"


@dataclass
class Injection:
    """An effect at a fixed size, in the protocol of :func:`turgorbayes.synthetic.simulate_cells`.

    ``cell_parameters`` changes the per-cell wall parameters, ``observations`` adds the
    effect's measurement corruption (extra bulge-pressure scatter multiplies ``k_b`` and its
    reported error by :math:`e^{\\sigma_P \\epsilon}`, which shifts :math:`\\ln\\hat P` by
    :math:`\\sigma_P\\epsilon` exactly; corrupted stiffness readings replace ``k_c`` but not its
    reported error), ``radius_and_stiffness`` (present only if the effect changes the wall model)
    swaps the wall model, ``describe`` goes into the sidecar JSON.
    """

    effect: Effect
    size: float
    values: dict = field(init=False)

    def __post_init__(self):
        self.values = self.effect.values_for_size(self.size)
        if type(self.effect).radius_and_stiffness is not Effect.radius_and_stiffness:
            self.radius_and_stiffness = self._radius_and_stiffness

    def cell_parameters(self, params, design, rng):
        out = dict(params)
        walls = self.effect.cell_walls({k: np.asarray(v, float) for k, v in params.items()},
                                       self.values, np.asarray(design.is_bulged), rng)
        out.update({k: np.broadcast_to(v, design.P.shape).copy() for k, v in walls.items()})
        return out

    def observations(self, obs, design, rng):
        obs = dict(obs)
        b = np.asarray(design.is_bulged)
        sd = float(self.effect.log_pressure_sd(self.values))
        if sd > 0:
            factor = np.where(b, np.exp(sd * rng.standard_normal(b.size)), 1.0)
            obs["k_b"] = obs["k_b"] * factor
            obs["k_b_err"] = obs["k_b_err"] * factor
        # until turgorbayes.synthetic reports them, the k_c errors are k_c_rel_sd * true k_c
        k_true = obs["k_c_err"] / design.k_c_rel_sd
        obs["k_c"] = self.effect.observe_k(obs["k_c"], k_true, self.values,
                                           np.ones(b.size, bool), rng)
        return obs

    def _radius_and_stiffness(self, P, params, surrogate):
        if surrogate is None:
            from turgorbayes import surrogate as surrogate_module

            surrogate = surrogate_module.load()
        walls = {k: v for k, v in params.items() if k != "P0"}
        return self.effect.radius_and_stiffness(P, walls, params.get("P0", 5e3), surrogate)

    def describe(self):
        return {"effect": self.effect.name, "size_parameter": self.effect.size_parameter,
                "size": self.size, "values": dict(self.values)}


# ---------------------------------------------------------------------------------- context
def gaussian_k_logpdf(k_obs, k, k_err):
    """``ln N(k_obs; k, sd)``, ``sd = (k_err/k_obs) k`` (the baseline's stiffness density,
    relative error: :func:`turgorbayes.inference.likelihood.stiffness_sd`; NaN where ``k`` is NaN)."""
    sd = stiffness_sd(k, k_obs, k_err)
    z = (k_obs - k) / sd
    return -0.5 * (z * z + _LOG_2PI) - np.log(sd)


def gaussian_R_logpdf(R_obs, R, R_err):
    """``ln N(R_obs; R, R_err)`` (the baseline's radius density; NaN where ``R`` is NaN)."""
    z = (R_obs - R) / R_err
    return -0.5 * (z * z + _LOG_2PI) - np.log(R_err)


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
    radius_and_stiffness : callable
        ``(P, walls, P0, surrogate) -> (R_c, k_c)``, broadcasting.
    values : dict
        Per-walker values ``(W,)`` of every parameter (for effects that need each other's).
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
        self.radius_and_stiffness = baseline_radius_and_stiffness
        self.values = values

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


def baseline_radius_and_stiffness(P, walls, P0, surrogate):
    """The baseline wall model (:func:`turgorbayes.forward.cell_radius_and_stiffness`)."""
    return forward.cell_radius_and_stiffness(P, walls["gamma"], walls["E0t"], walls["R0"], P0,
                                             surrogate)


def default_cell_logpdf(ctx, lnR, lnk, obs, log_w):
    """Independent densities of ``R_c`` and ``k_c``, averaged over the wall variants.

    .. math:: \\ln \\sum_v w_v\\, p_R(R_{obs} \\mid R_v)\\, p_k(k_{obs} \\mid k_v)

    Parameters
    ----------
    lnR, lnk : ndarray (W, V, n, K)
    obs : tuple of ndarray (n, 1)
        ``R_obs, R_err, k_obs, k_err`` [m, m, N/m, N/m].
    log_w : ndarray (W, V) or None
        Log weights of the variants (None: a single variant).

    Returns
    -------
    ndarray (W, n, K)
    """
    R_obs, R_err, k_obs, k_err = obs
    with np.errstate(over="ignore", invalid="ignore"):
        f = ctx.R_logpdf(R_obs, np.exp(lnR), R_err) + ctx.k_logpdf(k_obs, np.exp(lnk), k_err)
    if f.shape[1] == 1:
        return f[:, 0]
    f = np.where(np.isnan(f), -np.inf, f)
    return _logsumexp(f + log_w[:, :, None, None], axis=1)


# ------------------------------------------------------------------------------- likelihood
def _logsumexp(a, axis):
    m = np.max(a, axis=axis, keepdims=True)
    m = np.where(np.isfinite(m), m, 0.0)
    with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
        return np.log(np.sum(np.exp(a - m), axis=axis)) + np.squeeze(m, axis=axis)


def _refine(a):
    """Values on a grid of step h -> step h/2 by 4-point cubic midpoints (edges NaN)."""
    fine = np.full(a.shape[:-1] + (2 * a.shape[-1] - 1,), np.nan)
    fine[..., ::2] = a
    fine[..., 3:-3:2] = (9 * (a[..., 1:-2] + a[..., 2:-1]) - a[..., :-3] - a[..., 3:]) / 16
    return fine


class _Bulged:
    """Trapezoidal integration over each bulged cell's latent ln P (module docstring)."""

    def __init__(self, obs, step=GRID_STEP, n_sigma=N_SIGMA):
        self.h = float(step)
        self.n_sigma = float(n_sigma)
        self.mu = obs.log_P_bulge
        self.s = obs.sd_log_P_bulge
        self.obs_all = obs
        b = obs.bulged
        self.obs = tuple(a[b][:, None] for a in (obs.R_c, obs.R_c_err, obs.k_c, obs.k_c_err))

    def nodes(self, s_max):
        """Coarse grid (ln P) and each cell's window of fine-grid indices ``(nb, K)``."""
        h = self.h
        # never wider than the latent prior's support (huge scatters in a proposal's tails)
        half = min(self.n_sigma * s_max, 0.5 * (LOG_P_LATENT[1] - LOG_P_LATENT[0]))
        start = np.clip(self.mu - half, LOG_P_LATENT[0], LOG_P_LATENT[1] - 2 * half)
        lo = np.floor(start / h).astype(int)  # fine index of each window start
        K = int(np.ceil(2 * half / h)) + 2
        J0 = int(np.floor(lo.min() / 2)) - 2  # coarse index range, 2 guard points per side
        J1 = int(np.ceil((lo.max() + K) / 2)) + 2
        coarse = 2 * h * np.arange(J0, J1 + 1)
        idx = (lo - 2 * J0)[:, None] + np.arange(K)
        return coarse, idx, 2 * h * J0 + h * idx

    def __call__(self, ctx, P0, surrogate):
        s_tot = np.sqrt(self.s[None, :] ** 2 + ctx.extra_log_sd[:, None] ** 2)  # (W, nb)
        s_max = float(np.max(s_tot[np.isfinite(s_tot)], initial=np.max(self.s)))
        coarse, idx, x = self.nodes(s_max)
        walls = {k: a[..., None] for k, a in ctx.walls["bulged"].items()}  # (W, V, 1)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            R, k = ctx.radius_and_stiffness(np.exp(coarse), walls, P0, surrogate)
            lnR, lnk = _refine(np.log(R))[..., idx], _refine(np.log(k))[..., idx]  # (W,V,nb,K)
        f = ctx.cell_logpdf(ctx, lnR, lnk, self.obs, ctx.log_w["bulged"])  # (W, nb, K)
        prior = latent_log_density(self.obs_all, x[None], ctx.extra_log_sd)  # (W|1, nb, K)
        total = f + prior
        total = np.where(np.isnan(total), -np.inf, total)
        return _logsumexp(total, axis=-1) + np.log(self.h), x, total


class _Intact:
    """Intact cells at ``P_phys``: the cell density at one pressure node."""

    def __init__(self, obs):
        i = obs.intact
        self.obs = tuple(a[i][:, None] for a in (obs.R_c, obs.R_c_err, obs.k_c, obs.k_c_err))

    def __call__(self, ctx, P_phys, P0, surrogate):
        walls = {k: a[..., None, None] for k, a in ctx.walls["intact"].items()}  # (W, V, 1, 1)
        P = np.asarray(P_phys, float)[:, None, None, None]
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            R, k = ctx.radius_and_stiffness(P, walls, P0, surrogate)
            lnR, lnk = np.log(R), np.log(k)
        f = ctx.cell_logpdf(ctx, lnR, lnk, self.obs, ctx.log_w["intact"])[..., 0]  # (W, ni)
        f = np.where(np.isnan(f), -np.inf, f)
        return f


# ------------------------------------------------------------------------------------ model
class ExtendedModel(models.BaselineModel):
    """The baseline model plus a list of effects (module docstring).

    Parameters
    ----------
    cells : turgorbayes.io.CellData
    surrogate : turgorbayes.surrogate.Surrogate
    effects : sequence of str or Effect
        Applied in order; empty gives the baseline model.
    n_nodes : int
        Accepted for interface compatibility with :class:`turgorbayes.inference.models.BaselineModel`
        (this model integrates by the trapezoidal rule, not Gauss-Hermite).
    P0 : float [Pa]
    grid_step : float
        Trapezoid step in ln P.
    n_sigma : float
        Window half-width in prior sds.
    """

    bayesian = True

    def __init__(self, cells, surrogate, effects=(), n_nodes=10, P0=5e3, grid_step=GRID_STEP,
                 n_sigma=N_SIGMA):
        super().__init__(cells, surrogate, n_nodes=n_nodes, P0=P0)
        self.effects = tuple(get_effect(e) if isinstance(e, str) else e for e in effects)
        names = [e.name for e in self.effects]
        if len(set(names)) != len(names):
            raise ValueError(f"an effect may appear only once in a model, got {names}")
        self.name = model_name(self.effects)
        self.parameters = models.BASELINE_PARAMETERS + tuple(
            p for e in self.effects for p in e.parameters)
        self._bulged = _Bulged(self.obs, grid_step, n_sigma)
        self._intact = _Intact(self.obs)

    # ------------------------------------------------------------------ likelihood
    def context(self, v):
        """The :class:`LikelihoodContext` for physical values ``v`` (dict of ``(W,)``)."""
        ctx = LikelihoodContext(v, v)
        for e in self.effects:
            e.apply(ctx, v)
        return ctx

    def pointwise_log_likelihood(self, u):
        """``(W, n_cells)`` log-likelihood per cell (latent quantities integrated out)."""
        v = self.to_physical(u)
        ctx = self.context(v)
        lb = self._bulged(ctx, self.P0, self.surrogate)[0]
        li = self._intact(ctx, v["P_phys"], self.P0, self.surrogate)
        out = np.empty((ctx.W, self.obs.n_cells))
        out[:, self.obs.bulged] = lb
        out[:, self.obs.intact] = li
        return out

    def cell_pressures(self, u):
        """``(W, n_cells)``: E[P_i | data_i, theta] for bulged cells, P_phys for intact [Pa]."""
        v = self.to_physical(u)
        ctx = self.context(v)
        _, x, total = self._bulged(ctx, self.P0, self.surrogate)
        w = np.exp(total - _logsumexp(total, axis=-1)[..., None])
        out = np.empty((ctx.W, self.obs.n_cells))
        out[:, self.obs.bulged] = np.sum(w * np.exp(x), axis=-1)
        out[:, self.obs.intact] = v["P_phys"][:, None]
        return out

    # ------------------------------------------------------------------ generative model
    def _cell_walls(self, v, rng):
        """Per-cell walls ``(W, n_cells)`` (``rng`` None: median cells)."""
        n = self.obs.n_cells
        walls = {k: np.broadcast_to(np.asarray(v[k], float)[:, None], (len(v[k]), n))
                 for k in ("gamma", "E0t", "R0")}
        for e in self.effects:
            walls = e.cell_walls(walls, _column_values(e, v), self.obs.is_bulged, rng)
        return walls

    def _radius_and_stiffness(self):
        for e in reversed(self.effects):
            if type(e).radius_and_stiffness is not Effect.radius_and_stiffness:
                return e.radius_and_stiffness
        return baseline_radius_and_stiffness

    def predicted_means(self, u):
        """Plug-in predictions ``{"R_c", "k_c"}`` ``(W, n_cells)`` of the median cell.

        Bulged cells at their bulge-derived pressure, intact cells at ``P_phys``; no random
        per-cell effect (used as the centre of the standardized residuals of the checks).
        """
        v = self.to_physical(u)
        log_P = self._log_pressure_centre(v)
        R, k = self._radius_and_stiffness()(np.exp(log_P), self._cell_walls(v, None), self.P0,
                                            self.surrogate)
        return {"R_c": R, "k_c": k}

    def _log_pressure_centre(self, v):
        W = len(v["gamma"])
        log_P = np.empty((W, self.obs.n_cells))
        log_P[:, self.obs.bulged] = self.obs.log_P_bulge
        log_P[:, self.obs.intact] = np.log(v["P_phys"])[:, None]
        return log_P

    def posterior_predictive(self, u, rng):
        """Replicated ``R_c``, ``k_c`` ``(W, n_cells)``, one per draw, from the generative model.

        Bulged cells: ``ln P`` from the bulge (sd ``sqrt(s_i^2 + sigma_P^2)``) times the
        population prior (:func:`turgorbayes.inference.likelihood.latent_prior`; conditioned on the bulge
        only), every effect's per-cell wall parameters and stiffness corruption drawn anew,
        then the reported Gaussian errors.
        """
        v = self.to_physical(u)
        W, b = len(v["gamma"]), self.obs.bulged
        extra = np.zeros(W)
        for e in self.effects:
            extra = np.hypot(extra, e.log_pressure_sd(_values(e, v)))
        log_P = self._log_pressure_centre(v)
        log_P[:, b] = sample_latent(self.obs, rng, W, extra)  # bulge x population prior
        walls = self._cell_walls(v, rng)
        R, k = self._radius_and_stiffness()(np.exp(log_P), walls, self.P0, self.surrogate)
        R_rep = R + self.obs.R_c_err * rng.standard_normal(R.shape)
        k_rep = k + stiffness_sd(k, self.obs.k_c, self.obs.k_c_err) * rng.standard_normal(k.shape)
        for e in self.effects:
            k_rep = e.observe_k(k_rep, k, _column_values(e, v), np.ones(k.shape, bool), rng)
        return {"R_c": R_rep, "k_c": k_rep}

    def curves(self, u, P):
        """Model ``R_c(P)``, ``k_c(P)`` of the median intact-cell wall: ``(W, len(P))``."""
        v = self.to_physical(u)
        ctx = self.context(v)
        walls = {k: _median_variant(ctx, "intact", k) for k in ctx.walls["intact"]}
        return ctx.radius_and_stiffness(np.asarray(P, float)[None, :], walls, self.P0,
                                        self.surrogate)

    def derived(self, u, rng):
        """E_perp, E_par of the (peptidoglycan) wall at P_phys [Pa], lognormal thickness drawn."""
        v = self.to_physical(u)
        t = models.THICKNESS_MEDIAN * np.exp(models.THICKNESS_LOG_SD
                                             * rng.standard_normal(v["gamma"].shape))
        for e in reversed(self.effects):
            moduli = getattr(e, "wall_moduli", None)
            if moduli is not None:
                E_perp_t, E_par_t = moduli(v, self.P0)
                return {"E_perp": E_perp_t / t, "E_par": E_par_t / t}
        E_perp, E_par = models.moduli_at_pressure(v["gamma"], v["E0t"], v["R0"], v["P_phys"], t,
                                                  self.P0)
        return {"E_perp": E_perp, "E_par": E_par}

    # ------------------------------------------------------------------ starting point
    def start_values(self, guess):
        """Full physical starting values from baseline ``guess`` plus each effect's ``start``."""
        out = {k: guess[k] for k in ("gamma", "E0t", "R0", "P_phys")}
        for e in self.effects:
            for p in e.parameters:
                out[p.name] = guess.get(p.name, e.start[p.name])
        return out


def _median_variant(ctx, group, key):
    """A group's wall parameter of the median cell: the middle variant ``(W, 1)``."""
    a = ctx.walls[group][key]
    return a[:, a.shape[1] // 2][:, None]


def _values(effect, v):
    return {p.name: np.asarray(v[p.name], float) for p in effect.parameters}


def _column_values(effect, v):
    """An effect's per-walker values as ``(W, 1)`` columns (broadcast over cells)."""
    return {p.name: np.asarray(v[p.name], float)[:, None] for p in effect.parameters}


def _load_effect_modules():
    from turgorbayes.effects import (  # noqa: F401
        bad_curves,
        outer_membrane,
        pressure_error,
        radius_spread,
        wall_softening,
    )


_load_effect_modules()
