"""When each cell was measured: the optional ``time_min`` column, or the file's row order
(docs/data_format.md, "Measurement order").

A drifting cantilever or tip, or cells that change on the slide, move readings with time; the
criticism's ``order`` checks look for residuals that drift with :func:`measurement_order` and
the ``drift`` effect describes such a drift.
"""

import numpy as np

from turgorbayes.cells.columns import column_values

__all__ = ["TIME_COLUMN", "measurement_order"]

#: The optional cell-data column: minutes since the session (or experiment) began.
TIME_COLUMN = "time_min"


def measurement_order(cells):
    """Each cell's place in the measurement, scaled to ``[-0.5, 0.5]`` (first to last).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData

    Returns
    -------
    s : ndarray (n_cells,)
        ``time_min`` scaled linearly (when the column is present), else the row index; all 0
        for a single cell or a constant time.
    source : str
        ``"time_min"`` or ``"row order"``.

    Raises
    ------
    DataError
        A ``time_min`` value that is not a finite number (the cell named).
    """
    t = column_values(cells, TIME_COLUMN, _parse_time)
    source = TIME_COLUMN
    if t is None:
        t, source = np.arange(len(cells.cell_id), dtype=float), "row order"
    span = np.ptp(t) if t.size else 0.0
    if span == 0:
        return np.zeros_like(t), source
    return (t - t.min()) / span - 0.5, source


def _parse_time(text, bulged):
    """A ``time_min`` entry [min]: any finite number, on bulged and intact rows alike."""
    try:
        value = float(text)
    except ValueError:
        value = np.nan
    if not np.isfinite(value):
        raise ValueError(f"must be a finite number of minutes, got {text!r}")
    return value
