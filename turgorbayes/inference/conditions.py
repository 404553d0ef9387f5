"""Several experimental conditions in one data set: labels, the model, the fit, contrasts.

A cell-data file may carry the optional ``condition`` column (any non-empty text per row,
docs/data_format.md). Each condition ``c`` has its own physiological turgor ``P_phys[c]`` and
rest radius ``R0[c]``. The wall's material (``gamma``, ``E0t``) is either shared by every
condition (``wall_prior`` empty: the contrast then assumes the treatment left the wall alone)
or may differ from the reference condition's under a stated prior (``wall_prior``,
:data:`WALL_PRIOR`): ``ln(E0t[c] / E0t[ref]) ~ N(0, sd_E0t)`` and ``gamma[c] - gamma[ref] ~
N(0, sd_gamma)``. Where a condition has bulged cells its data pin its wall and the prior hardly
matters; where it has none, the prior is all there is, and the turgor contrast widens by what
a wall change could hide (docs/statistics.md, "Several conditions"). ``per_condition`` frees
``gamma`` or ``E0t`` of a condition whose bulged cells can identify them (flat prior).

* :func:`condition_labels`, :class:`ConditionSet`: the labels, checked, and the design
  (:mod:`turgorbayes.inference.condition_design`, re-exported here).
* :class:`ConditionsModel` (this module): the baseline's likelihood per condition (one
  :class:`~turgorbayes.inference.likelihood.CellLikelihood` per condition, its latent
  population deconvolved from that condition's bulges).
* :func:`~turgorbayes.workflows.conditions.fit_conditions`: the fit; one condition without
  freed parameters *is* :func:`turgorbayes.workflows.fit.fit_cells` (same code path,
  identical draws).
* :func:`condition_entries`, :func:`contrasts`: the ``conditions`` and ``contrasts`` of
  ``summary.json``; :func:`contrast_sentence` says a contrast in words
  (:mod:`turgorbayes.inference.condition_contrasts`, re-exported here).
"""

import contextlib
import dataclasses

import numpy as np

from turgorbayes.inference import models, priors, sampling
from turgorbayes.inference import population_noise as pop_noise
from turgorbayes.inference.condition_contrasts import (
    condition_entries,
    contrast_sentence,
    contrasts,
    modulus_variables,
    variable,
)
from turgorbayes.inference.condition_design import (
    CONDITION_COLUMN,
    FREEABLE,
    MIN_BULGED,
    PER_CONDITION,
    SEP,
    WALL_DIFFERENCE,
    WALL_PRIOR,
    ConditionSet,
    condition_labels,
    condition_set,
)
from turgorbayes.inference.context import LikelihoodContext, apply_effects
from turgorbayes.inference.engine import stream_rng
from turgorbayes.inference.likelihood import CellLikelihood
from turgorbayes.inference.mode import value_and_gradient
from turgorbayes.inference.observations import (
    DEFAULT_LATENT,
    latent_population,
    observations_from_cells,
    sample_latent,
    stiffness_sd,
)
from turgorbayes.inference.population import DeconvolvedPopulation

__all__ = [
    "CONDITION_COLUMN",
    "FREEABLE",
    "MIN_BULGED",
    "PER_CONDITION",
    "SEP",
    "WALL_DIFFERENCE",
    "WALL_PRIOR",
    "ConditionSet",
    "ConditionsModel",
    "condition_entries",
    "condition_labels",
    "condition_parameters",
    "condition_set",
    "contrast_sentence",
    "contrasts",
    "model_factory",
    "modulus_variables",
    "variable",
]


def condition_parameters(cs):
    """Model parameters: the shared wall, then each condition's own (priors as baseline),
    then the wall differences of the tied conditions (normal priors of ``wall_prior``)."""
    base = {p.name: p for p in models.BASELINE_PARAMETERS}
    shared = [base[q] for q in FREEABLE if any(not cs.own(q, c) for c in range(len(cs.names)))]
    own = [dataclasses.replace(base[q], name=cs.variable(q, c),
                               key=f"{base[q].key}[{cs.names[c]}]")
           for c in range(len(cs.names)) for q in cs.quantities(c)
           if not (cs.tied(q, c) or cs.released(q, c))]
    tied = [models.Parameter(cs.difference_variable(q, c), priors.Normal(0.0, cs.wall_prior[q]),
                             f"{WALL_DIFFERENCE[q]}[{cs.names[c]}]", 1.0, WALL_DIFFERENCE[q])
            for c in range(len(cs.names)) for q in FREEABLE if cs.tied(q, c)]
    return tuple(shared + own + tied)


def _sub_observations(obs, cells_idx, latent):
    """The :class:`CellObservations` of the cells ``cells_idx`` of ``obs`` (errors as pooled
    over the whole data set), with a latent population from their own bulges."""
    is_b = obs.is_bulged[cells_idx]
    rank = np.cumsum(obs.is_bulged) - 1  # position of each bulged cell among the bulged
    b = rank[cells_idx[is_b]]
    log_P, sd = obs.log_P_bulge[b], obs.sd_log_P_bulge[b]
    return dataclasses.replace(
        obs, is_bulged=is_b, R_c=obs.R_c[cells_idx], R_c_err=obs.R_c_err[cells_idx],
        k_c=obs.k_c[cells_idx], k_c_err=obs.k_c_err[cells_idx], log_P_bulge=log_P,
        sd_log_P_bulge=sd, bulged=np.flatnonzero(is_b), intact=np.flatnonzero(~is_b),
        population=latent_population(log_P, sd, latent),
        rho_R_k=None if obs.rho_R_k is None else np.asarray(obs.rho_R_k)[cells_idx])


@dataclasses.dataclass
class _Part:
    """One condition's cells (``idx`` into the data set), observations and likelihood."""

    idx: np.ndarray
    cells: object
    obs: object
    lik: CellLikelihood
    surrogate: object
    P0: float
    effects: tuple = ()

    @property
    def has_bulged(self):
        return self.obs.bulged.size > 0

    def context(self, v, skip=()):
        """The likelihood context of this condition's cells for physical values ``v``: its
        effects applied (a density-replacing one first, as in the extended model), those
        named in ``skip`` left out (the gross-error screen's interface of a model)."""
        return apply_effects(LikelihoodContext(v, v), self.effects, v, skip)


class ConditionsModel(models.BaselineModel):
    """The baseline with per-condition ``P_phys``, ``R0`` (and freed wall parameters).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
    surrogate : turgorbayes.surrogate.Surrogate
    conditions : ConditionSet
    n_nodes : int
    P0 : float [Pa]
    latent : str
    """

    name = "conditions"

    def __init__(self, cells, surrogate, conditions, n_nodes=models.DEFAULT_NODES,
                 P0=models.P0, latent=DEFAULT_LATENT):
        self.cells = cells.require_both_groups()
        self.surrogate = surrogate
        self.P0 = float(P0)
        self.conditions = conditions
        self.parameters = condition_parameters(conditions)
        self.latent = latent
        self.n_nodes = int(n_nodes)
        self.obs = observations_from_cells(cells, latent=latent)
        self.lik = None  # one per condition: self.parts
        self.parts = []
        for c in range(len(conditions.names)):
            idx = np.flatnonzero(conditions.index == c)
            obs = _sub_observations(self.obs, idx, latent)
            self.parts.append(_Part(idx, cells.take(idx), obs,
                                    CellLikelihood(obs, surrogate, n_nodes=n_nodes, P0=P0),
                                    surrogate, self.P0))

    def values(self, v, c):
        """``(P_phys, gamma, E0t, R0)`` ``(W,)`` of condition index ``c`` from physical ``v``
        (a tied wall: the reference's times ``exp(ln_E0t_ratio)``, plus ``gamma_difference``)."""
        cs = self.conditions

        def value(q):
            if cs.released(q, c):  # sampled shared; its own once released
                return v.get(cs.variable(q, c), v[cs.variable(q, cs.ref)])
            if not cs.tied(q, c):
                return v[cs.variable(q, c)]
            ref, d = v[cs.variable(q, cs.ref)], v[cs.difference_variable(q, c)]
            return ref * np.exp(d) if q == "E0t" else ref + d

        return tuple(value(q) for q in ("P_phys", "gamma", "E0t", "R0"))

    def _each(self, u):
        v = self.to_physical(u)
        for c, part in enumerate(self.parts):
            yield part, self.values(v, c)

    def pointwise_log_likelihood(self, u):
        """``(W, n_cells)``: each condition's cells under its own parameters."""
        out = np.empty((np.atleast_2d(u).shape[0], self.obs.n_cells))
        for part, (P, g, e, r) in self._each(u):
            if part.has_bulged:
                out[:, part.idx] = part.lik.pointwise(g, e, r, P)
            else:  # intact only: direct evaluation at P_phys
                out[:, part.idx] = part.lik.intact(g, e, r, P)
        return out

    def curves(self, u, P):
        """Model ``R_c(P)``, ``k_c(P)`` of the reference condition's wall ``(W, len(P))``."""
        _, g, e, r = self.values(self.to_physical(u), self.conditions.ref)
        return self.parts[0].lik.forward(np.log(np.asarray(P, float)), g, e, r)

    def cell_pressures(self, u):
        """``(W, n_cells)``: E[P_i | data_i, theta] (bulged), the condition's P_phys (intact)."""
        out = np.empty((np.atleast_2d(u).shape[0], self.obs.n_cells))
        for part, (P, g, e, r) in self._each(u):
            o = part.obs
            if part.has_bulged:
                out[:, part.idx[o.bulged]] = part.lik.latent_pressure_mean(g, e, r)
            out[:, part.idx[o.intact]] = P[:, None]
        return out

    def posterior_predictive(self, u, rng):
        """Replicated ``R_c``, ``k_c`` ``(W, n_cells)`` (as the baseline, per condition)."""
        W = np.atleast_2d(u).shape[0]
        R, k = np.empty((W, self.obs.n_cells)), np.empty((W, self.obs.n_cells))
        for part, (P, g, e, r) in self._each(u):
            o = part.obs
            log_P = np.empty((W, o.n_cells))
            if part.has_bulged:
                log_P[:, o.bulged] = sample_latent(o, rng, W)
            log_P[:, o.intact] = np.log(P)[:, None]
            R_c, k_c = part.lik.forward(log_P, g, e, r, walker_axis=True)
            R[:, part.idx] = R_c + o.R_c_err * rng.standard_normal(R_c.shape)
            k[:, part.idx] = k_c + stiffness_sd(k_c, o.k_c, o.k_c_err) * rng.standard_normal(
                k_c.shape)
        return {"R_c": R, "k_c": k}

    def derived(self, u, rng):
        """The reference condition's ``P_phys``, ``gamma``, ``E0t``, ``R0`` under their
        baseline names (what every single-condition output reads), and E_perp, E_par [Pa] of
        every condition at its own P_phys (:meth:`ConditionSet.modulus_variable`), with one
        lognormal wall thickness per draw shared by the conditions: the wall is the same
        material, so their ratio carries no thickness uncertainty."""
        v = self.to_physical(u)
        cs = self.conditions
        P, g, e, r = self.values(v, cs.ref)
        out = {k: a for k, a in zip(("P_phys", "gamma", "E0t", "R0"), (P, g, e, r),
                                    strict=True) if k not in v}
        for c in range(len(cs.names)):  # a tied or released wall under its own variable
            for q, x in zip(("gamma", "E0t"), self.values(v, c)[1:3], strict=True):
                if cs.tied(q, c) or cs.released(q, c):
                    out[cs.variable(q, c)] = x
        t = models.THICKNESS_MEDIAN * np.exp(models.THICKNESS_LOG_SD
                                             * rng.standard_normal(P.shape))
        for c in range(len(cs.names)):
            moduli = models.moduli_at_pressure(*self.values(v, c), t, self.P0)
            out.update(zip((cs.modulus_variable("E_perp", c), cs.modulus_variable("E_par", c)),
                           moduli, strict=True))
        return out

    def start_values(self, estimate):
        """Every parameter's starting value from the pooled least-squares ``estimate`` (no
        wall difference)."""
        return {p.name: estimate.get(p.name.split(SEP)[0], 0.0) for p in self.parameters}

    # ------------------------------------------------------------------ population noise
    @contextlib.contextmanager
    def using_population(self, c, population):
        """Condition ``c``'s latent population replaced inside the block."""
        part = self.parts[c]
        obs, lik = part.obs, part.lik
        part.obs = dataclasses.replace(obs, population=population)
        part.lik = CellLikelihood(part.obs, lik.surrogate, n_nodes=lik.n_nodes, P0=lik.P0)
        try:
            yield self
        finally:
            part.obs, part.lik = obs, lik

    def population_shift_covariance(self, u_map, cov, seed, n_boot=pop_noise.N_BOOTSTRAP):
        """``Sigma_g`` of :mod:`turgorbayes.inference.population_noise` summed over the
        conditions whose population is deconvolved from their bulges (independent
        resamples per condition: stream 2718 of ``seed`` keyed by the condition's label,
        :data:`turgorbayes.inference.engine.STREAMS`), ``(ndim, ndim)``."""
        total = np.zeros((u_map.size, u_map.size))
        g0 = value_and_gradient(self, u_map)[1]
        for c, part in enumerate(self.parts):
            if not isinstance(part.obs.population, DeconvolvedPopulation):
                continue
            # keyed by the condition's label, not by its place in the file
            rng = stream_rng(seed, 2718, self.conditions.names[c])
            shifts = []
            for pop in pop_noise.bootstrap_populations(part.obs.population, n_boot, rng):
                with self.using_population(c, pop):
                    shifts.append(cov @ (value_and_gradient(self, u_map)[1] - g0))
            total += np.cov(np.array(shifts), rowvar=False).reshape(cov.shape)
        return total

    # ------------------------------------------------------------------ screening
    def flag_cells(self, draws, cell_ids, n_draws, screen_cells):
        """Readings that look like gross errors, screened per condition at its own
        parameters by ``screen_cells`` (:func:`turgorbayes.effects.outliers.flagged_cells`, passed
        by :func:`turgorbayes.workflows.fit.flag_cells`) at ``n_draws`` draws."""
        flat = {n: np.asarray(draws[n]).reshape(-1) for n in self.names}
        keep = sampling.evenly_spaced(next(iter(flat.values())).size, n_draws)
        v = {n: a[keep] for n, a in flat.items()}
        flags = []
        for c, part in enumerate(self.parts):
            P, g, e, r = self.values(v, c)
            screen = part if part.has_bulged else self._with_bulged(part)
            ids = [cell_ids[i] for i in screen.idx]
            mine = {cell_ids[i] for i in part.idx}
            flags += [f for f in screen_cells(
                screen, {"P_phys": P, "gamma": g, "E0t": e, "R0": r}, ids)
                if f["cell_id"] in mine]
        return sorted(flags, key=lambda d: -d["score"])

    def _with_bulged(self, part):
        """``part`` (intact cells only) joined by the data set's bulged cells: the screen's
        engine integrates bulged cells, and each cell's screen depends only on its own
        readings and the parameters, so the intact cells' flags are theirs alone."""
        idx = np.concatenate([part.idx, self.obs.bulged])
        obs = _sub_observations(self.obs, idx, self.latent)
        return _Part(idx, self.cells.take(idx), obs,
                     CellLikelihood(obs, self.surrogate, n_nodes=self.n_nodes, P0=self.P0),
                     self.surrogate, self.P0)


# ---------------------------------------------------------------------- the fit
def model_factory(conditions):
    def build(cells, surrogate, n_nodes=None):
        return ConditionsModel(cells, surrogate, conditions,
                               n_nodes=models.DEFAULT_NODES if n_nodes is None else n_nodes)

    return models.ModelFactory(build, "baseline")
