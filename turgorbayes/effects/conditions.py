"""The criticism's models for data with several conditions: :class:`ConditionsExtendedModel`.

The baseline with conditions (:class:`turgorbayes.inference.conditions.ConditionsModel`: the
wall ``gamma``, ``E0t`` shared, each condition its own ``P_phys`` and ``R0``) plus a list of
effects. Each condition's cells are one :class:`~turgorbayes.effects.ExtendedModel` on that
condition's observations (its own latent-pressure population), evaluated at that condition's
``P_phys``, ``R0`` and the shared wall; an effect's parameters are shared by the conditions
and the effect acts within each condition (docs/effects.md, "Several conditions"):

* a population property (``turgor_spread``, ``radius_spread``) spreads each condition's cells
  about that condition's own ``P_phys`` or ``R0``, with one spread for every condition;
* ``calibration`` keeps one factor per measurement session across the conditions (a session
  may hold cells of several conditions): the effect is bound to the whole data set and each
  condition sees its own cells' sessions (:meth:`turgorbayes.effects.base.Effect.restrict`);
* the effects of the readings (``outliers``, ``bad_curves``, ``heavy_tails``,
  ``pressure_error``, ``discrepancy``) and of the wall model (``wall_softening``,
  ``outer_membrane``, ``tip_radius``, ``wall_thickness``) act on every cell with one size.

Effects listed in :data:`NOT_CONDITION_AWARE` are not candidates for data with several
conditions (:func:`conditions_reason`).
"""

import dataclasses

import numpy as np

from turgorbayes.effects import outliers
from turgorbayes.effects.model import ExtendedModel
from turgorbayes.effects.registry import get_effect, model_name
from turgorbayes.inference import models
from turgorbayes.inference.conditions import (
    FREEABLE,
    SEP,
    ConditionsModel,
    condition_labels,
    condition_set,
)
from turgorbayes.inference.likelihood import DEFAULT_NODES
from turgorbayes.inference.observations import DEFAULT_LATENT
from turgorbayes.physics.parameters import P0

__all__ = ["NOT_CONDITION_AWARE", "ConditionsExtendedModel", "conditions_reason",
           "has_conditions", "own_walls"]

#: Effects that are not candidates for data with several conditions, with the reason.
NOT_CONDITION_AWARE = {
    "pressure_range": (
        "its population of the bulged cells' pressures is one for the whole data set, while "
        "with several conditions each condition's population is estimated from its own bulges"),
}

#: The per-condition quantities of the baseline with conditions.
_OWN = ("P_phys", "R0")


def has_conditions(cells):
    """Whether ``cells`` hold more than one condition (a ``condition`` column with at least
    two labels)."""
    return len(set(condition_labels(cells) or ())) > 1


def conditions_reason(effect, cells, design=None):
    """Why ``effect`` (a name or :class:`~turgorbayes.effects.base.Effect`) is not a candidate
    for ``cells`` because they hold several conditions (one phrase), or None: not made
    condition-aware, or (with the criticism's ``design``, a
    :class:`~turgorbayes.inference.conditions.ConditionSet`) a wall ratio of its own for a
    wall quantity that ``--per-condition`` already frees."""
    name = effect if isinstance(effect, str) else effect.name
    if name in NOT_CONDITION_AWARE and has_conditions(cells):
        return f"not made condition-aware yet: {NOT_CONDITION_AWARE[name]}"
    e = get_effect(effect) if isinstance(effect, str) else effect
    if design is not None and design.freed and e.applicable(cells):
        freed = own_walls(design)
        clash = [f"{q} of {design.names[c]}" for q, c in e.bind(cells).wall_ratios()
                 if c in freed.get(q, ())]
        if clash:
            return f"--per-condition already frees {', '.join(clash)}"
    return None


def own_walls(cs):
    """``{quantity: (condition index, ...)}``: the conditions other than the reference whose
    wall ``quantity`` is a parameter of their own in :class:`ConditionsExtendedModel`."""
    out = {}
    for q, chosen in cs.freed.items():
        own = {cs.names.index(n) for n in chosen} - {cs.ref}
        if cs.reference in chosen and len(chosen) < len(cs.names):
            if len(cs.names) > 2:
                raise ValueError(
                    f"--per-condition {q}:{cs.reference} frees the reference condition's "
                    f"{q} alone, which the criticism's models cannot name with three or more "
                    f"conditions: free {q} of the other conditions instead (e.g. "
                    f"--per-condition {q}:{next(n for n in cs.names if n != cs.reference)})")
            own = set(range(len(cs.names))) - {cs.ref}  # two conditions: the same model
        if own:
            out[q] = tuple(sorted(own))
    return out


class ConditionsExtendedModel(models.BaselineModel):
    """The baseline with conditions plus a list of effects (module docstring).

    Parameters: the baseline's four under their own names are the reference condition's
    (``P_phys``, ``R0``) and the shared wall, so every single-condition output reads them;
    then ``P_phys__c``, ``R0__c`` of every other condition index ``c``; then the effects'.

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
    surrogate : turgorbayes.surrogate.Surrogate
    effects : sequence of str or Effect
    n_nodes : int
    P0 : float [Pa]
    latent : str
    conditions : turgorbayes.inference.conditions.ConditionSet, optional
        The design (default: :func:`~turgorbayes.inference.conditions.condition_set` of
        ``cells``, reference the first condition). A freed wall quantity (``E0t`` or
        ``gamma``, ``criticize --per-condition``) of a condition other than the reference is
        its own parameter ``E0t__c`` (key ``E0t_N_per_m[NAME]``, the baseline's prior); the
        reference keeps the baseline's, which every condition not freed shares. Freeing the
        reference alone is the same model as freeing the other condition when there are two,
        and is refused with three or more (the shared wall would need a name of its own).
    """

    bayesian = True

    def __init__(self, cells, surrogate, effects=(), n_nodes=DEFAULT_NODES, P0=P0,
                 latent=DEFAULT_LATENT, conditions=None):
        cs = condition_set(cells) if conditions is None else conditions
        self._walls = own_walls(cs)
        base = ConditionsModel(cells, surrogate, cs, n_nodes=n_nodes, P0=P0, latent=latent)
        self.cells, self.surrogate, self.P0 = base.cells, surrogate, float(P0)
        self.conditions, self.obs, self.lik = cs, base.obs, None
        self.effects = tuple((get_effect(e) if isinstance(e, str) else e).bind(cells)
                             for e in effects)
        names = [e.name for e in self.effects]
        refused = [n for n in names if n in NOT_CONDITION_AWARE]
        if refused:
            raise ValueError(f"{refused[0]} is not made condition-aware yet: "
                             f"{NOT_CONDITION_AWARE[refused[0]]}")
        if len(set(names)) != len(names):
            raise ValueError(f"an effect may appear only once in a model, got {names}")
        self.name = model_name(self.effects)
        #: (quantity, condition index) -> the effect parameter of its log ratio to the
        #: reference's (an effect with ``wall_ratios``, e.g. own_wall)
        self._ratios = {k: p for e in self.effects for k, p in e.wall_ratios().items()}
        clash = [f"{q} of {cs.names[c]}" for q, c in self._ratios if c in self._walls.get(q, ())]
        if clash:
            raise ValueError(f"{clash[0]} is both freed (--per-condition) and a ratio of an "
                             "effect's: use one")
        effect_parameters = tuple(p for e in self.effects for p in e.parameters)
        base_params = {p.name: p for p in models.BASELINE_PARAMETERS}
        own = tuple(dataclasses.replace(base_params[q], name=self._name(q, c),
                                        key=f"{base_params[q].key}[{cs.names[c]}]")
                    for c in range(len(cs.names)) if c != cs.ref for q in _OWN)
        own += tuple(dataclasses.replace(base_params[q], name=self._name(q, c),
                                         key=f"{base_params[q].key}[{cs.names[c]}]")
                     for q in FREEABLE for c in self._walls.get(q, ()))
        self.parameters = models.BASELINE_PARAMETERS + own + effect_parameters
        where = {p.name: i for i, p in enumerate(self.parameters)}
        self.parts, self.idx, self.columns = [], [], []
        for c, part in enumerate(base.parts):
            restricted = tuple(e.restrict(part.idx) for e in self.effects)
            self.parts.append(ExtendedModel.on_observations(
                part.cells, surrogate, restricted, part.obs, part.lik, P0=P0))
            self.idx.append(part.idx)
            # the part's parameters (baseline names, then its effects') as global columns
            self.columns.append(np.array(
                [where[self._name(q, c)] for q in ("gamma", "E0t", "R0", "P_phys")]
                + [where[p.name] for p in effect_parameters]))

    def variable(self, quantity, c):
        """Posterior name of ``quantity`` (``P_phys``, ``R0``, ``gamma``, ``E0t``) in
        condition index ``c``: the baseline's name where the condition shares it or is the
        reference, else ``quantity__c`` (a parameter, or derived from an effect's ratio:
        :meth:`derived`)."""
        if (quantity, c) in self._ratios:
            return f"{quantity}{SEP}{c}"
        return self._name(quantity, c)

    def condition_values(self, v):
        """``[(cell indices, values)]``: each condition's cells and the physical values ``v``
        (global names) as its wall model sees them: :meth:`part_values` with an effect's wall
        ratio applied (for checks that evaluate the wall without the effects, e.g. the FE
        table's domain)."""
        out = []
        for c, idx in enumerate(self.idx):
            values = self.part_values(v, c)
            for (q, cc), name in self._ratios.items():
                if cc == c:
                    values[q] = values[q] * np.exp(v[name])
            out.append((idx, values))
        return out

    def _name(self, quantity, c):
        """Posterior name of ``quantity`` in condition index ``c``."""
        if c != self.conditions.ref and (quantity in _OWN
                                         or c in self._walls.get(quantity, ())):
            return f"{quantity}{SEP}{c}"
        return quantity

    # ------------------------------------------------------------------ per condition
    def part_values(self, v, c):
        """Physical values ``v`` (global names) as condition ``c``'s part model names them."""
        part = self.parts[c]
        return {p.name: v[self.parameters[j].name]
                for p, j in zip(part.parameters, self.columns[c], strict=True)}

    def _scatter(self, fn, W, keys=None):
        """``fn(c, part)`` per condition, its ``(W, n_c)`` outputs placed at the condition's
        cells (a dict of them if ``keys``)."""
        n = self.obs.n_cells
        out = {k: np.empty((W, n)) for k in keys} if keys else np.empty((W, n))
        for c, part in enumerate(self.parts):
            r = fn(c, part)
            if keys:
                for k in keys:
                    out[k][:, self.idx[c]] = r[k]
            else:
                out[:, self.idx[c]] = r
        return out

    def pointwise_log_likelihood(self, u):
        """``(W, n_cells)``: each condition's cells under its part model."""
        u = np.atleast_2d(np.asarray(u, float))
        return self._scatter(
            lambda c, part: part.pointwise_log_likelihood(u[:, self.columns[c]]), len(u))

    def cell_pressures(self, u):
        """``(W, n_cells)``: E[P_i | data_i, theta] (bulged), the condition's P_phys (intact)."""
        u = np.atleast_2d(np.asarray(u, float))
        return self._scatter(lambda c, part: part.cell_pressures(u[:, self.columns[c]]), len(u))

    def predicted_means(self, u):
        """Plug-in ``{"R_c", "k_c"}`` ``(W, n_cells)`` of each condition's median cell."""
        u = np.atleast_2d(np.asarray(u, float))
        return self._scatter(lambda c, part: part.predicted_means(u[:, self.columns[c]]),
                             len(u), keys=("R_c", "k_c"))

    def log_pressure_centre(self, v):
        """``ln P`` each cell is centred on ``(W, n_cells)`` (its bulge's, or its condition's
        ``P_phys``)."""
        W = len(v["gamma"])
        return self._scatter(lambda c, part: part.log_pressure_centre(self.part_values(v, c)),
                             W)

    def posterior_predictive(self, u, rng):
        """Replicated ``R_c``, ``k_c`` ``(W, n_cells)``, condition by condition."""
        u = np.atleast_2d(np.asarray(u, float))
        return self._scatter(
            lambda c, part: part.posterior_predictive(u[:, self.columns[c]], rng), len(u),
            keys=("R_c", "k_c"))

    def curves(self, u, P):
        """Model ``R_c(P)``, ``k_c(P)`` of the reference condition's median intact cell."""
        u = np.atleast_2d(np.asarray(u, float))
        ref = self.conditions.ref
        return self.parts[ref].curves(u[:, self.columns[ref]], P)

    def derived(self, u, rng):
        """The reference condition's derived quantities (E_perp, E_par; with a common
        calibration scale also ``P_phys``, ``E0t``, ``R0`` in true units, and then every
        other condition's ``P_phys__c``, ``R0__c`` too)."""
        u = np.atleast_2d(np.asarray(u, float))
        ref = self.conditions.ref
        out = self.parts[ref].derived(u[:, self.columns[ref]], rng)
        if "P_phys" in out:
            for c, part in enumerate(self.parts):
                if c != ref:  # no thickness drawn from rng: the moduli are the reference's
                    d = part.derived(u[:, self.columns[c]], np.random.default_rng(0))
                    out.update({self._name(q, c): d[q] for q in _OWN + FREEABLE
                                if q in d and self._name(q, c) != q})
        if self._ratios:  # each condition's own value from its ratio to the reference's
            v = self.to_physical(u)
            for (q, c), name in self._ratios.items():
                out[self.variable(q, c)] = out.get(q, v[q]) * np.exp(v[name])
        return out

    def start_values(self, guess):
        """Every parameter's starting value: ``guess`` where it has it (a condition's own
        quantity from its baseline name otherwise), each effect's ``start`` for the rest."""
        out = {}
        for p in self.parameters:
            if p.name in guess:
                out[p.name] = guess[p.name]
            elif p.name.split(SEP)[0] in guess:
                out[p.name] = guess[p.name.split(SEP)[0]]
        for e in self.effects:
            for p in e.parameters:
                out.setdefault(p.name, e.start[p.name])
        return out

    def flagged_cells(self, v, cell_ids, gross=False):
        """:func:`turgorbayes.effects.outliers.flagged_cells` condition by condition, each at
        its own parameters; most certain first."""
        flags = []
        for c, part in enumerate(self.parts):
            ids = [cell_ids[i] for i in self.idx[c]]
            flags += outliers.flagged_cells(part, self.part_values(v, c), ids, gross=gross)
        return sorted(flags, key=lambda d: -d["score"])

    def without(self, keep, cells, surrogate, reread):
        """The model refitted to the cells ``keep`` for an exact leave-one-out refit, each
        condition reading its cells as the full model does: ``reread(part, full_obs,
        keep_c)`` (:func:`turgorbayes.criticism.loo.with_full_data_observations`)."""
        keep = np.asarray(keep, bool)
        cs = dataclasses.replace(self.conditions, index=self.conditions.index[keep])
        sub = type(self)(cells.take(keep), surrogate, effects=self.effects, P0=self.P0,
                         conditions=cs)
        for c, part in enumerate(sub.parts):
            reread(part, self.parts[c].obs, keep[self.idx[c]])
        return sub
