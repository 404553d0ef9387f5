"""Several conditions, each measured as an osmotic series: its own turgor and its own wall.

Intact cells of every condition were measured in media of several known osmolarities (the
``condition`` and ``medium_mOsm`` columns). A condition's series measures its wall on its own
(the turgor moves by a known osmotic step, so how ``R_c`` and ``k_c`` follow tells the wall's
stiffness from the turgor), so no prior on how far the walls may differ is needed. Each
condition ``c`` has its own ``P_phys[c]`` (the turgor in the reference medium), ``E0t[c]`` and
``R0[c]``; the stiffening exponent ``gamma`` (unless freed per condition) and the
osmotically inactive fraction ``b`` are shared (docs/statistics.md, "Osmotic series",
"Conditions").

Each condition is an :class:`~turgorbayes.inference.osmotic.OsmoticModel` of its own cells
(its balance, its bulged cells' latent population, its errors pooled over its own cells);
:class:`OsmoticConditionsModel` hands each one its condition's values and joins the results.
Posterior variables follow :mod:`turgorbayes.inference.conditions` (``P_phys__1``,
``E0t__1`` ...), each condition's level turgors are ``P_level__k__c``.
"""

import collections
import dataclasses

import numpy as np

from turgorbayes.cells.medium import medium_levels, medium_osmolarity
from turgorbayes.errors import DataError
from turgorbayes.inference import models
from turgorbayes.inference import population_noise as pop_noise
from turgorbayes.inference.conditions import (
    CONDITION_COLUMN,
    SEP,
    condition_parameters,
    condition_set,
)
from turgorbayes.inference.engine import stream_rng
from turgorbayes.inference.likelihood import DEFAULT_NODES
from turgorbayes.inference.mode import value_and_gradient
from turgorbayes.inference.observations import DEFAULT_LATENT, observations_from_cells
from turgorbayes.inference.osmotic import (
    B_PARAMETER,
    B_PRIOR,
    OsmoticModel,
    level_variable,
    osmotic_design,
)
from turgorbayes.inference.osmotic_wls import OsmoticWLS
from turgorbayes.inference.population import DeconvolvedPopulation
from turgorbayes.physics import osmotic
from turgorbayes.physics.parameters import P0

__all__ = ["SHARED_PHRASES", "OsmoticConditionsModel", "OsmoticConditionsWLS",
           "condition_level_variable", "series_condition_set", "series_designs"]

#: The wall quantities of the baseline, in the order :class:`ConditionSet` lists them.
QUANTITIES = ("P_phys", "gamma", "E0t", "R0")
#: What the conditions of a series share besides ``gamma``, in words (each contrast's
#: ``assumes``).
SHARED_PHRASES = ("b shared", "same reference medium")


_B_MEAN = B_PRIOR.a / (B_PRIOR.a + B_PRIOR.b)
_B_SD = np.sqrt(B_PRIOR.a * B_PRIOR.b / ((B_PRIOR.a + B_PRIOR.b) ** 2 * (B_PRIOR.a + B_PRIOR.b + 1)))


def condition_level_variable(k, c):
    """Posterior variable of the turgor at medium level ``k`` of condition index ``c``
    (``P_level__k__c``; ``k`` indexes that condition's own levels)."""
    return f"{level_variable(k)}{SEP}{c}"


def series_condition_set(cells, reference=None, per_condition=()):
    """The :class:`~turgorbayes.inference.conditions.ConditionSet` of conditions measured as
    osmotic series: ``E0t`` of every condition its own, ``gamma`` too with ``per_condition``
    ``"gamma"`` (or ``"gamma:NAME"``), no wall prior.

    Raises
    ------
    DataError
        Unknown reference or condition, a quantity that cannot be freed.
    """
    cs = condition_set(cells, reference)
    freed = {"E0t": cs.names}
    for spec in per_condition:
        quantity, _, which = str(spec).partition(":")
        if quantity == "E0t":
            continue  # every condition's own already
        if quantity != "gamma":
            raise DataError(f"--per-condition {spec!r}: with osmotic series E0t is every "
                            "condition's own; only gamma can be freed too", value=spec)
        if which and which not in cs.names:
            raise DataError(f"--per-condition {spec!r}: no condition {which!r} in the data "
                            f"(conditions: {', '.join(map(repr, cs.names))})", path=cells.path,
                            column=CONDITION_COLUMN, value=which)
        freed["gamma"] = tuple(dict.fromkeys(freed.get("gamma", ()) + ((which,) if which
                                                                       else cs.names)))
    series = tuple(_levels_of(cells, cs.index == c).size > 1 for c in range(len(cs.names)))
    return dataclasses.replace(cs, freed=freed, series=series, shared=SHARED_PHRASES)


def _levels_of(cells, mask):
    """The distinct media [mOsm] of the intact cells in ``mask``."""
    c = medium_osmolarity(cells)
    intact = mask & ~np.asarray(cells.is_bulged, bool)
    return np.unique(c[intact]) if c is not None else np.empty(0)


def series_designs(cells, conditions, reference_medium=None, temperature=osmotic.T_DEFAULT,
                   length_model="wall"):
    """Each condition's :class:`~turgorbayes.inference.osmotic.OsmoticDesign` (the reference
    medium the same for all: default the lowest level of the intact cells).

    Raises
    ------
    DataError
        A condition without intact cells, or whose intact cells were all measured in one
        medium and that has no bulged cells (its wall is not identified), or without intact
        cells in the reference medium.
    """
    reference = float(medium_levels(cells)[0]) if reference_medium is None else float(
        reference_medium)
    out = []
    for c, name in enumerate(conditions.names):
        sub = cells.take(np.flatnonzero(conditions.index == c))
        levels = _levels_of(sub, np.ones(len(sub), bool))
        if levels.size == 0:
            raise DataError(f"condition {name!r} has no intact cells: an osmotic series is a "
                            "series of intact cells", path=cells.path, column=CONDITION_COLUMN,
                            value=name)
        if levels.size < 2 and sub.n_bulged == 0:
            raise DataError(
                f"condition {name!r}: its intact cells were all measured at {levels[0]:g} "
                "mOsm and it has no bulged cells, so its wall is not identified (one medium "
                "level cannot tell its wall from its turgor); measure its intact cells at two "
                "or more osmolarities, or add bulged cells", path=cells.path,
                column=CONDITION_COLUMN, value=name)
        if not np.any(levels == reference):
            raise DataError(
                f"condition {name!r} has no intact cells at the reference medium "
                f"{reference:g} mOsm (its levels: {', '.join(f'{x:g}' for x in levels)} mOsm); "
                "every condition's P_phys is its turgor there (--reference-medium)",
                path=cells.path, column=CONDITION_COLUMN, value=name)
        out.append(osmotic_design(sub, reference, temperature, length_model))
    return out


def wall_references(conditions, names):
    """Each condition's ``(gamma, E0t, R0, P_phys)`` names where its ``E0t``, ``R0`` and
    ``P_phys`` are sampled parameters of its own (a wall shared with another condition, or
    tied to it, stays at ``P0``): sampled at its reference turgor
    (:mod:`turgorbayes.inference.wall_reference`)."""
    groups = [tuple(conditions.variable(q, c) for q in ("gamma", "E0t", "R0", "P_phys"))
              for c in range(len(conditions.names))]
    uses = collections.Counter(n for g in groups for n in g[1:])
    return tuple(g for g in groups if set(g) <= set(names) and all(uses[n] == 1 for n in g[1:]))


class OsmoticConditionsModel(models.BaselineModel):
    """Several conditions, each an osmotic series with its own turgor and wall (module
    docstring).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
        With ``condition`` and ``medium_mOsm``.
    surrogate : turgorbayes.surrogate.Surrogate
    conditions : turgorbayes.inference.conditions.ConditionSet
        From :func:`series_condition_set`.
    designs : list of OsmoticDesign
        Each condition's (:func:`series_designs`).
    n_nodes : int
    P0 : float [Pa]
    latent : str
    """

    name = "osmotic_conditions"

    def __init__(self, cells, surrogate, conditions, designs, n_nodes=DEFAULT_NODES, P0=P0,
                 latent=DEFAULT_LATENT):
        self.cells, self.surrogate, self.P0 = cells, surrogate, float(P0)
        self.conditions, self.designs, self.latent = conditions, list(designs), latent
        self.obs = observations_from_cells(cells, latent=latent)
        self.lik = None  # one per condition: self.parts
        self.index = [np.flatnonzero(conditions.index == c) for c in range(len(conditions.names))]
        self.parts = [OsmoticModel(cells.take(idx), surrogate, d, n_nodes=n_nodes, P0=P0,
                                   latent=latent) for idx, d in zip(self.index, self.designs,
                                                                    strict=True)]
        has_b = any(d.n_levels > 1 for d in self.designs)
        self.parameters = condition_parameters(conditions) + ((B_PARAMETER,) if has_b else ())
        self.wall_references = wall_references(conditions, self.names)

    # ------------------------------------------------------------------ values
    def values(self, v, c):
        """Condition index ``c``'s physical values (``gamma``, ``E0t``, ``R0``, ``P_phys`` and
        ``b`` if sampled) from the model's ``v``: the names of its part's
        :class:`~turgorbayes.inference.osmotic.OsmoticModel`."""
        out = {q: v[self.conditions.variable(q, c)] for q in QUANTITIES}
        if "b" in v:
            out["b"] = v["b"]
        return out

    def reference_values(self, v):
        """The reference condition's values under the baseline names (those missing from
        ``v``): what single-condition outputs read."""
        ref = self.values(v, self.conditions.ref)
        return {q: ref[q] for q in QUANTITIES if q not in v}

    def _each(self, u):
        v = self.to_physical(u)
        for c, part in enumerate(self.parts):
            yield self.index[c], part, self.values(v, c)

    # ------------------------------------------------------------------ likelihood
    def pointwise_log_likelihood(self, u):
        """``(W, n_cells)``: each condition's cells under its own values."""
        out = np.empty((np.atleast_2d(u).shape[0], self.obs.n_cells))
        for idx, part, v in self._each(u):
            out[:, idx] = part.log_likelihood_at(v)
        return out

    def cell_pressures(self, u):
        """``(W, n_cells)``: each condition's cells as its series model says [Pa]."""
        out = np.empty((np.atleast_2d(u).shape[0], self.obs.n_cells))
        for idx, part, v in self._each(u):
            out[:, idx] = part.cell_pressures_at(v)
        return out

    def posterior_predictive(self, u, rng):
        """Replicated ``R_c``, ``k_c`` ``(W, n_cells)``, each condition by its series model."""
        W = np.atleast_2d(u).shape[0]
        out = {"R_c": np.empty((W, self.obs.n_cells)), "k_c": np.empty((W, self.obs.n_cells))}
        for idx, part, v in self._each(u):
            for name, rep in part.posterior_predictive_at(v, rng).items():
                out[name][:, idx] = rep
        return out

    def curves(self, u, P):
        """Model ``R_c(P)``, ``k_c(P)`` of the reference condition's wall ``(W, len(P))``."""
        v = self.values(self.to_physical(u), self.conditions.ref)
        lik = self.parts[self.conditions.ref].lik
        return lik.forward(np.log(np.asarray(P, float)), v["gamma"], v["E0t"], v["R0"])

    def derived(self, u, rng):
        """The reference condition's values under the baseline names, every condition's
        wall moduli at its own ``P_phys`` (one lognormal thickness per draw for all: the
        ratio of two conditions' moduli is the ratio of their ``E0t``-scaled walls), and its
        level turgors (``P_level__k__c``) and buffering factor (``buffering__c``)."""
        v = self.to_physical(u)
        cs = self.conditions
        out = self.reference_values(v)
        t = models.THICKNESS_MEDIAN * np.exp(models.THICKNESS_LOG_SD
                                             * rng.standard_normal(len(v["gamma"])))
        for c, part in enumerate(self.parts):
            x = self.values(v, c)
            moduli = models.moduli_at_pressure(x["P_phys"], x["gamma"], x["E0t"], x["R0"], t,
                                               self.P0)
            out.update(zip((cs.modulus_variable("E_perp", c), cs.modulus_variable("E_par", c)),
                           moduli, strict=True))
            series = part.series_at(x)
            out.update({condition_level_variable(k, c): series[level_variable(k)]
                        for k in range(part.design.n_levels)})
            out[f"buffering{SEP}{c}"] = series["buffering"]
        return out

    # ------------------------------------------------------------------ hooks
    def least_squares(self):
        """The joint weighted least squares of the conditions (:class:`OsmoticConditionsWLS`)."""
        return OsmoticConditionsWLS(self)

    def start_values(self, guess):
        """Every parameter's start from a guess with the model's names (``b`` at its prior
        mean unless given)."""
        out = dict(guess)
        out.setdefault("b", _B_MEAN)
        return {p.name: out[p.name] for p in self.parameters}

    def population_shift_covariance(self, u_map, cov, seed, n_boot=pop_noise.N_BOOTSTRAP):
        """``Sigma_g`` summed over the conditions whose bulged cells' population was
        deconvolved (stream 2718 of ``seed`` keyed by the condition's label); zeros without
        bulged cells."""
        total = np.zeros((u_map.size, u_map.size))
        g0 = None
        for c, part in enumerate(self.parts):
            if not isinstance(part.obs.population, DeconvolvedPopulation):
                continue
            g0 = value_and_gradient(self, u_map)[1] if g0 is None else g0
            rng = stream_rng(seed, 2718, self.conditions.names[c])
            shifts = []
            for pop in pop_noise.bootstrap_populations(part.obs.population, n_boot, rng):
                with pop_noise.using_population(part, pop):
                    shifts.append(cov @ (value_and_gradient(self, u_map)[1] - g0))
            total += np.cov(np.array(shifts), rowvar=False).reshape(cov.shape)
        return total

    def flag_cells(self, draws, cell_ids, n_draws, screen_cells):
        """The gross-error screen of each condition's series model at its own draws."""
        flags, mine = [], {n: draws[n] for n in self.names}
        for c, part in enumerate(self.parts):
            sub = self.values(mine, c)
            ids = [cell_ids[i] for i in self.index[c]]
            flags += part.flag_cells(sub, ids, n_draws, screen_cells)
        return sorted(flags, key=lambda d: -d["score"])


class OsmoticConditionsWLS(models.PaperWLS):
    """Weighted least squares of an :class:`OsmoticConditionsModel`: every condition's
    readings (:meth:`OsmoticWLS.reading_residuals` at its values), then ``b``'s prior once.
    The estimate holds the reference condition's values under the baseline names too (the
    report's least-squares column).

    Parameters
    ----------
    model : OsmoticConditionsModel
    """

    name = "osmotic_wls"

    def __init__(self, model):
        self.model = model
        self.cells, self.surrogate, self.P0 = model.cells, model.surrogate, model.P0
        self.parameters = model.parameters
        self.parts = [OsmoticWLS(part) for part in model.parts]
        self.obs = observations_from_cells(model.cells, relative_errors="reported")
        self._with_b = "b" in model.names

    def to_physical(self, u):
        """Physical values with the reference condition's under the baseline names."""
        v = super().to_physical(u)
        v.update(self.model.reference_values(v))
        return v

    def residuals(self, u):
        """Weighted residuals: each condition's R_c then k_c, in condition order, then b's."""
        v = {k: a[:1] for k, a in self.to_physical(u).items()}
        r = [w.reading_residuals(self.model.values(v, c)) for c, w in enumerate(self.parts)]
        if self._with_b:
            r.append([(v["b"][0] - _B_MEAN) / _B_SD])
        return np.concatenate(r)

    def _starts(self):
        """Each condition's own starts (the same stiffening exponents in the same order),
        joined; a shared ``gamma`` from the reference condition's."""
        cs = self.model.conditions
        for starts in zip(*(w._starts() for w in self.parts), strict=True):
            out = {}
            for c, start in enumerate(starts):
                for q in QUANTITIES:
                    name = cs.variable(q, c)
                    if name not in out or c == cs.ref:
                        out[name] = start[q]
            if self._with_b:
                out["b"] = _B_MEAN
            yield out

    def fit(self, starts=None, loss="linear"):
        """As :meth:`PaperWLS.fit`; the reference condition's sds under the baseline names
        too."""
        result = super().fit(starts, loss)
        cs = self.model.conditions
        for q in QUANTITIES:
            result.sd.setdefault(q, result.sd[cs.variable(q, cs.ref)])
        return result
