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

The module is longer than most (about 650 lines) because one concept, the file format, owns
both directions and every line-, column- and value-precise error message of the reader;
the physical plausibility of the values is :mod:`turgorbayes.cells.plausibility`.
"""

import csv
import hashlib
import importlib.resources
import io
import re
import types
import warnings
from dataclasses import dataclass, field
from decimal import Decimal
from pathlib import Path

import numpy as np

from turgorbayes.cells import plausibility
from turgorbayes.cells.columns import NUMERIC_COLUMNS
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

GROUPS = ("bulged", "intact")
#: Filled on every row.
REQUIRED_COLUMNS = ("cell_id", "group", "Rc_nm", "Rc_err_nm", "kc_N_per_m", "kc_err_N_per_m")
#: Filled on bulged rows, empty on intact rows (but always present in the header).
BULGE_COLUMNS = ("Rb_nm", "Rb_err_nm", "kb_N_per_m", "kb_err_N_per_m", "hb_nm")
#: All standard columns in canonical order.
COLUMNS = REQUIRED_COLUMNS + BULGE_COLUMNS

# numeric column -> (CellData field, decimal exponent e with value_SI = value_CSV * 10**-e)
_NUMERIC = {c: (col.field, col.exponent) for c, col in NUMERIC_COLUMNS.items()}
_BULGE_FIELDS = tuple(_NUMERIC[c][0] for c in BULGE_COLUMNS)
_CORE_FIELDS = tuple(_NUMERIC[c][0] for c in REQUIRED_COLUMNS[2:])
_NUMBER = re.compile(r"([+-]?(?:\d+\.?\d*|\.\d+))(?:[eE]([+-]?\d+))?")
_NONFINITE = {"nan", "inf", "infinity"}


# --------------------------------------------------------------------------- data set
def _rebuilt(kwargs):
    """A :class:`CellData` from its pickled arguments (:meth:`CellData.__reduce__`)."""
    return CellData(**kwargs)


@dataclass(frozen=True, eq=False)
class CellData:
    """A validated, immutable set of measured cells, SI units inside.

    Build it with :func:`read_cells` or directly (the constructor validates the same rules as
    the loader, naming the cell instead of the line). Arrays are copied and made read-only.

    Parameters
    ----------
    cell_id : sequence of str
        Unique, non-empty names (no surrounding whitespace, not starting with ``#``).
    group : sequence of str
        ``"bulged"`` or ``"intact"`` per cell.
    R_c, R_c_err : array_like [m]
        Cell radius and its standard error, > 0 for every cell.
    k_c, k_c_err : array_like [N/m]
        Cell-body stiffness and its standard error, > 0 for every cell.
    R_b, R_b_err : array_like [m], optional
        Bulge radius and its error: > 0 on bulged cells, NaN on intact cells.
    k_b, k_b_err : array_like [N/m], optional
        Bulge stiffness and its error: > 0 on bulged cells, NaN on intact cells.
    h_b : array_like [m], optional
        Bulge indentation depth at which k_b was read: > 0 on bulged, NaN on intact cells.
        The five bulge arrays may be omitted (all NaN) when there is no bulged cell.
    extra : mapping of str to sequence of str, optional
        Further columns, carried along as text, in order.
    comments : sequence of str, optional
        Provenance lines, each starting with ``#``.
    path : str, optional
        The file the data came from.
    sha256 : str, optional
        SHA-256 hex digest of that file's bytes.

    Attributes
    ----------
    is_bulged : numpy.ndarray of bool
        ``group == "bulged"`` per cell.
    """

    cell_id: tuple
    group: tuple
    R_c: np.ndarray
    R_c_err: np.ndarray
    k_c: np.ndarray
    k_c_err: np.ndarray
    R_b: np.ndarray = None
    R_b_err: np.ndarray = None
    k_b: np.ndarray = None
    k_b_err: np.ndarray = None
    h_b: np.ndarray = None
    extra: types.MappingProxyType = field(default_factory=dict)
    comments: tuple = ()
    path: str = None
    sha256: str = None
    is_bulged: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        cell_id = _check_cell_ids(self.cell_id, self.path)
        n = len(cell_id)
        group = _check_groups(self.group, n, cell_id, self.path)
        is_bulged = _readonly(np.array([g == "bulged" for g in group], dtype=bool))
        values = {
            name: _check_numeric(getattr(self, name), name, is_bulged, cell_id, self.path)
            for name in _CORE_FIELDS + _BULGE_FIELDS
        }
        extra = _check_extra(self.extra, n, self.path)
        comments = _check_comments(self.comments, self.path)
        path = None if self.path is None else str(self.path)
        for name, value in dict(
            values, cell_id=cell_id, group=group, is_bulged=is_bulged, extra=extra,
            comments=comments, path=path,
        ).items():
            object.__setattr__(self, name, value)

    def __len__(self):
        return len(self.cell_id)

    def __reduce__(self):
        """Pickled as its constructor's arguments (the read-only ``extra`` mapping as a dict),
        so that worker processes can receive cells (:mod:`turgorbayes.parallel`)."""
        fields = {name: getattr(self, name) for name in _CORE_FIELDS + _BULGE_FIELDS}
        return _rebuilt, (dict(fields, cell_id=self.cell_id, group=self.group,
                               extra=dict(self.extra), comments=self.comments, path=self.path,
                               sha256=self.sha256),)

    def __repr__(self):
        source = f", path={self.path!r}" if self.path else ""
        return f"CellData({self.n_bulged} bulged, {self.n_intact} intact{source})"

    @property
    def n_bulged(self):
        """Number of bulged cells."""
        return int(np.count_nonzero(self.is_bulged))

    @property
    def n_intact(self):
        """Number of intact cells."""
        return len(self) - self.n_bulged

    def bulged(self):
        """The bulged cells, in file order, as a new :class:`CellData`."""
        return self.take(np.flatnonzero(self.is_bulged))

    def intact(self):
        """The intact cells, in file order, as a new :class:`CellData`."""
        return self.take(np.flatnonzero(~self.is_bulged))

    def take(self, indices):
        """The cells at ``indices`` (integers, in that order, or a boolean mask of length
        ``len(self)``) as a new :class:`CellData`.

        Comments, path and sha256 (of the source file) are kept as provenance.
        """
        idx = np.asarray(indices)
        if idx.dtype == bool:
            if idx.shape != (len(self),):
                raise ValueError(f"boolean mask has shape {idx.shape}, expected ({len(self)},)")
            idx = np.flatnonzero(idx)
        idx = idx.astype(np.intp, casting="same_kind").reshape(-1)
        arrays = {name: getattr(self, name)[idx] for name in _CORE_FIELDS + _BULGE_FIELDS}
        return CellData(
            cell_id=tuple(self.cell_id[i] for i in idx),
            group=tuple(self.group[i] for i in idx),
            extra={k: tuple(v[i] for i in idx) for k, v in self.extra.items()},
            comments=self.comments, path=self.path, sha256=self.sha256, **arrays,
        )

    def require_both_groups(self):
        """Return self if there are bulged and intact cells, else raise :class:`DataError`.

        The global fit needs bulged cells (their bulges give each cell's pressure, which
        calibrates the wall elasticity) and intact cells (whose pressure is the physiological
        turgor to be estimated). Loading a single group is allowed, e.g. to inspect it.
        """
        missing = [g for g, n in (("bulged", self.n_bulged), ("intact", self.n_intact)) if n == 0]
        if missing:
            raise DataError(
                f"no {' and no '.join(missing)} cells (found {self.n_bulged} bulged, "
                f"{self.n_intact} intact); the fit needs bulged cells to calibrate the wall "
                "elasticity and intact cells to estimate the physiological turgor",
                path=self.path,
            )
        return self


def _readonly(arr):
    arr.flags.writeable = False
    return arr


def _ids_text(cell_id, bad, limit=5):
    names = [repr(cell_id[i]) for i in np.flatnonzero(bad)[:limit]]
    more = int(np.count_nonzero(bad)) - len(names)
    return ", ".join(names) + (f" and {more} more" if more > 0 else "")


def _check_cell_ids(cell_id, path):
    if isinstance(cell_id, str):
        raise DataError(f"cell_id must be a sequence of str, got one str {cell_id!r}", path=path)
    cell_id = tuple(cell_id)
    seen = {}
    for i, cid in enumerate(cell_id):
        problem = _cell_id_problem(cid)
        if problem is None and cid in seen:
            problem = f"duplicate cell_id {cid!r} (cells {seen[cid] + 1} and {i + 1})"
        if problem is not None:
            raise DataError(problem, path=path, column="cell_id", value=cid)
        seen[cid] = i
    return cell_id


def _cell_id_problem(cid):
    if not isinstance(cid, str):
        return f"cell_id must be str, got {type(cid).__name__} {cid!r}"
    if not cid.strip():
        return "cell_id is empty; every cell needs a unique name"
    if cid != cid.strip() or "\n" in cid or "\r" in cid:
        return f"cell_id {cid!r} has surrounding whitespace or a line break"
    if cid.startswith("#"):
        return f"cell_id {cid!r} starts with '#', which would read as a comment line"
    return None


def _check_groups(group, n, cell_id, path):
    group = tuple(group)
    if len(group) != n:
        raise DataError(f"group has {len(group)} entries for {n} cells", path=path, column="group")
    for cid, g in zip(cell_id, group, strict=True):
        if g not in GROUPS:
            raise DataError(
                f"group must be one of {', '.join(map(repr, GROUPS))}, got {g!r} "
                f"(cell_id {cid!r})",
                path=path, column="group", value=g,
            )
    return group


def _check_numeric(values, name, is_bulged, cell_id, path):
    n = len(cell_id)
    is_bulge = name in _BULGE_FIELDS
    if values is None and is_bulge:
        values = np.full(n, np.nan)
    try:
        arr = np.array(values, dtype=float, copy=True)
    except (TypeError, ValueError) as err:
        raise DataError(f"{name} must be numeric: {err}", path=path, column=name) from None
    if arr.shape != (n,):
        raise DataError(f"{name} has shape {arr.shape}, expected ({n},)", path=path, column=name)
    must_be_set = is_bulged if is_bulge else np.ones(n, dtype=bool)
    bad = must_be_set & ~(np.isfinite(arr) & (arr > 0))
    if bad.any():
        raise DataError(
            f"{name} must be finite and > 0 [SI]; bad for cell_id {_ids_text(cell_id, bad)}"
            f" (values {arr[bad][:5].tolist()})",
            path=path, column=name,
        )
    stray = ~must_be_set & ~np.isnan(arr)
    if stray.any():
        raise DataError(
            f"{name} must be NaN on intact cells (a bulge field); set for cell_id "
            f"{_ids_text(cell_id, stray)}",
            path=path, column=name,
        )
    return _readonly(arr)


def _check_extra(extra, n, path):
    checked = {}
    for name, values in dict(extra).items():
        if not isinstance(name, str) or not name.strip() or name in COLUMNS:
            raise DataError(
                f"extra column name must be a non-empty str other than the standard columns, "
                f"got {name!r}",
                path=path,
            )
        values = tuple(values)
        if len(values) != n or not all(isinstance(v, str) for v in values):
            raise DataError(
                f"extra column must hold {n} str values, got {len(values)} entries",
                path=path, column=name,
            )
        checked[name] = values
    return types.MappingProxyType(checked)


def _check_comments(comments, path):
    if isinstance(comments, str):
        comments = (comments,)
    comments = tuple(comments)
    for c in comments:
        if not isinstance(c, str) or not c.startswith("#") or "\n" in c or "\r" in c:
            raise DataError(
                f"comment lines must be str starting with '#' without line breaks, got {c!r}",
                path=path,
            )
    return comments


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
    problem = _cell_id_problem(cid)
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
