"""``turgorbayes report DIR``: one self-contained HTML page from fit (and criticism) outputs."""

import click

__all__ = ["report"]


@click.command()
@click.argument("fit_dir", default="turgorbayes_fit", required=False,
                type=click.Path(exists=True, file_okay=False))
@click.option("--criticism", "criticism_dir", default=None,
              type=click.Path(exists=True, file_okay=False),
              help="Output directory of `turgorbayes criticize` (default: FIT_DIR/criticism, "
                   "where `criticize` writes by default, then FIT_DIR, if one holds "
                   "criticism.json).")
@click.option("--out", default=None, type=click.Path(dir_okay=False),
              help="HTML file to write (default: FIT_DIR/report.html).")
@click.option("--surrogate", "surrogate_path", default=None, type=click.Path(dir_okay=False),
              help="k/(PR) table of the fit (default: the path in summary.json, then the "
                   "shipped one; checked by sha256).")
def report(fit_dir, criticism_dir, out, surrogate_path):
    """Write report.html for FIT_DIR (written by `turgorbayes fit`; default turgorbayes_fit, where
    `fit` writes by default): warnings for every failed
    diagnostic, provenance, parameter and criticism tables, figures embedded as PNG."""
    from pathlib import Path

    from turgorbayes.cli.validate import check_output_file

    # before the slow imports and the figures: a bad --out fails at once
    path = check_output_file(Path(out) if out else Path(fit_dir) / "report.html")
    from turgorbayes import report as report_module
    from turgorbayes import surrogate

    table = surrogate.load(surrogate_path) if surrogate_path else None
    outputs = report_module.load_outputs(fit_dir, criticism_dir)
    warnings = report_module.diagnostic_warnings(outputs["summary"],
                                                 outputs["criticism_diagnostics"],
                                                 dict(outputs["tree"].attrs))
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(report_module.render_html(outputs, table), encoding="utf-8")
    for w in warnings:
        click.echo(f"warning: {w}", err=True)
    click.echo(f"wrote {path}")
