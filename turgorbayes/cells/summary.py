"""What a cell-data file holds: bulge-derived pressures, unusual values, a one-screen summary.

:func:`validation_summary` is what ``turgorbayes validate`` prints; :func:`bulge_pressures`
gives each bulged cell's pressure from the bulge model (``docs/physics.md``).
"""

import numpy as np

from turgorbayes.cells import plausibility
from turgorbayes.cells.columns import (
    BULGE_COLUMNS,
    CONDITION_COLUMN,
    NUMERIC_COLUMNS,
    REQUIRED_COLUMNS,
)
from turgorbayes.cells.medium import medium_levels, medium_osmolarity
from turgorbayes.errors import DataError

__all__ = ["bulge_pressures", "validation_summary"]

# column -> (CellData field, factor from SI to the CSV unit); display only
_DISPLAY = {c: (col.field, col.per_si) for c, col in NUMERIC_COLUMNS.items()}
_MAX_LISTED = 10


def bulge_pressures(cells):
    """Pressure implied by each bulged cell's bulge, and the reason where there is none.

    Parameters
    ----------
    cells : CellData

    Returns
    -------
    P : ndarray [Pa]
        One value per bulged cell (file order), NaN where the bulge model gives no pressure.
    reasons : dict
        ``cell_id -> reason`` for those NaN entries.
    """
    from turgorbayes.physics.bulge import pressure_from_bulge

    bulged = cells.bulged()
    try:
        P = np.asarray(pressure_from_bulge(bulged.k_b, bulged.R_b, bulged.h_b), dtype=float)
        reasons = {}
    except ValueError:
        # The vectorized call rejects the whole array; find the offending cells one by one.
        P, reasons = _pressures_one_by_one(bulged, pressure_from_bulge)
    for cid, p in zip(bulged.cell_id, P, strict=True):
        if not np.isfinite(p) and cid not in reasons:
            reasons[cid] = "bulge model returned no finite pressure"
    return P, reasons


def _pressures_one_by_one(bulged, pressure_from_bulge):
    P = np.full(len(bulged), np.nan)
    reasons = {}
    for i, cid in enumerate(bulged.cell_id):
        try:
            P[i] = float(pressure_from_bulge(bulged.k_b[i], bulged.R_b[i], bulged.h_b[i]))
        except ValueError as err:
            reasons[cid] = str(err)
    return P, reasons


def _stats_row(label, values):
    if values.size == 0:
        return f"  {label:<24} {0:>5}"
    lo, med, hi = np.min(values), np.median(values), np.max(values)
    return f"  {label:<24} {values.size:>5} {lo:>11.4g} {med:>11.4g} {hi:>11.4g}"


def _column_rows(cells):
    rows = [f"  {'column':<24} {'n':>5} {'min':>11} {'median':>11} {'max':>11}"]
    for column in REQUIRED_COLUMNS[2:]:
        name, factor = _DISPLAY[column]
        for group, mask in (("bulged", cells.is_bulged), ("intact", ~cells.is_bulged)):
            if mask.any():
                rows.append(_stats_row(f"{column} ({group})", getattr(cells, name)[mask] * factor))
    for column in BULGE_COLUMNS:
        name, factor = _DISPLAY[column]
        if cells.n_bulged:
            rows.append(_stats_row(column, getattr(cells, name)[cells.is_bulged] * factor))
    return rows


def _pressure_rows(cells):
    if cells.n_bulged == 0:
        return ["bulge pressure: no bulged cells"]
    P, reasons = bulge_pressures(cells)
    ok = np.isfinite(P)
    rows = ["bulge pressure [kPa] (bulge model, alpha = pi/12):"]
    rows.append(_stats_row("P from bulge", P[ok] / 1e3) if ok.any() else "  none finite")
    if not reasons:
        rows.append(f"  all {cells.n_bulged} bulged cells have a physical pressure")
        return rows
    rows.append(f"  {len(reasons)} bulged cell(s) without a physical pressure:")
    for cid, why in list(reasons.items())[:_MAX_LISTED]:
        rows.append(f"    {cid}: {why}")
    if len(reasons) > _MAX_LISTED:
        rows.append(f"    ... and {len(reasons) - _MAX_LISTED} more")
    return rows


def _medium_rows(cells):
    """The intact cells per medium osmolarity (the ``medium_mOsm`` column), if any."""
    c = medium_osmolarity(cells)
    if c is None:
        return []
    is_intact = ~np.asarray(cells.is_bulged, bool)
    levels, counts = np.unique(c[is_intact], return_counts=True)
    row = ", ".join(f"{x:g} ({n})" for x, n in zip(levels, counts, strict=True))
    how = (" -> the osmotic model (docs/statistics.md, \"Osmotic series\")" if levels.size > 1
           else "")
    rows = ["", f"medium [mOsm] (intact cells): {row}{how}"]
    labels = cells.extra.get(CONDITION_COLUMN)
    names = list(dict.fromkeys(labels)) if labels is not None else []
    if len(names) < 2:
        return rows
    labels = np.asarray(labels)
    rows.append(f"  per condition (each its own series; P_phys its turgor at {levels[0]:g} mOsm "
                "unless --reference-medium names another level):")
    for name in names:
        mine = c[is_intact & (labels == name)]
        got = ", ".join(f"{x:g} ({np.sum(mine == x)})" for x in levels)
        bulged = np.sum(~is_intact & (labels == name))
        alone = np.unique(mine).size < 2 and bulged == 0
        rows.append(f"    {name}: {got}" + ("  <- one level and no bulged cell: this condition "
                                            "cannot tell its wall from its turgor" if alone
                                            else ""))
    return rows


def _warnings(cells):
    out = []
    series = medium_levels(cells).size > 1  # intact cells alone can carry the fit
    try:
        if not (series and cells.n_intact):
            cells.require_both_groups()
    except DataError as err:
        out.append(f"warning: {err.problem}")
    problems = plausibility.check(cells)
    if problems:
        out.append(f"warning: {len(problems)} value(s) no bacterium can have (bounds: "
                   "docs/data_format.md), let through by --allow-unusual:")
        out.append(plausibility.describe(problems, limit=_MAX_LISTED))
    return out


def _shorten(text, width=72):
    return text if len(text) <= width else text[: width - 3] + "..."


def validation_summary(cells):
    """The one-screen summary printed by ``turgorbayes validate``, as a list of lines."""
    lines = [
        f"file      {cells.path}",
        f"sha256    {cells.sha256[:16]}...",
        f"comments  {len(cells.comments)} line(s)"
        + (f"; first: {_shorten(cells.comments[0])}" if cells.comments else ""),
        f"cells     {len(cells)}: {cells.n_bulged} bulged, {cells.n_intact} intact",
    ]
    if cells.extra:
        lines.append(f"extra     {', '.join(cells.extra)}")
    lines += ["", "columns (CSV units):", *_column_rows(cells), "", *_pressure_rows(cells),
              *_medium_rows(cells)]
    warnings = _warnings(cells)
    verdict = "OK: the file is valid."
    if any("--allow-unusual" in w for w in warnings):
        verdict = "OK: the file is valid, with the unusual values above (--allow-unusual)."
    return lines + ([""] + warnings if warnings else []) + ["", verdict]
