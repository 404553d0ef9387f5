"""Cell-data files: the CSV format users write their measurements in, its loader and writer.

One row per cell, a header row, units in the column names (the only place where units other
than SI appear):

============== ======= =========================================================
column         unit    meaning
============== ======= =========================================================
cell_id        --      unique, non-empty name of the cell
group          --      ``bulged`` (a bulge was measured) or ``intact``
Rc_nm          nm      cell radius R_c
Rc_err_nm      nm      its standard error
kc_N_per_m     N/m     cell-body stiffness k_c
kc_err_N_per_m N/m     its standard error
Rb_nm          nm      bulge radius R_b (bulged rows only)
Rb_err_nm      nm      its standard error (bulged rows only)
kb_N_per_m     N/m     bulge stiffness k_b (bulged rows only)
kb_err_N_per_m N/m     its standard error (bulged rows only)
hb_nm          nm      bulge indentation depth at which k_b was read (bulged rows only)
============== ======= =========================================================

All eleven columns must appear in the header (in any order); the five bulge columns are empty
on intact rows. Values no bacterium can have (a radius in um, a stiffness in pN/nm, ...) are
refused by :func:`read_cells` unless ``allow_unusual`` (:mod:`turgorbayes.cells.plausibility`,
``docs/data_format.md``). Further columns are carried along as text. Lines starting with ``#`` before
the header are comments (provenance); they are kept and written back. Line numbers in error
messages are 1-based physical lines of the file, comments included.

Canonical form (what :func:`write_cells` produces, so that write -> read -> write is
byte-identical): UTF-8 without BOM, ``\\n`` line ends, the comment lines, the header with the
eleven columns in the order above followed by the extra columns in their order, one row per
cell in the order of the data set, intact rows with empty bulge fields, minimal CSV quoting,
no blank lines. Each number is the shortest decimal that reads back to exactly the same SI
double (Python's ``repr`` of the SI value with the decimal point shifted to the CSV unit),
in fixed notation for 1e-4 <= x < 1e16 and as ``1.5e-05`` otherwise. Reading converts by the
same exact decimal shift, so an SI value survives write -> read bit for bit.

This module is the file format: both directions and every line-, column- and value-precise
error message of the reader. The data set it reads into is :class:`CellData`
(:mod:`turgorbayes.cells.cell_data`, re-exported here); the physical plausibility of the values
is :mod:`turgorbayes.cells.plausibility`.
"""

import csv
import hashlib
import importlib.resources
import io
import re
import warnings
from decimal import Decimal
from pathlib import Path

import numpy as np

from turgorbayes.cells import plausibility
from turgorbayes.cells.cell_data import CellData, cell_id_problem
from turgorbayes.cells.columns import (
    BULGE_COLUMNS,
    COLUMNS,
    GROUPS,
    NUMERIC_COLUMNS,
    REQUIRED_COLUMNS,
)
from turgorbayes.cells.correlation import check_row_correlation
from turgorbayes.cells.medium import check_row_medium, check_row_minutes
from turgorbayes.errors import DataError

__all__ = [
    "BULGE_COLUMNS",
    "COLUMNS",
    "GROUPS",
    "REQUIRED_COLUMNS",
    "CellData",
    "example_path",
    "is_simulated",
    "read_cells",
    "write_cells",
]

# numeric column -> (CellData field, decimal exponent e with value_SI = value_CSV * 10**-e)
_NUMERIC = {c: (col.field, col.exponent) for c, col in NUMERIC_COLUMNS.items()}
_NUMBER = re.compile(r"([+-]?(?:\d+\.?\d*|\.\d+))(?:[eE]([+-]?\d+))?")
_NONFINITE = {"nan", "inf", "infinity"}


# --------------------------------------------------------------------------- reading
def read_cells(path, allow_unusual=False):
    """Read and validate a cell-data CSV file, physical plausibility included.

    Parameters
    ----------
    path : str or pathlib.Path
        The CSV file (format in the module docstring).
    allow_unusual : bool
        Let values outside the physical bounds of :mod:`turgorbayes.cells.plausibility` through
        with an :class:`~turgorbayes.cells.plausibility.UnusualValueWarning` listing them, instead
        of refusing the file.

    Returns
    -------
    CellData
        The cells in file order, SI units (m, N/m), with the file's comment lines, path and
        SHA-256 of its bytes. Files with only one group load; see
        :meth:`CellData.require_both_groups`.

    Raises
    ------
    DataError
        For any malformed content; the message names the file, the 1-based physical line,
        the column, the offending text and what is allowed. Nothing is dropped or clamped.
        Also for values no bacterium can have (unless ``allow_unusual``): up to five are
        listed with their lines and the likely unit slip (``docs/data_format.md``).
    OSError
        If the file cannot be read.
    """
    path_str = str(path)
    raw = Path(path).read_bytes()
    lines = io.StringIO(_decode(raw, path_str), newline="").readlines()
    n_comments = next((i for i, s in enumerate(lines) if not s.startswith("#")), len(lines))
    comments = tuple(s.rstrip("\r\n") for s in lines[:n_comments])
    body = lines[n_comments:]
    header_line = n_comments + 1
    reader = csv.reader(body)
    header = _read_header(reader, body, path_str, header_line)
    columns = _parse_rows(reader, body, header, path_str, header_line)
    row_lines = columns.pop("lines")
    cells = CellData(
        comments=comments, path=path_str, sha256=hashlib.sha256(raw).hexdigest(), **columns
    )
    _check_plausible(cells, row_lines, allow_unusual)
    return cells


def _check_plausible(cells, row_lines, allow_unusual):
    """Refuse (or, if allowed, warn about) values no bacterium can have."""
    problems = plausibility.check(cells)
    if not problems:
        return
    listing = plausibility.describe(problems, row_lines)
    n = len(problems)
    if allow_unusual:
        warnings.warn(
            f"{cells.path}: {n} unusual value(s) let through by allow_unusual:\n{listing}",
            plausibility.UnusualValueWarning, stacklevel=3,
        )
        return
    first = problems[0]
    raise DataError(
        f"{n} value(s) no bacterium can have (bounds and sources: docs/data_format.md; "
        f"--allow-unusual lets them through with a warning):\n{listing}",
        path=cells.path, line=row_lines[first.row], column=first.column,
        value=f"{first.value:.6g}",
    )


def _decode(raw, path):
    try:
        return raw.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        line = raw[: err.start].count(b"\n") + 1
        raise DataError(
            f"not UTF-8 text (byte {raw[err.start:err.start + 1]!r} at offset {err.start}); "
            "save the file as UTF-8 CSV",
            path=path, line=line,
        ) from None


def _read_header(reader, body, path, line):
    if not body:
        what = "only comment lines" if line > 1 else "empty"
        raise DataError(
            f"file is {what}; expected a header line with the columns {', '.join(COLUMNS)}",
            path=path,
        )
    if not body[0].strip():
        raise DataError(
            "blank line where the header should be; the header must be the first line "
            "after the '#' comment lines",
            path=path, line=line,
        )
    header = [name.strip() for name in next(reader)]
    _check_header(header, path, line)
    return header


def _check_header(header, path, line):
    for j, name in enumerate(header):
        if not name:
            raise DataError(
                f"header field {j + 1} is empty (a trailing comma?); every column needs a name",
                path=path, line=line,
            )
        if name in header[:j]:
            raise DataError(
                f"duplicate column {name!r} (header fields {header.index(name) + 1} and {j + 1})",
                path=path, line=line, column=name, value=name,
            )
    missing = [c for c in COLUMNS if c not in header]
    if missing:
        hint = ""
        if len(header) == 1 and (";" in header[0] or "\t" in header[0]):
            hint = "; the file seems to use ';' or tabs as separator, turgorbayes expects commas"
        raise DataError(
            f"missing required column {missing[0]!r} (missing: {', '.join(missing)}; "
            f"required: {', '.join(COLUMNS)}){hint}",
            path=path, line=line, column=missing[0],
        )


def _parse_rows(reader, body, header, path, header_line):
    extras = [name for name in header if name not in COLUMNS]
    cols = {"cell_id": [], "group": [], **{f: [] for f, _ in _NUMERIC.values()}}
    extra = {name: [] for name in extras}
    first_line = {}
    blank = None
    for line, fields in _records(reader, path, header_line - 1):
        if not fields or (len(fields) == 1 and not fields[0].strip()):
            blank = line if blank is None else blank
            continue
        _check_row_shape(fields, header, body[line - header_line], blank, path, line)
        row = dict(zip(header, fields, strict=True))
        _parse_row(row, cols, path, line, first_line)
        for name in extras:
            extra[name].append(row[name])
        check_row_correlation(row, path, line)
        check_row_medium(row, path, line)
        check_row_minutes(row, path, line)
    if not cols["cell_id"]:
        raise DataError(
            "no data rows after the header; expected one row per cell",
            path=path, line=header_line,
        )
    return dict(cols, extra=extra, lines=[first_line[c] for c in cols["cell_id"]])


def _records(reader, path, offset):
    """Yield (first physical line number, fields) per CSV record."""
    previous = reader.line_num
    while True:
        try:
            fields = next(reader)
        except StopIteration:
            return
        except csv.Error as err:
            raise DataError(f"unreadable CSV: {err}", path=path,
                            line=offset + reader.line_num) from None
        yield offset + previous + 1, fields
        previous = reader.line_num


def _check_row_shape(fields, header, raw_line, blank, path, line):
    if blank is not None:
        raise DataError(
            "blank line between data rows; remove it (comments are only allowed before the "
            "header)",
            path=path, line=blank,
        )
    if raw_line.startswith("#"):
        raise DataError(
            "'#' comment line after the header; comments are only allowed before the header "
            "(to exclude a cell, delete its row and say why in a comment at the top)",
            path=path, line=line,
        )
    if len(fields) != len(header):
        raise DataError(
            f"row has {len(fields)} fields but the header has {len(header)} (a stray comma, "
            "a decimal comma, or a field with a comma that needs \"quotes\"?)",
            path=path, line=line,
        )


def _parse_row(row, cols, path, line, first_line):
    cid = row["cell_id"].strip()
    problem = cell_id_problem(cid)
    if problem is None and cid in first_line:
        problem = (f"duplicate cell_id {cid!r} (first on line {first_line[cid]}, "
                   f"again on line {line})")
    if problem is not None:
        raise DataError(problem, path=path, line=line, column="cell_id", value=row["cell_id"])
    first_line[cid] = line
    group = row["group"].strip()
    if group not in GROUPS:
        raise DataError(
            f"unknown group {row['group']!r}; allowed: {', '.join(map(repr, GROUPS))}",
            path=path, line=line, column="group", value=row["group"],
        )
    cols["cell_id"].append(cid)
    cols["group"].append(group)
    for column in REQUIRED_COLUMNS[2:]:
        value = _parse_value(row, column, "every row needs it", path, line)
        cols[_NUMERIC[column][0]].append(value)
    for column in BULGE_COLUMNS:
        if group == "bulged":
            value = _parse_value(row, column, "bulged rows need all of " + ", ".join(BULGE_COLUMNS),
                                 path, line)
        else:
            value = _empty_on_intact(row, column, path, line)
        cols[_NUMERIC[column][0]].append(value)


def _empty_on_intact(row, column, path, line):
    if row[column].strip():
        raise DataError(
            f"{row[column]!r} on an intact row; the bulge columns ({', '.join(BULGE_COLUMNS)}) "
            "must be empty on intact rows (is the group wrong?)",
            path=path, line=line, column=column, value=row[column],
        )
    return np.nan


def _parse_value(row, column, why_needed, path, line):
    text = row[column].strip()
    if not text:
        raise DataError(f"empty value; {why_needed}", path=path, line=line, column=column, value="")
    try:
        value = _to_si(text, _NUMERIC[column][1])
    except ValueError as err:
        raise DataError(str(err), path=path, line=line, column=column, value=text) from None
    return value


def _to_si(text, exponent):
    """Convert CSV text to SI by an exact decimal shift: '540.7' nm -> float('540.7e-9')."""
    if text.lower().lstrip("+-") in _NONFINITE:
        raise ValueError(f"{text!r} is not allowed; values must be finite numbers > 0")
    match = _NUMBER.fullmatch(text)
    if match is None:
        raise ValueError(f"{text!r} is not a number (expected e.g. 540.7 or 1.2e-2)")
    mantissa, exp = match.group(1), int(match.group(2) or 0)
    value = float(f"{mantissa}e{exp - exponent}")
    if not np.isfinite(value):
        raise ValueError(f"{text!r} overflows to infinity; values must be finite")
    if value <= 0:
        detail = " (underflows to 0)" if float(mantissa) > 0 else ""
        raise ValueError(f"must be > 0, got {text}{detail}; radii, stiffnesses, their errors "
                         "and the bulge depth are positive")
    return value


# --------------------------------------------------------------------------- writing
def write_cells(cells, path):
    """Write a :class:`CellData` in the canonical CSV form (see the module docstring).

    Parameters
    ----------
    cells : CellData
        The data set; SI values are converted back to the CSV units exactly.
    path : str or pathlib.Path
        Output file (overwritten).

    Returns
    -------
    pathlib.Path
        The written file.
    """
    if not isinstance(cells, CellData):
        raise TypeError(f"write_cells needs a CellData, got {type(cells).__name__}")
    path = Path(path)
    buf = io.StringIO(newline="")
    for comment in cells.comments:
        buf.write(comment + "\n")
    writer = csv.writer(buf, lineterminator="\n")
    writer.writerow(COLUMNS + tuple(cells.extra))
    for i in range(len(cells)):
        writer.writerow(_row_fields(cells, i))
    path.write_bytes(buf.getvalue().encode("utf-8"))
    return path


def _row_fields(cells, i):
    numbers = []
    for column in COLUMNS[2:]:
        name, exponent = _NUMERIC[column]
        value = float(getattr(cells, name)[i])
        numbers.append("" if np.isnan(value) else _format_number(value, exponent))
    extras = [values[i] for values in cells.extra.values()]
    return [cells.cell_id[i], cells.group[i], *numbers, *extras]


def _format_number(value, exponent):
    """Shortest CSV text that reads back to exactly ``value`` [SI]: repr shifted by 10**exponent."""
    d = Decimal(repr(value)).scaleb(exponent).normalize()
    if -4 <= d.adjusted() < 16:
        return format(d, "f")
    sign, digits, _ = d.as_tuple()
    mantissa = str(digits[0]) + ("." + "".join(map(str, digits[1:])) if len(digits) > 1 else "")
    return f"{'-' if sign else ''}{mantissa}e{d.adjusted():+03d}"


def example_path():
    """Path of the bundled example data set ``turgorbayes/data/example_cells.csv``."""
    return Path(str(importlib.resources.files("turgorbayes") / "data" / "example_cells.csv"))


def is_simulated(cells):
    """Whether a comment line of the cells' file says they are simulated."""
    return any("simulated" in c.lower() for c in cells.comments)
