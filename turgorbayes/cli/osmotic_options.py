"""The ``--reference-medium``, ``--temperature-K`` and ``--length-model`` options shared by
``fit`` and ``criticize``: how an osmotic series' balance is evaluated (docs/statistics.md,
"Osmotic series")."""

import click

__all__ = ["OSMOTIC_OPTIONS", "OSMOTIC_SETTINGS", "series_options"]

#: keyword -> option name, for messages.
OSMOTIC_OPTIONS = {"reference_medium": "--reference-medium", "temperature": "--temperature-K",
                   "length_model": "--length-model"}


def OSMOTIC_SETTINGS(command):  # noqa: N802  (a decorator named like FE_SETTINGS)
    """Add the osmotic series' options to a click command."""
    reference = click.option(
        "--reference-medium", "reference_medium", default=None, type=float, metavar="MOSM",
        help="With a medium_mOsm column (an osmotic series): the medium whose turgor is "
             "P_phys (default: the lowest, the growth medium).")
    temperature = click.option(
        "--temperature-K", "temperature", default=None,
        type=click.FloatRange(min=0, min_open=True),
        help="With an osmotic series: the temperature of the measurement [K] (default "
             "298.15; turgor is RT times the osmolarity difference).")
    length = click.option(
        "--length-model", "length_model", default=None, type=click.Choice(["wall", "fixed"]),
        help="With an osmotic series: the cell length follows the wall law at the axial "
             "tension (wall, default) or stays fixed over a shift (docs/physics.md).")
    return reference(temperature(length(command)))


def series_options(cells, options):
    """The given osmotic options (keyword -> value, those not None) when the intact cells of
    ``cells`` were measured in media of two or more osmolarities, else None.

    Raises
    ------
    TurgorBayesError
        An option given for data that are not an osmotic series.
    """
    from turgorbayes.cells.medium import medium_levels
    from turgorbayes.errors import TurgorBayesError

    given = {k: v for k, v in options.items() if v is not None}
    if medium_levels(cells).size < 2:
        if given:
            raise TurgorBayesError(f"{', '.join(OSMOTIC_OPTIONS[k] for k in given)} need(s) "
                                   "intact cells measured in media of two or more osmolarities "
                                   "(the medium_mOsm column, docs/data_format.md)")
        return None
    return given
