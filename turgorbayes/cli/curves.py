"""``turgorbayes curves MANIFEST.csv --out cells.csv``: raw force curves to the cell-data table."""

import warnings
from pathlib import Path

import click

from turgorbayes.cells.columns import CURVE_FLAGS
from turgorbayes.cli.progress import PROGRESS

__all__ = ["CACHE_DIR", "curves"]

#: The cache of reduced rows, beside ``--out`` (:mod:`turgorbayes.cache`).
CACHE_DIR = ".cache/curves"


@click.command()
@click.argument("manifest", type=click.Path(exists=True, dir_okay=False, path_type=Path))
@click.option("--out", required=True, type=click.Path(dir_okay=False, path_type=Path),
              help="Cell-data CSV to write; the per-curve table goes beside it.")
@click.option("--curves-out", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Per-curve table [default: curves.csv beside --out].")
@click.option("--method", type=click.Choice(["powerlaw", "threshold"]), default="powerlaw",
              show_default=True, help="Contact-point method (docs/curves.md).")
@click.option("--bulge-max-force-nN", "bulge_max_force_nN", type=click.FloatRange(min=0, min_open=True),
              default=None, help="Read k_b at the deepest point reached below this force "
                                 "[default: the whole approach].")
@click.option("--bulge-depth-nm", "bulge_depth_nm", type=click.FloatRange(min=0, min_open=True),
              default=None, help="Read k_b at this fixed depth instead of the deepest point.")
@click.option("--figures", "figures", type=click.Choice(["problems", "all", "none"]),
              default="problems", show_default=True,
              help="Per-curve PNGs in curve_figures/ and the overview page curves.html beside the "
                   "per-curve table: for the curves to look at (rejected curves, the curves of "
                   "cells left out or read with a low signal, force maps), for every curve (about "
                   "0.2 s each), or none (no page either).")
@click.option("--no-figures", is_flag=True, hidden=True, help="Old name of --figures none.")
@click.option("--workers", type=click.IntRange(min=1), default=None,
              help="Processes that reduce the curves (default: every core); the output is the "
                   "same whatever their number.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Reduce the curves on a Dask cluster (tcp://HOST:PORT, or 'local' for a "
                   "local cluster of --workers processes).")
@click.option("--no-glass-correction", is_flag=True,
              help="Report each session's glass slope (target glass rows) without correcting its "
                   "curves' deflection sensitivity.")
@click.option("--no-cache", is_flag=True,
              help=f"Reduce every file again, and keep nothing in {CACHE_DIR}/ beside --out (by default "
                   "a file reduced before, with the same settings and package version, is taken from "
                   "there, so a killed or extended run reduces only what is missing; docs/curves.md).")
@PROGRESS
def curves(manifest, out, curves_out, method, bulge_max_force_nN, bulge_depth_nm, figures,
           no_figures, workers, scheduler, no_glass_correction, no_cache, progress):
    """Reduce the force curves listed in MANIFEST.csv (one row per curve file: file, cell_id,
    target, Rc_nm, Rc_err_nm, Rb_nm, Rb_err_nm on bulge rows; docs/curves.md) to stiffnesses,
    and write the cell-data CSV that `turgorbayes fit` reads, plus a per-curve table with every
    curve's status (rejected curves with their reason), one figure per curve in curve_figures/
    and an overview page curves.html beside it. A row with curve_index 'map' reduces a whole
    force map (R_c from its height map if Rc_nm is empty, k_c from its crest curves) and adds
    force_maps.csv and a pixel table per map in force_maps/."""
    from turgorbayes.cache import Cache
    from turgorbayes.curves import ReductionSettings
    from turgorbayes.curves.glass import glass_report
    from turgorbayes.curves.pipeline import LOW_SIGNAL, low_signal_cells
    from turgorbayes.workflows.curves import reduce_to_tables, write_cell_table

    settings = ReductionSettings(
        method=method, bulge_max_force=None if bulge_max_force_nN is None else bulge_max_force_nN * 1e-9,
        bulge_depth=None if bulge_depth_nm is None else bulge_depth_nm * 1e-9,
        glass_correction=not no_glass_correction)
    curves_out = curves_out or out.parent / "curves.csv"
    figures = "none" if no_figures else figures
    writer = None
    if figures == "all":  # drawn as they are reduced: no second reduction
        from turgorbayes.plots.curves import FIGURE_DIR, CurveFigureWriter

        writer = CurveFigureWriter(curves_out.parent / FIGURE_DIR)
    from turgorbayes.parallel import default_workers

    cache = None if no_cache else Cache(out.parent / CACHE_DIR, report=click.echo)
    result = reduce_to_tables(manifest, curves_out, settings, progress=progress, on_curve=writer,
                              workers=workers or default_workers(), scheduler=scheduler, cache=cache)
    if cache is not None:
        click.echo(f"reduced {len(result.results) - cache.hits} of {len(result.results)} rows; {cache.hits} from the "
                   f"cache {cache.folder} (--no-cache: reduce every one)")
    out.parent.mkdir(parents=True, exist_ok=True)
    n_ok = sum(r.accepted for r in result.results)
    click.echo(f"{n_ok} of {len(result.results)} curves accepted; per-curve table {curves_out}")
    for line in glass_report(result.manifest, result.results, settings):
        click.echo(line)
    for row, res in zip(result.manifest.rows, result.results, strict=True):
        if not res.accepted:
            click.echo(f"rejected: {row.name} (line {row.line}, cell {row.cell_id}): "
                       f"{res.status}: {res.detail}")
        elif not res.ok:
            click.echo(f"{res.status}: {row.name} (line {row.line}, cell {row.cell_id}): "
                       f"{res.detail}")
    for cell_id, why in result.left_out.items():
        click.echo(f"warning: cell {cell_id} left out: {why}")
    soft = [c for c in low_signal_cells(result.manifest.rows, result.results) if c not in result.left_out]
    if soft:
        click.echo(f"warning: {len(soft)} cell(s) read with a force at R_c/20 under {LOW_SIGNAL:g}x the "
                   f"baseline noise ({', '.join(soft[:8])}{', ...' if len(soft) > 8 else ''}): such "
                   "stiffnesses come out high (+6 % at 2x, +24 % at 1x the noise) and shift the fit "
                   "(docs/curves.md, 'From raw curves to posteriors'); marked low_signal in the "
                   f"{CURVE_FLAGS} column of {out.name}, which fit names")
    if figures != "none":  # before a failure below: they show why
        _write_figures(result, curves_out, figures, progress, writer)
    write_cell_table(result, out, manifest, curves_out)
    click.echo(f"wrote {result.cells.n_bulged} bulged + {result.cells.n_intact} intact cells to {out}")
    for line in _unusual_lines(out):
        click.echo(line)


def _unusual_lines(out):
    """Lines naming the values of the table just written that no bacterium can have (``fit``
    and ``validate`` refuse them unless given ``--allow-unusual``; this command was not)."""
    from turgorbayes.cells import plausibility
    from turgorbayes.cells.plausibility import UnusualValueWarning
    from turgorbayes.cells.table import read_cells

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", UnusualValueWarning)
        cells = read_cells(out, allow_unusual=True)
    problems = plausibility.check(cells)
    if not problems:
        return []
    return [f"warning: {out}: {len(problems)} value(s) no bacterium can have; fit and validate "
            "refuse them unless given --allow-unusual:", plausibility.describe(problems)]


def _write_figures(result, curves_out, which, progress, writer):
    """The PNGs in ``curve_figures/`` (``which``: "problems" or "all"; those ``writer`` drew
    during the reduction are kept) and the overview page beside the per-curve table."""
    from turgorbayes.curves.pipeline import problem_rows
    from turgorbayes.plots.curves import FIGURE_DIR, write_curve_figures
    from turgorbayes.report.curves_html import write_curves_html

    only = problem_rows(result) if which == "problems" else None
    names, seconds = write_curve_figures(result, curves_out.parent / FIGURE_DIR, progress, only, writer)
    page = curves_out.with_suffix(".html")
    write_curves_html(page, result, names, FIGURE_DIR, curves_out.name)
    drawn = sum(n is not None for n in names)
    per_curve = 1e3 * seconds / max(drawn, 1)
    scope = (f"{drawn} of {len(names)} curves (the ones to look at; --figures all draws every "
             "one)" if which == "problems" else f"{drawn} curves")
    click.echo(f"wrote figures of {scope} to {curves_out.parent / FIGURE_DIR} "
               f"({per_curve:.0f} ms per figure) and the overview page {page}")
