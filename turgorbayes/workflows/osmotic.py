"""Fit an osmotic series: intact cells in media of known osmolarities, bulged cells optional
(:class:`turgorbayes.inference.osmotic.OsmoticModel`; docs/statistics.md, "Osmotic series").

:func:`fit_osmotic` is :func:`turgorbayes.workflows.fit.fit_cells` with the osmotic model, then
the FE-table check with each level's cells at its own turgor and the ``osmotic`` section of
``summary.json`` (:func:`osmotic_section`): each level's turgor, the inactive fraction, the
buffering factor and how well each level's cells fit.
"""

import dataclasses
import json

import numpy as np

from turgorbayes.inference import models, table_check
from turgorbayes.inference.osmotic import (
    B_PRIOR,
    OsmoticModel,
    level_variable,
    osmotic_design,
)
from turgorbayes.physics import osmotic
from turgorbayes.workflows.fit import fit_cells

__all__ = ["LEVEL_MISFIT_Z", "SeriesPart", "finish_series", "fit_osmotic", "model_factory",
           "osmotic_section"]

#: A level whose cells' mean standardized residual (R_c or k_c) is this many standard errors
#: from 0 at the posterior mean is named: plasmolysis, osmoadaptation before the measurement,
#: or a wrong medium value break the balance there (docs/statistics.md, "Osmotic series").
LEVEL_MISFIT_Z = 4.0


def model_factory(design):
    """The :class:`~turgorbayes.inference.models.ModelFactory` of the series' OsmoticModel for
    :func:`fit_cells` (it checks its own design)."""
    def build(cells, surrogate, n_nodes=None):
        kwargs = {} if n_nodes is None else {"n_nodes": n_nodes}
        return OsmoticModel(cells, surrogate, design, **kwargs)

    return models.ModelFactory(build, "osmotic", own_design=True)


def fit_osmotic(cells, reference_medium=None, temperature=osmotic.T_DEFAULT,
                length_model="wall", seed=0, surrogate=None, settings=None):
    """Fit the osmotic model (module docstring).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
        With the ``medium_mOsm`` column.
    reference_medium : float, optional [mOsm]
        The level whose turgor is ``P_phys`` (default the lowest).
    temperature : float [K]
    length_model : str
        One of :data:`turgorbayes.physics.osmotic.LENGTH_MODELS`.
    seed : int
    surrogate : Surrogate, optional
    settings : turgorbayes.workflows.fit.FitSettings, optional

    Returns
    -------
    turgorbayes.workflows.fit.FitResult
        Named ``osmotic``, with ``sections["osmotic"]`` (:func:`osmotic_section`).
    """
    design = osmotic_design(cells, reference_medium, temperature, length_model)
    result = fit_cells(cells, model_factory(design), seed=seed, surrogate=surrogate,
                       settings=settings)
    parts = [SeriesPart(None, design, np.arange(len(cells)), result.draws,
                        tuple(level_variable(k) for k in range(design.n_levels)), "buffering")]
    finish_series(result, parts, ("buffering", "b"))
    return result


@dataclasses.dataclass(frozen=True)
class SeriesPart:
    """One osmotic series of a fit: a condition's cells, or all of them.

    Attributes
    ----------
    condition : str or None
        The condition's name (None: the data set has no conditions).
    design : turgorbayes.inference.osmotic.OsmoticDesign
    index : ndarray of int
        Its cells in the data set.
    draws : dict
        Its ``P_phys``, ``gamma``, ``E0t``, ``R0`` draws (SI).
    levels : tuple of str
        The posterior variables of its levels' turgors, in ``design.levels`` order.
    buffering : str
        The posterior variable of its buffering factor.
    """

    condition: object
    design: object
    index: np.ndarray
    draws: dict
    levels: tuple
    buffering: str


def finish_series(result, parts, variables=()):
    """The FE-table check with each level's cells at its own turgor, the ``osmotic`` section
    of ``summary.json`` (:func:`osmotic_section`) and its variables (``variables`` and the
    level turgors) left out of ``parameters``."""
    _recheck_table(result, parts)
    result.section_variables = tuple(v for p in parts for v in p.levels) + tuple(variables)
    result.sections = {"osmotic": osmotic_section(result, parts)}
    if result.tree is not None:
        result.tree.attrs["osmotic"] = json.dumps(result.sections["osmotic"])


def _recheck_table(result, parts):
    """The FE-table check with each level's intact cells at its own turgor draws."""
    cells = result.cells
    bulged = np.asarray(cells.is_bulged, bool)
    checked = []
    for p in parts:
        if np.any(bulged[p.index]):
            checked.append((p.index[bulged[p.index]], p.draws))
        intact = p.index[~bulged[p.index]]
        for k, name in enumerate(p.levels):
            checked.append((intact[p.design.level_of == k],
                            dict(p.draws, P_phys=result.draws[name])))
    check = table_check.check_draws(None, cells, result.surrogate, parts=checked)
    result.table_check = check
    if result.tree is not None:
        result.tree.attrs["fe_table_undefined_fraction"] = check["fraction_of_draws"]
        result.tree.attrs["fe_table_undefined_note"] = table_check.describe(check)


def _stats(x, factor=1.0):
    x = np.asarray(x, float).ravel() / factor
    q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
    return {"mean": float(np.mean(x)), "sd": float(np.std(x, ddof=1)), "q05": float(q05),
            "q50": float(q50), "q95": float(q95)}


def _level_misfit(result, part):
    """Per level of ``part``: the mean standardized residual of R_c and of k_c at the
    posterior-mean replicate, in standard errors of the level's mean (``z``)."""
    cells = result.cells
    intact = part.index[~np.asarray(cells.is_bulged, bool)[part.index]]
    R_pred = np.asarray(result.ppc["R_c"], float).reshape(-1, len(cells))[:, intact].mean(0)
    k_pred = np.asarray(result.ppc["k_c"], float).reshape(-1, len(cells))[:, intact].mean(0)
    zR = (np.asarray(cells.R_c)[intact] - R_pred) / np.asarray(cells.R_c_err)[intact]
    zk = (np.asarray(cells.k_c)[intact] - k_pred) / np.asarray(cells.k_c_err)[intact]
    out = []
    for k in range(part.design.n_levels):
        m = part.design.level_of == k
        n = int(m.sum())
        out.append({"R_c": float(zR[m].mean() * np.sqrt(n)), "k_c": float(zk[m].mean() * np.sqrt(n))})
    return out


def _levels(result, part):
    """The section's entries of ``part``'s levels (with its condition, if any)."""
    misfit = _level_misfit(result, part)
    d = part.design
    out = []
    for k, (c, n) in enumerate(zip(d.levels, d.counts(), strict=True)):
        entry = {} if part.condition is None else {"condition": part.condition}
        out.append({**entry, "medium_mOsm": float(c), "n_intact": int(n),
                    "reference": bool(k == d.ref),
                    "turgor_kPa": _stats(result.draws[part.levels[k]], 1e3),
                    "misfit_z": misfit[k]})
    return out


def osmotic_section(result, parts):
    """``summary["osmotic"]``: the design, ``b`` and the buffering factor (of the first
    part: the reference condition), and per level (of every part, its ``condition`` named
    when there are conditions) its osmolarity, cells, turgor [kPa] (mean, sd, q05, q50, q95)
    and misfit ``z``; ``misfit_levels_mOsm`` names the levels beyond
    :data:`LEVEL_MISFIT_Z`, ``misfit_levels`` the same with their condition."""
    levels = [lv for p in parts for lv in _levels(result, p)]
    named = [lv for lv in levels
             if max(abs(lv["misfit_z"]["R_c"]), abs(lv["misfit_z"]["k_c"])) > LEVEL_MISFIT_Z]
    b = result.draws.get("b")
    design = parts[0].design
    out = {
        "reference_medium_mOsm": float(design.reference),
        "temperature_K": design.temperature, "length_model": design.length_model,
        "turgor_per_mOsm_kPa": float(osmotic.osmotic_pressure(1.0, design.temperature) / 1e3),
        "b": (_stats(b) if b is not None else
              {"fixed": B_PRIOR.a / (B_PRIOR.a + B_PRIOR.b), "why": "one medium level"}),
        "b_prior": B_PRIOR.describe(),
        "buffering": _stats(result.draws[parts[0].buffering]),
        "levels": levels,
        "misfit_levels_mOsm": [lv["medium_mOsm"] for lv in named],
    }
    if parts[0].condition is not None:
        out["buffering_by_condition"] = {p.condition: _stats(result.draws[p.buffering])
                                         for p in parts}
        out["misfit_levels"] = [{"condition": lv["condition"], "medium_mOsm": lv["medium_mOsm"]}
                                for lv in named]
    return out
