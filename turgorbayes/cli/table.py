"""``turgorbayes table DIR``: the numbers to quote from a fit or criticism folder, as one table."""

import click

from turgorbayes.report.table import FORMATS

__all__ = ["table"]


@click.command()
@click.argument("folder", default="turgorbayes_fit", required=False,
                type=click.Path(file_okay=False))
@click.option("--format", "fmt", default="csv", show_default=True, type=click.Choice(FORMATS),
              help="csv (full precision), markdown or latex (a booktabs tabular; both with 4 "
                   "significant digits).")
@click.option("--out", default=None, type=click.Path(dir_okay=False),
              help="File to write (default: print the table).")
def table(folder, fmt, out):
    """Print (or write to --out) the numbers to quote from FOLDER, the output folder of
    `turgorbayes fit` (summary.json; with its criticism/ when there is one) or of `turgorbayes
    criticize` (criticism.json): parameters with R-hat and ESS, each condition and contrast
    with what it assumes, the verdict and the model average, and the provenance."""
    from pathlib import Path

    from turgorbayes.cli.validate import check_output_file
    from turgorbayes.report.table import quote_table, render

    path = check_output_file(Path(out)) if out else None
    text = render(quote_table(folder), fmt)
    if path is None:
        click.echo(text, nl=False)
        return
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    click.echo(f"wrote {path}")
