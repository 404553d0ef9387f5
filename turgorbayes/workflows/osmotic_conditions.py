"""Fit several conditions, each measured as an osmotic series: each condition's own turgor
and wall, and their contrasts
(:class:`turgorbayes.inference.osmotic_conditions.OsmoticConditionsModel`; docs/statistics.md,
"Osmotic series", "Conditions").

:func:`fit_osmotic_conditions` is :func:`turgorbayes.workflows.fit.fit_cells` with that model,
then what a fit with conditions carries (:attr:`FitResult.conditions`: ``summary.json``'s
``conditions`` and ``contrasts``, the conditions figure) and what a series carries (the
FE-table check at each level's turgor, the ``osmotic`` section with every condition's levels).
"""

import json

import numpy as np

from turgorbayes.inference import models
from turgorbayes.inference.conditions import SEP, variable
from turgorbayes.inference.osmotic_conditions import (
    QUANTITIES,
    OsmoticConditionsModel,
    condition_level_variable,
    series_condition_set,
    series_designs,
)
from turgorbayes.physics import osmotic
from turgorbayes.workflows.conditions import alias_diagnostics
from turgorbayes.workflows.fit import fit_cells
from turgorbayes.workflows.osmotic import SeriesPart, finish_series

__all__ = ["fit_osmotic_conditions", "model_factory"]


def model_factory(conditions, designs):
    """The :class:`~turgorbayes.inference.models.ModelFactory` of the conditions' series for
    :func:`fit_cells` (it checks its own design)."""
    def build(cells, surrogate, n_nodes=None):
        kwargs = {} if n_nodes is None else {"n_nodes": n_nodes}
        return OsmoticConditionsModel(cells, surrogate, conditions, designs, **kwargs)

    return models.ModelFactory(build, "osmotic", own_design=True)


def fit_osmotic_conditions(cells, reference=None, per_condition=(), reference_medium=None,
                           temperature=osmotic.T_DEFAULT, length_model="wall", seed=0,
                           surrogate=None, settings=None):
    """Fit the conditions' osmotic series (module docstring).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
        With the ``condition`` and ``medium_mOsm`` columns.
    reference : str, optional
        Reference condition of the contrasts (default: the first in file order).
    per_condition : sequence of str
        ``"gamma"`` or ``"gamma:NAME"``: that condition's own stiffening exponent too
        (:func:`~turgorbayes.inference.osmotic_conditions.series_condition_set`).
    reference_medium : float, optional [mOsm]
        The medium whose turgor is each condition's ``P_phys`` (default the lowest level).
    temperature : float [K]
    length_model : str
    seed : int
    surrogate : Surrogate, optional
    settings : turgorbayes.workflows.fit.FitSettings, optional

    Returns
    -------
    turgorbayes.workflows.fit.FitResult
        Named ``osmotic``, with ``conditions`` and ``sections["osmotic"]``.

    Raises
    ------
    DataError
        A condition whose wall its data do not identify (one medium level, no bulged
        cells), or without intact cells in the reference medium.
    """
    cs = series_condition_set(cells, reference, per_condition)
    designs = series_designs(cells, cs, reference_medium, temperature, length_model)
    result = fit_cells(cells, model_factory(cs, designs), seed=seed, surrogate=surrogate,
                       settings=settings)
    result.conditions = cs
    alias_diagnostics(result, cs)
    parts = [_part(result, cs, c, d) for c, d in enumerate(designs)]
    ref = parts.pop(cs.ref)
    finish_series(result, [ref, *parts],
                  tuple(f"buffering{SEP}{c}" for c in range(len(cs.names))) + ("b",))
    if result.tree is not None:
        result.tree.attrs["conditions"] = json.dumps(
            {"names": list(cs.names), "reference": cs.reference, "wall_prior": {},
             "bulged": list(cs.bulged), "series": list(cs.series),
             "variables": {n: {q: variable(result, q, c) for q in QUANTITIES}
                           for c, n in enumerate(cs.names)}})
    return result


def _part(result, cs, c, design):
    """Condition index ``c``'s series: its cells, draws and level variables."""
    return SeriesPart(cs.names[c], design, np.flatnonzero(cs.index == c),
                      {q: result.draws[cs.variable(q, c)] for q in QUANTITIES},
                      tuple(condition_level_variable(k, c) for k in range(design.n_levels)),
                      f"buffering{SEP}{c}")
