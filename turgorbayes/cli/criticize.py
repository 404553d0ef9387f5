"""``turgorbayes criticize [DATA.csv] --out DIR``: what the model gets wrong, its cause, the gain."""

import click

from turgorbayes.cli.fe_options import FE_SETTINGS, load_table
from turgorbayes.cli.osmotic_options import OSMOTIC_OPTIONS, OSMOTIC_SETTINGS, series_options
from turgorbayes.cli.progress import PROGRESS
from turgorbayes.cli.validate import ALLOW_UNUSUAL, check_output_dir, load_cells

__all__ = ["CACHE_DIR", "DEFAULT_OUT", "criticize", "run_criticize_command"]

#: Default output folder: inside ``fit``'s default, where ``report`` looks for a criticism.
DEFAULT_OUT = "turgorbayes_fit/criticism"

#: The cache of the candidates' fits, inside ``--out`` (:mod:`turgorbayes.cache`).
CACHE_DIR = ".cache/criticize"


def run_criticize_command(data, out, seed, surrogate_path, settings, echo=print,
                          allow_unusual=False, tip_radius_nm=None, wall_thickness_nm=None,
                          progress=True, cache=True):
    """Criticize ``data`` (the bundled example if None) and write every output into ``out``.

    The output folder is checked for writing, and the data read, before anything is computed.
    With ``cache`` the candidates' fits are kept in, and taken from, :data:`CACHE_DIR` inside
    ``out`` (:func:`turgorbayes.workflows.criticize.criticize`).

    Returns
    -------
    turgorbayes.workflows.criticize.CriticismResult
    """
    # before the slow imports: a bad --out or data file fails at once
    out = check_output_dir(out)
    path, cells = load_cells(data, allow_unusual, echo)
    from turgorbayes.report import criticism as report_criticism
    from turgorbayes.report.fit import cells_phrase
    from turgorbayes.workflows.criticize import (
        check_criticism_data,
        conditions_design,
        criticize,
        is_series,
        series_design,
    )

    check_criticism_data(cells)
    design = conditions_design(cells, settings)  # a refused --per-condition fails at once
    series_options(cells, {k: getattr(settings, k) for k in OSMOTIC_OPTIONS})
    series = series_design(cells, settings) if is_series(cells) else None  # a bad one fails now
    if any("simulated" in c.lower() for c in cells.comments):
        echo(f"note: {path} holds SIMULATED data (see its comment lines)")
    table = load_table(surrogate_path, tip_radius_nm, wall_thickness_nm, echo)
    from turgorbayes.inference.conditions import condition_labels

    names = list(dict.fromkeys(condition_labels(cells) or ()))
    own = "; ".join(f"{q} of {', '.join(n)} its own" for q, n in (design.freed.items()
                                                                 if design else ()))
    within = (f" in {len(names)} conditions ({', '.join(names)}; the wall shared"
              f"{' except ' + own if own else ''})" if len(names) > 1 else "")
    if series is not None:
        within = (" in an osmotic series (" + ", ".join(f"{c:g}" for c in series.levels)
                  + f" mOsm; each intact cell at its level's turgor, P_phys at "
                    f"{series.reference:g} mOsm)")
    echo(f"criticizing the baseline fit of {cells_phrase(cells.n_bulged, cells.n_intact)}"
         f"{within} (seed {seed}, engine {settings.engine})")
    from turgorbayes.cache import Cache

    result = criticize(cells, table, seed=seed, settings=settings,
                       progress=(lambda msg: echo("  " + msg)) if progress else None,
                       cache=Cache(out / CACHE_DIR, report=echo) if cache else None)
    d = report_criticism.write_outputs(result, out, data_path=path)  # every output, one place
    flagged = [c["name"] for c in d["checks"] if c["flagged"]]
    echo(f"checks flagged (baseline): {', '.join(flagged) if flagged else 'none'}")
    echo(f"best named effect: {d['selected_effect']}")
    if d["selected_effect"]:
        echo(f"gain: delta elpd {d['gain']['delta_elpd']:.1f} +- {d['gain']['se']:.1f}")
    from turgorbayes.inference import table_check

    note = table_check.describe(d["fe_table"]) if d.get("fe_table") else ""
    if note:
        echo(f"warning: {note}")
    echo(f"wrote {out}/criticism.json, criticism_diagnostics.json, misfit.png, report.md "
         f"({result.timing_s:.0f} s)")
    for line in report_criticism.verdict_lines(d):
        echo(line)
    return result


@click.command()
@click.argument("data", required=False, type=click.Path(exists=True, dir_okay=False))
@click.option("--out", default=DEFAULT_OUT, show_default=True,
              type=click.Path(file_okay=False),
              help="Output directory (the default is where `turgorbayes report turgorbayes_fit` "
                   "looks).")
@click.option("--seed", default=0, show_default=True, type=int, help="Random seed.")
@click.option("--surrogate", "surrogate_path", default=None, type=click.Path(dir_okay=False),
              help="k/(PR) surrogate table (default: the shipped one).")
@click.option("--engine", default="importance", show_default=True,
              type=click.Choice(["importance", "emcee"]),
              help="importance: PSIS importance sampling with emcee wherever it is unreliable; "
                   "emcee: every model by MCMC (slow).")
@click.option("--draws", default=2000, show_default=True, type=click.IntRange(min=100),
              help="Importance-sampling draws per round.")
@click.option("--effects", "effect_list", default=None,
              help="Comma-separated candidate effects (default: all).")
@click.option("--max-refits", default=10, show_default=True, type=click.IntRange(min=0),
              help="Exact leave-one-out refits per model for cells with a high Pareto k.")
@click.option("--per-condition", "per_condition", multiple=True,
              help="With a condition column: criticize the model with E0t or gamma freed per "
                   "condition (E0t: in every condition, E0t:NAME: in condition NAME only), as "
                   "`fit --per-condition`; refused for a condition without bulged cells. Every "
                   "candidate is then that model plus its effect. Repeatable.")
@click.option("--workers", default=1, show_default=True, type=click.IntRange(min=1),
              help="Worker processes for every heavy step of the criticism: the candidates "
                   "are fitted side by side (each in a thread that sends its mode searches and "
                   "batches of draws to the workers), and the baseline's, the pair's and the "
                   "screen's batches go there too; the criticism is the same whatever their "
                   "number.")
@click.option("--scheduler", default=None, metavar="ADDRESS",
              help="Fit the candidates on a Dask cluster (tcp://HOST:PORT, or 'local').")
@click.option("--no-cache", is_flag=True,
              help=f"Fit every candidate again, and keep nothing in {CACHE_DIR}/ inside --out (by "
                   "default a candidate fitted before to the same data, seed and settings with the "
                   "same package version is taken from there, so a killed or extended run fits only "
                   "the missing ones; docs/outputs.md).")
@OSMOTIC_SETTINGS
@FE_SETTINGS
@ALLOW_UNUSUAL
@PROGRESS
def criticize(data, out, seed, surrogate_path, engine, draws, effect_list, max_refits,
              tip_radius_nm, wall_thickness_nm, allow_unusual, progress, per_condition=(),
              workers=1, scheduler=None, no_cache=False, reference_medium=None,
              temperature=None, length_model=None):
    """Fit the baseline to DATA (default: the bundled, simulated example), run posterior
    predictive checks, fit every effect of turgorbayes.effects as an extension, compare them by
    PSIS-LOO and name the cause; writes criticism.json, misfit.png and report.md into --out."""
    check_output_dir(out)  # before the slow imports below
    from turgorbayes import effects
    from turgorbayes.errors import TurgorBayesError
    from turgorbayes.workflows.criticize import CriticismSettings

    names = None
    if effect_list:
        names = tuple(n.strip() for n in effect_list.split(",") if n.strip())
        unknown = [n for n in names if n not in effects.EFFECTS]
        if unknown:
            raise TurgorBayesError(f"unknown effect(s) {', '.join(unknown)}; known: "
                                   f"{', '.join(effects.EFFECTS)}")
    settings = CriticismSettings(engine=engine, n_draws=draws, effects=names,
                                 max_refits=max_refits, per_condition=tuple(per_condition),
                                 workers=workers, scheduler=scheduler,
                                 reference_medium=reference_medium, temperature=temperature,
                                 length_model=length_model)
    run_criticize_command(data, out, seed, surrogate_path, settings, echo=click.echo,
                          allow_unusual=allow_unusual, tip_radius_nm=tip_radius_nm,
                          wall_thickness_nm=wall_thickness_nm, progress=progress,
                          cache=not no_cache)
