"""The criticism's residual figure: the baseline and the adopted extension against pressure."""

from pathlib import Path

import numpy as np

from turgorbayes.cells.table import is_simulated
from turgorbayes.criticism.checks import check_spec, replicates
from turgorbayes.plots.style import figure, format_p, log_axis

__all__ = ["check_label", "misfit_plot", "plot_misfit"]

_OBS = (("R_c", "$R_c$"), ("k_c", "$k_c$"))
_FLAG, _CLEARED = "#c0392b", "#1e8449"


def check_label(name):
    """Readable name of a check: ``"scatter_R_c_intact"`` -> ``"scatter vs. errors, intact
    cells"``; ``"correlation_R_c_k_c"`` -> ``"correlation of $R_c$ and $k_c$ residuals"``.

    The observable is left out (the figure shows it in the column); see :func:`_observable`.
    """
    kind = check_spec(name).kind
    rest = name[len(kind) + 1:]
    group = next((g for g in ("bulged", "intact") if rest.endswith("_" + g)), None)
    return check_spec(name).label + (f", {group} cells" if group else "")


def _observable(name):
    """``"R_c"``, ``"k_c"`` or ``None`` (a check of both: the residual correlation, the
    conditions' residuals)."""
    kind = check_spec(name).kind
    return None if kind in ("correlation", "conditions") else name[len(kind) + 1:][:3]


def _p(c, n_rep):
    """A check's p-value for figure text: ``"p = 0.412"``, ``"p < 0.0014"`` (``n_rep``
    posterior-predictive replicates; :func:`turgorbayes.formatting.format_p_value`)."""
    return format_p(c["p_value"], replicates(c["name"], n_rep))


def _residuals(arrays, obs):
    """Mean standardized residual per cell and the 5-95 % range of replicated ones."""
    y, s = arrays["y"][obs], arrays["sigma"][obs]
    mu, rep = arrays["mu"][obs], arrays["y_rep"][obs]
    z = np.nanmean((y - mu) / s, axis=0)
    zr = (rep - mu) / s
    return z, np.nanquantile(zr, 0.05, axis=0), np.nanquantile(zr, 0.95, axis=0)


def _pressure_kPa(arrays):
    """Posterior median pressure of each cell [kPa]."""
    return np.exp(np.median(arrays["log_pressure"], axis=0)) / 1e3


def _model_title(name, result):
    if name == "baseline":
        return "baseline model"
    return f"{'adopted extension' if name == result.selected else 'extension'}: " + \
        name.replace("_", " ")


def _flag_note(checks, base_checks, obs, n_rep):
    """Lines (text, colour) for the checks of ``obs`` flagged in this model or the baseline."""
    base = {c["name"]: c for c in base_checks}
    lines = []
    for c in checks:
        if _observable(c["name"]) != obs:
            continue
        b = base.get(c["name"], c)
        if not (c["flagged"] or b["flagged"]):
            continue
        text = f"{check_label(c['name'])}: {_p(c, n_rep)}"
        if b is not c:
            text += f" (baseline: {_p(b, n_rep)})"
        lines.append((text, _FLAG if c["flagged"] else _CLEARED))
    return lines or [("no check flagged", _CLEARED)]


def _residual_panel(ax, P, z, lo, hi, bulged, ghost=None):
    """Residuals against pressure: grey replicated 90 % ranges, cells, baseline ghosts."""
    order = np.argsort(P)
    ax.vlines(P[order], lo[order], hi[order], color="0.82", lw=2.5, zorder=1,
              label="90 % of replications")
    if ghost is not None:
        ax.scatter(P, ghost, s=14, facecolors="none", edgecolors="0.45", lw=0.7, zorder=2,
                   label="baseline's residual (extension rows)")
    ax.scatter(P[bulged], z[bulged], s=13, c="C0", label="bulged cells", zorder=3)
    ax.scatter(P[~bulged], z[~bulged], s=13, c="C3", label="intact cells", zorder=3)
    ax.axhline(0, color="k", lw=0.6)
    log_axis(ax)
    ax.set_xlabel("pressure [kPa] (posterior median)")


def _annotate(ax, lines):
    """Write ``lines`` (text, colour) at the top of ``ax``, above the data (room is made)."""
    lo, hi = ax.get_ylim()
    ax.set_ylim(lo, hi + (hi - lo) * 0.085 * len(lines))
    for i, (text, color) in enumerate(lines):
        ax.text(0.02, 0.975 - 0.07 * i, text, transform=ax.transAxes, va="top", fontsize=9.5,
                color=color)


def _correlation_panel(ax, zs, bulged, checks, n_rep):
    ax.scatter(zs["R_c"][bulged], zs["k_c"][bulged], s=13, c="C0")
    ax.scatter(zs["R_c"][~bulged], zs["k_c"][~bulged], s=13, c="C3")
    ax.axhline(0, color="k", lw=0.6)
    ax.axvline(0, color="k", lw=0.6)
    ax.set_xlabel("residual of $R_c$")
    ax.set_ylabel("residual of $k_c$")
    corr = [c for c in checks if _observable(c["name"]) is None]
    title = "$R_c$ vs. $k_c$ residuals"
    if corr:
        title += f"\ncorrelation check: {_p(corr[0], n_rep)}"
    ax.set_title(title, fontsize=11, color=_FLAG if corr and corr[0]["flagged"] else "k")


def _draw_row(axes, name, result):
    arrays = result.check_arrays[name]
    P, bulged = _pressure_kPa(arrays), arrays["group"] == "bulged"
    base = result.check_arrays["baseline"]
    zs = {}
    for ax, (obs, label) in zip(axes[:2], _OBS, strict=False):
        z, lo, hi = _residuals(arrays, obs)
        zs[obs] = z
        ghost = None if name == "baseline" else _residuals(base, obs)[0]
        _residual_panel(ax, P, z, lo, hi, bulged, ghost)
        ax.set_ylabel(f"residual of {label} [error units]")
        ax.set_title(f"{_model_title(name, result)}: {label}", fontsize=12, loc="left")
        _annotate(ax, _flag_note(result.checks[name], result.checks["baseline"], obs,
                                 result.settings.n_rep))
    _correlation_panel(axes[2], zs, bulged, result.checks[name], result.settings.n_rep)


def _table_cell(c, base, n_rep):
    """Text and background colour of one model's p-value of one check."""
    if c is None:
        return "", "white"
    p = _p(c, n_rep).removeprefix("p = ").removeprefix("p ")
    if c["flagged"]:
        return p + " flagged", "#f5b7b1"
    if base is not None and base["flagged"]:
        return p + " cleared", "#abebc6"
    return p, "white"


def _name_in_column(names, obs):
    """The check among ``names`` shown in ``obs``'s columns (the correlation under ``R_c``)."""
    for n in names:
        if _observable(n) == obs or (_observable(n) is None and obs == "R_c"):
            return n
    return None


def _check_table(ax, result, rows):
    """All checks as a table: one line per check, p per observable and model, flags coloured."""
    by = {m: {c["name"]: c for c in result.checks[m]} for m in rows}
    labels = {}
    for name in by["baseline"]:
        labels.setdefault(check_label(name), []).append(name)
    head = ["check"] + [f"{label}: {m.replace('_', ' ')}" for _, label in _OBS for m in rows]
    text, colours = [], []
    for label, names in labels.items():
        line, colour = [label], ["white"]
        for obs, _ in _OBS:
            name = _name_in_column(names, obs)
            for m in rows:
                base = by["baseline"].get(name) if m != "baseline" else None
                t, col = _table_cell(by[m].get(name), base, result.settings.n_rep)
                line.append(t)
                colour.append(col)
        text.append(line)
        colours.append(colour)
    ax.axis("off")
    widths = [0.28] + [0.72 / (len(head) - 1)] * (len(head) - 1)
    table = ax.table(cellText=text, cellColours=colours, colLabels=head, colWidths=widths,
                     cellLoc="center", bbox=[0.0, 0.0, 1.0, 1.0])
    table.auto_set_font_size(False)
    table.set_fontsize(9.5)
    ax.set_title("posterior predictive p-values (flagged: below the Bonferroni level, "
                 "family-wise 5 %)", fontsize=11)
    return table


def plot_misfit(result, path):
    """Residual figure: one row per model (baseline, adopted extension), and a table of checks.

    Columns: standardized residual of ``R_c`` and of ``k_c`` against the posterior median of
    each cell's pressure (intact cells at ``P_phys``), each cell's 90 % range of replicated
    residuals in grey; and ``z(k_c)`` against ``z(R_c)``. A model that fits leaves the points
    inside the grey ranges. Each residual panel names the checks of its observable flagged in
    either model with their p-values (an extension's panel also the baseline's p-value, red if
    still flagged, green if cleared), and the extension's panels show the baseline's residuals
    as grey circles. Below, every check's p-value per observable and model, flags in red,
    flags the extension clears in green. p-values never print as 0: one counted from ``n_rep``
    replicates of which none is as extreme prints as ``p < 1/n_rep``.

    Returns
    -------
    matplotlib.figure.Figure
        Also written to ``path`` as PNG (110 dpi).
    """
    rows = ["baseline"] + [m for m in [result.selected] if m]
    n_checks = len({check_label(c["name"]) for c in result.checks["baseline"]})
    fig = figure((13.5, 4.0 * len(rows) + 0.25 * n_checks + 1.6))
    grid = fig.add_gridspec(len(rows) + 1, 3,
                            height_ratios=[4.0] * len(rows) + [0.25 * (n_checks + 1)])
    for r, name in enumerate(rows):
        axes = [fig.add_subplot(grid[r, c]) for c in range(3)]
        _draw_row(axes, name, result)
    fig.legend(*axes[0].get_legend_handles_labels(), loc="outside lower center", ncol=4,
               fontsize=10, frameon=False)
    _check_table(fig.add_subplot(grid[len(rows), :]), result, rows)
    for ax in fig.axes:  # >= 10 px where the HTML report shows the figure at its page width
        ax.tick_params(which="both", labelsize=10)
    fig.suptitle("Standardized residuals: (reading - model mean) / reported error; grey bars: "
                 "90 % of the model's own replications" +
                 ("\nSIMULATED DATA" if is_simulated(result.cells) else ""), fontsize=12)
    fig.savefig(path, dpi=110)
    return fig


def misfit_plot(criticism_result, path):
    """The criticism's residual figure (:func:`plot_misfit`).

    One row per model (the baseline, and the adopted extension if any), residuals of ``R_c``
    and ``k_c`` against pressure with each cell's 90 % replicated range, and a table of the
    checks' p-values; written to ``path``.

    Returns
    -------
    pathlib.Path
    """
    plot_misfit(criticism_result, path)
    return Path(path)
