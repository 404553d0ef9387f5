"""``turgorbayes validate [DATA.csv]``: check a cell-data file and print a one-screen summary."""

import warnings
from pathlib import Path

import click

from turgorbayes.data_summary import bulge_pressures, validation_summary
from turgorbayes.io import example_path, read_cells
from turgorbayes.plausibility import UnusualValueWarning

__all__ = ["ALLOW_UNUSUAL", "bulge_pressures", "example_path", "load_cells", "summary_lines",
           "validate"]

#: The library's :func:`turgorbayes.data_summary.validation_summary` (old name).
summary_lines = validation_summary

#: The ``--allow-unusual`` option shared by ``validate``, ``fit`` and ``criticize``.
ALLOW_UNUSUAL = click.option(
    "--allow-unusual", is_flag=True,
    help="Accept values no bacterium can have (radii outside 50 nm-5 um, stiffnesses outside "
         "1e-5-1 N/m, bulge pressures outside 0.05-1000 kPa, ...; docs/data_format.md) with a "
         "warning listing them, instead of refusing the file.")


def load_cells(data, allow_unusual=False, echo=print):
    """Read DATA (the bundled example if None); echo the unusual values let through, if any.

    Returns
    -------
    path : pathlib.Path
    cells : turgorbayes.io.CellData
    """
    path = example_path() if data is None else Path(data)
    if data is None and not path.is_file():
        raise click.ClickException(f"bundled example {path} is missing (broken install?)")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", UnusualValueWarning)
        cells = read_cells(path, allow_unusual=allow_unusual)
    for w in caught:
        if issubclass(w.category, UnusualValueWarning):
            echo(f"warning: {w.message}")
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    return path, cells


@click.command()
@click.argument(
    "data", required=False, type=click.Path(exists=True, dir_okay=False, path_type=Path)
)
@ALLOW_UNUSUAL
def validate(data, allow_unusual):
    """Check the cell-data file DATA.csv and print a summary (bundled example if omitted).

    Exits with status 2 and one error message (file, line, column, problem) if the file is
    malformed or holds values no bacterium can have (unless --allow-unusual).
    """
    # the summary lists the unusual values itself
    _, cells = load_cells(data, allow_unusual, echo=lambda msg: None)
    click.echo("\n".join(validation_summary(cells)))
