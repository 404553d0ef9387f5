"""The conditions of a fit in words and tables: command line, report.md and report.html."""

import html

from turgorbayes.inference.conditions import contrast_sentence

__all__ = ["assumption_phrase", "condition_lines", "html_section", "markdown_lines"]


def condition_lines(summary):
    """Plain-text lines: a per-condition table (mean and 90 % interval of each quantity)
    and every contrast in words; [] for a summary without conditions."""
    conds = summary.get("conditions")
    if not conds:
        return []
    keys = list(dict.fromkeys(k for entry in conds.values() for k in entry))
    rows = [["condition", *keys]] + [
        [name, *(f"{entry[k]['mean']:.4g} [{entry[k]['q05']:.4g}, {entry[k]['q95']:.4g}]"
                 if k in entry else "shared" for k in keys)] for name, entry in conds.items()]
    widths = [max(len(row[j]) for row in rows) + 2 for j in range(len(rows[0]))]
    lines = ["conditions (mean [90 % interval]):"]
    lines += [("  " + "".join(x.ljust(w) for x, w in zip(row, widths, strict=True))).rstrip()
              for row in rows]
    contrasts = summary.get("contrasts") or []
    if contrasts:
        lines.append("contrasts (difference's median [90 % interval], probability of the "
                     "direction):")
        for i, c in enumerate(contrasts):  # what they assume, once per condition
            lines.append("  " + contrast_sentence(c))
            if i + 1 == len(contrasts) or contrasts[i + 1]["condition"] != c["condition"]:
                lines.append(f"    {c['condition']} against {c['reference']} "
                             + assumption_phrase(c))
    shared = _shared_wall_turgor(summary)
    if shared:
        lines.append("if the wall were the same in every condition (an assumption, not the "
                     "headline):")
        lines += ["  " + contrast_sentence(c) + "; " + assumption_phrase(c) for c in shared]
    return lines


def _shared_wall_turgor(summary):
    """The turgor contrasts of the shared-wall model (printed beside the headline)."""
    return [c for c in summary.get("contrasts_shared_wall") or []
            if c["quantity"].startswith("P_phys")]


def assumption_phrase(contrast):
    """What a contrast assumes of the walls and whether the data check it, in words."""
    assumes = contrast.get("assumes")
    if assumes is None:  # a summary written before contrasts said what they assume
        return "assumes: the wall shared (not recorded)"
    text = "assumes: " + (", ".join(assumes) if assumes else "nothing of the walls")
    if contrast.get("checked_by_data"):
        return text + (" (both conditions have bulged cells or an osmotic series: the data "
                       "measure each wall)")
    return text + (" (not checked: a condition without bulged cells; its data cannot tell "
                   "its wall from its turgor)")


def markdown_lines(summary, figure="conditions.png"):
    """report.md section: table, contrasts and the figure ([] without conditions)."""
    conds = summary.get("conditions")
    if not conds:
        return []
    keys = list(dict.fromkeys(k for entry in conds.values() for k in entry))
    walls = ("its own wall (E0t), measured by its own osmotic series" if summary.get("osmotic")
             else "its wall differs from the reference's within the stated prior (or is "
             "shared, as each contrast says)")
    lines = ["", "## Conditions", "",
             f"Each condition has its own P_phys and R0; {walls}. The Parameters "
             "table above holds the reference's wall and the "
             f"reference condition ({(summary.get('contrasts') or [{}])[0].get('reference', '')}"
             ").", "", "| condition | " + " | ".join(keys) + " |",
             "|---|" + "---|" * len(keys)]
    for name, entry in conds.items():
        lines.append(f"| {name} | " + " | ".join(
            f"{entry[k]['mean']:.4g} [{entry[k]['q05']:.4g}, {entry[k]['q95']:.4g}]"
            if k in entry else "shared" for k in keys) + " |")
    lines += ["", "Contrasts (median difference [90 % interval], probability of the direction):",
              ""]
    lines += [f"- {contrast_sentence(c)}; {assumption_phrase(c)}"
              for c in summary.get("contrasts") or []]
    shared = _shared_wall_turgor(summary)
    if shared:
        lines += ["", "If the wall were the same in every condition (an assumption, not the "
                  "headline):", ""]
        lines += [f"- {contrast_sentence(c)}; {assumption_phrase(c)}" for c in shared]
    return lines + ["", f"![each condition's P_phys and the differences]({figure})"]


def html_section(summary):
    """The conditions' table and contrasts as HTML ('' without conditions)."""
    lines = condition_lines(summary)
    if not lines:
        return ""
    return "<h2>Conditions</h2><pre>" + html.escape("\n".join(lines)) + "</pre>"
