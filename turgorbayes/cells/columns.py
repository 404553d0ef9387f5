"""The columns of the cell-data file (docs/data_format.md): one table of the numeric columns
that parsing (:mod:`turgorbayes.cells.table`), display (:mod:`turgorbayes.cells.summary`) and
the plausibility checks (:mod:`turgorbayes.cells.plausibility`) read, the standard and the
optional columns' names, and the one way an optional column's entries are parsed and refused."""

from dataclasses import dataclass

import numpy as np

from turgorbayes.errors import DataError

__all__ = ["BULGE_COLUMNS", "COLUMNS", "CONDITION_COLUMN", "CURVE_FLAGS", "CURVE_FLAG_TEXT", "ERROR_CORRELATION",
           "GROUPS", "MEDIUM_COLUMN", "MINUTES_COLUMN", "NUMERIC_COLUMNS", "REQUIRED_COLUMNS",
           "Column", "check_row", "column_values"]

#: The groups of cells: a bulge was measured, or the cell is intact.
GROUPS = ("bulged", "intact")
#: The standard columns filled on every row.
REQUIRED_COLUMNS = ("cell_id", "group", "Rc_nm", "Rc_err_nm", "kc_N_per_m", "kc_err_N_per_m")
#: Filled on bulged rows, empty on intact rows (but always present in the header).
BULGE_COLUMNS = ("Rb_nm", "Rb_err_nm", "kb_N_per_m", "kb_err_N_per_m", "hb_nm")
#: All standard columns in canonical order.
COLUMNS = REQUIRED_COLUMNS + BULGE_COLUMNS

#: Extra column written by ``turgorbayes curves``: what to know about a cell's curves
#: (flags joined by ";"), empty for a cell without remark; ``fit`` names the flagged cells.
CURVE_FLAGS = "curve_flags"
#: Each flag of :data:`CURVE_FLAGS` and what it means.
CURVE_FLAG_TEXT = {
    "low_signal": "cell-body force at R_c/20 under 3x the baseline noise: k_c reads high "
                  "(+6 % at 2x, +24 % at 1x the noise; docs/curves.md)",
    "imprecise_curve": "a curve kept in the cell's mean has an error larger than its own "
                       "reading (status imprecise in curves.csv)",
}


@dataclass(frozen=True)
class Column:
    """A numeric column of the cell-data file: its :class:`CellData` field, its unit, the
    decimal exponent ``e`` with ``value_SI = value_CSV * 10**-e``, the kind of quantity
    (``radius``, ``stiffness``, ``depth``) and, for an error column, the value column it is
    the error of."""

    field: str
    unit: str
    exponent: int
    kind: str
    error_of: str = None

    @property
    def per_si(self):
        """CSV value per SI value, ``10**e``."""
        return 10.0**self.exponent


#: The one table of numeric columns (parsing, display and the plausibility checks read it).
NUMERIC_COLUMNS = {
    "Rc_nm": Column("R_c", "nm", 9, "radius"),
    "Rc_err_nm": Column("R_c_err", "nm", 9, "radius", "Rc_nm"),
    "kc_N_per_m": Column("k_c", "N/m", 0, "stiffness"),
    "kc_err_N_per_m": Column("k_c_err", "N/m", 0, "stiffness", "kc_N_per_m"),
    "Rb_nm": Column("R_b", "nm", 9, "radius"),
    "Rb_err_nm": Column("R_b_err", "nm", 9, "radius", "Rb_nm"),
    "kb_N_per_m": Column("k_b", "N/m", 0, "stiffness"),
    "kb_err_N_per_m": Column("k_b_err", "N/m", 0, "stiffness", "kb_N_per_m"),
    "hb_nm": Column("h_b", "nm", 9, "depth"),
}

#: Optional column (docs/data_format.md, "Correlated readings"): the correlation of a cell's
#: R_c and k_c measurement errors, in (-1, 1); empty where it is not known. ``turgorbayes
#: curves`` writes it for cells whose R_c it fitted from the same contact points as k_c.
ERROR_CORRELATION = "rho_R_c_k_c"

#: Optional column (docs/data_format.md, "Medium osmolarity"): the osmolarity of the medium the
#: cell was measured in [mOsm], finite and >= 0; needed on intact rows when present, may be
#: empty on bulged rows (a bulge measures its cell's pressure whatever the medium). Intact cells
#: at several levels are fitted by the osmotic model (docs/statistics.md, "Osmotic series").
MEDIUM_COLUMN = "medium_mOsm"

#: Optional column (docs/data_format.md, "Medium osmolarity"): minutes from the cell's transfer
#: into its medium to its measurement, a number >= 0 on intact rows when present, may be empty
#: on bulged rows; the ``osmoadaptation`` effect's recovery time (docs/effects.md).
MINUTES_COLUMN = "minutes_after_shift"

#: Optional column: each cell's experimental condition (docs/data_format.md; read by
#: :func:`turgorbayes.inference.conditions.condition_labels`).
CONDITION_COLUMN = "condition"


def check_row(row, path, line, column, parse):
    """Refuse a file row (``{column: text}``) whose entry of the optional ``column`` ``parse``
    refuses (:func:`turgorbayes.cells.table.read_cells`).

    Parameters
    ----------
    row : dict of str to str
        The row's entries by column name (``group`` tells a bulged row).
    path : str
        The file.
    line : int
        The row's 1-based physical line in the file.
    column : str
        The optional column; nothing is checked when the row has none.
    parse : callable
        ``parse(text, bulged=...)`` -> float, raising ValueError (saying what is allowed) for
        an entry it refuses.

    Raises
    ------
    DataError
        Naming the file, line, column and value, with ``parse``'s reason.
    """
    text = row.get(column)
    if text is not None:
        try:
            parse(text, bulged=row.get("group", "").strip() == "bulged")
        except ValueError as err:
            raise DataError(str(err), path=path, line=line, column=column, value=text) from None


def column_values(cells, column, parse):
    """Each cell's entry of the optional ``column`` as parsed by ``parse``, or None without the
    column.

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
    column : str
        The optional column (an extra column of ``cells``).
    parse : callable
        ``parse(text, bulged=...)`` -> float (units as the column's), raising ValueError for
        an entry it refuses.

    Returns
    -------
    ndarray (n_cells,) or None

    Raises
    ------
    DataError
        An entry ``parse`` refuses, the cell named (:func:`read_cells
        <turgorbayes.cells.table.read_cells>` already refuses it with its line).
    """
    raw = dict(cells.extra).get(column)
    if raw is None:
        return None
    out = np.empty(len(raw))
    for i, text in enumerate(raw):
        try:
            out[i] = parse(text, bulged=bool(cells.is_bulged[i]))
        except ValueError as err:
            raise DataError(f"{err} (cell_id {cells.cell_id[i]!r})", path=cells.path,
                            column=column, value=text) from None
    return out
