"""The interface of a model extension ("effect"): :class:`Effect`, its synthetic-data
protocol :class:`Injection` and the effect-size prior coordinate :class:`SqrtCoordinate`.

An effect is a small subclass: its parameters and priors, :meth:`Effect.apply` (how it edits
the :class:`turgorbayes.inference.context.LikelihoodContext`) and its generative hooks
(docs/effects.md).
"""

from dataclasses import dataclass, field, replace

import numpy as np

from turgorbayes.cells.medium import medium_levels
from turgorbayes.physics.parameters import P0

__all__ = ["Effect", "Injection", "SqrtCoordinate", "StiffnessFactor"]


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
    """Base class of a model extension (docs/effects.md). Subclasses set the attributes.

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
    tension_parameters : tuple of str
        Extra parameters in N/m (2D moduli): they scale with a common factor on every
        stiffness reading (:meth:`log_common_scale`), like ``P_phys``.
    size_unit : tuple
        ``(unit, SI factor)`` of the size on the command line (``simulate --effect-size``):
        SI by default, ``("nm", 1e-9)`` for lengths.
    """

    name = ""
    parameters = ()
    size_parameter = ""
    null_value = 0.0
    realistic_size = 0.0
    realistic_size_reason = ""
    start = {}
    cause = ""
    tension_parameters = ()
    size_unit = ("", 1.0)
    #: False for a generic description of misfit (:mod:`~turgorbayes.effects.discrepancy`):
    #: it may win the comparison but is never reported as a cause (docs/effects.md, verdict).
    names_cause = True
    #: True for an effect whose cause is readings that are gross errors (wrong cell, unit or
    #: curve): only when it is the explained cause are flagged readings called gross errors.
    gross_errors = False
    #: Effects that describe the same data near-equally (measured: docs/validation.md, "When
    #: the cause is not in the library") share a family name; the verdict names the family.
    family = None
    #: True for an effect that changes the wall each cell's stiffness is read at (per-cell
    #: walls, a softer bulge wall, another envelope law): the FE-table check, made at the
    #: baseline's wall, is then approximate (:mod:`turgorbayes.inference.table_check`).
    changes_wall = False
    #: The design its realistic size needs to be seen in data of the paper's size, as
    #: :func:`turgorbayes.simulation.planted.planted_cells` draws it: ``n_sessions`` (the
    #: measurement sessions), ``R_c_err_nm`` ((lo, hi) of the per-cell R_c error, nm). Empty:
    #: the paper's design.
    realistic_design = {}
    #: What ``turgorbayes simulate`` warns when the effect is planted with the default R_c
    #: errors, which it would drown or double (None: nothing to say).
    default_radius_errors_warning = None
    #: True for an effect that replaces the Gaussian stiffness density itself
    #: (``ctx.k_logpdf``); :class:`ExtendedModel` applies it before the effects that wrap it.
    replaces_k_density = False

    #: Why the effect cannot act on an osmotic series (intact cells in media of several
    #: osmolarities, :class:`turgorbayes.effects.series.SeriesModel`), as one phrase; None
    #: (the default): it acts within the series' levels like on one medium
    #: (:meth:`series_refusal`).
    series_reason = None

    # -- data set -------------------------------------------------------------------------
    def not_applicable_reason(self, cells):
        """Why the effect cannot be fitted to ``cells`` (e.g. it needs a column), as one
        phrase; None when it can. The default: :meth:`series_refusal` (an effect that
        overrides this calls it too when it declares a :attr:`series_reason`)."""
        return self.series_refusal(cells)

    def series_refusal(self, cells):
        """:attr:`series_reason` as a reason not to fit the effect when ``cells`` are an
        osmotic series (intact cells at two or more medium levels); None otherwise."""
        if self.series_reason is None or medium_levels(cells).size < 2:
            return None
        return f"it cannot act on an osmotic series: {self.series_reason}"

    def applicable(self, cells):
        """Whether the effect can be fitted to ``cells``."""
        return self.not_applicable_reason(cells) is None and self.series_refusal(cells) is None

    def bind(self, cells):
        """The effect for one data set (default: itself; an effect whose parameters depend on
        the data, such as one factor per measurement session, returns a new instance)."""
        return self

    def restrict(self, idx):
        """The bound effect for the cells ``idx`` (integer indices) of its data set, with the
        same parameters (one condition of several,
        :class:`turgorbayes.effects.conditions.ConditionsExtendedModel`). Default: itself; an
        effect that holds per-cell arrays returns a copy with them taken at ``idx``."""
        return self

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

    def log_common_scale(self, v):
        """Log of a factor shared by every stiffness reading that the data cannot see (a
        common calibration error), per walker ``(W,)``; None (the default) when the effect
        has none. The model reports ``P_phys``, ``E0t`` and the moduli divided by it
        (:meth:`turgorbayes.effects.ExtendedModel.derived`)."""
        return None

    def intact_log_pressure_offsets(self, v, n, rng):
        """Offsets of the intact cells' true ``ln P`` from ``ln P_phys`` (default None: every
        intact cell at ``P_phys``, and no random number is drawn).

        Parameters
        ----------
        v : dict
            This effect's parameter values, scalars (simulation) or ``(W, 1)`` columns (one
            per posterior draw).
        n : int
            Number of intact cells.
        rng : numpy.random.Generator

        Returns
        -------
        ndarray ``(n,)`` or ``(W, n)``, or None
        """
        return None

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

    def observe_R(self, R_obs, v, is_cell, rng):
        """Radius readings ``R_c`` [m] after the effect (default unchanged; arguments as in
        :meth:`observe_k`)."""
        return R_obs

    def observe_bulge(self, k_b, v, is_bulged, rng):
        """Bulge stiffness readings ``k_b`` [N/m] after the effect (default unchanged; NaN for
        intact cells)."""
        return k_b

    def reading_correlation(self, v):
        """Correlation of the R_c and k_c errors of the cells whose own is not known, per
        walker ``(W,)`` (the readings' bivariate normal, docs/statistics.md, "Correlated
        readings"); None (the default): the effect leaves them as they are."""
        return None

    def radius_and_stiffness(self, P, walls, P0, surrogate):
        """Wall model of the effect, or None to keep :func:`turgorbayes.physics.forward.cell_radius_and_stiffness`."""
        return None

    def wall_ratios(self):
        """``{(quantity, condition index): parameter name}``: wall quantities (``E0t``,
        ``gamma``) that the effect gives a condition of its own as a log ratio to the
        reference condition's (:mod:`turgorbayes.effects.own_wall`); empty by default."""
        return {}

    def describe(self, summary):
        """What a generic description of misfit absorbed, as one phrase, from its posterior
        ``summary``; None (the default) for an effect that names a cause."""
        return None

    def channel_scales(self, summary):
        """``{observable: s}``: the extra log-scatter a generic description of misfit finds in
        the readings of each observable (:mod:`turgorbayes.criticism.misfit_band`); None (the
        default) for an effect that is not one."""
        return None

    def cause_text(self, summary):
        """:attr:`cause` with the fitted size (the median of the size parameter in
        ``summary``, a posterior summary keyed like ``summary.json``)."""
        key = next(p.key for p in self.parameters if p.name == self.size_parameter)
        return self.cause.format(size=summary[key]["q50"])

    def injection(self, size):
        """The effect at ``size`` as an injection for :func:`turgorbayes.simulation.cells.simulate_cells`."""
        return Injection(self, float(size))

    def values_for_size(self, size):
        """All extra parameters (SI) when the size parameter is ``size`` (others at defaults)."""
        return {self.size_parameter: float(size)}

    def __repr__(self):
        return f"<effect {self.name}>"


class StiffnessFactor(Effect):
    """An effect that multiplies every stiffness reading (``k_c``, ``k_b``) of cell ``i`` by
    ``exp(log_factors(v)[:, i])``, through the likelihood's calibration path
    (:attr:`turgorbayes.inference.context.LikelihoodContext.log_k_scale`): a session's
    calibration, a drift with measurement order. Replicated data read the same context
    (:meth:`turgorbayes.effects.ExtendedModel.posterior_predictive`), so the effect has no
    :meth:`observe_k` of its own. A subclass gives :meth:`log_factors` and :meth:`is_bound`
    (whether it holds the per-cell data it needs)."""

    def log_factors(self, v):
        """Log factor per walker and cell ``(W, n_cells)``."""
        raise NotImplementedError

    def is_bound(self):
        """Whether the effect holds its data set's per-cell data (:meth:`Effect.bind`)."""
        raise NotImplementedError

    def apply(self, ctx, v):
        if not self.is_bound():
            raise ValueError(f"{self.name} must be bound to a data set "
                             f"({type(self).__name__}.bind)")
        log_c = self.log_factors(v)
        ctx.log_k_scale = log_c if ctx.log_k_scale is None else ctx.log_k_scale + log_c


@dataclass
class Injection:
    """An effect at a fixed size, in the protocol of :func:`turgorbayes.simulation.cells.simulate_cells`.

    ``pressures`` draws the intact cells' own pressures (where the effect has them),
    ``cell_parameters`` changes the per-cell wall parameters, ``observations`` adds the
    effect's measurement corruption (extra bulge-pressure scatter multiplies ``k_b`` and its
    reported error by :math:`e^{\\sigma_P \\epsilon}`, which shifts :math:`\\ln\\hat P` by
    :math:`\\sigma_P\\epsilon` exactly; corrupted readings replace ``k_c``, ``R_c`` or ``k_b``
    but not their reported errors), ``radius_and_stiffness`` (present only if the effect changes the wall model)
    swaps the wall model, ``describe`` goes into the sidecar JSON.
    """

    effect: Effect
    size: float
    values: dict = field(init=False)

    def __post_init__(self):
        self.values = self.effect.values_for_size(self.size)
        if type(self.effect).radius_and_stiffness is not Effect.radius_and_stiffness:
            self.radius_and_stiffness = self._radius_and_stiffness

    def pressures(self, design, rng):
        """``design`` with the intact cells' true pressures [Pa] moved by the effect's offsets
        in ``ln P`` (:meth:`Effect.intact_log_pressure_offsets`); unchanged, and no random
        number drawn, for an effect without them."""
        intact = ~np.asarray(design.is_bulged)
        offsets = self.effect.intact_log_pressure_offsets(self.values, int(intact.sum()), rng)
        if offsets is None:
            return design
        P = np.array(design.P, float)
        P[intact] = P[intact] * np.exp(offsets)
        return replace(design, P=P)

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
        # until turgorbayes.simulation.cells reports them, the k_c errors are k_c_rel_sd * true k_c
        k_true = obs["k_c_err"] / design.k_c_rel_sd
        every = np.ones(b.size, bool)
        obs["k_c"] = self.effect.observe_k(obs["k_c"], k_true, self.values, every, rng)
        obs["R_c"] = self.effect.observe_R(obs["R_c"], self.values, every, rng)
        obs["k_b"] = self.effect.observe_bulge(obs["k_b"], self.values, b, rng)
        return obs

    def _radius_and_stiffness(self, P, params, surrogate):
        if surrogate is None:
            from turgorbayes import surrogate as surrogate_module

            surrogate = surrogate_module.load()
        walls = {k: v for k, v in params.items() if k != "P0"}
        return self.effect.radius_and_stiffness(P, walls, params.get("P0", P0), surrogate)

    def describe(self):
        return {"effect": self.effect.name, "size_parameter": self.effect.size_parameter,
                "size": self.size, "values": dict(self.values)}
