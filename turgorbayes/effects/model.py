"""The baseline model plus a list of effects: :class:`ExtendedModel`.

Effects only edit the shared likelihood context, so any set of them combines without code
per pair (docs/effects.md).
"""

import numpy as np

from turgorbayes.effects.base import Effect
from turgorbayes.effects.registry import get_effect, model_name
from turgorbayes.inference import models
from turgorbayes.inference.context import (
    LikelihoodContext,
    apply_effects,
    baseline_radius_and_stiffness,
    density_first,
)
from turgorbayes.inference.likelihood import DEFAULT_NODES
from turgorbayes.inference.observations import DEFAULT_LATENT, sample_latent, stiffness_sd
from turgorbayes.inference.reading_correlation import cell_correlations, cell_rho, correlated_normals
from turgorbayes.physics.parameters import P0

__all__ = ["ExtendedModel"]


# ------------------------------------------------------------------------------------ model
class ExtendedModel(models.BaselineModel):
    """The baseline model plus a list of effects (docs/effects.md).

    Each effect edits a :class:`turgorbayes.inference.context.LikelihoodContext`; the
    baseline's likelihood engine (:meth:`CellLikelihood.pointwise_context
    <turgorbayes.inference.likelihood.CellLikelihood.pointwise_context>`) evaluates it, so
    without effects this is :class:`turgorbayes.inference.models.BaselineModel`.

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
    surrogate : turgorbayes.surrogate.Surrogate
    effects : sequence of str or Effect
        Applied in order; empty gives the baseline model.
    n_nodes : int
        Gauss-Hermite nodes per bulged cell.
    P0 : float [Pa]
    latent : str
        Prior of the latent pressures (:data:`turgorbayes.inference.observations.LATENT_PRIORS`).
    """

    bayesian = True

    def __init__(self, cells, surrogate, effects=(), n_nodes=DEFAULT_NODES, P0=P0,
                 latent=DEFAULT_LATENT):
        super().__init__(cells, surrogate, n_nodes=n_nodes, P0=P0, latent=latent)
        self.effects = tuple((get_effect(e) if isinstance(e, str) else e).bind(cells)
                             for e in effects)
        names = [e.name for e in self.effects]
        if len(set(names)) != len(names):
            raise ValueError(f"an effect may appear only once in a model, got {names}")
        self.name = model_name(self.effects)
        self.parameters = models.BASELINE_PARAMETERS + tuple(
            p for e in self.effects for p in e.parameters)

    @classmethod
    def on_observations(cls, cells, surrogate, effects, obs, lik, P0=P0):
        """The model of ``cells`` with ``effects`` already bound (used as given) on given
        observations ``obs`` and their likelihood ``lik`` (one condition of a data set with
        several: :class:`turgorbayes.effects.conditions.ConditionsExtendedModel`)."""
        model = cls.__new__(cls)
        model.cells, model.surrogate, model.P0 = cells, surrogate, float(P0)
        model.obs, model.lik = obs, lik
        model.effects = tuple(effects)
        model.name = model_name(model.effects)
        model.parameters = models.BASELINE_PARAMETERS + tuple(
            p for e in model.effects for p in e.parameters)
        return model

    # ------------------------------------------------------------------ likelihood
    def context(self, v, skip=()):
        """The :class:`LikelihoodContext` for physical values ``v`` (dict of ``(W,)``), the
        effects named in ``skip`` left out, a density-replacing one first
        (:func:`~turgorbayes.inference.context.density_first`)."""
        return apply_effects(self.base_context(v), self.effects, v, skip)

    def base_context(self, v):
        """The context before the effects edit it (the baseline's; a model whose intact cells
        have turgors of their own sets :attr:`LikelihoodContext.intact_log_P` here)."""
        return LikelihoodContext(v, v)

    def pointwise_log_likelihood(self, u):
        """``(W, n_cells)`` log-likelihood per cell (latent quantities integrated out)."""
        v = self.to_physical(u)
        return self.lik.pointwise_context(self.context(v), v["P_phys"])

    def cell_pressures(self, u):
        """``(W, n_cells)``: E[P_i | data_i, theta] for bulged cells; for intact cells their
        own turgor where the context gives one (a series' levels), else P_phys [Pa]."""
        v = self.to_physical(u)
        ctx = self.context(v)
        out = np.empty((len(v["gamma"]), self.obs.n_cells))
        out[:, self.obs.bulged] = self.lik.latent_pressure_mean_context(ctx)
        out[:, self.obs.intact] = (v["P_phys"][:, None] if ctx.intact_log_P is None
                                   else np.exp(ctx.intact_log_P))
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

        Bulged cells at their bulge-derived pressure, intact cells at ``P_phys``, read through
        the context's stiffness scale as the replicates are (:meth:`_readings`); no random
        per-cell effect (used as the centre of the standardized residuals of the checks).
        """
        v = self.to_physical(u)
        ctx = self.context(v)
        R, k = self._readings(self.log_pressure_centre(v, ctx), self._cell_walls(v, None),
                              ctx.log_k_scale)
        return {"R_c": R, "k_c": k}

    def _readings(self, log_P, walls, log_c):
        """Noise-free readings ``R_c`` [m], ``k_c`` [N/m] ``(W, n_cells)`` of cells at ``ln P``
        ``(W, n_cells)`` [ln Pa] with per-cell ``walls``, read as the likelihood reads them.

        ``log_c`` is the context's stiffness scale ``ln c`` ``(W, n_cells)``
        (:attr:`~turgorbayes.inference.context.LikelihoodContext.log_k_scale`; None: none). A
        bulged cell's ``ln P`` is then its apparent pressure: its wall is read at ``ln P - ln
        c``; every cell's ``k_c`` is ``c`` times its wall's (docs/effects.md, "The extended
        likelihood", stiffness scale).
        """
        wall_model = self._radius_and_stiffness()
        if log_c is None:
            return wall_model(np.exp(log_P), walls, self.P0, self.surrogate)
        at = np.array(log_P, float)
        at[:, self.obs.bulged] -= log_c[:, self.obs.bulged]
        R, k = wall_model(np.exp(at), walls, self.P0, self.surrogate)
        return R, k * np.exp(log_c)

    def log_pressure_centre(self, v, ctx=None):
        """``ln P`` each cell is centred on, per walker ``(W, n_cells)``: its bulge pressure if
        bulged, else its own turgor where the context gives one (a series' level), else
        ``P_phys`` (``v``: physical parameters, as :meth:`to_physical` gives; ``ctx``: their
        :meth:`context`, built here if None)."""
        W = len(v["gamma"])
        ctx = self.context(v) if ctx is None else ctx
        log_P = np.empty((W, self.obs.n_cells))
        log_P[:, self.obs.bulged] = self.obs.log_P_bulge
        log_P[:, self.obs.intact] = ctx.intact_log_pressure(v["P_phys"])
        return log_P

    def posterior_predictive(self, u, rng):
        """Replicated ``R_c``, ``k_c`` ``(W, n_cells)``, one per draw, from the generative model.

        Bulged cells: ``ln P`` from the bulge (sd ``sqrt(s_i^2 + sigma_P^2)``) times the
        population prior (:func:`turgorbayes.inference.observations.latent_prior`; conditioned on the bulge
        only); intact cells at ``P_phys`` (or their own turgor: :meth:`log_pressure_centre`),
        or each at its own pressure drawn anew where an
        effect spreads them (:meth:`turgorbayes.effects.base.Effect.intact_log_pressure_offsets`);
        every effect's per-cell wall parameters and stiffness corruption drawn anew, then the
        reported Gaussian errors (correlated where a cell's or an effect's correlation says so).
        The draw's stiffness scale (a session's calibration, a drift) is the likelihood's, from
        the same context (:meth:`_readings`): a bulged cell's latent pressure is the apparent
        one, its wall read at ``P/c``, and each ``k_c`` is ``c`` times the wall's before the
        errors and the effects' corruption are added.
        """
        v = self.to_physical(u)
        W, b = len(v["gamma"]), self.obs.bulged
        extra = np.zeros(W)
        for e in self.effects:
            extra = np.hypot(extra, e.log_pressure_sd(_values(e, v)))
        ctx = self.context(v)
        log_P = self.log_pressure_centre(v, ctx)
        if b.size:
            log_P[:, b] = sample_latent(self.obs, rng, W, extra)  # bulge x population prior
        log_P[:, self.obs.intact] += self._intact_log_pressure_offsets(v, rng)
        walls = self._cell_walls(v, rng)
        R, k = self._readings(log_P, walls, ctx.log_k_scale)
        z_R, z_k = correlated_normals(rng, R.shape, self._reading_rho(v))
        R_rep = R + self.obs.R_c_err * z_R
        k_rep = k + stiffness_sd(k, self.obs.k_c, self.obs.k_c_err) * z_k
        every = np.ones(k.shape, bool)
        for e in density_first(self.effects):
            k_rep = e.observe_k(k_rep, k, _column_values(e, v), every, rng)
            R_rep = e.observe_R(R_rep, _column_values(e, v), every, rng)
        return {"R_c": R_rep, "k_c": k_rep}

    def _reading_rho(self, v):
        """Correlation of every cell's R_c and k_c errors ``(W|1, n_cells)``: the cell's own
        where known, else an effect's; None when all are 0."""
        walkers = None
        for e in self.effects:
            rho = e.reading_correlation(_values(e, v))
            walkers = walkers if rho is None else rho
        return cell_rho(cell_correlations(self.obs), walkers, 2)

    def _intact_log_pressure_offsets(self, v, rng):
        """The effects' offsets of the intact cells' ``ln P`` from ``ln P_phys``, summed,
        ``(W, n_intact)`` or 0.0 (random numbers are drawn only by effects that have them)."""
        total = 0.0
        for e in self.effects:
            offsets = e.intact_log_pressure_offsets(_column_values(e, v), self.obs.intact.size,
                                                    rng)
            if offsets is not None:
                total = total + offsets
        return total

    def curves(self, u, P):
        """Model ``R_c(P)``, ``k_c(P)`` of the median intact-cell wall: ``(W, len(P))``."""
        v = self.to_physical(u)
        ctx = self.context(v)
        walls = {k: _median_variant(ctx, "intact", k) for k in ctx.walls["intact"]}
        return ctx.radius_and_stiffness(np.asarray(P, float)[None, :], walls, self.P0,
                                        self.surrogate)

    def derived(self, u, rng):
        """E_perp, E_par of the (peptidoglycan) wall at P_phys [Pa], lognormal thickness drawn.

        With an effect that has a common factor on every stiffness reading
        (:meth:`turgorbayes.effects.base.Effect.log_common_scale`, ``delta`` per draw), also
        ``P_phys``, ``E0t``, ``R0`` and the effects' tension parameters in true units: the
        wall law is unchanged when ``P`` and every tension scale by ``exp(delta)``, ``E0t`` by
        ``exp((1 - gamma) delta)`` (``E_perp t = E0t (P/P0)^gamma``) and ``R0`` becomes the
        radius at the apparent pressure ``P0 exp(delta)``; the sampled values are apparent ones
        and these replace them (docs/effects.md, calibration).
        """
        v = self.to_physical(u)
        deltas = [d for e in self.effects
                  if (d := e.log_common_scale(_values(e, v))) is not None]
        if not deltas:
            return self._moduli(v, rng)
        v = self._true_units(v, np.sum(deltas, axis=0))
        names = ("P_phys", "E0t", "R0") + self._tension_names()
        return {**{n: v[n] for n in names}, **self._moduli(v, rng)}

    def _tension_names(self):
        return tuple(n for e in self.effects for n in e.tension_parameters)

    def _true_units(self, v, delta):
        """``v`` with the apparent stiffness scale ``exp(delta)`` removed (:meth:`derived`)."""
        v = dict(v)
        walls = {n: np.asarray(v[n], float) for n in ("gamma", "E0t", "R0") + self._tension_names()}
        with np.errstate(all="ignore"):
            v["R0"], _ = self._radius_and_stiffness()(self.P0 * np.exp(delta), walls, self.P0,
                                                      self.surrogate)
        v["P_phys"] = v["P_phys"] * np.exp(-delta)
        v["E0t"] = v["E0t"] * np.exp(-(1.0 - v["gamma"]) * delta)
        for n in self._tension_names():
            v[n] = v[n] * np.exp(-delta)
        return v

    def _moduli(self, v, rng):
        t = models.THICKNESS_MEDIAN * np.exp(models.THICKNESS_LOG_SD
                                             * rng.standard_normal(v["gamma"].shape))
        for e in reversed(self.effects):
            moduli = getattr(e, "wall_moduli", None)
            if moduli is not None:
                E_perp_t, E_par_t = moduli(v, self.P0)
                return {"E_perp": E_perp_t / t, "E_par": E_par_t / t}
        E_perp, E_par = models.moduli_at_pressure(v["P_phys"], v["gamma"], v["E0t"], v["R0"], t,
                                                  self.P0)
        return {"E_perp": E_perp, "E_par": E_par}

    # ------------------------------------------------------------------ starting point
    def without(self, keep, cells, surrogate, reread):
        """The model refitted to the cells ``keep`` for an exact leave-one-out refit, reading
        its cells as the full model does: ``reread(model, full_obs, keep)``
        (:func:`turgorbayes.criticism.loo.with_full_data_observations`)."""
        keep = np.asarray(keep, bool)
        return reread(type(self)(cells.take(keep), surrogate, effects=self.effects, P0=self.P0),
                      self.obs, keep)

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
