"""The optional ``medium_mOsm`` column: the osmolarity of the medium each cell was measured in
(docs/data_format.md, "Medium osmolarity").

Intact cells measured in media of known, different osmolarities tie turgor, volume and
stiffness to known osmotic quantities (docs/physics.md, "Osmotic shifts of the medium"); the
fit of such a series is :mod:`turgorbayes.inference.osmotic`. An entry may be empty on a
bulged row only: a bulge measures its cell's pressure in any medium.
"""

import numpy as np

from turgorbayes.cells.columns import MEDIUM_COLUMN, MINUTES_COLUMN, check_row, column_values
from turgorbayes.errors import DataError

__all__ = ["MEDIUM_COLUMN", "MINUTES_COLUMN", "check_row_medium", "check_row_minutes",
           "medium_levels", "medium_osmolarity", "minutes_after_shift", "parse_medium",
           "parse_minutes", "require_one_medium"]


def parse_medium(text, bulged=False):
    """The osmolarity written as ``text`` [mOsm]: a finite number >= 0; NaN for an empty entry
    of a bulged cell (``bulged``).

    Raises
    ------
    ValueError
        Empty on an intact cell, not a number, not finite, or negative.
    """
    text = text.strip()
    if not text:
        if bulged:
            return np.nan
        raise ValueError("empty on an intact row; every intact cell needs the osmolarity of the "
                         "medium it was measured in (mOsm), bulged rows may leave it empty")
    try:
        value = float(text)
    except ValueError:
        raise ValueError(f"{text!r} is not a number; the medium's osmolarity in mOsm "
                         "(e.g. 300), >= 0") from None
    if not np.isfinite(value):
        raise ValueError(f"{text!r} is not allowed; the osmolarity must be a finite number of "
                         "mOsm")
    if value < 0:
        raise ValueError(f"must be >= 0 mOsm, got {text}; an osmolarity is never negative")
    return value


def check_row_medium(row, path, line):
    """Refuse a file row (``{column: text}``) whose medium entry :func:`parse_medium` refuses,
    naming the file, line, column and value (:func:`turgorbayes.cells.table.read_cells`)."""
    check_row(row, path, line, MEDIUM_COLUMN, parse_medium)


def medium_osmolarity(cells):
    """Each cell's medium osmolarity [mOsm] (NaN: an empty bulged entry), or None without the
    column.

    Raises
    ------
    DataError
        An entry :func:`parse_medium` refuses (the cell named; :func:`read_cells
        <turgorbayes.cells.table.read_cells>` already refuses it with its line).
    """
    return column_values(cells, MEDIUM_COLUMN, parse_medium)


def medium_levels(cells):
    """The distinct medium osmolarities of the intact cells [mOsm], ascending (empty without
    the column)."""
    c = medium_osmolarity(cells)
    if c is None:
        return np.empty(0)
    return np.unique(c[~np.asarray(cells.is_bulged, bool)])


def require_one_medium(cells, what="this model"):
    """Refuse intact cells measured in media of several osmolarities for a model that puts
    every intact cell at one turgor (it would read the series' turgor changes as scatter).

    Raises
    ------
    DataError
        Naming the levels and the osmotic model that fits them.
    """
    levels = medium_levels(cells)
    if levels.size > 1:
        shown = ", ".join(f"{c:g}" for c in levels)
        raise DataError(
            f"the intact cells were measured in media of {levels.size} osmolarities ({shown} "
            f"mOsm), whose turgors differ; {what} puts every intact cell at one turgor. `turgorbayes "
            "fit` and `criticize` fit such a series with the osmotic model (in Python: "
            "turgorbayes.workflows.osmotic.fit_osmotic, or fit_osmotic_conditions with a "
            "condition column; docs/statistics.md, \"Osmotic series\")",
            path=cells.path, column=MEDIUM_COLUMN)
    return cells


def parse_minutes(text, bulged=False):
    """Minutes after the shift written as ``text`` [min]: a finite number >= 0; NaN for an
    empty entry of a bulged cell (``bulged``).

    Raises
    ------
    ValueError
        Empty on an intact cell, not a number, not finite, or negative.
    """
    text = str(text).strip()
    if not text and bulged:
        return np.nan
    try:
        value = float(text)
    except ValueError:
        value = np.nan
    if not (np.isfinite(value) and value >= 0):
        raise ValueError(f"{text!r} is not a number of minutes >= 0; every intact row needs "
                         "the minutes from the cell's transfer into its medium to its "
                         "measurement, bulged rows may leave it empty")
    return value


def check_row_minutes(row, path, line):
    """Refuse a file row whose ``minutes_after_shift`` entry :func:`parse_minutes` refuses,
    naming the file, line, column and value (:func:`turgorbayes.cells.table.read_cells`)."""
    check_row(row, path, line, MINUTES_COLUMN, parse_minutes)


def minutes_after_shift(cells):
    """Each cell's minutes after the shift [min] (NaN: an empty bulged entry), or None without
    the column.

    Raises
    ------
    DataError
        An entry :func:`parse_minutes` refuses (the cell named; :func:`read_cells
        <turgorbayes.cells.table.read_cells>` already refuses it with its line).
    """
    return column_values(cells, MINUTES_COLUMN, parse_minutes)
