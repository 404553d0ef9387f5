"""``turgorbayes simulate --out DATA.csv``: synthetic cells with known truths (+ JSON sidecar)."""

from pathlib import Path

import click

from turgorbayes.cli.fe_options import FE_SETTINGS, load_table
from turgorbayes.cli.registry_help import EffectHelpOption
from turgorbayes.workflows.simulated import sidecar_path, write_simulated

__all__ = ["simulate"]


@click.command()
@click.option("--out", required=False, type=click.Path(dir_okay=False),
              help="CSV file to write (a JSON sidecar with the truths goes beside it); "
                   "required unless --raw-curves is given.")
@click.option("--n-bulged", default=72, show_default=True, type=click.IntRange(min=0),
              help="Bulged cells; 0 only with --osmotic-series (intact cells alone need known "
                   "osmotic shifts to tell the wall from the turgor).")
@click.option("--n-intact", default=42, show_default=True, type=click.IntRange(min=1))
@click.option("--seed", default=0, show_default=True, type=int)
@click.option("--gamma", default=1.22, show_default=True, type=click.FloatRange(min=0),
              help="Stress-stiffening exponent.")
@click.option("--E0t", "E0t", default=0.026, show_default=True,
              type=click.FloatRange(min=0, min_open=True), help="E0 t at 5 kPa [N/m].")
@click.option("--R0-nm", "R0_nm", default=464.2, show_default=True,
              type=click.FloatRange(min=0, min_open=True), help="Radius at 5 kPa [nm].")
@click.option("--P-phys-kPa", "P_phys_kPa", default=29.0, show_default=True,
              type=click.FloatRange(min=0, min_open=True),
              help="Physiological turgor of the intact cells [kPa].")
@click.option("--noise-free", is_flag=True, help="Observables without measurement noise.")
@click.option("--Rc-err-nm", "Rc_err_nm", nargs=2, default=(15.0, 25.0), show_default=True,
              type=click.FloatRange(min=0, min_open=True), metavar="LO HI",
              help="Range of the per-cell R_c measurement sd [nm] (uniform). The default "
                   "puts the paper's whole intact-cell scatter (20 nm) into the measurement; "
                   "with --effect radius_spread use a smaller one (e.g. 8 12).")
@click.option("--P-range-kPa", "P_range_kPa", nargs=2, default=(1.0, 25.0), show_default=True,
              type=click.FloatRange(min=0, min_open=True), metavar="LO HI",
              help="Range of the bulged cells' true pressures [kPa] (log-uniform): the paper's "
                   "experiment by default; another one to plan an experiment (which design "
                   "would detect an effect, studies/criticism_power.py).")
@click.option("--P-distribution", "P_distribution", default="loguniform", show_default=True,
              type=click.Choice(["loguniform", "lognormal"]),
              help="Population of the bulged cells' pressures: log-uniform over --P-range-kPa "
                   "(hard edges, the paper's experiment) or lognormal with 95 % of the cells "
                   "inside it (a smooth population).")
@click.option("--effect", "effect_names", multiple=True, cls=EffectHelpOption,
              help="Inject a model effect (turgorbayes.effects: {effects}); repeatable, "
                   "paired in order with --effect-size.")
@click.option("--effect-size", "effect_sizes", multiple=True, type=float, cls=EffectHelpOption,
              help="Size of the matching --effect, its size parameter in SI units unless a "
                   "unit is given ({sizes}; e.g. --effect tip_radius --effect-size 20: a 20 nm "
                   "tip).")
@click.option("--n-sessions", "n_sessions", type=click.IntRange(min=1), default=None,
              help="Assign the cells to N measurement sessions (a session column); "
                   "--effect calibration needs it.")
@click.option("--raw-curves", "raw_curves", type=click.Path(file_okay=False), default=None,
              help="Also write raw AFM force curves of the simulated cells (3 per cell and "
                   "target, afmformats .tab, curves at the true stiffnesses), manifest.csv and "
                   "truth.json into this folder, for `turgorbayes curves` (docs/curves.md).")
@click.option("--conditions", "conditions", default=None, metavar="NAME:kPa,...",
              help="Simulate several conditions sharing the wall, each with its own turgor "
                   "[kPa], e.g. wt:29,treated:22 (a condition column; --n-bulged bulged cells "
                   "in the first condition only unless --n-bulged-per-condition, "
                   "--n-intact-per-condition intact in each).")
@click.option("--n-intact-per-condition", "n_intact_per_condition", default=42,
              show_default=True, type=click.IntRange(min=1),
              help="With --conditions: intact cells per condition.")
@click.option("--n-bulged-per-condition", "n_bulged_per_condition", default=None,
              metavar="N|NAME:N,...",
              help="With --conditions: bulged cells in every condition (N), or per condition "
                   "(e.g. wt:72,treated:36; a condition not named gets none); replaces "
                   "--n-bulged, which puts them in the first condition only.")
@click.option("--condition-wall", "condition_walls", multiple=True,
              metavar="NAME:Q=V[,Q=V...]",
              help="With --conditions: plant a wall of condition NAME's own, a wall the "
                   "baseline with conditions does not allow (what `criticize`'s check "
                   "conditions_R_c_k_c and `--per-condition E0t` are for): E0t=FACTOR times "
                   "--E0t, gamma=VALUE, R0=NM; e.g. treated:E0t=0.7 (30 % softer) or "
                   "treated:gamma=1.4,R0=480. Repeatable; the truths go into OUT.json "
                   "(walls, SI).")
@click.option("--osmotic-series", "osmotic_series", default=None, metavar="MOSM,...",
              help="An osmotic series: mOsm added to the growth medium at each level, 0 "
                   "included (e.g. 0,50,100,150); the intact cells (--n-intact in all) are split "
                   "evenly over the levels, each at the turgor the osmotic balance gives "
                   "(a medium_mOsm column; docs/physics.md). Bulged cells stay in the growth "
                   "medium. With --conditions: every condition a series of "
                   "--n-intact-per-condition intact cells at its own turgor and wall "
                   "(--condition-wall), e.g. --conditions wt:29,treated:29 --condition-wall "
                   "treated:E0t=0.7 --n-bulged 0.")
@click.option("--growth-medium-mOsm", "growth_mOsm", default=300.0, show_default=True,
              type=click.FloatRange(min=0), help="With --osmotic-series: the growth medium's "
                                                  "osmolarity, whose turgor is --P-phys-kPa.")
@click.option("--inactive-fraction", "inactive_fraction", default=0.3, show_default=True,
              type=click.FloatRange(min=0, max=1, max_open=True),
              help="With --osmotic-series: the osmotically inactive volume V_b as a fraction of "
                   "the volume in the growth medium (b).")
@click.option("--temperature-K", "temperature", default=298.15, show_default=True,
              type=click.FloatRange(min=0, min_open=True),
              help="With --osmotic-series: the temperature [K].")
@click.option("--length-model", "length_model", default="wall", show_default=True,
              type=click.Choice(["wall", "fixed"]),
              help="With --osmotic-series: the cell length follows the wall law (wall) or "
                   "stays fixed over a shift.")
@FE_SETTINGS
def simulate(out, n_bulged, n_intact, seed, gamma, E0t, R0_nm, P_phys_kPa, noise_free,
             Rc_err_nm, P_range_kPa, effect_names, effect_sizes, n_sessions=None,
             raw_curves=None, P_distribution="loguniform", tip_radius_nm=None,
             wall_thickness_nm=None, conditions=None, n_intact_per_condition=42,
             n_bulged_per_condition=None, condition_walls=(), osmotic_series=None,
             growth_mOsm=300.0, inactive_fraction=0.3, temperature=298.15,
             length_model="wall"):
    """Simulate bulged and intact cells from the baseline model (defaults: the paper's
    values and experiment; error assumptions in turgorbayes.simulation.cells), optionally with
    effects, and write them as a cell-data CSV labelled SIMULATED, plus OUT.json with the
    true values (and the injected effects)."""
    from turgorbayes.simulation.cells import ErrorModel, Truth, simulate_cells

    if out is None and raw_curves is None:
        raise click.UsageError("give --out DATA.csv, --raw-curves DIR or both")
    truth = Truth(gamma=gamma, E0t=E0t, R0=R0_nm * 1e-9, P_phys=P_phys_kPa * 1e3)
    injections = _injections(effect_names, effect_sizes)
    lo, hi = _ordered("--Rc-err-nm", Rc_err_nm, strict=False)
    _warn_default_radius_errors(effect_names)
    errors = ErrorModel(R_c_sd=(lo * 1e-9, hi * 1e-9))
    P_lo, P_hi = _ordered("--P-range-kPa", P_range_kPa, strict=True)
    if conditions is None and (n_bulged_per_condition is not None or condition_walls):
        from turgorbayes.errors import TurgorBayesError

        raise TurgorBayesError("--n-bulged-per-condition and --condition-wall need --conditions")
    if n_bulged == 0 and osmotic_series is None:
        from turgorbayes.errors import TurgorBayesError

        raise TurgorBayesError("--n-bulged 0 needs --osmotic-series: intact cells at one turgor "
                               "cannot tell the wall from the turgor")
    table = load_table(None, tip_radius_nm, wall_thickness_nm, click.echo)
    series = None if osmotic_series is None else dict(
        added=osmotic_series, growth=growth_mOsm, b=inactive_fraction, temperature=temperature,
        length_model=length_model)
    if series is not None and conditions is None:
        return _simulate_series(out, series, n_bulged, n_intact, truth, seed, errors, table,
                                noise_free, bool(raw_curves or n_sessions), injections)
    if conditions is not None:
        design = {"P_range": (P_lo * 1e3, P_hi * 1e3), "P_distribution": P_distribution}
        return _simulate_conditions(out, conditions, n_bulged, n_intact_per_condition, truth,
                                    seed, errors, table, noise_free, design,
                                    bool(injections or raw_curves or n_sessions),
                                    n_bulged_per_condition, condition_walls, series)
    try:
        cells, truths = simulate_cells(n_bulged, n_intact, truth, seed, errors=errors,
                                                 surrogate=table,
                                                 noise=not noise_free, effects=injections,
                                                 design_kwargs={"P_range": (P_lo * 1e3, P_hi * 1e3),
                                                                "P_distribution": P_distribution},
                                                 n_sessions=n_sessions)
    except ValueError as err:
        from turgorbayes.errors import TurgorBayesError

        raise TurgorBayesError(str(err)) from None
    if raw_curves is not None:
        from turgorbayes.simulation.raw_dataset import write_raw_dataset

        manifest = write_raw_dataset(raw_curves, cells, truths, seed=seed)
        click.echo(f"wrote the raw force curves of {n_bulged} bulged + {n_intact} intact simulated "
                   f"cells, their manifest {manifest} and truths in {Path(raw_curves) / 'truth.json'}")
    if out is None:
        return
    out = write_simulated(cells, truths, out)
    click.echo(f"wrote {n_bulged} bulged + {n_intact} intact simulated cells to {out} "
               f"(truths in {sidecar_path(out)})")


def _simulate_conditions(out, conditions, n_bulged, n_intact, truth, seed, errors, table,
                         noise_free, design, unsupported, bulged_per_condition=None,
                         wall_specs=(), series=None):
    """``simulate --conditions``: write the experiment (CSV + JSON truths) to ``out``; bulged
    cells by ``--n-bulged-per-condition`` (else ``n_bulged`` in the first condition), walls of
    a condition's own by ``--condition-wall``; with ``series`` (``--osmotic-series`` and its
    options) each condition's intact cells an osmotic series at its own wall and turgor."""
    from turgorbayes.errors import TurgorBayesError
    from turgorbayes.simulation import conditions as synthetic_conditions
    from turgorbayes.simulation.osmotic import parse_series

    if out is None or unsupported:
        raise TurgorBayesError("--conditions needs --out and does not combine with --effect, "
                               "--n-sessions or --raw-curves")
    try:
        turgors = synthetic_conditions.parse_conditions(conditions)
        names = list(turgors)
        bulged = ({names[0]: n_bulged} if bulged_per_condition is None else
                  synthetic_conditions.parse_bulged_counts(bulged_per_condition, names))
        walls = synthetic_conditions.parse_walls(wall_specs, names, truth)
        if series is not None:
            series = dict(series, added=parse_series(series["added"]))
        cells, truths = synthetic_conditions.simulate_conditions(
            turgors, n_intact=n_intact, n_bulged=bulged, truth=truth, seed=seed,
            surrogate=table, errors=errors, noise=not noise_free, design_kwargs=design,
            walls=walls, series=series)
    except ValueError as err:
        raise TurgorBayesError(str(err)) from None
    out = write_simulated(cells, truths, out)
    where = ", ".join(f"{b} in {n}" for n, b in bulged.items() if b)
    own = "".join(f"; the wall of {n} its own: " + ", ".join(
        f"{q} = {x / truth.E0t:g} x --E0t" if q == "E0t" else
        f"{q} = {x * (1e9 if q == 'R0' else 1):g}{' nm' if q == 'R0' else ''}"
        for q, x in w.items()) for n, w in walls.items())
    levels = "" if series is None else (", each an osmotic series at " + ", ".join(
        f"{x:g}" for x in series["added"]) + " mOsm added")
    click.echo(f"wrote {len(turgors)} conditions ({', '.join(turgors)}; bulged cells: "
               f"{where or 'none'}; {n_intact} intact in each{levels}{own}) to {out} (truths in "
               f"{sidecar_path(out)})")


def _simulate_series(out, series, n_bulged, n_intact, truth, seed, errors, table, noise_free,
                     unsupported, injections=()):
    """``simulate --osmotic-series``: write the series (CSV + JSON truths, with ``osmotic``:
    each level's true turgor and radius, b, the cytoplasm's osmolarity) to ``out``, with the
    ``--effect`` injections planted after the levels' turgors are set (e.g. osmoadaptation
    moves them back toward P_phys)."""
    from turgorbayes.errors import TurgorBayesError
    from turgorbayes.simulation.osmotic import parse_series, simulate_osmotic_series

    if out is None or unsupported:
        raise TurgorBayesError("--osmotic-series needs --out and does not combine with "
                               "--n-sessions or --raw-curves")
    try:
        added = parse_series(series.pop("added"))
        cells, truths = simulate_osmotic_series(added, n_intact=n_intact, n_bulged=n_bulged,
                                                truth=truth, seed=seed, errors=errors,
                                                surrogate=table, noise=not noise_free,
                                                effects=tuple(injections), **series)
    except ValueError as err:
        raise TurgorBayesError(str(err)) from None
    out = write_simulated(cells, truths, out)
    levels = ", ".join(f"{lv['medium_mOsm']:g} mOsm {lv['P_kPa']:.3g} kPa ({lv['n_intact']})"
                       for lv in truths["osmotic"]["levels"])
    click.echo(f"wrote an osmotic series of {n_intact} intact (+ {n_bulged} bulged) simulated "
               f"cells to {out}: turgor per level {levels} (truths in {sidecar_path(out)})")


def _warn_default_radius_errors(effect_names):
    """Say so when an effect is simulated with the default R_c errors and declares that they
    would mislead (:attr:`turgorbayes.effects.Effect.default_radius_errors_warning`)."""
    from turgorbayes.effects import get_effect

    source = click.get_current_context().get_parameter_source("Rc_err_nm")
    if source != click.core.ParameterSource.DEFAULT:
        return
    for name in effect_names:
        why = get_effect(name).default_radius_errors_warning
        if why:
            click.echo(f"warning: --effect {name} with the default --Rc-err-nm 15 25: {why}",
                       err=True)


def _ordered(option, pair, strict):
    """``LO HI`` of a range option, checked: LO < HI (``strict``) or LO <= HI."""
    lo, hi = pair
    if lo > hi or (strict and lo == hi):
        from turgorbayes.errors import TurgorBayesError

        raise TurgorBayesError(f"{option} LO HI needs LO {'<' if strict else '<='} HI, "
                               f"got {lo:g} {hi:g}")
    return lo, hi


def _injections(names, sizes):
    """``--effect``/``--effect-size`` pairs -> injections for :func:`simulate_cells`."""
    from turgorbayes.errors import TurgorBayesError

    if len(names) != len(sizes):
        raise TurgorBayesError(f"--effect and --effect-size must come in pairs, got {len(names)} "
                               f"--effect and {len(sizes)} --effect-size")
    if not names:
        return []
    from turgorbayes import effects

    out = []
    for name, size in zip(names, sizes, strict=True):
        if name not in effects.EFFECTS:
            raise TurgorBayesError(f"unknown effect {name!r}; known: {', '.join(effects.EFFECTS)}")
        effect = effects.get_effect(name)
        out.append(effect.injection(size * effect.size_unit[1]))
    return out
