"""The ``turgorbayes`` command line.

Sub-commands live in their own modules and are imported only when invoked, so that
``turgorbayes --help`` stays fast. Errors of type :class:`turgorbayes.errors.TurgorBayesError`
are printed as one message and exit with status 2 (no traceback); so are operating-system
errors on files (a folder that cannot be written, a disk that is full), whose message names
the path.
"""

import importlib
import sys

import click

from turgorbayes import __version__
from turgorbayes.errors import TurgorBayesError

__all__ = ["main"]

# name -> "module:attribute" of a click command; add one line per sub-command.
_COMMANDS = {
    "criticize": "turgorbayes.cli.criticize:criticize",
    "design": "turgorbayes.cli.design:design",
    "curves": "turgorbayes.cli.curves:curves",
    "fit": "turgorbayes.cli.fit:fit",
    "report": "turgorbayes.cli.report:report",
    "simulate": "turgorbayes.cli.simulate:simulate",
    "validate": "turgorbayes.cli.validate:validate",
    "surrogate": "turgorbayes.cli.surrogate:surrogate",
    "table": "turgorbayes.cli.table:table",
}

# name -> one whole sentence for `turgorbayes --help` (click would cut the docstring mid-sentence)
_SHORT_HELP = {
    "criticize": "Find what the model gets wrong and name its cause.",
    "curves": "Turn raw AFM force curves into a cell-data file.",
    "design": "What a planned two-condition experiment can tell about turgor.",
    "fit": "Fit a model to cell data; write the posterior and a report.",
    "report": "Write one HTML page from fit (and criticism) outputs.",
    "simulate": "Simulate a cell-data file with known truths.",
    "validate": "Check a cell-data file and print a summary.",
    "surrogate": "Build, check or inspect the FE stiffness table.",
    "table": "The numbers to quote from a fit or criticism folder, as one table.",
}


class _LazyGroup(click.Group):
    def list_commands(self, ctx):
        return sorted(_COMMANDS)

    def get_command(self, ctx, name):
        if name not in _COMMANDS:
            return None
        module, attr = _COMMANDS[name].split(":")
        command = getattr(importlib.import_module(module), attr)
        command.short_help = command.short_help or _SHORT_HELP.get(name)
        return command


@click.group(cls=_LazyGroup, context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="turgorbayes")
def cli():
    """Turgor pressure and cell-wall elasticity from AFM indentation of bacteria."""


def main(argv=None):
    """Console-script entry point: run the CLI, turning package errors into exit code 2."""
    try:
        cli.main(args=argv, prog_name="turgorbayes", standalone_mode=False)
    except TurgorBayesError as err:
        click.echo(f"error: {err}", err=True)
        sys.exit(2)
    except OSError as err:  # e.g. [Errno 13] Permission denied: 'out/summary.json'
        click.echo(f"error: {err}", err=True)
        sys.exit(2)
    except click.exceptions.Abort:
        click.echo("aborted", err=True)
        sys.exit(1)
    except click.ClickException as err:
        err.show()
        sys.exit(err.exit_code)
    sys.exit(0)
