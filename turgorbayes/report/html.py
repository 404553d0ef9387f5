"""``report.html``: one self-contained page from the output directories of ``fit`` and ``criticize``.

:func:`write_report` reads only what the commands wrote (``posterior.nc``, ``summary.json``,
``criticism.json``, ``criticism_diagnostics.json``, ``misfit.png``, ``extended_bands.json``):
the criticism's verdict first, then the warnings, provenance, parameters beside the paper's,
diagnostics, the criticism's tables and the figures of :mod:`turgorbayes.plots` embedded as
base64 PNG (docs/outputs.md, The HTML report).
"""

import base64
import html
import io
import json
import re
from pathlib import Path

import numpy as np

from turgorbayes import __version__, plots
from turgorbayes.criticism.checks import replicates
from turgorbayes.criticism.verdict import gross_error_verdict
from turgorbayes.errors import TurgorBayesError
from turgorbayes.formatting import format_p_value
from turgorbayes.inference import diagnostics
from turgorbayes.physics.parameters import QUANTITIES
from turgorbayes.plots.conditions import conditions_figure
from turgorbayes.report.conditions import html_section
from turgorbayes.report.criticism import verdict_lines
from turgorbayes.report.fit import PUBLISHED_TABLE, cells_phrase
from turgorbayes.report.text import monte_carlo_note, thickness_note
from turgorbayes.workflows.bands import read_bands

__all__ = ["CRITICISM_SUBDIR", "CSS", "criticism_dir_of", "diagnostic_warnings", "load_outputs",
           "render_html", "write_report"]

#: Folder inside a fit directory where ``turgorbayes criticize`` writes by default.
CRITICISM_SUBDIR = "criticism"

_NAMES = {q.key: q.description for q in QUANTITIES.values()}
#: The style sheet of ``report.html`` (the curve report adds its own rules to it).
CSS = """body{font-family:sans-serif;max-width:1100px;margin:auto;padding:1em;color:#222}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #bbb;padding:3px 8px;
text-align:left}th{background:#eee}.warn{background:#fde2e2;border:2px solid #c00;padding:
.5em 1em}.note{background:#fff6d5;border:1px solid #d9a400;padding:.5em 1em}.ok{background:
#e3f5e1;border:1px solid #3a3;padding:.5em 1em}img{max-width:100%}code{font-size:90%}"""


# ------------------------------------------------------------------------------ reading
def _read_json(path):
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)


def criticism_dir_of(fit_dir, criticism_dir=None):
    """The criticism folder a report of ``fit_dir`` reads, or None when there is none.

    Parameters
    ----------
    fit_dir : path-like
        Output directory of ``turgorbayes fit``.
    criticism_dir : path-like, optional
        Given explicitly (``--criticism``): it must hold ``criticism.json``. Default: the
        first of ``fit_dir/criticism`` (where ``turgorbayes criticize`` writes by default)
        and ``fit_dir`` itself that holds one.

    Returns
    -------
    pathlib.Path or None

    Raises
    ------
    turgorbayes.errors.TurgorBayesError
        If ``criticism_dir`` is given and holds no ``criticism.json``.
    """
    if criticism_dir is not None:
        cdir = Path(criticism_dir)
        if not (cdir / "criticism.json").is_file():
            raise TurgorBayesError(f"{cdir} holds no criticism.json (write one with "
                                   "`turgorbayes criticize --out DIR`)")
        return cdir
    for cdir in (Path(fit_dir) / CRITICISM_SUBDIR, Path(fit_dir)):
        if (cdir / "criticism.json").is_file():
            return cdir
    return None


def load_outputs(fit_dir, criticism_dir=None):
    """Read the files of a ``fit`` directory and, if any, of a ``criticize`` directory.

    Parameters
    ----------
    fit_dir : path-like
        Holds ``posterior.nc`` and ``summary.json``.
    criticism_dir : path-like, optional
        Holds ``criticism.json``; default :func:`criticism_dir_of` (``fit_dir/criticism``,
        then ``fit_dir``).

    Returns
    -------
    dict
        ``fit_dir``, ``tree`` (DataTree), ``summary``, ``criticism``,
        ``criticism_diagnostics``, ``misfit_png``, ``extended_bands`` (None where absent).
    """
    import xarray as xr

    fit_dir = Path(fit_dir)
    missing = [n for n in ("posterior.nc", "summary.json") if not (fit_dir / n).is_file()]
    if missing:
        raise TurgorBayesError(f"{fit_dir} is not a fit output directory: {', '.join(missing)} "
                               "missing (write one with `turgorbayes fit --out DIR`)")
    try:
        tree = xr.open_datatree(fit_dir / "posterior.nc", engine="h5netcdf").load()
    except (OSError, ValueError) as err:
        raise TurgorBayesError(f"cannot read {fit_dir / 'posterior.nc'}: not a posterior written "
                               f"by `turgorbayes fit` ({type(err).__name__})") from None
    out = {"fit_dir": fit_dir, "summary": _read_json(fit_dir / "summary.json"), "tree": tree,
           "criticism": None, "criticism_diagnostics": None, "misfit_png": None,
           "extended_bands": None}
    cdir = criticism_dir_of(fit_dir, criticism_dir)
    if cdir is not None:
        out["criticism"] = _read_json(cdir / "criticism.json")
        if (cdir / "criticism_diagnostics.json").is_file():
            out["criticism_diagnostics"] = _read_json(cdir / "criticism_diagnostics.json")
        if (cdir / "misfit.png").is_file():
            out["misfit_png"] = (cdir / "misfit.png").read_bytes()
        if (cdir / "extended_bands.json").is_file():
            out["extended_bands"] = read_bands(cdir / "extended_bands.json")
    return out


# ------------------------------------------------------------------------------ warnings
def _fit_warnings(summary):
    out = []
    if not summary.get("converged", False):
        out.append("The fit did NOT converge: its numbers are not a posterior summary.")
    for key, e in summary["parameters"].items():
        r = e.get("r_hat")
        if r is not None and not r < diagnostics.RHAT_MAX:
            out.append(f"R-hat of {key} is {r:.4f} (needs < {diagnostics.RHAT_MAX}).")
        for k in ("ess_bulk", "ess_tail"):
            v = e.get(k)
            if v is not None and not v >= diagnostics.ESS_MIN:
                out.append(f"{k} of {key} is {v:.0f} (needs >= {diagnostics.ESS_MIN}).")
    bad = (summary.get("loo") or {}).get("n_pareto_k_bad")
    if bad:
        out.append(f"PSIS-LOO: {bad} cell(s) with Pareto k above the threshold; their LOO "
                   "values, and the elpd, are unreliable.")
    return out


def _criticism_warnings(cdiag):
    out = []
    for name, m in (cdiag or {}).get("models", {}).items():
        if not m.get("converged", True):
            out.append(f"criticism model {name} ({m.get('engine')}) did NOT converge: "
                       + "; ".join(m.get("reasons", [])))
        left = m.get("loo", {}).get("n_bad_not_refitted", 0)
        if left:
            out.append(f"criticism model {name}: {left} cell(s) with high Pareto k were not "
                       "refitted exactly; its LOO comparison is unreliable.")
    return out


def diagnostic_warnings(summary, criticism_diagnostics=None, tree_attrs=None):
    """Every failed diagnostic, in words (empty when all pass).

    Parameters
    ----------
    summary : dict
        The content of ``summary.json``.
    criticism_diagnostics : dict, optional
        The content of ``criticism_diagnostics.json``.
    tree_attrs : dict, optional
        Attributes of ``posterior.nc`` (its ``fe_table_undefined_note``: cells whose plausible
        pressures reach where the FE table has no stiffness, :mod:`turgorbayes.inference.table_check`).

    Returns
    -------
    list of str
    """
    table = [(tree_attrs or {}).get("fe_table_undefined_note", "")]
    return (_fit_warnings(summary) + [t for t in table if t]
            + _criticism_warnings(criticism_diagnostics))


# ------------------------------------------------------------------------------ html parts
def _e(x):
    return html.escape(str(x))


def _table(header, rows):
    head = "".join(f"<th>{_e(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{_e(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _sentence(text):
    """A report sentence as HTML: escaped, with its `code` spans as <code>."""
    return re.sub(r"`([^`]*)`", r"<code>\1</code>", _e(text))


def _num(x, fmt=".4g"):
    return "n/a" if x is None or not np.isfinite(x) else format(x, fmt)


def _png(fig_or_bytes, alt):
    if isinstance(fig_or_bytes, bytes):
        data = fig_or_bytes
    else:
        buf = io.BytesIO()
        fig_or_bytes.savefig(buf, format="png", dpi=100)
        data = buf.getvalue()
    src = base64.b64encode(data).decode("ascii")
    return f'<p><img alt="{_e(alt)}" src="data:image/png;base64,{src}"></p>'


def _provenance(outputs):
    s, dt = outputs["summary"], outputs["tree"]
    d, sur = s["data"], s["surrogate"]
    rows = [("data", f"{d['path']} ({cells_phrase(d['n_bulged'], d['n_intact'])})"),
            ("data sha256", d["sha256"]), ("surrogate", sur["path"]),
            ("surrogate sha256", sur["sha256"]), ("model", s["model"]),
            ("fit seed", s["seed"]), ("turgorbayes version of the fit", s["version"]),
            ("fit wall time", f"{s['timing_s']:.1f} s"),
            ("posterior.nc", f"{dt['posterior'].sizes.get('chain')} chains (independent "
                             f"ensembles) x {dt['posterior'].sizes.get('draw')} draws"),
            ("report written by", f"turgorbayes {__version__}")]
    cd = outputs["criticism_diagnostics"]
    if cd:
        st = cd.get("settings", {})
        if "seed" in cd:
            rows.append(("criticism seed", cd["seed"]))
        rows.append(("criticism settings", ", ".join(f"{k}={v}" for k, v in st.items())))
    return "<h2>Provenance</h2>" + _table(("item", "value"), rows)


def _parameters(summary):
    rows = []
    for key, e in summary["parameters"].items():
        pub, pub_sd = PUBLISHED_TABLE.get(key, (None, None))
        z = "" if pub is None else f"{(e['mean'] - pub) / np.hypot(e['sd'], pub_sd):+.2f}"
        rows.append((_NAMES.get(key, key), f"{_num(e['mean'])} ± {_num(e['sd'], '.2g')}",
                     f"[{_num(e['q05'])}, {_num(e['q95'])}]",
                     "" if pub is None else f"{pub} ± {pub_sd}", z))
    return ("<h2>Parameters</h2>" + _table(
        ("quantity", "this fit: mean ± sd", "90 % interval", "published (Deng et al. 2011)",
         "z vs published"), rows)
            + "<p>z: difference to the published value over sqrt(sd² + sd_published²).</p>"
            + f"<p>{_sentence(thickness_note())}</p>")


def _flagged(flagged, title="Readings that look like gross errors", gross=True):
    if not flagged:
        return (f"<h2>{title}</h2><p>None" + (": no reading is more likely a gross error than a "
                "measurement" if gross else "") + ".</p>")
    return f"<h2>{title}</h2>" + _table(
        ("cell", "quantity", "probability" if gross else "score", "why"),
        [(f["cell_id"], f["quantity"], f"{f['score']:.2f}", f["reason"]) for f in flagged])


def _diagnostics(summary):
    rows = [(k, _num(e.get("r_hat"), ".4f"), _num(e.get("ess_bulk"), ".0f"),
             _num(e.get("ess_tail"), ".0f")) for k, e in summary["parameters"].items()]
    loo = summary.get("loo") or {}
    text = ("<p>PSIS-LOO: elpd = {} ± {}, p_loo = {}, cells with high Pareto k: {}.</p>".format(
        _num(loo.get("elpd"), ".1f"), _num(loo.get("se"), ".1f"), _num(loo.get("p_loo"), ".1f"),
        loo.get("n_pareto_k_bad", "n/a")))
    return ("<h2>Convergence</h2>" + _table(("parameter", "R-hat (rank)", "ESS bulk", "ESS tail"),
                                            rows)
            + f"<p>Rule: R-hat &lt; {diagnostics.RHAT_MAX}, bulk and tail ESS &ge; "
              f"{diagnostics.ESS_MIN} (Vehtari et al. 2021).</p>" + text)


def _p_value(name, p, n_rep):
    """A check's p-value (:func:`~turgorbayes.formatting.format_p_value`); without
    ``criticism_diagnostics.json`` the replicates' number is unknown, so 0 and 1 are said in
    words."""
    if n_rep is None and replicates(name, 1) is not None and p in (0.0, 1.0):
        return "no replicate as extreme" if p == 0.0 else "every replicate as extreme"
    return format_p_value(p, replicates(name, n_rep))


def _verdict(crit):
    """The verdict's status in words, its paragraph and the numbers to quote (the same lines
    as the command line's and report.md's end); empty for a criticism.json without one."""
    if not crit or "verdict" not in crit:
        return ""
    status, text, numbers, *conditions = verdict_lines(crit)
    extra = f"<pre>{_e(chr(10).join(conditions))}</pre>" if conditions else ""
    return f"<p><b>{_e(status)}</b></p><p>{_e(text)}</p><p>{_e(numbers)}</p>{extra}"


def _verdict_section(crit, n_warnings):
    """The page's first section: the criticism's verdict, or how to get one; a pointer to
    the failed diagnostics below it when there are any."""
    if crit is None:
        body = ("<p class='note'>No model criticism yet: the fit alone does not say what the "
                "model gets wrong. Run <code>turgorbayes criticize</code> and write this page "
                "again.</p>")
    else:
        body = _verdict(crit) or ("<p class='note'>This <code>criticism.json</code> holds no "
                                  "verdict (written by an older turgorbayes).</p>")
    if n_warnings:
        body += (f"<p class='warn'>Read with care: {n_warnings} diagnostic(s) failed, listed "
                 "below.</p>")
    return f"<section id='verdict'><h2>Verdict</h2>{body}</section>"


def _fit_is_the_baseline(cdiag, fit_summary):
    """Whether the report's fit is the baseline of the criticism's data (same data sha256)."""
    return bool(fit_summary and cdiag and fit_summary.get("model") == "baseline"
                and cdiag.get("data_sha256")
                and cdiag["data_sha256"] == fit_summary["data"]["sha256"])


def _baseline_against_extension(crit, cdiag, fit_summary):
    """The baseline beside the adopted extension. The baseline column is the fit's (the one
    baseline of the report) when the fit is the baseline of the same data; otherwise the
    criticism's own baseline posterior, with its Monte Carlo error stated."""
    ext = crit["parameters"]["extended"]
    fit_is_base = _fit_is_the_baseline(cdiag, fit_summary)
    base = fit_summary["parameters"] if fit_is_base else crit["parameters"]["baseline"]
    rows = [(_NAMES.get(k, k), f"{_num(base[k]['q50'])} [{_num(base[k]['q05'])}, "
             f"{_num(base[k]['q95'])}]", f"{_num(ext[k]['q50'])} [{_num(ext[k]['q05'])}, "
             f"{_num(ext[k]['q95'])}]") for k in base if k in ext]
    if fit_is_base:
        note = ("The baseline column is the fit's posterior (the parameters above); the "
                "criticism's own baseline posterior served only to compare the candidates.")
        header = "baseline (the fit): median [90 %]"
    else:
        engine = (cdiag or {}).get("models", {}).get("baseline", {}).get("engine", "unknown")
        note = monte_carlo_note(crit["parameters"]["baseline"], engine)
        header = "baseline (the criticism's): median [90 %]"
    return ["<h3>Baseline against the adopted extension</h3>",
            _table(("quantity", header, f"{crit['selected_effect']}: median [90 %]"), rows),
            f"<p>{_sentence(note)}</p>"]


def _criticism(crit, cdiag=None, fit_summary=None):
    if crit is None:
        return ("<h2>Model criticism</h2><p>No <code>criticism.json</code> found: run "
                "<code>turgorbayes criticize DATA --out DIR</code> and pass "
                "<code>--criticism DIR</code>.</p>")
    g = crit["gain"]
    n_rep = (cdiag or {}).get("settings", {}).get("n_rep")
    best = crit["selected_effect"] or "none"
    parts = ["<h2>Model criticism</h2>",
             "<p>The verdict heads the page; the tables it rests on:</p>" if "verdict" in crit
             else "", "<ul>",
             f"<li>best named effect: <b>{_e(best)}</b>"
             + (f" (Δelpd = {g['delta_elpd']:.1f} ± {g['se']:.1f})" if crit["selected_effect"]
                else "") + "</li></ul>",
             "<h3>Posterior predictive checks of the baseline</h3>",
             _table(("check", "statistic", "p-value", "flagged"),
                    [(c["name"], _num(c["statistic"], ".3g"),
                      _p_value(c["name"], c["p_value"], n_rep),
                      "FLAGGED" if c["flagged"] else "") for c in crit["checks"]]),
             "<h3>Candidate causes (PSIS-LOO against the baseline)</h3>",
             _table(("effect", "Δelpd", "se", "size estimate [90 %]"),
                    [(c["effect"], _num(c["delta_elpd"], ".1f"), _num(c["delta_se"], ".1f"),
                      "; ".join(f"{k} = {_num(v['mean'], '.3g')} [{_num(v['q05'], '.3g')}, "
                                f"{_num(v['q95'], '.3g')}]" for k, v in c["estimate"].items())
                      or (f"could not be fitted: {c['failed']}" if c.get("failed") else ""))
                     for c in crit["candidates"]])]
    if "flagged_cells" in crit:
        gross = gross_error_verdict(crit.get("verdict"))
        parts.append(_flagged(crit["flagged_cells"], "Gross errors found by the criticism"
                              if gross else "Readings the model cannot explain", gross))
    ext = crit["parameters"]["extended"]
    if ext:
        parts += _baseline_against_extension(crit, cdiag, fit_summary)
    stack = (cdiag or {}).get("stacking")
    if stack:
        avg = stack["parameters"]
        weights = ", ".join(f"{n} {w:.2f}" for n, w in stack["weights"].items() if w >= 0.005)
        parts += [f"<h3>Model average (stacking: {_e(weights)})</h3>",
                  _table(("quantity", "median [90 %]"),
                         [(_NAMES.get(k, k), f"{_num(v['q50'])} [{_num(v['q05'])}, "
                           f"{_num(v['q95'])}]") for k, v in avg.items()])]
    return "".join(parts)


# ------------------------------------------------------------------------------ figures
def _surrogate(summary, surrogate):
    from turgorbayes import surrogate as surrogate_module

    if surrogate is not None:
        return surrogate
    want = summary["surrogate"]["sha256"]
    for path in (summary["surrogate"].get("path"), None):
        if path is None or Path(str(path)).is_file():
            table = surrogate_module.load(path)
            if not want or table.sha256 == want:
                return table
    raise TurgorBayesError(f"no surrogate table with the fit's sha256 {want} found (tried "
                           f"{summary['surrogate'].get('path')} and the shipped one); pass "
                           "--surrogate FILE")


def _figures(outputs, surrogate, problems):
    dt, summary = outputs["tree"], outputs["summary"]
    bayesian = summary["model"] != "paper_wls"
    ext = outputs["extended_bands"]
    specs = [("Fig. 3: radius and stiffness against pressure",
              lambda: plots.fig3(dt, extended=[ext] if ext else (),
                                 surrogate=_surrogate(summary, surrogate), seed=summary["seed"])),
             ("Joint posterior", lambda: plots.corner_plot(dt)),
             ("Posterior predictive residuals", lambda: plots.residual_plot(dt))]
    if dt.attrs.get("conditions"):
        specs.append(("Each condition's P_phys and its difference to the reference",
                      lambda: conditions_figure(dt)))
    if bayesian:
        specs += [("Trace plot (one line per independent ensemble)", lambda: plots.trace_plot(dt)),
                  ("Rank plot", lambda: plots.rank_plot(dt))]
    parts = ["<h2>Figures</h2>"]
    for title, make in specs:
        try:
            parts += [f"<h3>{_e(title)}</h3>", _png(make(), title)]
        except (TurgorBayesError, ValueError, KeyError, OSError) as err:
            problems.append(f"figure '{title}' could not be drawn: {err}")
    if outputs["extended_bands"] is None and outputs["criticism"] and \
            outputs["criticism"]["selected_effect"]:
        parts.append("<p class='note'>Fig. 3 shows the baseline only: the criticism directory "
                     "holds no <code>extended_bands.json</code>.</p>")
    if outputs["misfit_png"] is not None:
        parts += ["<h3>Criticism: residuals of the baseline and of the adopted extension</h3>",
                  _png(outputs["misfit_png"], "misfit")]
    return "".join(parts)


# ------------------------------------------------------------------------------ page
def _simulated_note(simulated):
    if not simulated:
        return ""
    return ("<p class='note'><b>SIMULATED DATA</b>: these cells were generated by "
            "<code>turgorbayes simulate</code>, not measured.</p>")


def _banner(items):
    if items:
        return ("<div class='warn' id='warnings'><b>Warnings: diagnostics failed.</b><ul>"
                + "".join(f"<li>{_e(w)}</li>" for w in items) + "</ul></div>")
    return ("<p class='ok' id='warnings'>Every diagnostic passed (convergence, R-hat, ESS, "
            "Pareto k).</p>")


def render_html(outputs, surrogate=None):
    """The report page of :func:`load_outputs`'s ``outputs`` (a self-contained HTML string).

    Parameters
    ----------
    outputs : dict
        From :func:`load_outputs`.
    surrogate : turgorbayes.surrogate.Surrogate, optional
        Table for Fig. 3; default the fit's (by path, then the shipped one, checked by sha256).
    """
    summary = outputs["summary"]
    problems = []
    figures = _figures(outputs, surrogate, problems)
    warnings = diagnostic_warnings(summary, outputs["criticism_diagnostics"],
                                   dict(outputs["tree"].attrs))
    simulated = bool(int(outputs["tree"].attrs.get("simulated_data", 0)))
    title = f"turgorbayes report: model {summary['model']}"
    items = warnings + problems
    body = [f"<h1>{_e(title)}</h1>", _simulated_note(simulated),
            _verdict_section(outputs["criticism"], len(items)), _banner(items),
            _provenance(outputs), _parameters(summary), html_section(summary),
            _diagnostics(summary),
            # one table of flagged readings: the criticism's (worded by its verdict) if any
            "" if outputs["criticism"] else _flagged(summary.get("flagged_cells") or [],
                                                     "Readings the model cannot explain", False),
            _criticism(outputs["criticism"], outputs["criticism_diagnostics"], summary),
            figures]
    return (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{_e(title)}</title>"
            f"<style>{CSS}</style></head><body>{''.join(body)}</body></html>\n")


def write_report(fit_dir, out=None, criticism_dir=None, surrogate=None):
    """Write ``report.html`` for a fit directory (and its criticism); return its path.

    Parameters
    ----------
    fit_dir : path-like
    out : path-like, optional
        Default ``fit_dir/report.html``.
    criticism_dir : path-like, optional
        See :func:`load_outputs`.
    surrogate : turgorbayes.surrogate.Surrogate, optional

    Returns
    -------
    pathlib.Path
    """
    outputs = load_outputs(fit_dir, criticism_dir)
    path = Path(out) if out is not None else Path(fit_dir) / "report.html"
    path.write_text(render_html(outputs, surrogate), encoding="utf-8")
    return path
