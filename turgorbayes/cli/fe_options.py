"""The ``--tip-radius-nm`` and ``--wall-thickness-nm`` options shared by ``simulate``, ``fit`` and
``criticize``: the k/(PR) table at other FE settings (:func:`turgorbayes.surrogate.load`)."""

import click

__all__ = ["FE_SETTINGS", "load_table"]


def FE_SETTINGS(command):  # noqa: N802  (a decorator named like the others, ALLOW_UNUSUAL)
    """Add ``--tip-radius-nm`` and ``--wall-thickness-nm`` to a click command."""
    tip = click.option(
        "--tip-radius-nm", type=click.FloatRange(min=0, min_open=True), default=None,
        help="Radius of the AFM tip in the FE stiffness table k/(PR) (3-30 nm; default: the "
             "table's own 7.5 nm, as in the paper's simulations). A blunter tip stiffens the "
             "response: 30 nm +9 %, 3 nm -4 % at the physiological point (docs/fem.md).")
    thickness = click.option(
        "--wall-thickness-nm", type=click.FloatRange(min=0, min_open=True), default=None,
        help="Wall thickness of the FE stiffness table k/(PR) (3-9 nm; default: the table's "
             "own 6 nm, as in the paper's simulations). It changes k/(PR) only through bending "
             "(4.5 nm: -2.1 % at the physiological point); the moduli E_perp, E_par divide "
             "E_perp t by t = 4.5 +- 1.5 nm either way.")
    return tip(thickness(command))


def load_table(surrogate_path, tip_radius_nm, wall_thickness_nm, echo):
    """The k/(PR) table for the command's FE options, saying which settings differ."""
    from turgorbayes import surrogate

    table = surrogate.load(surrogate_path, tip_radius_nm=tip_radius_nm,
                           thickness_nm=wall_thickness_nm)
    if wall_thickness_nm is not None:
        echo(f"k/(PR) for a wall {wall_thickness_nm:g} nm thick (FE thickness correction); "
             "E_perp and E_par still divide E_perp t by t = 4.5 +- 1.5 nm (report.md says why)")
    if tip_radius_nm is not None:
        echo(f"k/(PR) for an AFM tip of {tip_radius_nm:g} nm radius (FE tip-radius correction)")
    return table
