"""``turgorbayes design``: what a planned two-condition experiment can tell about turgor."""

import click

from turgorbayes.cli.progress import PROGRESS

__all__ = ["design", "parse_truths"]


def parse_truths(text):
    """``"0.7:0:0,1:0:-0.25,prior"`` -> list of (E0t ratio, gamma difference, turgor change)
    triples or ``"prior"``; a bad item raises :class:`click.BadParameter` naming it."""
    out = []
    for item in text.split(","):
        if item.strip() == "prior":
            out.append("prior")
            continue
        try:
            ratio, dgamma, change = (float(x) for x in item.split(":"))
        except ValueError:
            raise click.BadParameter(f"{item!r} is not RATIO:GAMMA_DIFF:CHANGE (e.g. 0.7:0:0) "
                                     "or 'prior'", param_hint="--truths") from None
        if not ratio > 0 or not change > -1:
            raise click.BadParameter(f"{item!r}: the E0t ratio must be > 0 and the turgor "
                                     "change > -1", param_hint="--truths")
        out.append((ratio, dgamma, change))
    return out


@click.command()
@click.option("--n-bulged", "n_bulged", default="wt:72", show_default=True,
              help="Bulged cells per condition: wt:N,treated:N (or N for both).")
@click.option("--n-intact", default=42, show_default=True, type=click.IntRange(min=2),
              help="Intact cells per condition.")
@click.option("--truths", default="0.7:0:0,1.3:0:0,1:0:-0.25", show_default=True,
              help="Treated's true E0t ratio:gamma difference:relative turgor change, "
                   "comma-separated; 'prior' draws a wall change from the wall prior.")
@click.option("--n", "n_experiments", default=20, show_default=True,
              type=click.IntRange(min=1), help="Simulated experiments per truth.")
@click.option("--seed", default=0, show_default=True, type=int, help="First data seed.")
@click.option("--wall-prior", default=None, metavar="E0t=SD,gamma=SD",
              help="The fit's wall prior (default E0t=0.35,gamma=0.2).")
@click.option("--out", default=None, type=click.Path(dir_okay=False),
              help="Write every experiment and the summary to this JSON file.")
@PROGRESS
def design(n_bulged, n_intact, truths, n_experiments, seed, wall_prior, out, progress):
    """Simulate and fit experiments of a planned design (conditions wt and treated, wt at
    29 kPa with the paper's wall) and print, per true change, how often the turgor contrast's
    90 % interval covers the truth and claims a direction, for the headline (walls may differ)
    and the shared-wall number: the false 'turgor changed' rate when only the wall changes,
    and the power when turgor does. About 2-6 s per experiment and truth."""
    from turgorbayes.cli.fit import parse_wall_prior
    from turgorbayes.simulation.conditions import parse_bulged_counts
    from turgorbayes.workflows.design import design_summary, simulate_design, summary_lines, write_design

    try:
        counts = parse_bulged_counts(n_bulged, ("wt", "treated"))
    except ValueError as err:
        raise click.BadParameter(str(err), param_hint="--n-bulged") from None
    rows = simulate_design(counts, n_intact, parse_truths(truths), n_experiments, seed,
                           wall_prior=parse_wall_prior(wall_prior), progress_bar=progress)
    summary = design_summary(rows)
    for line in summary_lines(summary):
        click.echo(line)
    if out:
        write_design(out, summary, rows)
        click.echo(f"wrote {out}")
