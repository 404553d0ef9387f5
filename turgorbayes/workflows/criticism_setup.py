"""What a criticism fits, and how: :class:`CriticismSettings`, the model class of the data
(:func:`model_class`, :func:`criticism_model`), the design of several conditions
(:func:`conditions_design`) and the data it refuses (:func:`check_criticism_data`).
"""

from dataclasses import dataclass

import numpy as np

from turgorbayes import effects
from turgorbayes.cells.medium import medium_levels
from turgorbayes.effects import outliers
from turgorbayes.effects.conditions import ConditionsExtendedModel, has_conditions, own_walls
from turgorbayes.effects.series import SeriesModel
from turgorbayes.errors import DataError
from turgorbayes.inference.conditions import CONDITION_COLUMN, condition_set
from turgorbayes.inference.engine import Settings
from turgorbayes.inference.osmotic import osmotic_design
from turgorbayes.physics import osmotic

__all__ = ["NUMERICAL_FAILURES", "CriticismSettings", "check_criticism_data", "conditions_design",
           "criticism_model", "is_series", "model_class", "series_design"]

#: What a candidate's fit may raise without ending the criticism: numerical failures (an
#: overflow, a singular matrix, a mode search or sampler that gives up). The candidate is
#: recorded with the reason (:func:`~turgorbayes.workflows.criticism_candidates.failed_candidate`)
#: and left out of the comparison; a programming error (TypeError, KeyError, ...) still ends
#: the run.
NUMERICAL_FAILURES = (ArithmeticError, ValueError, np.linalg.LinAlgError, RuntimeError)


@dataclass
class CriticismSettings(Settings):
    """The settings of :func:`~turgorbayes.workflows.criticize.criticize`: the posterior
    engine's (:class:`turgorbayes.inference.engine.Settings`, with the criticism's defaults: engine
    ``"importance"``, emcee where it is unreliable, no progress bar) and the criticism's own.
    Tests use fewer draws.

    Attributes
    ----------
    n_rep : int
        Posterior draws of the predictive checks (>= 2/alpha resolves the threshold).
    max_refits : int
        Exact leave-one-out refits per model for cells with a large Pareto k.
    effects : tuple of str or None
        The candidate effects (None: every registered one that applies).
    flag_draws : int
        Draws of the adopted model screened for gross errors.
    per_condition : tuple of str
        Several conditions: the wall quantities freed per condition in every model
        (``"E0t"``, ``"E0t:NAME"``, as ``fit --per-condition``); empty: the wall shared.
    workers : int
        Processes of one :func:`turgorbayes.parallel.task_pool` kept open for the whole
        criticism: the candidates are fitted in threads (:func:`turgorbayes.parallel.threaded_imap`)
        that send their mode searches and importance sampling's batches of draws
        (:func:`turgorbayes.inference.posterior.log_lik_and_prior`) to it, as do the baseline,
        the pair and the screen of readings; the criticism is the same whatever their number
        (each candidate's draws are keyed by its name, and a batch holds the same draws on any
        number of workers).
    scheduler : str or None
        A Dask scheduler's address (or ``"local"``) to fit the candidates on instead.
    reference_medium : float or None [mOsm]
        An osmotic series: the level whose turgor is ``P_phys`` (None: the lowest).
    temperature : float or None [K]
        An osmotic series: the temperature of the balance (None: 298.15 K).
    length_model : str or None
        An osmotic series: ``"wall"`` (None) or ``"fixed"``
        (:data:`turgorbayes.physics.osmotic.LENGTH_MODELS`).
    """

    engine: str = "importance"
    progress: bool = False
    n_rep: int = 1000
    max_refits: int = 10
    effects: tuple = None
    flag_draws: int = outliers.FLAG_DRAWS
    per_condition: tuple = ()
    workers: int = 1
    scheduler: str = None
    reference_medium: float = None
    temperature: float = None
    length_model: str = None

    def __post_init__(self):
        if self.engine not in ("importance", "emcee"):  # needs a convergence check
            raise ValueError(f"engine must be 'importance' or 'emcee', got {self.engine!r}")
        super().__post_init__()
        for name in ("n_rep", "flag_draws"):
            if int(getattr(self, name)) < 2:
                raise ValueError(f"{name} must be an integer >= 2, got {getattr(self, name)!r}")
        if self.max_refits < 0:
            raise ValueError(f"max_refits must be >= 0, got {self.max_refits!r}")


def model_class(cells):
    """The criticism's model of ``cells``: :class:`turgorbayes.effects.ExtendedModel`, or
    with several conditions :class:`turgorbayes.effects.conditions.ConditionsExtendedModel`
    (the wall shared, ``P_phys`` and ``R0`` per condition, effects within conditions), or for
    an osmotic series :class:`turgorbayes.effects.series.SeriesModel` (each intact cell at its
    medium level's turgor, effects within levels)."""
    if is_series(cells):
        return SeriesModel
    return ConditionsExtendedModel if has_conditions(cells) else effects.ExtendedModel


def is_series(cells):
    """Whether ``cells`` are an osmotic series: intact cells in media of two or more
    osmolarities (the ``medium_mOsm`` column)."""
    return medium_levels(cells).size > 1


def check_criticism_data(cells):
    """Refuse data the criticism cannot model, before anything is computed: one medium needs
    both groups of cells; an osmotic series needs intact cells (bulged ones optional) and no
    ``condition`` column with two or more conditions (a series per condition is not modelled).

    Raises
    ------
    DataError
    """
    if not is_series(cells):
        cells.require_both_groups()
        return cells
    if has_conditions(cells):
        raise DataError("an osmotic series with several conditions is not supported by "
                        "criticize: its models put every intact cell at its medium level's "
                        "turgor from one P_phys; criticize each condition's series on its own",
                        path=cells.path, column=CONDITION_COLUMN)
    return cells


def criticism_model(cells, surrogate, names, settings=None):
    """The criticism's model of ``cells`` with the effects ``names``: :func:`model_class`,
    with several conditions on the design of ``settings.per_condition`` (the wall quantities
    freed per condition; :func:`conditions_design`)."""
    cls = model_class(cells)
    if cls is ConditionsExtendedModel:
        return cls(cells, surrogate, names, conditions=conditions_design(cells, settings))
    if cls is SeriesModel:
        return cls(cells, surrogate, names, design=series_design(cells, settings))
    return cls(cells, surrogate, names)


def series_design(cells, settings=None):
    """The :class:`~turgorbayes.inference.osmotic.OsmoticDesign` of an osmotic series with the
    reference medium, temperature and length model of ``settings`` (None: the defaults).

    Raises
    ------
    DataError
        A reference medium that is not a level, a temperature or length model not allowed.
    """
    s = settings or CriticismSettings()
    return osmotic_design(cells, s.reference_medium,
                          osmotic.T_DEFAULT if s.temperature is None else s.temperature,
                          s.length_model or "wall")


def conditions_design(cells, settings=None):
    """The :class:`~turgorbayes.inference.conditions.ConditionSet` of the criticism's models
    (reference: the first condition) with ``settings.per_condition`` freed, checked as
    ``fit --per-condition`` is (a condition without bulged cells is refused), or None for one
    condition (then ``per_condition`` is refused).

    Raises
    ------
    DataError
        ``per_condition`` without several conditions, or refused for these data.
    """
    per_condition = tuple(settings.per_condition or ())
    if not has_conditions(cells):
        if per_condition:
            raise DataError("--per-condition needs a condition column naming two or more "
                            "conditions (docs/data_format.md)", path=cells.path,
                            column=CONDITION_COLUMN)
        return None
    cs = condition_set(cells, None, per_condition)
    try:
        own_walls(cs)
    except ValueError as err:
        raise DataError(str(err), path=cells.path, column=CONDITION_COLUMN) from None
    return cs
