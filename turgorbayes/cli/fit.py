"""``turgorbayes fit [DATA.csv] --out DIR``: fit a model and write posterior, summary, report."""

import click

from turgorbayes.cli.fe_options import FE_SETTINGS, load_table
from turgorbayes.cli.osmotic_options import OSMOTIC_SETTINGS, series_options
from turgorbayes.cli.progress import PROGRESS
from turgorbayes.cli.registry_help import EffectHelpOption
from turgorbayes.cli.validate import ALLOW_UNUSUAL, check_output_dir, load_cells

__all__ = ["curve_flag_lines", "fit", "flagged_lines", "parse_wall_prior", "run_fit_command"]


def run_fit_command(data, out, model, seed, surrogate_path, settings, echo=print,
                    wall_thickness_nm=None, allow_unusual=False, tip_radius_nm=None,
                    reference=None, per_condition=(), wall_prior=None, osmotic=None):
    """Fit ``data`` (the bundled example if None) and write every output into ``out``.

    ``allow_unusual`` lets values outside the physical bounds through with a warning
    (:func:`turgorbayes.cells.table.read_cells`). The output folder is checked for writing, and the
    data read, before anything is computed. Data with a ``condition`` column are fitted by
    :func:`turgorbayes.workflows.conditions.fit_conditions` (``reference``, ``per_condition``,
    ``wall_prior``: None for the default prior, ``{}`` for one shared wall). Data whose intact
    cells were measured in media of several osmolarities (``medium_mOsm``) are fitted by
    :func:`turgorbayes.workflows.osmotic.fit_osmotic` (``osmotic``: its keyword arguments,
    ``reference_medium``, ``temperature``, ``length_model``); with a ``condition`` column too,
    by :func:`turgorbayes.workflows.osmotic_conditions.fit_osmotic_conditions` (each
    condition's series measures its own wall; ``wall_prior`` is then refused).

    Returns
    -------
    turgorbayes.workflows.fit.FitResult
    """
    # before the slow imports: a bad --out or data file fails at once
    out = check_output_dir(out)
    path, cells = load_cells(data, allow_unusual, echo)
    from turgorbayes.cells.table import is_simulated
    from turgorbayes.inference import table_check
    from turgorbayes.report import fit as report_fit
    from turgorbayes.workflows.fit import LARGE_FIT, fit_cells

    series = _osmotic_series(cells, model, osmotic or {})
    series_conditions = _series_conditions(cells, series, reference, per_condition, wall_prior)
    if series is None:
        cells.require_both_groups()
    conditions = None if series is not None else _condition_design(cells, model, reference,
                                                                   per_condition)
    if is_simulated(cells):
        echo(f"note: {path} holds SIMULATED data (see its comment lines)")
    table = load_table(surrogate_path, tip_radius_nm, wall_thickness_nm, echo)
    echo(f"fitting {report_fit.cells_phrase(cells.n_bulged, cells.n_intact)} with model "
         f"{'osmotic' if series is not None else model} (seed {seed})")
    if series is not None and series_conditions is not None:
        from turgorbayes.workflows.osmotic_conditions import fit_osmotic_conditions

        conditions = series_conditions
        echo(f"conditions: {', '.join(conditions.names)} (reference {conditions.reference}), "
             "each an osmotic series that measures its own wall: per condition P_phys, E0t, R0"
             + (", gamma" if "gamma" in conditions.freed else "; gamma shared")
             + "; the inactive fraction b shared")
        result = fit_osmotic_conditions(cells, reference, per_condition, seed=seed,
                                        surrogate=table, settings=settings, **series)
    elif series is not None:
        from turgorbayes.workflows.osmotic import fit_osmotic

        result = fit_osmotic(cells, seed=seed, surrogate=table, settings=settings, **series)
    elif conditions is None:
        result = fit_cells(cells, model=model, seed=seed, surrogate=table, settings=settings)
    else:
        from turgorbayes.workflows.conditions import fit_conditions

        echo(f"conditions: {', '.join(conditions.names)} (reference {conditions.reference})")
        from turgorbayes.inference.conditions import WALL_PRIOR

        prior = WALL_PRIOR if wall_prior is None else wall_prior
        echo("the walls of the conditions " + ("may differ (prior: " + ", ".join(
            ("ln E0t ratio" if q == "E0t" else "gamma difference") + f" sd {sd:g}"
            for q, sd in prior.items()) + "; --assume-shared-wall for one wall)" if prior
            else "are assumed equal (--assume-shared-wall): a wall change would read as a "
            "turgor change"))
        result = fit_conditions(cells, reference, per_condition, seed=seed, surrogate=table,
                                settings=settings, wall_prior=prior)
    if len(cells) >= LARGE_FIT:  # every draw of every cell: 876 MB of posterior.nc at 10 000
        echo(f"writing the outputs of {len(cells)} cells into {out}...")
    summary = report_fit.write_outputs(result, out)  # every output, in one place
    status = "converged" if result.converged else "NOT CONVERGED: " + "; ".join(result.reasons)
    echo(f"{status}; {summary['timing_s']:.1f} s")
    note = table_check.describe(result.table_check) if result.table_check else ""
    if note:
        echo(f"warning: {note}")
    if conditions is not None:
        echo(f"the reference condition {conditions.reference} (its turgor and wall; every "
             "condition below):")
    for key, entry in summary["parameters"].items():
        echo(f"  {key:<12} {entry['mean']:.4g} +- {entry['sd']:.2g} "
             f"[{entry['q05']:.4g}, {entry['q95']:.4g}]")
    bad_k = summary["loo"].get("n_pareto_k_bad") or 0
    if bad_k:
        echo(f"note: {bad_k} cell(s) have a Pareto k above {result.loo['good_k']:.2f}: their "
             "leave-one-out values (elpd in summary.json) are unreliable; `turgorbayes "
             "criticize` refits such cells exactly")
    from turgorbayes.report.conditions import condition_lines

    for line in condition_lines(summary):
        echo(line)
    from turgorbayes.report.osmotic import osmotic_lines

    for line in osmotic_lines(summary):
        echo(line)
    for line in flagged_lines(result.flagged_cells):
        echo(line)
    for line in curve_flag_lines(cells):
        echo(line)
    extra = "" if conditions is None else ", conditions.png"
    echo(f"wrote {out}/posterior.nc, summary.json, corner.png, fit.png{extra}, report.md")
    return result


def _osmotic_series(cells, model, options):
    """The osmotic fit's keyword arguments when the intact cells were measured at several
    medium osmolarities, else None (``--reference-medium`` and friends then refused)."""
    from turgorbayes.errors import TurgorBayesError

    given = series_options(cells, options)
    if given is not None and model != "baseline":
        raise TurgorBayesError(f"the intact cells were measured in media of several "
                               f"osmolarities, which the osmotic model fits (the baseline's "
                               f"extension by the osmotic balance); --model {model} is not "
                               "available for such a series")
    return given


def _series_conditions(cells, series, reference, per_condition, wall_prior):
    """The :class:`~turgorbayes.inference.conditions.ConditionSet` of an osmotic series with a
    ``condition`` column (each condition's series measures its own wall), None without a
    series or without the column; options that do not apply are refused."""
    from turgorbayes.errors import TurgorBayesError
    from turgorbayes.inference.conditions import condition_labels
    from turgorbayes.inference.osmotic_conditions import series_condition_set

    if series is None:
        return None
    if condition_labels(cells) is None:
        if reference is not None or per_condition:
            raise TurgorBayesError("--reference and --per-condition need a condition column in "
                                   "the data (docs/data_format.md)")
        return None
    if wall_prior is not None:
        raise TurgorBayesError("--wall-prior and --assume-shared-wall do not apply to osmotic "
                               "series: each condition's series measures its own wall (E0t per "
                               "condition; --per-condition gamma frees gamma too)")
    return series_condition_set(cells, reference, per_condition)


def _condition_design(cells, model, reference, per_condition):
    """The data's :class:`~turgorbayes.inference.conditions.ConditionSet`, or None without a
    ``condition`` column (then ``--reference`` and ``--per-condition`` are refused)."""
    from turgorbayes.errors import TurgorBayesError
    from turgorbayes.inference.conditions import condition_labels, condition_set

    if condition_labels(cells) is None:
        if reference is not None or per_condition:
            raise TurgorBayesError("--reference and --per-condition need a condition column in "
                                   "the data (docs/data_format.md)")
        return None
    if model != "baseline":
        raise TurgorBayesError(f"the data have a condition column, which only the baseline model "
                               f"fits so far (got --model {model}); drop the column to fit one "
                               "condition at a time")
    return condition_set(cells, reference, per_condition)


def curve_flag_lines(cells, limit=8):
    """Command-line lines naming the cells ``turgorbayes curves`` marked (column
    :data:`~turgorbayes.cells.columns.CURVE_FLAGS`), by flag."""
    from turgorbayes.cells.columns import CURVE_FLAG_TEXT, CURVE_FLAGS

    by_flag = {}
    for cell_id, flags in zip(cells.cell_id, cells.extra.get(CURVE_FLAGS, ()), strict=False):
        for flag in filter(None, flags.split(";")):
            by_flag.setdefault(flag, []).append(cell_id)
    if not by_flag:
        return []
    n = len({c for ids in by_flag.values() for c in ids})
    lines = [f"warning: {n} cell(s) marked by `turgorbayes curves` ({CURVE_FLAGS}), fitted as "
             "they are:"]
    for flag, ids in by_flag.items():
        shown = ", ".join(ids[:limit]) + (f", ... ({len(ids)} in all)" if len(ids) > limit else "")
        lines.append(f"  {flag}: {shown}: {CURVE_FLAG_TEXT.get(flag, 'see the curves table')}")
    return lines


def flagged_lines(flagged):
    """Command-line lines naming the readings that look like gross errors."""
    if not flagged:
        return []
    lines = [f"warning: {len(flagged)} reading(s) far outside what the model predicts for "
             "their cell: gross errors, or an effect the model lacks (check these curves and "
             "images; `turgorbayes criticize` tells the two apart):"]
    return lines + [f"  {f['cell_id']:<8} {f['quantity']:<8} {f['reason']}" for f in flagged]


@click.command()
@click.argument("data", required=False, type=click.Path(exists=True, dir_okay=False))
@click.option("--out", default="turgorbayes_fit", show_default=True,
              type=click.Path(file_okay=False), help="Output directory.")
@click.option("--model", default="baseline", show_default=True, cls=EffectHelpOption,
              help="Model: baseline (Bayesian, latent bulge pressures), paper_wls (the "
                   "published weighted least squares), or the baseline extended by effects "
                   "joined with '+': {effects} (e.g. radius_spread+bad_curves).")
@click.option("--seed", default=0, show_default=True, type=int, help="Random seed.")
@click.option("--surrogate", "surrogate_path", default=None, type=click.Path(dir_okay=False),
              help="k/(PR) surrogate table (default: the shipped one).")
@click.option("--walkers", default=16, show_default=True, type=click.IntRange(min=10),
              help="Walkers per ensemble.")
@click.option("--ensembles", default=4, show_default=True, type=click.IntRange(min=1),
              help="Independent ensembles (>= 4 for between-chain R-hat).")
@click.option("--max-steps", default=20000, show_default=True, type=click.IntRange(min=100),
              help="Give up (not converged) after this many steps.")
@click.option("--nodes", default=8, show_default=True, type=click.IntRange(min=2),
              help="Gauss-Hermite nodes per bulged cell.")
@click.option("--reference", default=None,
              help="With a condition column: the condition every contrast is taken against "
                   "(default: the first condition in file order).")
@click.option("--per-condition", "per_condition", multiple=True,
              help="With a condition column: free E0t or gamma per condition (E0t: in every "
                   "condition, E0t:NAME: in condition NAME only); refused for a condition "
                   "without bulged cells. Repeatable.")
@click.option("--wall-prior", "wall_prior", default=None, metavar="E0t=SD,gamma=SD",
              help="With a condition column: how far a condition's wall may differ from the "
                   "reference's (sd of ln(E0t ratio) and of the gamma difference; default "
                   "E0t=0.35,gamma=0.2, docs/statistics.md). Where a condition has no bulged "
                   "cells its data cannot tell its wall, and its turgor contrast widens by "
                   "what this prior allows.")
@click.option("--assume-shared-wall", "shared_wall", is_flag=True,
              help="With a condition column: one wall for every condition (the contrast is "
                   "then conditional on that assumption, which these data may not check).")
@OSMOTIC_SETTINGS
@FE_SETTINGS
@PROGRESS
@ALLOW_UNUSUAL
def fit(data, out, model, seed, surrogate_path, walkers, ensembles, max_steps, nodes,
        tip_radius_nm, wall_thickness_nm, allow_unusual, progress, reference=None,
        per_condition=(), wall_prior=None, shared_wall=False, reference_medium=None,
        temperature=None, length_model=None):
    """Fit DATA (default: the bundled, simulated example) and write posterior.nc,
    summary.json, corner.png, fit.png and report.md into --out."""
    check_output_dir(out)  # before the slow imports below
    from turgorbayes.errors import TurgorBayesError
    from turgorbayes.workflows.fit import FitSettings, resolve_model

    try:
        resolve_model(model)
    except ValueError as err:
        raise TurgorBayesError(str(err)) from None
    settings = FitSettings(n_walkers=walkers, n_ensembles=ensembles, max_steps=max_steps,
                           n_nodes=nodes, progress=progress)
    if shared_wall and wall_prior is not None:
        raise TurgorBayesError("--assume-shared-wall and --wall-prior exclude each other: one "
                               "wall for every condition, or walls that may differ by a prior")
    run_fit_command(data, out, model, seed, surrogate_path, settings, echo=click.echo,
                    wall_thickness_nm=wall_thickness_nm, allow_unusual=allow_unusual,
                    tip_radius_nm=tip_radius_nm, reference=reference,
                    per_condition=per_condition,
                    wall_prior={} if shared_wall else parse_wall_prior(wall_prior),
                    osmotic={"reference_medium": reference_medium, "temperature": temperature,
                             "length_model": length_model})


def parse_wall_prior(text):
    """``"E0t=0.35,gamma=0.2"`` -> ``{"E0t": 0.35, "gamma": 0.2}``; None -> None (the default
    prior). A bad item raises :class:`~turgorbayes.errors.TurgorBayesError` naming it."""
    from turgorbayes.errors import TurgorBayesError

    if text is None:
        return None
    out = {}
    for item in text.split(","):
        name, _, value = item.partition("=")
        try:
            sd = float(value)
        except ValueError:
            sd = float("nan")
        if name.strip() not in ("E0t", "gamma") or not sd > 0 or sd == float("inf"):
            raise TurgorBayesError(f"--wall-prior {text!r}: item {item!r} must be E0t=SD or "
                                   "gamma=SD with a positive SD (e.g. E0t=0.35,gamma=0.2)")
        out[name.strip()] = sd
    return out
