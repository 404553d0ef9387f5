"""The optional ``rho_R_c_k_c`` column: the correlation of a cell's R_c and k_c errors
(docs/data_format.md, "Correlated readings").

One contact point sets both readings of a force map's cell: a late contact lowers the heights
the radius is fitted to and shortens the indentation the stiffness is read at, so the two
errors are correlated. ``turgorbayes curves`` writes the correlation it can compute; the
likelihood then reads the cell's two readings as one bivariate normal observation
(docs/statistics.md, "Correlated readings"). An empty entry means "not known".
"""

import dataclasses

import numpy as np

from turgorbayes.cells.columns import ERROR_CORRELATION, check_row, column_values

__all__ = ["ERROR_CORRELATION", "check_row_correlation", "error_correlation", "parse_correlation",
           "with_error_correlation"]


def parse_correlation(text):
    """The correlation written as ``text``: a float in (-1, 1), NaN for an empty entry.

    Raises
    ------
    ValueError
        Not a number, not finite, or not strictly between -1 and 1 (a correlation of +-1
        would make the two readings one: their covariance is singular).
    """
    text = text.strip()
    if not text:
        return np.nan
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a number; a correlation between -1 and 1 "
                         "(exclusive), or empty where it is not known") from None
    if not -1.0 < value < 1.0:
        raise ValueError(f"must be strictly between -1 and 1, got {text}; a correlation of "
                         "+-1 would make R_c and k_c one reading (leave it empty if unknown)")
    return value


def check_row_correlation(row, path, line):
    """Refuse a file row (``{column: text}``) whose correlation entry :func:`parse_correlation`
    refuses, naming the file, line, column and value (:func:`turgorbayes.cells.table.read_cells`)."""
    check_row(row, path, line, ERROR_CORRELATION, _parse_entry)


def _parse_entry(text, bulged):
    """:func:`parse_correlation` in the form :func:`~turgorbayes.cells.columns.column_values`
    calls: a correlation is read alike on bulged and intact rows."""
    return parse_correlation(text)


def error_correlation(cells):
    """Each cell's R_c-k_c error correlation, NaN where unknown (all NaN without the column).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData

    Returns
    -------
    ndarray (n_cells,)

    Raises
    ------
    DataError
        An entry :func:`parse_correlation` refuses (the cell named; :func:`read_cells
        <turgorbayes.cells.table.read_cells>` already refuses it with its line).
    """
    rho = column_values(cells, ERROR_CORRELATION, _parse_entry)
    return np.full(len(cells.cell_id), np.nan) if rho is None else rho


def with_error_correlation(cells, rho):
    """``cells`` (a :class:`turgorbayes.cells.table.CellData`) with the column set to ``rho``
    (a float for every cell, or one per cell; NaN writes an empty entry)."""
    rho = np.broadcast_to(np.asarray(rho, float), (len(cells.cell_id),))
    text = tuple("" if np.isnan(r) else repr(float(r)) for r in rho)
    for t in text:
        parse_correlation(t)
    return dataclasses.replace(cells, extra=dict(cells.extra, **{ERROR_CORRELATION: text}))
