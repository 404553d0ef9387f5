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

* :func:`condition_labels`, :class:`ConditionSet`: the labels, checked, and the design.
* :class:`ConditionsModel`: the baseline's likelihood per condition (one
  :class:`~turgorbayes.inference.likelihood.CellLikelihood` per condition, its latent
  population deconvolved from that condition's bulges).
* :func:`fit_conditions`: the fit; one condition without freed parameters *is*
  :func:`turgorbayes.workflows.fit.fit_cells` (same code path, identical draws).
* :func:`condition_entries`, :func:`contrasts`: the ``conditions`` and ``contrasts`` of
  ``summary.json``; :func:`contrast_sentence` says a contrast in words.
"""

import contextlib
import dataclasses

import numpy as np

from turgorbayes.errors import DataError
from turgorbayes.inference import models, priors, sampling
from turgorbayes.inference import population_noise as pop_noise
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
from turgorbayes.physics.parameters import QUANTITIES

__all__ = [
    "CONDITION_COLUMN",
    "FREEABLE",
    "MIN_BULGED",
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

#: The optional cell-data column naming each cell's experimental condition.
CONDITION_COLUMN = "condition"
#: Parameters that are per condition in every condition model.
PER_CONDITION = ("P_phys", "R0")
#: Wall parameters ``per_condition`` may free (shared otherwise).
FREEABLE = ("gamma", "E0t")
#: Posterior-variable separator: ``P_phys__1`` is P_phys of the condition with index 1.
SEP = "__"
#: The default prior on how far a condition's wall may differ from the reference's: the sd
#: of ``ln(E0t[c] / E0t[ref])`` and of ``gamma[c] - gamma[ref]`` (docs/statistics.md, "A wall
#: that may differ"): treatments and mutants change the E. coli envelope's stiffness by tens
#: of percent, rarely by more than a factor of two, so an E0t ratio of 0.7 or 1.4 is one sd
#: and 0.5 or 2 two sd; gamma has no published treatment series, 0.2 is 1.7 times the
#: paper's own uncertainty of gamma (1.22 +- 0.12).
WALL_PRIOR = {"E0t": 0.35, "gamma": 0.2}
#: Bulged cells a condition needs for its own wall to be checked (the ``conditions_R_c_k_c``
#: check) or estimated as a criticism candidate (:mod:`turgorbayes.effects.own_wall`).
MIN_BULGED = 4
#: The sampled wall difference of each prior-tied quantity: name and the map to the value.
_DIFF = {"E0t": "ln_E0t_ratio", "gamma": "gamma_difference"}


def condition_labels(cells):
    """Each cell's condition label (tuple of str), or None without a ``condition`` column.

    Raises
    ------
    DataError
        A cell with an empty label (file, column and the cells named).
    """
    labels = cells.extra.get(CONDITION_COLUMN)
    if labels is None:
        return None
    empty = [cid for cid, lab in zip(cells.cell_id, labels, strict=True) if not lab.strip()]
    if empty:
        raise DataError(
            f"empty condition for cell_id {', '.join(map(repr, empty[:5]))}"
            f"{f' and {len(empty) - 5} more' if len(empty) > 5 else ''}; every row needs its "
            "condition (any non-empty text, e.g. wt or treated)",
            path=cells.path, column=CONDITION_COLUMN, value="")
    return tuple(lab.strip() for lab in labels)


@dataclasses.dataclass(frozen=True)
class ConditionSet:
    """The conditions of a data set and which parameters each one has of its own.

    Attributes
    ----------
    names : tuple of str
        Conditions in file order (of their first row).
    index : ndarray of int (n_cells,)
        Each cell's condition, an index into ``names``.
    reference : str
        The condition every contrast is taken against.
    freed : dict
        Quantity in :data:`FREEABLE` -> tuple of the conditions that have their own (flat
        prior).
    wall_prior : dict
        Quantity in :data:`FREEABLE` -> sd of its difference from the reference condition's
        (:data:`WALL_PRIOR`); every other condition's, unless freed, is tied to the
        reference's by that prior. Empty: the wall is shared.
    bulged : tuple of bool
        Whether each condition has bulged cells (only they measure its pressure directly).
    series : tuple of bool
        Whether each condition's intact cells were measured in media of several
        osmolarities (an osmotic series, which measures its wall without bulged cells:
        :mod:`turgorbayes.inference.osmotic_conditions`); empty: none was.
    shared : tuple of str
        What else the conditions share, in words, for :meth:`assumptions` (e.g. the
        osmotically inactive fraction of a series).
    """

    names: tuple
    index: np.ndarray
    reference: str
    freed: dict
    wall_prior: dict = dataclasses.field(default_factory=dict)
    bulged: tuple = ()
    series: tuple = ()
    shared: tuple = ()

    @property
    def ref(self):
        """Index of the reference condition."""
        return self.names.index(self.reference)

    def own(self, quantity, c):
        """Whether condition index ``c`` has its own ``quantity`` (else the shared one)."""
        return (quantity in PER_CONDITION or self.names[c] in self.freed.get(quantity, ())
                or self.tied(quantity, c) or self.released(quantity, c))

    def _prior_wall(self, quantity, c):
        return (quantity in self.wall_prior and c != self.ref
                and self.names[c] not in self.freed.get(quantity, ()))

    def tied(self, quantity, c):
        """Whether condition index ``c``'s ``quantity`` is sampled as the reference's times
        (E0t) or plus (gamma) a difference under :attr:`wall_prior`: a condition with bulged
        cells, whose data inform its wall."""
        return self._prior_wall(quantity, c) and self.has_bulged(c)

    def released(self, quantity, c):
        """Whether condition index ``c``'s ``quantity`` differs from the reference's under
        :attr:`wall_prior` although its data cannot tell (no bulged cells): sampled shared,
        then released by :mod:`turgorbayes.inference.wall_release`."""
        return self._prior_wall(quantity, c) and not self.has_bulged(c)

    def has_bulged(self, c):
        """Whether condition index ``c`` has bulged cells (True when not recorded)."""
        return bool(self.bulged[c]) if self.bulged else True

    def measures_wall(self, c):
        """Whether condition index ``c``'s own data measure its wall: bulged cells, or an
        osmotic series of intact cells."""
        return self.has_bulged(c) or bool(self.series and self.series[c])

    def difference_variable(self, quantity, c):
        """The sampled difference of a tied ``quantity`` of condition index ``c``."""
        return f"{_DIFF[quantity]}{SEP}{c}"

    def assumptions(self, c):
        """What the contrast of condition index ``c`` against the reference assumes about
        the wall (list of phrases, then :attr:`shared`) and whether the data check it
        (bool): bulged cells or an osmotic series in both conditions measure each one's
        wall."""
        out = []
        for q in FREEABLE:
            if self._prior_wall(q, c):
                sd = self.wall_prior[q]
                out.append(f"ln({q} ratio) ~ N(0, {sd:g})" if q == "E0t"
                           else f"{q} difference ~ N(0, {sd:g})")
            elif not self.own(q, c) and not self.own(q, self.ref):
                out.append(f"{q} shared")
        return out + list(self.shared), self.measures_wall(c) and self.measures_wall(self.ref)

    def variable(self, quantity, c):
        """Posterior variable of ``quantity`` in condition index ``c``."""
        return f"{quantity}{SEP}{c}" if self.own(quantity, c) else quantity

    def quantities(self, c):
        """The quantities condition index ``c`` has of its own, in (P, gamma, E0t, R0) order."""
        return tuple(q for q in ("P_phys", "gamma", "E0t", "R0") if self.own(q, c))

    def modulus_variable(self, name, c):
        """Posterior variable of the wall modulus ``name`` (``"E_perp"``, ``"E_par"``) at
        condition index ``c``'s own turgor: the baseline name for the reference condition."""
        return name if c == self.ref else f"{name}{SEP}{c}"


def condition_set(cells, reference=None, per_condition=(), wall_prior=None):
    """The :class:`ConditionSet` of ``cells`` (one condition ``"all"`` without the column).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
    reference : str, optional
        The reference condition; the first in file order if None.
    per_condition : sequence of str
        ``"E0t"`` / ``"gamma"`` (every condition has its own) or ``"E0t:NAME"`` (condition
        NAME only).
    wall_prior : dict, optional
        ``{"E0t": sd, "gamma": sd}`` (a subset): each other condition's wall may differ from
        the reference's under that prior (:data:`WALL_PRIOR`); None or empty: one wall.

    Raises
    ------
    DataError
        Unknown reference or condition; a freed parameter in a condition without bulged
        cells (its data cannot identify it).
    """
    labels = condition_labels(cells) or ("all",) * len(cells)
    names = tuple(dict.fromkeys(labels))
    index = np.array([names.index(lab) for lab in labels], dtype=int)
    if reference is None:
        reference = names[0]
    if reference not in names:
        raise DataError(f"reference condition {reference!r} is not in the data (conditions: "
                        f"{', '.join(map(repr, names))})", path=cells.path,
                        column=CONDITION_COLUMN, value=reference)
    freed = _freed(cells, names, index, per_condition)
    prior = _wall_prior(wall_prior)
    bulged = tuple(bool(np.any(cells.is_bulged[index == c])) for c in range(len(names)))
    return ConditionSet(names=names, index=index, reference=reference, freed=freed,
                        wall_prior=prior if len(names) > 1 else {}, bulged=bulged)


def _wall_prior(wall_prior):
    prior = dict(wall_prior or {})
    for q, sd in prior.items():
        if q not in FREEABLE:
            raise DataError(f"wall prior: {q!r} is not a wall parameter (only "
                            f"{' and '.join(FREEABLE)} may differ between conditions)", value=q)
        if not np.isfinite(sd) or sd <= 0:
            raise DataError(f"wall prior: the sd of {q}'s difference must be a positive number, "
                            f"got {sd!r} (use --assume-shared-wall for one wall)", value=sd)
    return {q: float(prior[q]) for q in FREEABLE if q in prior}


def _freed(cells, names, index, per_condition):
    freed = {}
    for spec in per_condition:
        quantity, _, which = str(spec).partition(":")
        if quantity not in FREEABLE:
            raise DataError(f"--per-condition {spec!r}: only {' and '.join(FREEABLE)} can be "
                            "freed per condition (P_phys and R0 always are)", value=spec)
        chosen = names if not which else (which,)
        for name in chosen:
            if name not in names:
                raise DataError(f"--per-condition {spec!r}: no condition {name!r} in the data "
                                f"(conditions: {', '.join(map(repr, names))})", path=cells.path,
                                column=CONDITION_COLUMN, value=name)
            c = names.index(name)
            if not np.any(cells.is_bulged[index == c]):
                raise DataError(
                    f"--per-condition {spec!r} refused: condition {name!r} has no bulged cells, "
                    f"and without them its data cannot tell its own {quantity} from its turgor "
                    "(only bulges measure a cell's pressure)", path=cells.path,
                    column=CONDITION_COLUMN, value=name)
            freed[quantity] = tuple(dict.fromkeys(freed.get(quantity, ()) + (name,)))
    return freed


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
                             f"{_DIFF[q]}[{cs.names[c]}]", 1.0, _DIFF[q])
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


def _stats(x, fields=("mean", "sd", "q05", "q50", "q95")):
    x = np.asarray(x, float).ravel()
    q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
    out = {"mean": float(np.mean(x)), "sd": float(np.std(x, ddof=1)), "q05": float(q05),
           "q50": float(q50), "q95": float(q95)}
    return {k: out[k] for k in fields}


def variable(result, quantity, c, conditions=None):
    """The posterior variable of ``quantity`` in condition index ``c`` of a fit (the baseline
    name when the fit took the single-condition path)."""
    name = (result.conditions if conditions is None else conditions).variable(quantity, c)
    return name if name in result.draws else quantity


def _draws(result, quantity, c, conditions=None):
    """Draws of ``quantity`` in condition index ``c`` in summary units (kPa, nm ...)."""
    return np.asarray(result.draws[variable(result, quantity, c, conditions)], float) / QUANTITIES[
        quantity].factor


def modulus_variables(result, c):
    """``{"E_perp": variable, "E_par": variable}`` of condition index ``c`` in a fit's draws
    (the moduli at its own turgor; empty where the fit has none, e.g. a single condition's
    E_perp under another name)."""
    names = {m: result.conditions.modulus_variable(m, c) for m in ("E_perp", "E_par")}
    return {m: n for m, n in names.items() if n in result.draws}


def condition_entries(result):
    """``summary["conditions"]``: condition -> {key: {mean, sd, q05, q50, q95}} of each of
    its own quantities (``P_phys_kPa``, ``R0_nm`` and any freed one), then the wall moduli at
    its own turgor (``E_perp_MPa``, ``E_par_MPa``)."""
    cs = result.conditions

    def entry(q, name):  # statistics in SI, then the unit: as summary.json's parameters
        x = np.asarray(result.draws[name], float)
        return {k: v / QUANTITIES[q].factor for k, v in _stats(x).items()}

    # a wall quantity another condition has of its own: the reference's too, to compare
    walls = [q for q in FREEABLE if any(cs.own(q, c) for c in range(len(cs.names)))]

    def quantities(c):
        return cs.quantities(c) + tuple(q for q in walls if c == cs.ref and not cs.own(q, c))

    return {name: {**{QUANTITIES[q].key: entry(q, variable(result, q, c))
                      for q in quantities(c)},
                   **{QUANTITIES[m].key: entry(m, n) for m, n in modulus_variables(result, c).items()}}
            for c, name in enumerate(cs.names)}


def contrasts(result, conditions=None):
    """``summary["contrasts"]``: each condition against the reference, per own quantity.

    Returns
    -------
    list of dict
        ``{"condition", "reference", "quantity", "difference", "ratio", "prob_greater",
        "assumes", "checked_by_data"}``; ``difference`` (condition - reference, summary
        units) and ``ratio`` (condition / reference) with mean, q05, q50, q95 of the joint
        posterior draws; ``prob_greater`` the posterior probability that the condition's
        value is the larger; ``assumes`` what the model assumes of the two walls and
        ``checked_by_data`` whether the data can test it (:meth:`ConditionSet.assumptions`).
        ``conditions`` (a :class:`ConditionSet` of the same data) replaces the fit's: the
        contrasts of the shared-wall draws under that design's assumptions.
    """
    cs = result.conditions if conditions is None else conditions
    fields = ("mean", "q05", "q50", "q95")
    out = []
    for c, name in enumerate(cs.names):
        if c == cs.ref:
            continue
        for q in cs.quantities(c):
            x, ref = _draws(result, q, c, cs), _draws(result, q, cs.ref, cs)
            assumes, checked = cs.assumptions(c)
            out.append({"condition": name, "reference": cs.reference,
                        "quantity": QUANTITIES[q].key, "difference": _stats(x - ref, fields),
                        "ratio": _stats(x / ref, fields),
                        "prob_greater": float(np.mean(x > ref)),
                        "assumes": assumes, "checked_by_data": checked})
    return out


def contrast_sentence(contrast):
    """A contrast in words: ``"P_phys of treated is 6.1 kPa lower than wt [3.9, 8.4],
    probability 0.999"`` (the 90 % interval of the size of the difference, the probability
    of the direction stated)."""
    key = contrast["quantity"]
    if key == QUANTITIES["E0t"].key:  # a stiffness scale: its ratio says it
        r = contrast["ratio"]
        return (f"E0t of {contrast['condition']} is {r['q50']:.3g} times {contrast['reference']}'s "
                f"[{r['q05']:.3g}, {r['q95']:.3g}], probability "
                f"{max(contrast['prob_greater'], 1 - contrast['prob_greater']):.3f} that it is "
                f"{'larger' if contrast['prob_greater'] >= 0.5 else 'smaller'}")
    name, _, unit = key.rpartition("_")
    if name not in ("P_phys", "R0", "E0t", "gamma"):
        name, unit = key, ""
    d = contrast["difference"]
    lower = d["q50"] < 0
    sign = -1 if lower else 1
    lo, hi = sorted((sign * d["q05"], sign * d["q95"]))
    p = 1 - contrast["prob_greater"] if lower else contrast["prob_greater"]
    unit = {"kPa": " kPa", "nm": " nm", "N_per_m": " N/m", "": ""}.get(unit, " " + unit)
    return (f"{name} of {contrast['condition']} is {abs(d['q50']):.3g}{unit} "
            f"{'lower' if lower else 'higher'} than {contrast['reference']} "
            f"[{lo:.3g}, {hi:.3g}], probability {p:.3f}")
