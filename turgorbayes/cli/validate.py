"""``turgorbayes validate [DATA.csv]``: check a cell-data file and print a one-screen summary."""

from pathlib import Path

import click

from turgorbayes.data_summary import bulge_pressures, validation_summary
from turgorbayes.io import example_path, read_cells

__all__ = ["bulge_pressures", "example_path", "summary_lines", "validate"]

#: The library's :func:`turgorbayes.data_summary.validation_summary` (old name).
summary_lines = validation_summary


@click.command()
@click.argument(
    "data", required=False, type=click.Path(exists=True, dir_okay=False, path_type=Path)
)
def validate(data):
    """Check the cell-data file DATA.csv and print a summary (bundled example if omitted).

    Exits with status 2 and one error message (file, line, column, problem) if the file is
    malformed.
    """
    if data is None:
        data = example_path()
        if not data.is_file():
            raise click.ClickException(f"bundled example {data} is missing (broken install?)")
    cells = read_cells(data)
    click.echo("\n".join(validation_summary(cells)))
