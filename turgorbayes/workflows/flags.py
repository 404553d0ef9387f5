"""The one screen of readings that look like gross errors, shared by ``fit`` and
``criticize`` (docs/effects.md, outliers)."""

import numpy as np

from turgorbayes.inference import engine, sampling

__all__ = ["flag_cells"]


def flag_cells(model, draws, cell_ids, n_draws=None, weights=None, rng=None, gross=False,
               workers=1):
    """Readings that look like gross errors: the one screen of ``fit`` and ``criticize``
    (:func:`turgorbayes.effects.outliers.flagged_cells`; for a model without the ``outliers``
    effect, with 1 % of readings assumed to be gross errors), at ``n_draws`` posterior draws.

    Parameters
    ----------
    model : BaselineModel or ExtendedModel
    draws : dict
        Parameter name -> draws SI (any shape, flattened: ``(chain, draw)`` or ``(S,)``).
    cell_ids : sequence of str
    n_draws : int, optional
        Draws screened (default :data:`turgorbayes.effects.outliers.FLAG_DRAWS`).
    weights : ndarray (S,), optional
        Weights of the flattened draws: ``n_draws`` are then resampled by weight with ``rng``
        (:func:`turgorbayes.inference.engine.resample`); equal weights: evenly spaced.
    rng : numpy.random.Generator, optional
        With ``weights``.
    gross : bool
        Word the reasons as gross errors (:func:`turgorbayes.effects.outliers.flagged_cells`).
    workers : int
        Processes the screen's batches are spread over (the same flags on any number).

    Returns
    -------
    list of dict
    """
    from turgorbayes.effects import outliers

    n_draws = outliers.FLAG_DRAWS if n_draws is None else n_draws
    screened = model.flag_cells(draws, cell_ids, n_draws, outliers.flagged_cells)
    if screened is not None:  # a model with conditions screens each on its own
        return screened
    flat = {n: np.asarray(draws[n]).reshape(-1) for n in model.names}
    size = next(iter(flat.values())).size
    keep = (sampling.evenly_spaced(size, n_draws) if weights is None
            else engine.resample(weights, n_draws, rng))
    kept = {n: a[keep] for n, a in flat.items()}
    screened = model.flagged_cells(kept, cell_ids, gross=gross)
    if screened is not None:  # effects within conditions: each at its own values
        return screened
    return outliers.flagged_cells(model, kept, cell_ids, gross=gross, workers=workers)
