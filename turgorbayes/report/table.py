"""The numbers to quote from a finished output folder, as one long-format table.

:func:`quote_table` reads ``summary.json`` and/or ``criticism.json`` (nothing is recomputed);
:func:`render` writes the same rows as csv, markdown or a LaTeX ``tabular``.
"""

import csv
import io
import json
import math
from pathlib import Path

from turgorbayes.errors import TurgorBayesError
from turgorbayes.report.html import criticism_dir_of

__all__ = ["COLUMNS", "FORMATS", "NOT_RECORDED", "SHARED_WALL_NOTE", "criticism_rows", "latex_escape",
           "quote_table", "render", "summary_rows"]

#: The columns of every row, in order. ``value`` holds a single number or word (a probability,
#: a status, a sha256); ``mean`` ... ``q95`` a posterior summary in the quantity's own unit.
COLUMNS = ("section", "name", "quantity", "value", "mean", "sd", "q05", "q50", "q95", "r_hat",
           "ess_bulk", "note")
#: Output formats of :func:`render`.
FORMATS = ("csv", "markdown", "latex")
#: Said of a contrast's ``assumes`` / ``checked_by_data`` when the summary predates them.
NOT_RECORDED = "not recorded"
#: The note of every shared-wall contrast.
SHARED_WALL_NOTE = "conditional on a shared wall (an assumption, not the headline)"

_STATS = ("mean", "sd", "q05", "q50", "q95", "r_hat", "ess_bulk")


def _row(section, name, quantity, value=None, stats=None, note=""):
    row = dict.fromkeys(COLUMNS)
    row.update(section=section, name=name, quantity=quantity, value=value, note=note)
    for k in _STATS:
        row[k] = (stats or {}).get(k)
    return row


def _read_json(path):
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh)
    except json.JSONDecodeError as err:
        raise TurgorBayesError(f"cannot read {path}: not JSON ({err.msg}, line {err.lineno})"
                               ) from None


# ------------------------------------------------------------------------------ summary.json
def _parameter_rows(summary):
    """One row per entry of ``summary["parameters"]`` (mean, sd, q05, q50, q95, R-hat, ESS)."""
    note = ""
    if summary.get("conditions"):
        ref = next((c["reference"] for c in summary.get("contrasts") or []), None)
        what = ("the reference condition's own wall (osmotic series)" if summary.get("osmotic")
                else "shared wall and the reference condition")
        note = what + (f" ({ref})" if ref else "")
    model = summary.get("model", "")
    return [_row("parameters", model, key, stats=entry, note=note)
            for key, entry in summary.get("parameters", {}).items()]


def _condition_rows(summary):
    """One row per condition and quantity of ``summary["conditions"]``."""
    return [_row("condition", name, key, stats=entry)
            for name, quantities in (summary.get("conditions") or {}).items()
            for key, entry in quantities.items()]


def _assumption_note(contrast):
    assumes = contrast.get("assumes")
    checked = contrast.get("checked_by_data")
    assumes = NOT_RECORDED if assumes is None else (", ".join(assumes) or "nothing")
    checked = NOT_RECORDED if checked is None else ("yes" if checked else "no")
    return f"assumes: {assumes}; checked by data: {checked}"


def _contrast_rows(contrasts, section, note=""):
    """Rows of a list of contrasts: the difference, with ``prob_greater`` (the probability that
    it is > 0) in ``value``, and the ratio; each with mean, q05, q50, q95 and what it assumes."""
    rows = []
    for c in contrasts or []:
        name = f"{c['condition']} vs {c['reference']}"
        text = "; ".join(t for t in (note, _assumption_note(c)) if t)
        rows.append(_row(section, name, f"{c['quantity']} difference",
                         value=c.get("prob_greater"), stats=c.get("difference"),
                         note=f"value: P(difference > 0); {text}"))
        if c.get("ratio") is not None:
            rows.append(_row(section, name, f"{c['quantity']} ratio", stats=c["ratio"],
                             note=text))
    return rows


def _provenance_rows(name, version, data, surrogate, seed, dependencies):
    """Version, data and FE-table sha256, seed and dependency versions (those recorded)."""
    entries = [("version", version), ("data sha256", (data or {}).get("sha256")),
               ("surrogate sha256", (surrogate or {}).get("sha256")), ("seed", seed)]
    entries += list((dependencies or {}).items())
    return [_row("provenance", name, key, value=value) for key, value in entries
            if value is not None]


def summary_rows(summary):
    """Every row of a fit's ``summary.json``."""
    rows = _parameter_rows(summary) + _condition_rows(summary)
    rows += _contrast_rows(summary.get("contrasts"), "contrast")
    rows += _contrast_rows(summary.get("contrasts_shared_wall"), "contrast (shared wall)",
                           note=SHARED_WALL_NOTE)
    return rows + _provenance_rows("fit", summary.get("version"), summary.get("data"),
                                   summary.get("surrogate"), summary.get("seed"),
                                   summary.get("dependencies"))


# ------------------------------------------------------------------------------ criticism.json
def criticism_rows(criticism, diagnostics=None):
    """The verdict and the numbers it says to quote (``parameters[headline]``, the model
    average), with each condition's values and contrasts of the model average; provenance from
    ``criticism_diagnostics.json`` when given."""
    verdict = criticism.get("verdict") or {}
    headline = criticism.get("headline") or "model_average"
    rows = [_row("verdict", "criticism", "status", value=verdict.get("status")),
            _row("verdict", "criticism", "selected effect",
                 value=verdict.get("selected") or "none"),
            _row("verdict", "criticism", "headline", value=headline)]
    note = "every fitted model, weighted by stacking" if headline == "model_average" else ""
    for key, entry in ((criticism.get("parameters") or {}).get(headline) or {}).items():
        rows.append(_row("quote", headline, key, stats=entry, note=note))
    cond = verdict.get("conditions") or {}
    for name, quantities in ((cond.get("values") or {}).get(headline) or {}).items():
        rows += [_row("quote condition", name, key, stats=entry, note=headline)
                 for key, entry in quantities.items()]
    rows += _contrast_rows((cond.get("contrasts") or {}).get(headline), "quote contrast",
                           note=headline)
    if diagnostics is not None:
        rows += _provenance_rows("criticism", diagnostics.get("turgorbayes_version"),
                                 {"sha256": diagnostics.get("data_sha256")}, None,
                                 diagnostics.get("seed"), diagnostics.get("dependencies"))
    return rows


# ------------------------------------------------------------------------------ the table
def quote_table(path):
    """The rows of the table of numbers to quote from an output folder.

    Parameters
    ----------
    path : path-like
        A ``turgorbayes fit`` output folder (``summary.json``; its criticism is read too when
        ``criticism/criticism.json`` or ``criticism.json`` lies in it) or a
        ``turgorbayes criticize`` output folder (``criticism.json``).

    Returns
    -------
    list of dict
        Each with the keys :data:`COLUMNS` (None where a row has no such number).

    Raises
    ------
    turgorbayes.errors.TurgorBayesError
        If the folder holds neither file, or one is not JSON.
    """
    folder = Path(path)
    if not folder.is_dir():
        raise TurgorBayesError(f"{folder} is not a folder (expected the output folder of "
                               "`turgorbayes fit` or `turgorbayes criticize`)")
    summary = folder / "summary.json"
    cdir = criticism_dir_of(folder)
    if not summary.is_file() and cdir is None:
        raise TurgorBayesError(f"{folder} holds neither summary.json (written by `turgorbayes "
                               "fit`) nor criticism.json (written by `turgorbayes criticize`; "
                               "looked in the folder and in its criticism/)")
    rows = summary_rows(_read_json(summary)) if summary.is_file() else []
    if cdir is not None:
        diag = cdir / "criticism_diagnostics.json"
        rows += criticism_rows(_read_json(cdir / "criticism.json"),
                               _read_json(diag) if diag.is_file() else None)
    return rows


def _short(value):
    """A number to 4 significant digits, anything else as text ('' for None)."""
    if value is None:
        return ""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return str(value)
    if isinstance(value, int):
        return str(value)
    return "nan" if math.isnan(value) else f"{value:.4g}"


def _csv(rows):
    buf = io.StringIO()
    writer = csv.DictWriter(buf, fieldnames=COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({k: ("" if row[k] is None else row[k]) for k in COLUMNS})
    return buf.getvalue()


def _markdown(rows):
    def cell(value):
        return _short(value).replace("|", "\\|")

    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    lines += ["| " + " | ".join(cell(row[k]) for k in COLUMNS) + " |" for row in rows]
    return "\n".join(lines) + "\n"


_LATEX_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
                  "_": r"\_", "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}",
                  "^": r"\textasciicircum{}", "<": r"\textless{}", ">": r"\textgreater{}"}


def latex_escape(text):
    """``text`` with LaTeX's special characters escaped (``P_phys`` -> ``P\\_phys``)."""
    return "".join(_LATEX_SPECIAL.get(ch, ch) for ch in str(text))


def _latex_cell(value):
    text = _short(value)
    if isinstance(value, float) and "e" in text:  # 1.234e-05 -> $1.234\times10^{-5}$
        mantissa, exponent = text.split("e")
        return f"${mantissa}\\times10^{{{int(exponent)}}}$"
    return latex_escape(text)


def _latex(rows):
    lines = [r"\begin{tabular}{" + "l" * 4 + "r" * (len(COLUMNS) - 5) + "p{6cm}}", r"\toprule",
             " & ".join(latex_escape(c) for c in COLUMNS) + r" \\", r"\midrule"]
    lines += [" & ".join(_latex_cell(row[k]) for k in COLUMNS) + r" \\" for row in rows]
    lines += [r"\bottomrule", r"\end{tabular}"]
    return "\n".join(lines) + "\n"


def render(rows, fmt="csv"):
    """The rows of :func:`quote_table` as text.

    Parameters
    ----------
    rows : list of dict
    fmt : {"csv", "markdown", "latex"}
        csv keeps every number at full precision; markdown and latex show 4 significant
        digits (latex: a booktabs ``tabular``, special characters escaped).

    Returns
    -------
    str
    """
    renderers = {"csv": _csv, "markdown": _markdown, "latex": _latex}
    if fmt not in renderers:
        raise TurgorBayesError(f"table format must be one of {', '.join(FORMATS)}, got {fmt!r}")
    return renderers[fmt](rows)
