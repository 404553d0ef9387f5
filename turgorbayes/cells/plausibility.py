"""Physical plausibility of cell data: values no bacterium can have, and the unit slip they suggest.

:func:`check` compares every cell with bounds wide enough for any bacterium measured by AFM:
radii 50 nm-5 um, stiffnesses 1e-5-1 N/m, bulge depth 5 nm up to R_b, implied bulge pressure
0.05-1000 kPa, standard errors 0.1-100 % of their value. A value outside is named with the unit
slip that would make it plausible ("looks like um, the column is nm"). The bounds, their sources
and the slips they catch are tabulated in ``docs/data_format.md``.
"""

from dataclasses import dataclass

import numpy as np

from turgorbayes.cells.columns import NUMERIC_COLUMNS

__all__ = [
    "DEPTH_MIN",
    "LARGER_CELL_RADIUS",
    "PRESSURE_RANGE",
    "RADIUS_RANGE",
    "RELATIVE_ERROR_RANGE",
    "STIFFNESS_RANGE",
    "Problem",
    "UnusualValueWarning",
    "check",
    "describe",
]

#: Cell and bulge radius [m]: bacteria are 0.2-2 um in radius; 50 nm-5 um leaves a margin of
#: 4x below and 2.5x above, still far from a 1000x unit slip.
RADIUS_RANGE = (50e-9, 5e-6)
#: Radius up to which a value above RADIUS_RANGE is as likely a larger cell as a unit slip [m]:
#: yeast and mammalian cells are 2-25 um in radius. Up to it no unit is suggested (a 10 um
#: radius in nm was called Angstrom, 10000 A = 1 um); above it a slip is the likely cause.
LARGER_CELL_RADIUS = 50e-6
#: Cell and bulge stiffness [N/m]: AFM cantilevers are 0.01-1 N/m and a sample much stiffer
#: than the cantilever cannot be indented; a bulge at the pressure floor (0.05 kPa, R_b = 500 nm)
#: has k_b = P R_b khat(h_b/R_b) = 1e-5 N/m, so a softer value implies no bacterial pressure.
STIFFNESS_RANGE = (1e-5, 1.0)
#: Smallest bulge indentation depth [m]: the contact point of an AFM curve is uncertain by a
#: few nm. The largest is R_b (deeper, the cone would reach the cell body under the bulge).
DEPTH_MIN = 5e-9
#: Bulge pressure implied by k_b, R_b, h_b [Pa]: bacterial turgor is 10-300 kPa, the paper's
#: bulge pressures 1-25 kPa; 0.05-1000 kPa covers both with a wide margin.
PRESSURE_RANGE = (50.0, 1e6)
#: Standard error / value: no AFM or imaging measurement is better than 0.1 % (cantilever
#: calibration alone is 5-10 %); an error larger than its value carries no information.
RELATIVE_ERROR_RANGE = (1e-3, 1.0)

# CSV column -> (CellData field, CSV unit, CSV value per SI value, kind), from the one table
_COLUMNS = {c: (col.field, col.unit, col.per_si, col.kind) for c, col in NUMERIC_COLUMNS.items()
            if col.error_of is None}
# error column -> value column
_ERRORS = {c: col.error_of for c, col in NUMERIC_COLUMNS.items() if col.error_of}
_ERROR_FIELDS = {c: NUMERIC_COLUMNS[c].field for c in _ERRORS}
# kind -> (SI range, what it is, [(unit the value may really be in, CSV value per such unit)])
_KINDS = {
    "radius": (RADIUS_RANGE, "of any bacterium",
               [("um", 1e3), ("m", 1e9), ("Angstrom", 0.1), ("pm", 1e-3)]),
    "stiffness": (STIFFNESS_RANGE, "an AFM can measure on a cell",
                  [("pN/nm", 1e-3), ("pN/um", 1e-6), ("N/mm", 1e3)]),
    "depth": ((DEPTH_MIN, RADIUS_RANGE[1]), "for a bulge indentation",
              [("um", 1e3), ("m", 1e9), ("Angstrom", 0.1)]),
}
_PRESSURE_COLUMN = "P_bulge_kPa"
# units that are the same as another, named with it
_ALIAS = {"pN/nm": "pN/nm = mN/m", "pN/um": "pN/um = uN/m", "N/mm": "N/mm = kN/m"}


class UnusualValueWarning(UserWarning):
    """Values outside the plausible bounds were let through (``allow_unusual=True``)."""


@dataclass(frozen=True)
class Problem:
    """One implausible value.

    Attributes
    ----------
    row : int
        0-based index of the cell in the data set.
    cell_id : str
    column : str
        CSV column (``P_bulge_kPa`` for the pressure implied by the bulge columns).
    value : float
        The value in the column's CSV unit (kPa for ``P_bulge_kPa``).
    reason : str
        What is wrong and the likely unit slip.
    """

    row: int
    cell_id: str
    column: str
    value: float
    reason: str


def _range_text(lo, hi, unit):
    return f"{lo:g}-{hi:g} {unit}"


def _slip(value, lo, hi, slips, unit):
    """Reason clause naming the first unit in which ``value`` [CSV unit] would be plausible."""
    for label, factor in slips:
        if lo <= value * factor <= hi:
            return (f"it looks like {_ALIAS.get(label, label)}, the column is {unit} "
                    f"({value:.4g} {label} = {value * factor:.4g} {unit})")
    return "no simple unit slip explains it: check the measurement"


def _bounds_problems(cells, column):
    field, unit, scale, kind = _COLUMNS[column]
    (lo_si, hi_si), what, slips = _KINDS[kind]
    lo, hi = lo_si * scale, hi_si * scale
    values = np.asarray(getattr(cells, field), float) * scale
    bad = np.isfinite(values) & ~((values >= lo) & (values <= hi))
    out = []
    for i in np.flatnonzero(bad):
        v = float(values[i])
        side = "below" if v < lo else "above"
        if kind == "radius" and hi < v <= LARGER_CELL_RADIUS * scale:
            why = ("a cell larger than any bacterium (yeast and mammalian cells are 2-25 um in "
                   "radius), which the model does not describe, or a value in another unit: "
                   "check the measurement")
        else:
            why = _slip(v, lo, hi, slips, unit)
        out.append(Problem(int(i), cells.cell_id[i], column, v,
                           f"{v:.4g} {unit} is {side} the {_range_text(lo, hi, unit)} {what}; "
                           + why))
    return out


def _depth_problems(cells):
    h, R = np.asarray(cells.h_b, float), np.asarray(cells.R_b, float)
    bad = np.isfinite(h) & np.isfinite(R) & (h >= R)
    return [Problem(int(i), cells.cell_id[i], "hb_nm", float(h[i] * 1e9),
                    f"h_b = {h[i] * 1e9:.4g} nm is not smaller than R_b = {R[i] * 1e9:.4g} nm: a "
                    "cone that deep would reach the cell body under the bulge (are hb_nm and "
                    "Rb_nm swapped, or one of them in another unit?)")
            for i in np.flatnonzero(bad)]


def _error_problems(cells, column):
    value_column = _ERRORS[column]
    field, unit, scale, _ = _COLUMNS[value_column]
    err = np.asarray(getattr(cells, _ERROR_FIELDS[column]), float) * scale
    val = np.asarray(getattr(cells, field), float) * scale
    with np.errstate(invalid="ignore", divide="ignore"):
        rel = err / val
    lo, hi = RELATIVE_ERROR_RANGE
    bad = np.isfinite(rel) & ~((rel >= lo) & (rel <= hi))
    out = []
    for i in np.flatnonzero(bad):
        why = ("larger than the value itself (entered as a percentage, or in another unit?)"
               if rel[i] > hi else
               f"below {lo:.1%} of the value, more precise than any AFM or imaging measurement "
               "(entered in another unit?)")
        out.append(Problem(int(i), cells.cell_id[i], column, float(err[i]),
                           f"{err[i]:.4g} {unit} is {rel[i]:.3g} x {value_column} = "
                           f"{val[i]:.4g} {unit}: {why}"))
    return out


def _pressure_problems(cells, skip):
    """Bulges whose implied pressure is implausible, on rows whose inputs passed their bounds."""
    from turgorbayes.physics.bulge import pressure_from_bulge

    k, R, h = (np.asarray(getattr(cells, f), float) for f in ("k_b", "R_b", "h_b"))
    ok = np.isfinite(k) & np.isfinite(R) & np.isfinite(h) & (k > 0) & (h > 0) & (h < R)
    ok[list(skip)] = False
    P = np.full(k.shape, np.nan)
    if ok.any():
        P[ok] = pressure_from_bulge(k[ok], R[ok], h[ok])
    lo, hi = PRESSURE_RANGE
    bad = ok & ~((P >= lo) & (P <= hi))
    return [Problem(int(i), cells.cell_id[i], _PRESSURE_COLUMN, float(P[i] / 1e3),
                    f"the bulge (kb_N_per_m, Rb_nm, hb_nm) implies a pressure of "
                    f"{P[i] / 1e3:.4g} kPa, outside the {_range_text(lo / 1e3, hi / 1e3, 'kPa')} "
                    f"of any bacterium (turgor 10-300 kPa); {_pressure_slip(P[i], lo, hi)}")
            for i in np.flatnonzero(bad)]


def _pressure_slip(P, lo, hi):
    """P = k_b / (R_b khat(h_b/R_b)) [Pa] scales with k_b and 1/R_b: name the 1000x slips."""
    if lo <= P * 1e-3 <= hi:
        return ("1000x too high: is kb_N_per_m in pN/nm (= mN/m), or Rb_nm and hb_nm in um "
                "while h_b/R_b is right?")
    if lo <= P * 1e3 <= hi:
        return "1000x too low: is kb_N_per_m 1000x too small, or Rb_nm and hb_nm 1000x too large?"
    return "check the units of kb_N_per_m, Rb_nm and hb_nm"


def check(cells):
    """Every implausible value of a data set (bounds: module docstring, ``docs/data_format.md``).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData

    Returns
    -------
    list of Problem
        Sorted by row, then column; empty if every value is plausible. The implied bulge
        pressure is checked only on rows whose k_b, R_b and h_b passed their own bounds.
    """
    problems = []
    for column in _COLUMNS:
        problems += _bounds_problems(cells, column)
    problems += _depth_problems(cells)
    bulge_rows = {p.row for p in problems if p.column in ("kb_N_per_m", "Rb_nm", "hb_nm")}
    problems += _pressure_problems(cells, bulge_rows)
    for column in _ERRORS:
        problems += _error_problems(cells, column)
    order = {c: j for j, c in enumerate((*_COLUMNS, _PRESSURE_COLUMN, *_ERRORS))}
    return sorted(problems, key=lambda p: (p.row, order[p.column]))


def describe(problems, lines=None, limit=5):
    """A few lines listing ``problems`` (at most ``limit``), by file line if ``lines`` is given.

    Parameters
    ----------
    problems : list of Problem
    lines : sequence of int, optional
        1-based file line of each row.
    limit : int
    """
    out = []
    for p in problems[:limit]:
        where = f"line {lines[p.row]}" if lines is not None else f"cell {p.row + 1}"
        out.append(f"  {where} (cell_id {p.cell_id!r}), {p.column}: {p.reason}")
    if len(problems) > limit:
        out.append(f"  ... and {len(problems) - limit} more")
    return "\n".join(out)
