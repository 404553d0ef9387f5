"""``turgorbayes validate [DATA.csv]``: check a cell-data file and print a one-screen summary."""

import errno
import tempfile
import warnings
from pathlib import Path

import click

from turgorbayes.cells.plausibility import UnusualValueWarning
from turgorbayes.cells.summary import bulge_pressures, validation_summary
from turgorbayes.cells.table import example_path, read_cells

__all__ = ["ALLOW_UNUSUAL", "LARGE_TABLE_ROWS", "bulge_pressures", "check_output_dir", "check_output_file",
           "example_path", "load_cells", "summary_lines", "validate"]

#: The library's :func:`turgorbayes.cells.summary.validation_summary` (old name).
summary_lines = validation_summary

#: A data file of at least this many lines is announced before it is read (100 000 rows took
#: 6-9 s on a shared 2-core machine).
LARGE_TABLE_ROWS = 20_000

#: The ``--allow-unusual`` option shared by ``validate``, ``fit`` and ``criticize``.
ALLOW_UNUSUAL = click.option(
    "--allow-unusual", is_flag=True,
    help="Accept values no bacterium can have (radii outside 50 nm-5 um, stiffnesses outside "
         "1e-5-1 N/m, bulge pressures outside 0.05-1000 kPa, ...; docs/data_format.md) with a "
         "warning listing them, instead of refusing the file.")


def _reason(err):
    """The operating system's reason for ``err`` in words ("Permission denied")."""
    if err.errno == errno.ENOENT:
        return "the file system refuses to create it (No such file or directory)"
    return err.strerror or str(err)


def check_output_dir(path, option="--out"):
    """Check that the output folder ``path`` can be created and written, leaving nothing behind.

    Called before any computation, so that a folder that cannot be written fails at once
    instead of after the fit. Folders made for the check are removed again, so a run that then
    stops on bad data leaves no empty folder.

    Parameters
    ----------
    path : path-like
        The output folder (it may not exist yet, nor its parents).
    option : str
        The command-line option that named it, for the message.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    turgorbayes.errors.TurgorBayesError
        One line naming the folder, the option and the reason.
    """
    from turgorbayes.errors import TurgorBayesError

    path = Path(path)
    if path.exists() and not path.is_dir():
        raise TurgorBayesError(f"output folder {path} ({option}) is a file, not a folder")
    made = [p for p in (path, *path.parents) if not p.exists()]
    try:
        try:
            path.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise TurgorBayesError(f"cannot create the output folder {path} ({option}): "
                                   f"{_reason(err)}") from None
        try:
            with tempfile.TemporaryFile(dir=path):
                pass
        except OSError as err:
            raise TurgorBayesError(f"cannot write into the output folder {path} ({option}): "
                                   f"{_reason(err)}") from None
    finally:
        for p in made:  # deepest first; rmdir keeps a folder someone filled meanwhile
            _remove_empty(p)
    return path


def _remove_empty(path):
    """Remove the folder ``path`` if it exists and is empty."""
    try:
        path.rmdir()
    except OSError:
        pass


def check_output_file(path, option="--out"):
    """Check that the file ``path`` can be written (its folder may not exist yet).

    Parameters
    ----------
    path : path-like
    option : str
        The command-line option that named it, for the message.

    Returns
    -------
    pathlib.Path

    Raises
    ------
    turgorbayes.errors.TurgorBayesError
        One line naming the file, the option and the reason.
    """
    from turgorbayes.errors import TurgorBayesError

    path = Path(path)
    if path.is_dir():
        raise TurgorBayesError(f"output file {path} ({option}) is a folder, not a file")
    check_output_dir(path.parent, option)
    if path.exists() and not _writable(path):
        raise TurgorBayesError(f"cannot write the output file {path} ({option}): "
                               "Permission denied")
    return path


def _writable(path):
    """Whether the existing file ``path`` opens for appending (nothing is written)."""
    try:
        with open(path, "ab"):
            return True
    except OSError:
        return False


def _line_count(path):
    """Lines of the file ``path`` (0 if it cannot be read: :func:`read_cells` then says why)."""
    try:
        with open(path, "rb") as f:
            return sum(chunk.count(b"\n") for chunk in iter(lambda: f.read(1 << 20), b""))
    except OSError:
        return 0


def load_cells(data, allow_unusual=False, echo=print):
    """Read DATA (the bundled example if None); echo the unusual values let through, if any.

    Returns
    -------
    path : pathlib.Path
    cells : turgorbayes.cells.table.CellData
    """
    path = example_path() if data is None else Path(data)
    if data is None and not path.is_file():
        raise click.ClickException(f"bundled example {path} is missing (broken install?)")
    rows = _line_count(path)
    if rows >= LARGE_TABLE_ROWS:  # seconds of reading: say so before, not after
        echo(f"reading {path} ({rows} lines)...")
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
