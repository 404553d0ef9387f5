"""Simulated osmotic series: intact cells measured in the growth medium and in media with known
amounts of osmolyte added, each at the turgor the osmotic balance gives
(:func:`turgorbayes.physics.osmotic.turgor_after_shift`; docs/validation.md, "Turgor without
bulged cells").

:func:`simulate_osmotic_series` draws the cells with :func:`turgorbayes.simulation.cells.simulate_cells`
and an injection (:class:`OsmoticSeries`) that puts each intact cell at its level's turgor and
writes the ``medium_mOsm`` column; the truths hold each level's true turgor and radius.
"""

import numpy as np

from turgorbayes import surrogate as surrogate_module
from turgorbayes.cells.columns import MEDIUM_COLUMN
from turgorbayes.effects.osmoadaptation import REFERENCE_TURGOR
from turgorbayes.physics import osmotic
from turgorbayes.simulation.cells import PAPER_TRUTH, ErrorModel, simulate_cells

__all__ = ["DEFAULT_B", "DEFAULT_GROWTH_MEDIUM", "OsmoticSeries", "parse_series",
           "simulate_osmotic_series"]

#: Osmolarity of the growth medium [mOsm]: LB with 5-10 g/L NaCl is about 250-350 mOsm (NaCl
#: alone gives 160-320 mOsm; docs/physics.md, "Osmotic shifts of the medium").
DEFAULT_GROWTH_MEDIUM = 300.0
#: True osmotically inactive fraction of the simulated cells: the prior's mean
#: (:data:`turgorbayes.inference.osmotic.B_PRIOR`).
DEFAULT_B = 0.3


def parse_series(text):
    """``"0,50,100,150"`` -> ``(0.0, 50.0, 100.0, 150.0)`` [mOsm added]; ValueError naming the
    bad item (each a finite number, distinct, the growth medium's 0 included)."""
    out = []
    for item in str(text).split(","):
        try:
            x = float(item)
        except ValueError:
            x = float("nan")
        if not np.isfinite(x):
            raise ValueError(f"--osmotic-series {text!r}: item {item!r} is not a number of mOsm "
                             "added to the growth medium (e.g. 0,50,100,150)")
        out.append(x)
    if len(set(out)) != len(out) or len(out) < 2:
        raise ValueError(f"--osmotic-series {text!r}: give two or more distinct levels (mOsm "
                         "added to the growth medium, e.g. 0,50,100,150)")
    if 0.0 not in out:
        raise ValueError(f"--osmotic-series {text!r}: include 0, the growth medium itself, whose "
                         "turgor is P_phys")
    return tuple(out)


class OsmoticSeries:
    """An injection of :func:`~turgorbayes.simulation.cells.simulate_cells`: the intact cells,
    split evenly over the levels (in order), at their level's turgor.

    Parameters
    ----------
    added : sequence of float [mOsm]
        Osmolyte added to the growth medium at each level (0: the growth medium).
    growth : float [mOsm]
    b : float [-]
        Osmotically inactive fraction of the volume in the growth medium.
    truth : turgorbayes.simulation.cells.Truth
    temperature : float [K]
    length_model : str
    """

    def __init__(self, added, growth, b, truth, temperature=osmotic.T_DEFAULT,
                 length_model="wall"):
        self.levels = growth + np.asarray(added, float)
        if np.any(self.levels < 0):
            raise ValueError(f"a level's osmolarity is negative ({growth:g} mOsm growth medium "
                             f"with {min(added):g} added); the levels must be >= 0 mOsm")
        self.growth, self.b, self.truth = float(growth), float(b), truth
        self.temperature, self.length_model = float(temperature), length_model
        st = osmotic.turgor_after_shift(truth.P_phys, truth.gamma, truth.E0t, truth.R0,
                                        c_ref=growth, c_out=self.levels, b=b, P0=truth.P0,
                                        temperature=temperature, length_model=length_model)
        bad = ~(st["P"] > 0)
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            why = ("plasmolysed (turgor 0: the protoplast leaves the wall)" if st["plasmolysed"][k]
                   else "past the largest turgor the wall can bear")
            raise ValueError(f"at {self.levels[k]:g} mOsm the simulated cells are {why}; the "
                             "FE model has no stiffness there: choose smaller steps")
        self.P, self.R_c = st["P"], st["R_c"]
        self.level_of = None

    def pressures(self, design, rng):
        """The intact cells split evenly over the levels, each at its level's turgor; the
        growth medium's turgor in ``design.extra`` (for effects that move the levels' turgors
        toward it)."""
        intact = np.flatnonzero(~design.is_bulged)
        self.level_of = np.arange(intact.size) * self.levels.size // intact.size
        design.P[intact] = self.P[self.level_of]
        design.extra[REFERENCE_TURGOR] = float(self.truth.P_phys)  # an effect's (osmoadaptation)
        return design

    def observations(self, obs, design, rng):
        """The ``medium_mOsm`` column: each intact cell's level, the growth medium for bulged
        cells."""
        medium = np.full(design.P.size, self.growth)
        medium[~design.is_bulged] = self.levels[self.level_of]
        obs.setdefault("extra", {})[MEDIUM_COLUMN] = [f"{c:g}" for c in medium]
        return obs

    def describe(self):
        return {"effect": "osmotic_series", "growth_medium_mOsm": self.growth,
                "levels_mOsm": self.levels.tolist(), "b": self.b,
                "temperature_K": self.temperature, "length_model": self.length_model}

    def truths(self):
        """The series' truths (JSON-ready): levels, their turgor and radius, ``b``, the
        cytoplasm's osmolarity in the growth medium and the buffering factor there."""
        t = self.truth
        RT = osmotic.osmotic_pressure(1.0, self.temperature)
        return {"growth_medium_mOsm": self.growth, "b": self.b,
                "c_in_growth_mOsm": self.growth + t.P_phys / RT,
                "temperature_K": self.temperature, "length_model": self.length_model,
                "buffering": float(osmotic.buffering_factor(
                    t.P_phys, t.gamma, t.E0t, t.R0, c_out=self.growth, b=self.b, P0=t.P0,
                    temperature=self.temperature, length_model=self.length_model)),
                "levels": [{"medium_mOsm": float(c), "P_kPa": float(P / 1e3),
                            "R_c_nm": float(R * 1e9),
                            "n_intact": int(np.sum(self.level_of == k))}
                           for k, (c, P, R) in enumerate(zip(self.levels, self.P, self.R_c,
                                                             strict=True))]}


def simulate_osmotic_series(added=(0.0, 50.0, 100.0, 150.0), n_intact=120, n_bulged=0,
                            truth=PAPER_TRUTH, seed=0, growth=DEFAULT_GROWTH_MEDIUM,
                            b=DEFAULT_B, temperature=osmotic.T_DEFAULT, length_model="wall",
                            errors=None, surrogate=None, noise=True, effects=(),
                            design_kwargs=None):
    """Simulate an osmotic series (module docstring).

    Parameters
    ----------
    added : sequence of float [mOsm]
        Osmolyte added to the growth medium, one level each (0 included).
    n_intact : int
        Intact cells in all, split evenly over the levels.
    n_bulged : int
        Bulged cells (in the growth medium), 0 allowed.
    truth : turgorbayes.simulation.cells.Truth
        The wall and ``P_phys``, the turgor in the growth medium.
    seed : int
    growth : float [mOsm]
    b : float [-]
    temperature : float [K]
    length_model : str
    errors, surrogate, noise, effects, design_kwargs
        As in :func:`~turgorbayes.simulation.cells.simulate_cells` (``errors`` None: the
        default :class:`~turgorbayes.simulation.cells.ErrorModel`).

    Returns
    -------
    cells : turgorbayes.cells.table.CellData
        With the ``medium_mOsm`` column.
    truths : dict
        :func:`~turgorbayes.simulation.cells.simulate_cells`'s, plus ``osmotic``
        (:meth:`OsmoticSeries.truths`).
    """
    surrogate = surrogate_module.load() if surrogate is None else surrogate
    errors = ErrorModel() if errors is None else errors
    series = OsmoticSeries(added, growth, b, truth, temperature, length_model)
    cells, truths = simulate_cells(n_bulged, n_intact, truth, seed, errors=errors,
                                   surrogate=surrogate, noise=noise,
                                   effects=(series, *effects), design_kwargs=design_kwargs)
    truths["osmotic"] = series.truths()
    return cells, truths
