"""``report.md`` of a fit: parameters beside the paper's table, diagnostics, figures.

The table puts side by side: this fit (mean +- sd and 90 % interval), the published
weighted least-squares method re-run on the same data (``paper_wls``, estimate +- standard
error) and the paper's published values (:data:`turgorbayes.physics.parameters.PUBLISHED`), with the
difference to the published value in units of the combined uncertainty
``z = (this - published)/sqrt(sd^2 + sd_published^2)``.
"""

import math

import numpy as np

from turgorbayes.cells.table import is_simulated
from turgorbayes.inference import table_check
from turgorbayes.physics.parameters import BASELINE, PUBLISHED, PUBLISHED_SD, QUANTITIES
from turgorbayes.report import conditions as report_conditions
from turgorbayes.report import osmotic as report_osmotic
from turgorbayes.report.text import table_thickness_nm, thickness_note
from turgorbayes.workflows.fit import summary_dict, wls_parameters, write_results

__all__ = ["PUBLISHED_TABLE", "cells_phrase", "counted", "flagged_section", "render_report",
           "write_outputs", "write_report"]


def _shown(value, q):
    """SI -> display unit, rounded to 12 digits (464.2e-9 m is 464.2 nm, not 464.19999...)."""
    return float(f"{q.to_display(value):.12g}")


#: Published values and uncertainties in summary units, keyed like summary.json.
PUBLISHED_TABLE = {q.key: (_shown(PUBLISHED[n], q), _shown(PUBLISHED_SD[n], q))
                   for n, q in QUANTITIES.items()}
_NAMES = {q.key: q.ascii for q in QUANTITIES.values()}


def _fmt(x, sd=None):
    if x is None or not np.isfinite(x):
        return "n/a"
    digits = 3 if sd is None or not np.isfinite(sd) or sd <= 0 else max(
        2, 2 - int(math.floor(math.log10(abs(sd)))))
    mag = max(abs(x), 1e-300)
    if mag >= 1e4 or mag < 1e-3:
        return f"{x:.3g}"
    return f"{x:.{min(digits, 6)}f}" if mag < 1000 else f"{x:.1f}"


def _row(key, entry, wls_entry):
    pub, pub_sd = PUBLISHED_TABLE[key]
    m, sd = entry["mean"], entry["sd"]
    z = (m - pub) / math.hypot(sd, pub_sd)
    this = f"{_fmt(m, sd)} +- {_fmt(sd)} [{_fmt(entry['q05'], sd)}, {_fmt(entry['q95'], sd)}]"
    wls = "" if wls_entry is None else f"{_fmt(wls_entry['mean'], wls_entry['sd'])} +- " \
        f"{_fmt(wls_entry['sd'])}"
    return f"| {_NAMES[key]} | {this} | {wls} | {pub} +- {pub_sd} | {z:+.2f} |"


def _latent_effect(summary, wls_summary):
    """Lines on how baseline and paper_wls differ on the same data."""
    lines = ["", "### What the latent pressures change (baseline against paper_wls, same data)",
             "", "| quantity | shift (baseline - paper_wls) in baseline sd | width ratio "
             "(baseline sd / paper_wls se) |", "|---|---|---|"]
    for key in (QUANTITIES[n].key for n in BASELINE):
        b, w = summary["parameters"][key], wls_summary["parameters"][key]
        lines.append(f"| {_NAMES[key]} | {(b['mean'] - w['mean']) / b['sd']:+.2f} | "
                     f"{b['sd'] / w['sd']:.2f} |")
    lines += ["", "paper_wls treats every bulge-derived pressure as exact; the baseline "
              "integrates each bulged cell's pressure over its bulge-measurement "
              "uncertainty, which widens the intervals and removes the errors-in-variables "
              "bias of plugging noisy pressures into a nonlinear fit."]
    return lines


def _table_line(result):
    """The FE-table check (:mod:`turgorbayes.inference.table_check`) as a report line."""
    check = result.table_check
    if check is None:
        return []
    note = table_check.describe(check)
    if note:
        return [f"- **FE table:** {note}"]
    return ["- FE table: every cell's plausible pressures lie where the table has a stiffness "
            "(inside its domain, outside the region where the wall buckles under the tip)"
            + (" (checked on the baseline wall)" if check["approximate"] else "")]


def _diagnostics(result, summary):
    lines = ["", "## Diagnostics", ""] + _table_line(result)
    if result.model == "paper_wls":
        s = result.sampler
        lines += [f"- weighted least squares: chi2 = {s['chi2']:.1f} for {s['dof']} degrees of "
                  f"freedom (reduced {s['chi2'] / s['dof']:.2f}); intervals are not rescaled "
                  "by it", f"- optimizer: {s['message']} ({s['nfev']} evaluations)",
                  "- r_hat, ESS and LOO do not apply (no posterior)"]
        return lines
    s = result.sampler
    lines += [f"- sampler: emcee, {s['n_ensembles']} independent ensembles x "
              f"{s['n_walkers']} walkers ({s['moves']}), {s['n_steps']} steps each; "
              f"burn-in {s['burn']}, thinning {s['thin']:.0f}, "
              f"{s['n_draws_per_chain']} draws per ensemble kept; acceptance "
              f"{s['acceptance']:.2f}",
              "- integrated autocorrelation times [steps]: "
              + ", ".join(f"{k} {v:.1f}" for k, v in s["tau"].items())
              + f"; run length / tau >= {s['tol']:.0f} required"]
    if s.get("attempts"):  # the engine's ladder re-ran an unconverged run with more steps
        lines.append("- earlier run(s) that did not converge: " + "; ".join(
            f"{a['engine']}, {a['effort']}: {', '.join(a['reasons'])}" for a in s["attempts"]))
    pn = s.get("population_noise")
    if pn:
        lines.append(
            f"- the latent population's estimation noise is carried ({pn['n_bootstrap']} "
            "bootstrap populations; its sd over the Laplace sd: "
            + ", ".join(f"{k} {v:.2f}" for k, v in pn["shift_sd_over_laplace_sd"].items())
            + "); R-hat and ESS are of the sampler's own draws")
    lines += ["", "| parameter | R-hat (rank) | ESS bulk | ESS tail | ESS emcee (all steps) |",
              "|---|---|---|---|---|"]
    for name, d in result.chain_diag.items():
        emc = s["ess_emcee"].get(name)
        lines.append(f"| {name} | {d['r_hat']:.4f} | {d['ess_bulk']:.0f} | {d['ess_tail']:.0f}"
                     f" | {'' if emc is None else f'{emc:.0f}'} |")
    loo = summary["loo"]
    lines += ["", f"- PSIS-LOO: elpd = {loo['elpd']:.1f} +- {loo['se']:.1f}, p_loo = "
              f"{loo['p_loo']:.1f}, Pareto k above the threshold "
              f"({result.loo['good_k']:.2f}): {loo['n_pareto_k_bad']} of "
              f"{counted(result.cells.R_c.size, 'cell')}",
              f"- quadrature: {s['n_nodes']} adaptive Gauss-Hermite nodes per bulged cell"]
    return lines


def counted(n, noun):
    """``n`` and ``noun``, plural unless ``n`` is 1: ``counted(1, "cell")`` -> ``"1 cell"``."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def cells_phrase(n_bulged, n_intact):
    """``"72 bulged + 42 intact cells"`` (``"cell"`` when there is one in all)."""
    noun = "cell" if n_bulged + n_intact == 1 else "cells"
    return f"{n_bulged} bulged + {n_intact} intact {noun}"


def flagged_section(flagged, gross=True):
    """Markdown lines: the flagged readings (``flagged_cells``), called gross errors with their
    probability when ``gross`` (a criticism whose verdict is gross errors), else readings the
    model cannot explain with their screen score (the fit's screen, any other verdict)."""
    title = "Readings that look like gross errors" if gross else "Readings the model cannot explain"
    lines = ["", f"## {title}", ""]
    if not flagged:
        return lines + (["None: no reading is more likely a gross error than a measurement "
                         "(turgorbayes.effects.outliers)."] if gross else ["None."])
    lines += [f"| cell | quantity | {'probability' if gross else 'score'} | why |",
              "|---|---|---|---|"]
    return lines + [f"| {f['cell_id']} | {f['quantity']} | {f['score']:.2f} | {f['reason']} |"
                    for f in flagged]


def _wls_label(result):
    """The least-squares column's heading: the published method, or the osmotic model's own
    least squares (bulge pressures exact, intact cells at their level's turgor)."""
    if result.model == "osmotic":
        return "least squares (osmotic) on these data"
    return "paper_wls on these data"


def render_report(result):
    """Markdown text of the report of a :class:`turgorbayes.workflows.fit.FitResult`."""
    summary = summary_dict(result)
    # a least-squares fit that failed (a reading it cannot reach holds its penalty residual)
    # has no meaningful estimate or standard error: no column, and a sentence why
    wls_ok = result.model == "paper_wls" or result.wls.success
    wls_summary = {"parameters": wls_parameters(result)} if wls_ok else None
    cells = result.cells
    simulated = is_simulated(cells)
    lines = [f"# turgorbayes fit: model `{result.model}`", ""]
    if simulated:
        lines += ["> **SIMULATED DATA.** These cells were generated by `turgorbayes simulate`, "
                  "not measured. File comments:", ">"]
        lines += [f"> `{c}`" for c in cells.comments]
        lines.append("")
    state = "**converged**" if result.converged else "**NOT CONVERGED**"
    lines += [f"- data: `{summary['data']['path']}` (sha256 `{cells.sha256}`), "
              f"{cells_phrase(cells.n_bulged, cells.n_intact)}",
              f"- surrogate: `{summary['surrogate']['path']}` (sha256 "
              f"`{summary['surrogate']['sha256']}`)",
              f"- status: {state}"]
    lines += [f"  - {r}" for r in result.reasons]
    if not result.converged:
        lines.append("  - the numbers below are NOT a converged posterior summary")
    lines += [f"- seed {result.seed}, turgorbayes {summary['version']}, "
              f"{summary['timing_s']:.1f} s", "", "## Parameters", "",
              f"| quantity | this fit: mean +- sd [90 % interval] | {_wls_label(result)} | "
              "published | z vs published |", "|---|---|---|---|---|"]
    for key in (q.key for q in QUANTITIES.values()):
        wls_entry = None if wls_summary is None else wls_summary["parameters"][key]
        lines.append(_row(key, summary["parameters"][key], wls_entry))
    lines += ["", "z: difference to the published value over the combined uncertainty "
              "sqrt(sd^2 + sd_published^2).", "",
              thickness_note(table_thickness_nm(result.surrogate))]
    if not wls_ok:
        lines += ["", f"paper_wls did not fit these data ({result.wls.message}; at its best "
                  "point the model cannot produce some reading), so its column is empty and "
                  "it is not compared."]
    elif result.model not in ("paper_wls", "osmotic"):
        lines += _latent_effect(summary, wls_summary)
    lines += _diagnostics(result, summary)
    lines += flagged_section(summary["flagged_cells"], gross=False)
    lines += report_conditions.markdown_lines(summary)
    lines += report_osmotic.markdown_lines(summary)
    lines += ["", "## Figures", "", "![joint posterior](corner.png)", "",
              "![data and fit](fit.png)", ""]
    return "\n".join(lines)


def write_outputs(result, out):
    """Write every output of ``turgorbayes fit`` into ``out`` (one place): ``posterior.nc`` and
    ``summary.json`` (:func:`turgorbayes.workflows.fit.write_results`), ``conditions.png`` (data
    with conditions), ``corner.png``, ``fit.png`` and ``report.md``.

    Returns
    -------
    dict
        The summary written.
    """
    from pathlib import Path

    from turgorbayes.plots import corner_plot, fig3

    out = Path(out)
    summary = write_results(result, out)
    if result.conditions is not None:
        from turgorbayes.plots.conditions import conditions_figure

        conditions_figure(result, path=out / "conditions.png")
    corner_plot(result, path=out / "corner.png")
    fig3(result, seed=result.seed, path=out / "fit.png")
    write_report(result, out / "report.md")
    return summary


def write_report(result, path):
    """Write :func:`render_report` to ``path``."""
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(render_report(result))
