"""An osmotic series as a model of the criticism, with any effects: :class:`SeriesModel`.

Intact cells measured in media of known osmolarities (the ``medium_mOsm`` column) sit at their
medium level's turgor from the osmotic balance (conserved osmolytes and the wall law,
:func:`turgorbayes.inference.osmotic.level_balance`); their radius and stiffness at that turgor
are the wall law's, the baseline's forward model. So the series model is the baseline with
each intact cell's turgor given per cell (:attr:`LikelihoodContext.intact_log_P
<turgorbayes.inference.context.LikelihoodContext>`) instead of one ``P_phys``, set before the
effects edit the context: every effect composes with a series and acts within its levels
(``turgor_spread`` spreads each cell about its level's turgor; ``osmoadaptation`` moves the
levels back towards ``P_phys``). Without effects its likelihood is
:class:`turgorbayes.inference.osmotic.OsmoticModel`'s (docs/effects.md, "Osmotic series").
"""

import dataclasses

import numpy as np

from turgorbayes.effects.model import ExtendedModel
from turgorbayes.effects.registry import get_effect, model_name
from turgorbayes.errors import DataError
from turgorbayes.inference import models
from turgorbayes.inference.context import LikelihoodContext
from turgorbayes.inference.likelihood import DEFAULT_NODES, CellLikelihood
from turgorbayes.inference.observations import DEFAULT_LATENT, observations_from_cells
from turgorbayes.inference.osmotic import (
    B_PARAMETER,
    B_PRIOR,
    OsmoticModel,
    level_balance,
    level_states,
    level_variable,
    osmotic_design,
)
from turgorbayes.physics import osmotic
from turgorbayes.physics.parameters import P0

__all__ = ["SeriesModel"]


class SeriesModel(ExtendedModel):
    """An osmotic series plus a list of effects (module docstring).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
        Intact cells with ``medium_mOsm``; bulged cells optional.
    surrogate : turgorbayes.surrogate.Surrogate
    effects : sequence of str or Effect
        Applied in order after the levels' turgors are set; empty: the osmotic model.
    n_nodes : int
    P0 : float [Pa]
    latent : str
    design : turgorbayes.inference.osmotic.OsmoticDesign, optional
        Default :func:`~turgorbayes.inference.osmotic.osmotic_design` of ``cells`` (reference:
        the lowest level).

    Raises
    ------
    DataError
        As :class:`~turgorbayes.inference.osmotic.OsmoticModel`.
    ValueError
        An effect that cannot act on a series (:meth:`Effect.series_refusal
        <turgorbayes.effects.base.Effect.series_refusal>`) or given twice.
    """

    #: Sampled at the reference turgor, as the osmotic model.
    wall_references = OsmoticModel.wall_references

    def __init__(self, cells, surrogate, effects=(), n_nodes=DEFAULT_NODES, P0=P0,
                 latent=DEFAULT_LATENT, design=None):
        design = osmotic_design(cells) if design is None else design
        if design.n_levels < 2 and cells.n_bulged == 0:
            raise DataError(f"the intact cells were all measured at {design.levels[0]:g} mOsm "
                            "and there are no bulged cells: one medium level cannot tell the "
                            "wall from the turgor", path=cells.path)
        self.cells, self.surrogate, self.P0 = cells, surrogate, float(P0)
        self.design, self.latent = design, latent
        self.obs = observations_from_cells(cells, latent=latent)
        self.lik = CellLikelihood(self.obs, surrogate, n_nodes=n_nodes, P0=P0)
        self.effects = tuple((get_effect(e) if isinstance(e, str) else e).bind(cells)
                             for e in effects)
        names = [e.name for e in self.effects]
        refused = [(e.name, r) for e in self.effects if (r := e.series_refusal(cells))]
        if refused:
            raise ValueError(f"{refused[0][0]}: {refused[0][1]}")
        if len(set(names)) != len(names):
            raise ValueError(f"an effect may appear only once in a model, got {names}")
        self.name = model_name(self.effects)
        self.parameters = models.BASELINE_PARAMETERS + (
            (B_PARAMETER,) if design.n_levels > 1 else ()) + tuple(
            p for e in self.effects for p in e.parameters)

    # ------------------------------------------------------------------ the levels
    def base_context(self, v):
        """The baseline's context with each intact cell at its level's turgor
        (:attr:`LikelihoodContext.intact_log_P`, ``(W, n_intact)`` [ln Pa];
        NaN where the level is plasmolysed or no state exists: the cell's density is then 0)."""
        ctx = LikelihoodContext(v, v)
        P = level_balance(v, self.design, self.P0)["P"][:, self.design.level_of]
        with np.errstate(divide="ignore", invalid="ignore"):
            ctx.intact_log_P = np.where(P > 0, np.log(P), np.nan)
        return ctx

    def level_states(self, v):
        """Each level's turgor, radius and stiffness (:func:`turgorbayes.inference.osmotic.level_states`)."""
        return level_states(v, self.design, self.P0, self.surrogate)

    def intact_levels(self):
        """Each intact cell's medium level (the predictive checks centre within levels)."""
        return self.design.level_of

    def condition_values(self, v):
        """``[(cell indices, values)]``: the bulged cells at ``v``, each level's intact cells
        with ``P_phys`` replaced by the level's turgor (the FE-table check)."""
        P = level_balance(v, self.design, self.P0)["P"]
        intact = self.obs.intact
        parts = [(self.obs.bulged, v)] if self.obs.bulged.size else []
        return parts + [(intact[self.design.level_of == k], dict(v, P_phys=P[:, k]))
                        for k in range(self.design.n_levels)]

    def derived(self, u, rng):
        """As :meth:`ExtendedModel.derived`, plus each level's turgor from the balance
        (``P_level__k`` [Pa], before any effect moves it) and the buffering factor at ``P_phys``
        (:func:`turgorbayes.physics.osmotic.buffering_factor`)."""
        out = super().derived(u, rng)
        v = self.to_physical(u)
        P = level_balance(v, self.design, self.P0)["P"]
        out.update({level_variable(k): P[:, k] for k in range(self.design.n_levels)})
        d = self.design
        b = v.get("b", np.full(len(v["gamma"]), B_PRIOR.a / (B_PRIOR.a + B_PRIOR.b)))
        out["buffering"] = osmotic.buffering_factor(
            v["P_phys"], v["gamma"], v["E0t"], v["R0"], c_out=d.reference, b=b, P0=self.P0,
            temperature=d.temperature, length_model=d.length_model)
        return out

    # ------------------------------------------------------------------ starting point
    def least_squares(self):
        """The osmotic series' weighted least squares
        (:class:`turgorbayes.inference.osmotic_wls.OsmoticWLS`) of the model without effects."""
        return OsmoticModel(self.cells, self.surrogate, self.design, P0=self.P0,
                            latent=self.latent).least_squares()

    def start_values(self, guess):
        """:meth:`ExtendedModel.start_values` with ``b`` (the guess's, else its prior mean)."""
        out = super().start_values(guess)
        if self.design.n_levels > 1:
            out["b"] = guess.get("b", B_PRIOR.a / (B_PRIOR.a + B_PRIOR.b))
        return out

    def without(self, keep, cells, surrogate, reread):
        """The model refitted to the cells ``keep`` (exact leave-one-out refits), its intact
        cells at their levels of the full design."""
        keep = np.asarray(keep, bool)
        design = dataclasses.replace(self.design,
                                     level_of=self.design.level_of[keep[self.obs.intact]])
        return reread(type(self)(cells.take(keep), surrogate, effects=self.effects, P0=self.P0,
                                 latent=self.latent, design=design), self.obs, keep)
