"""Outputs of the criticism workflow: ``criticism.json``, ``misfit.png`` and ``report.md``.

:func:`write_outputs` writes, into one directory,

* ``criticism.json``: exactly the keys of :data:`turgorbayes.workflows.criticize.CRITICISM_KEYS`;
* ``criticism_diagnostics.json``: per model the inference engine and its diagnostics, the LOO
  summary (Pareto k, exact refits) and the selection-rule quantities (kept out of
  ``criticism.json``, whose keys are fixed);
* ``misfit.png``: standardized residuals of the baseline and of the adopted extension against
  pressure, with the model's own 90 % predictive range
  (:func:`turgorbayes.plots.misfit.plot_misfit`);
* ``report.md``: the checks, the figure, the comparison table and the change in the headline
  numbers.
"""

from pathlib import Path

import numpy as np

from turgorbayes import criticism
from turgorbayes.cells.table import is_simulated
from turgorbayes.criticism import checks as checks_module
from turgorbayes.criticism.checks import replicates
from turgorbayes.criticism.verdict import gross_error_verdict
from turgorbayes.formatting import format_p_value
from turgorbayes.inference import table_check
from turgorbayes.physics.parameters import QUANTITIES
from turgorbayes.plots.misfit import plot_misfit
from turgorbayes.report.fit import cells_phrase, counted, flagged_section
from turgorbayes.report.text import monte_carlo_note, table_thickness_nm, thickness_note
from turgorbayes.workflows.criticism_files import write_criticism
from turgorbayes.workflows.criticize import criticism_dict
from turgorbayes.workflows.fit import file_name

__all__ = ["plot_misfit", "render_report", "replicates", "verdict_lines", "write_outputs"]

_HEADLINE = tuple(q.key for q in QUANTITIES.values())


def _fmt(entry):
    return f"{entry['q50']:.4g} [{entry['q05']:.4g}, {entry['q95']:.4g}]"


def _checks_table(result):
    names = ["baseline"] + [m for m in [result.selected] if m]
    n = len(result.checks["baseline"])
    alpha = checks_module.check_level(n)
    lines = ["| check | fingerprint of | " + " | ".join(f"{m}: statistic, p" for m in names)
             + " |", "|---|---|" + "---|" * len(names)]
    by_model = {m: {c["name"]: c for c in result.checks[m]} for m in names}
    for c in result.checks["baseline"]:
        cells = []
        for m in names:
            e = by_model[m][c["name"]]
            p = format_p_value(e["p_value"], replicates(c["name"], result.settings.n_rep))
            cells.append(f"{e['statistic']:.3g}, {p}" + (" **FLAGGED**" if e["flagged"] else ""))
        lines.append(f"| `{c['name']}` | {checks_module.check_spec(c['name']).fingerprint} | "
                     + " | ".join(cells) + " |")
    lines.append("")
    lines.append(f"Threshold: a check is flagged when its p-value is below {alpha:.2g} (upper "
                 f"checks) or outside [{alpha / 2:.2g}, {1 - alpha / 2:.4g}] (two-sided): "
                 f"Bonferroni over the {n} checks, so that a correct model is flagged anywhere "
                 f"with probability at most {checks_module.FAMILY_ALPHA:.0%} "
                 "(turgorbayes.criticism.checks). "
                 f"p-values are counted from {result.settings.n_rep} posterior-predictive "
                 f"replicates, so when none is as extreme as the data the p-value is printed as "
                 f"< {1 / result.settings.n_rep:.2g}, not 0 (the `loo_pit` p-values come from "
                 "ArviZ's uniformity test and are printed as computed).")
    return lines


def _comparison_table(result):
    lines = ["| model | delta elpd | se | P(gain > 0) | size estimate [90% interval] | engine | "
             "converged | cells with high Pareto k (refitted) |", "|---|---|---|---|---|---|---|---|"]
    for c in result.candidates:
        if c.get("failed"):
            lines.append(f"| {c['effect']} | - | - | - | could not be fitted: {c['failed']} | - | "
                         "NO | - |")
            continue
        post, loo = result.posteriors[c["effect"]], result.loo[c["effect"]]
        est = "; ".join(f"{k} = {v['mean']:.3g} [{v['q05']:.3g}, {v['q95']:.3g}]"
                        for k, v in c["estimate"].items())
        mark = " (selected)" if c["effect"] == result.selected else ""
        lines.append(f"| {c['effect']}{mark} | {c['delta_elpd']:.1f} | {c['delta_se']:.1f} | "
                     f"{c['p_gain']:.3f} | {est} | {post.engine} | {'yes' if post.converged else 'NO'} | "
                     f"{loo['n_bad']} ({len(loo['refitted'])}) |")
    base = result.loo["baseline"]
    lines.append("")
    lines.append(f"Baseline: elpd_loo = {base['elpd']:.1f} +- {base['se']:.1f}, p_loo = "
                 f"{base['p_loo']:.1f}, {counted(base['n_bad'], 'cell')} with high Pareto k "
                 f"({len(base['refitted'])} refitted exactly).")
    left = sum(result.loo[m].get("n_bad_left", 0) for m in result.loo)
    if left:
        lines.append(f"**{counted(left, 'high-k cell')} not refitted (max_refits = "
                     f"{result.settings.max_refits}); their PSIS values are used and are "
                     "unreliable.**")
    lines.append("")
    lines.append(f"Selection rule: the best extension is selected when delta elpd > "
                 f"{criticism.DELTA_ELPD_MIN:g} nats and the Bayesian-bootstrap probability of a "
                 f"positive gain is at least {criticism.P_GAIN_MIN:g} (the robust form of "
                 "delta > 2 se); the selected effect is then fitted together with the runner-up, "
                 "and the pair is adopted only if it beats the single effect by the same rule.")
    return lines


def _headline_table(result):
    base = result.summaries["baseline"]
    ext = result.summaries[result.selected] if result.selected else None
    avg = (result.stacking or {}).get("parameters")
    band = result.misfit_band if (result.misfit_band or {}).get("applied") else None
    header = "| quantity | baseline: median [90%] |"
    if ext:
        header += f" {result.selected}: median [90%] | change of the median |"
    if avg:
        header += " model average (stacking): median [90%] |"
    if band:
        header += " with the misfit band: median [90%] |"
    lines = [header, "|---|---|" + ("---|---|" if ext else "") + ("---|" if avg else "")
             + ("---|" if band else "")]
    for key in _HEADLINE:
        row = f"| {key} | {_fmt(base[key])} |"
        if ext:
            change = ext[key]["q50"] - base[key]["q50"]
            rel = change / abs(base[key]["q50"]) if base[key]["q50"] else np.nan
            row += f" {_fmt(ext[key])} | {change:+.3g} ({rel:+.1%}) |"
        if avg:
            row += f" {_fmt(avg[key])} |"
        if band:
            row += f" {_fmt(band['parameters'][key])} |"
        lines.append(row)
    if avg:
        weights = ", ".join(f"{n} {w:.2f}" for n, w in result.stacking["weights"].items()
                            if w >= 0.005)
        lines += ["", f"Model average: the mixture of every fitted model's posterior, weighted by "
                  f"stacking of their leave-one-out predictive densities ({weights}; "
                  "turgorbayes.criticism.stacking). It does not depend on the selection rule: when no "
                  "cause is clear, it is the honest answer to what P_phys is."]
    return lines


#: The verdict's status in words (the line that ends the command line, report.md and the HTML).
STATUS_WORDS = {
    "no_misfit": "no misfit: the baseline model describes these data",
    "explained": "misfit explained by a named effect",
    "partly_explained": ("misfit partly explained: a named effect describes it, but checks "
                         "remain or a description that names no cause fits as well"),
    "unexplained": "misfit that no effect in the library explains",
}
#: What each entry of ``parameters`` is, in words.
HEADLINE_WORDS = {
    "model_average": "the model average (every fitted model, weighted by stacking)",
    "baseline": "the baseline model",
    "extended": "the adopted extension",
    "widened": ("the model average with the misfit band (the bias an unexplained misfit of "
                "this size could hide)"),
}


def headline_numbers(d):
    """``(words, "P_phys 28.5 [27.4, 29.6] kPa, ...")``: the parameters to quote."""
    which = d["headline"]
    params = d["parameters"][which]
    text = ", ".join(f"{q.name} {params[q.key]['q50']:.4g} [{params[q.key]['q05']:.4g}, "
                     f"{params[q.key]['q95']:.4g}] {q.unit}".rstrip()
                     for q in QUANTITIES.values())
    return HEADLINE_WORDS[which], text


def verdict_lines(d):
    """The lines that end the command line's output (and report.md): the status in words, the
    verdict's paragraph and the numbers to quote (with several conditions: the reference
    condition's, then each condition's P_phys and the contrasts, :func:`condition_verdict_lines`).

    Parameters
    ----------
    d : dict
        The content of ``criticism.json`` (:func:`turgorbayes.workflows.criticize.criticism_dict`).

    Returns
    -------
    list of str
        ``verdict: STATUS: ...``, the verdict's paragraph, ``quote ...`` with the numbers, then
        the lines of each condition (none without conditions).
    """
    v = d["verdict"]
    words, numbers = headline_numbers(d)
    cond = v.get("conditions")
    which = status_note = ""
    if cond:
        shared = [q for q in ("gamma", "E0t") if q not in cond["freed"]]
        which = (f" for the reference condition {cond['reference']}"
                 + (f" and the shared {' and '.join(shared)}" if shared else ""))
        if not cond["check"]["ran"]:
            status_note = (f" (but {cond['check']['name']} did not run: the wall is assumed "
                           "the same in every condition)")
    return [f"verdict: {v['status'].upper().replace('_', ' ')}: {STATUS_WORDS[v['status']]}"
            f"{status_note}",
            v["text"], f"quote {words}{which}, median [90 % interval]: {numbers}"
            ] + condition_verdict_lines(cond)


def condition_verdict_lines(cond):
    """Each condition's P_phys and the contrasts against the reference (median [90 %
    interval], probability of the direction), of the model average and of the adopted model;
    no lines without conditions."""
    if not cond:
        return []
    lines = []
    same = cond["values"]["adopted"] == cond["values"]["model_average"]
    for which, words in (("model_average", "model average"
                          + (f" (= the adopted model, {cond['adopted']})" if same else "")),
                         ("adopted", f"adopted model ({cond['adopted']})")):
        values = cond["values"][which]
        if values is None or (same and which == "adopted"):
            continue
        lines.append(f"conditions, {words}: P_phys " + ", ".join(
            f"{n} {e['P_phys_kPa']['q50']:.4g} [{e['P_phys_kPa']['q05']:.4g}, "
            f"{e['P_phys_kPa']['q95']:.4g}] kPa" for n, e in values.items()))
        lines += [f"  {c['sentence']}" for c in cond["contrasts"][which]]
    return lines


def render_report(result, data_path=None):
    """The text of ``report.md``."""
    d = criticism_dict(result)
    sim = is_simulated(result.cells)
    lines = ["# Model criticism", ""]
    if sim:
        lines += ["> **SIMULATED DATA** (not measurements): see the comment lines of the data "
                  "file.", ""]
    lines += [f"Data: `{file_name(data_path or result.cells.path)}` (sha256 "
              f"`{result.cells.sha256}`, {cells_phrase(result.cells.n_bulged, result.cells.n_intact)}"
              f"), seed {result.seed}, engine "
              f"{result.settings.engine}, {result.timing_s:.0f} s.", "",
              "## Verdict", ""] + _verdict_block(d) + [
              f"* best named effect: **{d['selected_effect'] or 'none'}**"
              + (f" (delta elpd = {d['gain']['delta_elpd']:.1f} +- {d['gain']['se']:.1f})"
                 if d["selected_effect"] else ""), "",
              "## What the baseline gets wrong: posterior predictive checks", ""]
    lines += _checks_table(result)
    lines += ["", "![misfit](misfit.png)", "",
              "Standardized residuals (data minus the model's median-cell prediction, in units "
              "of the reported errors) against pressure; grey bars are the 90% range of the "
              "model's own replicated residuals. "
              + ("Top: baseline; bottom: the adopted extension." if result.selected
                 else "No extension was adopted, so only the baseline is shown."),
              "", "## Candidate causes: PSIS-LOO comparison with the baseline", ""]
    lines += _comparison_table(result)
    lines += flagged_section(d["flagged_cells"], gross=gross_error_verdict(d["verdict"]))
    note = table_check.describe(d["fe_table"]) if d.get("fe_table") else ""
    if note:
        lines += ["", f"**FE table** (adopted model): {note}"]
    lines += ["", "## Headline numbers", ""]
    lines += _headline_table(result)
    base_post = result.posteriors["baseline"]
    lines += ["", "Parameter keys and units as in `summary.json`. "
              + thickness_note(table_thickness_nm(base_post.model.surrogate)), "",
              monte_carlo_note(result.summaries["baseline"], base_post.engine), ""]
    lines += ["## Inference", "", "See `criticism_diagnostics.json`. Engine "
              f"`{result.settings.engine}`: Pareto-smoothed importance sampling from a "
              "Student-t around each posterior mode, emcee wherever its Pareto k exceeds "
              f"{criticism.K_MAX} or its ESS is below {result.settings.ess_min:g} "
              "(turgorbayes.criticism).", ""]
    for name, post in result.posteriors.items():
        diag = post.diagnostics
        detail = (f"k = {diag['k_hat']:.2f}, ESS = {diag['ess']:.0f}" if post.engine == "importance"
                  else f"{diag['n_chains']} ensembles, {diag['n_steps']} steps")
        status = "converged" if post.converged else "NOT converged: " + "; ".join(post.reasons)
        lines.append(f"* {name}: {post.engine} ({detail}), {status}")
    lines += ["", "## Verdict, again", ""] + _verdict_block(d)
    return "\n".join(lines) + "\n"


def _verdict_block(d):
    status, text, numbers, *conditions = verdict_lines(d)
    return [f"**{status}**", "", text, "", numbers] + (["", "```", *conditions, "```"]
                                                       if conditions else [])


def write_outputs(result, out, data_path=None):
    """Write every output of ``turgorbayes criticize`` into ``out`` (one place): the data
    files (criticism.json, criticism_diagnostics.json and, when an extension is adopted,
    extended_bands.json: :func:`turgorbayes.workflows.criticism_files.write_criticism`), then
    misfit.png and report.md drawn from them.

    Returns
    -------
    dict
        The criticism.json content.
    """
    out = Path(out)
    d = write_criticism(result, out)  # the data files, written by the workflow
    plot_misfit(result, out / "misfit.png")
    (out / "report.md").write_text(render_report(result, data_path))
    return d
