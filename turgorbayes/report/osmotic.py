"""An osmotic series' levels in words and tables: command line and report.md (the ``osmotic``
section of ``summary.json``, :func:`turgorbayes.workflows.osmotic.osmotic_section`)."""

__all__ = ["markdown_lines", "osmotic_lines"]


def _interval(s, fmt=".3g"):
    return f"{s['mean']:{fmt}} +- {s['sd']:.2g} [{s['q05']:{fmt}}, {s['q95']:{fmt}}]"


def _b_text(section):
    b = section["b"]
    if "fixed" in b:
        return f"b = {b['fixed']:g} (fixed: {b['why']})"
    return f"b = {_interval(b)} (prior {section['b_prior']})"


def _whose(section):
    """' of the reference condition' when the series has conditions."""
    return " of the reference condition" if "buffering_by_condition" in section else ""


def _condition_head(section):
    """The condition column's heading, as wide as the longest name ('' without conditions)."""
    names = [lv["condition"] for lv in section["levels"] if "condition" in lv]
    return "condition".ljust(max(map(len, names + ["condition"])) + 2) if names else ""


def osmotic_lines(summary):
    """Plain-text lines: the design, b, the buffering factor, each level's turgor and the
    levels that do not fit; [] for a summary without an osmotic series."""
    o = summary.get("osmotic")
    if not o:
        return []
    lines = [f"osmotic series (P_phys is the turgor at {o['reference_medium_mOsm']:g} mOsm; "
             f"{o['temperature_K']:g} K, {o['turgor_per_mOsm_kPa']:.3f} kPa per mOsm; length "
             f"model {o['length_model']}):",
             f"  osmotically inactive volume {_b_text(o)}",
             f"  buffering dP/d(RT c_out) at P_phys{_whose(o)}: {_interval(o['buffering'])} (the "
             "rest of a small step of the medium is taken up by the volume)",
             f"  {_condition_head(o)}medium_mOsm  cells  turgor_kPa mean +- sd [90 % interval]"]
    width = len(_condition_head(o))
    for lv in o["levels"]:
        ref = "  (P_phys)" if lv["reference"] else ""
        lines.append(f"  {lv.get('condition', ''):<{width}}{lv['medium_mOsm']:>11g}  "
                     f"{lv['n_intact']:>5d}  {_interval(lv['turgor_kPa'], '.4g')}{ref}")
    if o["misfit_levels_mOsm"]:
        shown = ", ".join(f"{lv['condition']} {lv['medium_mOsm']:g}" for lv in o["misfit_levels"]) \
            if "misfit_levels" in o else ", ".join(f"{c:g}" for c in o["misfit_levels_mOsm"])
        lines.append(f"warning: the cells at {shown} mOsm do not fit the osmotic balance (mean "
                     "R_c or k_c more than 4 standard errors from the model's): plasmolysis, "
                     "osmoadaptation before the measurement or a wrong medium_mOsm there "
                     "(docs/statistics.md, \"Osmotic series\")")
    return lines


def markdown_lines(summary):
    """report.md section of the series ([] without one)."""
    o = summary.get("osmotic")
    if not o:
        return []
    cond = any("condition" in lv for lv in o["levels"])
    lines = ["", "## Osmotic series", "",
             f"P_phys is the turgor in the medium of {o['reference_medium_mOsm']:g} mOsm; each "
             "other level's turgor follows from it by the osmotic balance (conserved osmolytes, "
             f"the wall law; {o['temperature_K']:g} K, length model `{o['length_model']}`; "
             "docs/physics.md, \"Osmotic shifts of the medium\").", "",
             f"- osmotically inactive volume: {_b_text(o)}",
             f"- buffering factor dP/d(RT c_out) at P_phys{_whose(o)}: "
             f"{_interval(o['buffering'])}", "",
             f"| {'condition | ' if cond else ''}medium [mOsm] | intact cells | turgor [kPa]: "
             "mean +- sd [90 % interval] | misfit z (R_c, k_c) |",
             "|---|---|---|---|" + ("---|" if cond else "")]
    for lv in o["levels"]:
        z = lv["misfit_z"]
        lines.append(f"| {lv['condition'] + ' | ' if cond else ''}"
                     f"{lv['medium_mOsm']:g}{' (P_phys)' if lv['reference'] else ''} | "
                     f"{lv['n_intact']} | {_interval(lv['turgor_kPa'], '.4g')} | "
                     f"{z['R_c']:+.1f}, {z['k_c']:+.1f} |")
    lines += ["", "misfit z: the level's mean standardized residual in standard errors of its "
              "mean; beyond 4 the level is named (plasmolysis, osmoadaptation or a wrong "
              "medium value break the balance there)."]
    if o["misfit_levels_mOsm"]:
        lines.append(f"**Levels that do not fit:** {', '.join(f'{c:g}' for c in o['misfit_levels_mOsm'])} mOsm.")
    return lines
