"""The curve manifest: one row per force-curve file, with the cell it belongs to (docs/curves.md).

Errors name the manifest, its 1-based physical line, the column and the value.
"""

import csv
import hashlib
import io
import math
from dataclasses import dataclass, field
from decimal import Decimal
from pathlib import Path

from turgorbayes.curves import load
from turgorbayes.curves.qc import CurveRejected
from turgorbayes.errors import DataError

__all__ = ["KNOWN_COLUMNS", "REQUIRED_COLUMNS", "Manifest", "ManifestRow", "read_manifest"]

REQUIRED_COLUMNS = ("file", "cell_id", "target", "Rc_nm", "Rc_err_nm")
#: Columns with a meaning; all others are carried along.
KNOWN_COLUMNS = REQUIRED_COLUMNS + ("Rb_nm", "Rb_err_nm", "spring_constant_N_per_m",
                                    "sensitivity_m_per_V", "curve_index")
#: ``glass``: a curve on the hard substrate, the deflection-sensitivity reference of its session.
_TARGETS = ("cell", "bulge", "glass")
# column -> (field, SI factor)
_NUMBERS = {"Rc_nm": ("R_c", 1e-9), "Rc_err_nm": ("R_c_err", 1e-9), "Rb_nm": ("R_b", 1e-9),
            "Rb_err_nm": ("R_b_err", 1e-9), "spring_constant_N_per_m": ("spring_constant", 1.0),
            "sensitivity_m_per_V": ("sensitivity", 1.0)}


@dataclass(frozen=True)
class ManifestRow:
    """One curve of the manifest, SI units (NaN/None where the column is empty).

    ``session`` is an extra column (carried to the outputs); :attr:`session` reads it.
    ``whole_map`` rows (``curve_index`` = ``map``) use every curve of a force map
    (:mod:`turgorbayes.curves.forcemap`); their ``R_c`` may be NaN (fitted from the map).
    """

    line: int
    file: Path
    name: str
    cell_id: str
    target: str
    R_c: float
    R_c_err: float
    R_b: float = math.nan
    R_b_err: float = math.nan
    spring_constant: float = None
    sensitivity: float = None
    extra: dict = field(default_factory=dict)
    curve_index: int = 0
    whole_map: bool = False

    @property
    def session(self):
        """The row's ``session`` (empty text if none)."""
        return self.extra.get("session", "")


@dataclass(frozen=True)
class Manifest:
    """A read and checked manifest."""

    path: Path
    sha256: str
    rows: tuple
    extra_columns: tuple
    comments: tuple


def read_manifest(path):
    """Read and check a curve manifest.

    Parameters
    ----------
    path : str or pathlib.Path
        CSV with the columns of :data:`REQUIRED_COLUMNS`, ``Rb_nm``/``Rb_err_nm`` on bulge
        rows, optional calibration overrides, an optional ``curve_index`` (curve of a
        multi-curve file, default 0; ``map``: the whole force map, whose fit gives ``R_c`` if
        ``Rc_nm`` is empty) and any other columns (carried along; ``session`` is
        required on ``glass`` rows, which have no radii). Lines starting with ``#`` before the
        header are comments. ``file`` is relative to the manifest's folder.

    Returns
    -------
    Manifest

    Raises
    ------
    turgorbayes.errors.DataError
        Naming the line, column and value of the first problem.
    """
    path = Path(path)
    raw = path.read_bytes()
    lines = raw.decode("utf-8-sig").splitlines(keepends=True)
    n_comments = next((i for i, s in enumerate(lines) if not s.startswith("#")), len(lines))
    reader = csv.reader(io.StringIO("".join(lines[n_comments:])))
    header = next(reader, None)
    if not header:
        raise DataError("no header row", path=path)
    header = [h.strip() for h in header]
    for column in REQUIRED_COLUMNS:
        if column not in header:
            raise DataError(f"missing column {column!r} (required: {', '.join(REQUIRED_COLUMNS)})",
                            path=path, line=n_comments + 1)
    from turgorbayes.cells.table import COLUMNS

    for column in header:
        if column in COLUMNS and column not in KNOWN_COLUMNS:
            raise DataError(f"column {column!r} belongs to the cell-data output; rename it",
                            path=path, line=n_comments + 1, column=column)
    rows, n_curves = [], {}
    for offset, fields in enumerate(reader):
        line = n_comments + 2 + offset
        if not any(f.strip() for f in fields):
            continue
        if len(fields) != len(header):
            raise DataError(f"{len(fields)} fields, the header has {len(header)}", path=path, line=line)
        row = _row(dict(zip(header, (f.strip() for f in fields), strict=True)), path, line)
        _check_curve_index(row, path, n_curves)
        rows.append(row)
    if not rows:
        raise DataError("no curves listed", path=path)
    _check_cells(rows, path)
    extra = tuple(h for h in header if h not in KNOWN_COLUMNS)
    return Manifest(path=path, sha256=hashlib.sha256(raw).hexdigest(), rows=tuple(rows),
                    extra_columns=extra, comments=tuple(s.rstrip("\r\n") for s in lines[:n_comments]))


def _number(record, column, path, line, required):
    text = record.get(column, "")
    if text == "":
        if required:
            raise DataError("must not be empty", path=path, line=line, column=column)
        return None
    try:
        value = float(text)
    except ValueError:
        raise DataError(f"not a number: {text!r}", path=path, line=line, column=column,
                        value=text) from None
    if not (math.isfinite(value) and value > 0):
        raise DataError(f"must be a finite number > 0, got {text!r}", path=path, line=line,
                        column=column, value=text)
    # an exact decimal shift (540.7 nm -> float("540.7e-9")), as the cell-data CSV is read, so
    # that 500 nm is written back as 500, not 500.0000000000001 (500 * 1e-9 rounds twice)
    return float(Decimal(text) * Decimal(repr(_NUMBERS[column][1])))


#: ``curve_index`` of a row that uses every curve of a force map (docs/curves.md, Whole force maps).
WHOLE_MAP = "map"


def _curve_index(record, path, line):
    text = record.get("curve_index", "")
    if text == "" or text == WHOLE_MAP:
        return 0
    if not (text.isascii() and text.isdigit()):
        raise DataError(f"curve_index must be an integer >= 0 (0-based index of the curve in its "
                        f"file) or {WHOLE_MAP!r} (the whole force map), got {text!r}", path=path,
                        line=line, column="curve_index", value=text)
    return int(text)


def _check_whole_map(record, path, line):
    """A whole-map row is a cell-body or a bulge row; without ``Rc_nm`` (``Rb_nm`` on a bulge
    row) it has no ``Rc_err_nm`` (``Rb_err_nm``) either."""
    if record["target"] not in ("cell", "bulge"):
        raise DataError(f"a whole force map (curve_index {WHOLE_MAP!r}) gives the cell body's k_c "
                        f"and R_c (target 'cell') or its bulge's k_b and R_b (target 'bulge'): "
                        f"target must be 'cell' or 'bulge', got {record['target']!r}", path=path,
                        line=line, column="target", value=record["target"])
    radius = "Rb" if record["target"] == "bulge" else "Rc"
    if record.get(f"{radius}_err_nm", "") and not record.get(f"{radius}_nm", ""):
        raise DataError(f"{radius}_err_nm without {radius}_nm: leave both empty (the map's fit "
                        f"gives {radius[0]}_{radius[1]} and its error) or give both", path=path,
                        line=line, column=f"{radius}_err_nm", value=record[f"{radius}_err_nm"])


def _check_curve_index(row, path, n_curves):
    """A ``curve_index`` past 0 must exist in the file (counted once per file)."""
    if row.curve_index == 0:
        return
    if row.file not in n_curves:
        try:
            n_curves[row.file] = load.count_curves(row.file)
        except CurveRejected:  # reported as the curve's status (unreadable_file)
            n_curves[row.file] = None
    n = n_curves[row.file]
    if n is not None and row.curve_index >= n:
        raise DataError(load.curve_index_problem(row.curve_index, n, repr(row.name)), path=path,
                        line=row.line, column="curve_index", value=str(row.curve_index))


def _check_glass(record, path, line):
    """A glass row names its session and has no cell radii."""
    if not record.get("session", ""):
        raise DataError("a glass row needs a session (the glass curve checks its session's "
                        "deflection sensitivity)", path=path, line=line, column="session")
    for column in ("Rc_nm", "Rc_err_nm", "Rb_nm", "Rb_err_nm"):
        if record.get(column, ""):
            raise DataError(f"a glass row has no cell: {column} must be empty, got "
                            f"{record[column]!r}", path=path, line=line, column=column,
                            value=record[column])


def _row(record, path, line):
    target = record["target"]
    if target not in _TARGETS:
        raise DataError(f"target must be 'cell', 'bulge' or 'glass', got {target!r}", path=path,
                        line=line, column="target", value=target)
    if target == "glass":
        _check_glass(record, path, line)
    elif not record["cell_id"]:
        raise DataError("must not be empty", path=path, line=line, column="cell_id")
    if not record["file"]:
        raise DataError("must not be empty", path=path, line=line, column="file")
    file = path.parent / record["file"]
    if not file.is_file():
        raise DataError(f"curve file {str(file)!r} does not exist", path=path, line=line,
                        column="file", value=record["file"])
    whole_map = record.get("curve_index", "") == WHOLE_MAP
    if whole_map:
        _check_whole_map(record, path, line)
    values = {}
    for column, (name, _) in _NUMBERS.items():
        # R_c may come from a force map's fit: checked per cell (_check_fitted_radius)
        required = column.startswith({"cell": "Rc", "bulge": "Rb"}.get(target, "-")) and not whole_map
        if column == "Rc_err_nm" and record.get("Rc_nm", ""):
            required = target != "glass"
        if column == "Rb_err_nm" and record.get("Rb_nm", ""):
            required = target == "bulge"
        value = _number(record, column, path, line, required)
        values[name] = math.nan if value is None and column.startswith("R") else value
    extra = {k: v for k, v in record.items() if k not in KNOWN_COLUMNS}
    return ManifestRow(line=line, file=file, name=record["file"], cell_id=record["cell_id"], target=target,
                       extra=extra, curve_index=_curve_index(record, path, line),
                       whole_map=whole_map, **values)


def _check_fitted_radius(cell_id, cell_rows, path):
    """An empty ``Rc_nm`` is allowed only on every row of a cell whose one cell-body row is a
    whole force map (its fit gives R_c)."""
    empty = [r for r in cell_rows if math.isnan(r.R_c)]
    if not empty:
        return
    body = [r for r in cell_rows if r.target == "cell"]
    fitted = len(body) == 1 and body[0].whole_map
    bad = next((r for r in cell_rows if not math.isnan(r.R_c)), None) if fitted else empty[0]
    if bad is None:
        return
    n_maps = sum(r.whole_map for r in body)
    why = (f"must not be empty: cell {cell_id!r} has {len(body)} cell-body "
           f"row{'s' if len(body) != 1 else ''}, {n_maps} of them whole force maps"
           if not fitted else f"cell {cell_id!r} gets R_c from its force map (empty Rc_nm on "
           f"line {body[0].line}): Rc_nm must be empty on all its rows, got {bad.R_c * 1e9:g}")
    raise DataError(why + f"; R_c is fitted only for a cell whose single cell-body row is a "
                    f"whole force map (curve_index {WHOLE_MAP!r})", path=path, line=bad.line,
                    column="Rc_nm")


def _check_fitted_bulge_radius(cell_id, cell_rows, path):
    """An empty ``Rb_nm`` is allowed only on a cell whose one bulge row is a whole force map."""
    bulges = [r for r in cell_rows if r.target == "bulge"]
    empty = [r for r in bulges if math.isnan(r.R_b)]
    if not empty or (len(bulges) == 1 and bulges[0].whole_map):
        return
    raise DataError(f"must not be empty: cell {cell_id!r} has {len(bulges)} bulge rows; R_b is "
                    f"fitted only for a cell whose single bulge row is a whole force map "
                    f"(curve_index {WHOLE_MAP!r})", path=path, line=empty[0].line, column="Rb_nm")


def _check_cells(rows, path):
    """Each cell has a cell-body curve, and one R_c (and one R_b) on all its rows."""
    by_cell = {}
    for row in rows:
        if row.target != "glass":  # glass rows belong to a session, never to a cell
            by_cell.setdefault(row.cell_id, []).append(row)
    for cell_id, cell_rows in by_cell.items():
        if not any(r.target == "cell" for r in cell_rows):
            raise DataError(f"cell {cell_id!r} has no 'cell' curve (k_c is needed for every cell)",
                            path=path, line=cell_rows[0].line, column="target")
        _check_fitted_radius(cell_id, cell_rows, path)
        _check_fitted_bulge_radius(cell_id, cell_rows, path)
        for name, column, rs in (("R_c", "Rc_nm", cell_rows), ("R_c_err", "Rc_err_nm", cell_rows),
                                 ("R_b", "Rb_nm", [r for r in cell_rows if r.target == "bulge"]),
                                 ("R_b_err", "Rb_err_nm", [r for r in cell_rows if r.target == "bulge"])):
            values = {getattr(r, name) for r in rs}
            if len(values) > 1:
                bad = next(r for r in rs if getattr(r, name) != getattr(rs[0], name))
                raise DataError(f"cell {cell_id!r} has {column} {sorted(v * 1e9 for v in values)} on "
                                "different rows; one cell has one value", path=path, line=bad.line,
                                column=column)
