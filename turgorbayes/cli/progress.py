"""``--no-progress``: the one progress flag of every command that shows progress."""

import functools

import click

__all__ = ["PROGRESS"]


def PROGRESS(command):  # noqa: N802 (a decorator constant, as FE_SETTINGS and ALLOW_UNUSUAL)
    """Add ``--no-progress`` (and the hidden old name ``--quiet``, removed in 0.4.0) to a
    command; the command receives ``progress: bool``."""

    @functools.wraps(command)
    def wrapper(*args, no_progress, quiet, **kwargs):
        if quiet:
            click.echo("note: --quiet is now --no-progress, the same flag on every command; "
                       "--quiet goes in turgorbayes 0.4.0", err=True)
        return command(*args, progress=not (no_progress or quiet), **kwargs)

    wrapper = click.option("--quiet", is_flag=True, hidden=True,
                           help="Old name of --no-progress.")(wrapper)
    return click.option("--no-progress", is_flag=True,
                        help="No progress bars or progress lines.")(wrapper)
