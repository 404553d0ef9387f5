"""Power and false-selection rates of the criticism workflow (``docs/validation.md``).

For each effect of :mod:`turgorbayes.effects` at its realistic size, and for null data (the
baseline model), simulate ``--n`` data sets of 72 bulged + 42 intact cells (the paper's values,
seeds 1000, 1001, ...), run :func:`turgorbayes.workflows.criticize.criticize` blind and count

* **power**: the effect (alone or paired with another) is selected;
* **wrong**: another effect is selected instead; **false selection** on null data: anything;
* **size coverage**: the selected model's 90 % interval of the effect size covers the truth;
* **P_phys coverage**: the adopted model's (the baseline's if nothing is selected) 90 %
  interval for P_phys covers 29 kPa; **avg P cov**: the same for the model average
  (stacking of all fitted models, :mod:`turgorbayes.criticism.stacking`);
* the median gain (delta elpd of the true effect over the baseline) and wall time;
* **converged**: the share of all fitted models (baseline, every candidate, a pair) whose
  posterior converged after the re-runs (``docs/statistics.md``, "Posterior engines of the
  criticism"); an unconverged candidate is never selected, so it lowers the power.

Targets: power >= 0.9 at the realistic size, false selection <= 0.1.

Usage (``--size``: a power curve of one effect at several sizes; ``--P-range-kPa``,
``--n-bulged``, ``--n-intact``: another experimental design than the paper's 72 bulged cells at
1-25 kPa and 42 intact cells)::

    python studies/criticism_power.py --n 20 [--effects radius_spread,null] \
        [--surrogate TABLE.nc] [--draws 1000] [--json results.json] [--size X1 X2 ...] \
        [--candidates tip_radius,wall_thickness] \
        [--P-range-kPa 0.5 25] [--n-bulged 72] [--n-intact 42] [--n-sessions 6] \
        [--R-c-err-nm 8 12]
    python studies/criticism_power.py --summarize ROWS.jsonl [MORE.jsonl ...]

Heavy: about 10-30 s per data set on 2 cores (an emcee fallback adds minutes); run it alone.
"""

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from turgorbayes import __version__, effects, provenance, surrogate
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

TRUE_P_PHYS_KPA = 29.0


#: The paper's design: 72 bulged cells at 1-25 kPa (log-uniform) and 42 intact cells.
PAPER_DESIGN = {"n_bulged": 72, "n_intact": 42, "P_range_kPa": [1.0, 25.0]}


def _simulate(name, seed, table, size, design):
    inj = [] if name == "null" else [effects.get_effect(name).injection(size)]
    cells, _ = synthetic.simulate_cells(
        n_bulged=design["n_bulged"], n_intact=design["n_intact"], seed=seed, surrogate=table,
        effects=inj, design_kwargs={"P_range": tuple(1e3 * p for p in design["P_range_kPa"])},
        n_sessions=design.get("n_sessions"),
        errors=synthetic.ErrorModel(R_c_sd=tuple(1e-9 * e for e in design["R_c_err_nm"]))
        if "R_c_err_nm" in design else synthetic.ErrorModel())
    return cells


def one(name, seed, table, settings, size=None, design=PAPER_DESIGN):
    """Criticize one simulated data set (effect ``name`` at ``size``, default its realistic
    size; cells drawn with ``design``); returns a dict of outcomes."""
    if name != "null" and size is None:
        size = effects.get_effect(name).realistic_size
    cells = _simulate(name, seed, table, size, design)
    t0 = time.perf_counter()
    res = criticize(cells, table, seed=seed, settings=settings)
    d = criticism_dict(res)
    sel = d["selected_effect"]
    out = {"effect": name, "size": size, "design": design, "seed": seed, "version": __version__,
           "candidates": list(settings.effects) if settings.effects else "all",
           "selected": sel,
           "time_s": time.perf_counter() - t0,
           "converged": all(p.converged for p in res.posteriors.values()),
           "n_fits": len(res.posteriors),
           "n_converged": sum(bool(p.converged) for p in res.posteriors.values()),
           "n_rerun": sum(bool(p.attempts) for p in res.posteriors.values()),
           "engines": sorted({p.engine for p in res.posteriors.values()})}
    params = d["parameters"]["extended"] or d["parameters"]["baseline"]
    # what the baseline makes of the data (its posterior medians and 90 % intervals)
    out["baseline"] = {k: [v["q05"], v["q50"], v["q95"]]
                       for k, v in d["parameters"]["baseline"].items()}
    P = params["P_phys_kPa"]
    out["P_covered"] = bool(P["q05"] <= TRUE_P_PHYS_KPA <= P["q95"])
    A = res.stacking["parameters"]["P_phys_kPa"]
    out["P_covered_avg"] = bool(A["q05"] <= TRUE_P_PHYS_KPA <= A["q95"])
    out["stacking_weights"] = res.stacking["weights"]
    if name != "null":
        e = effects.get_effect(name)
        key = next(p.key for p in e.parameters if p.name == e.size_parameter)
        cand = next(c for c in res.candidates if c["effect"] == name)
        out["delta_elpd"] = cand["delta_elpd"]
        out["p_gain"] = cand["p_gain"]
        out["found"] = bool(sel is not None and name in effects.parse_model_name(sel))
        if out["found"]:
            est = d["parameters"]["extended"][key]
            factor = next(p.factor for p in e.parameters if p.name == e.size_parameter)
            out["size_estimate"] = [est["q05"], est["q50"], est["q95"]]  # display unit
            out["size_covered"] = bool(est["q05"] <= size / factor <= est["q95"])
    return out


def _size(row):
    """The simulated effect size of a row (rows written before sizes were recorded: realistic)."""
    if row["effect"] == "null":
        return None
    return row.get("size", effects.get_effect(row["effect"]).realistic_size)


def _design(row):
    """The design of a row as a label (rows written before designs were recorded: the paper's)."""
    d = dict(row.get("design", PAPER_DESIGN))
    sessions = d.pop("n_sessions", None)
    label = f"  [{sessions} sessions]" if sessions else ""
    if row.get("candidates", "all") != "all":
        label += f"  [candidates: {', '.join(row['candidates'])}]"
    if d == PAPER_DESIGN:
        return label
    lo, hi = d["P_range_kPa"]
    return f"  [{d['n_bulged']}+{d['n_intact']} cells, bulges {lo:g}-{hi:g} kPa]" + label


def summarize(rows):
    """Rates per effect (and size and design) as printable lines."""
    lines = [f"{'effect':<16}{'size':>8}{'n':>4}{'power':>7}{'wrong':>7}{'size cov':>9}"
             f"{'P cov':>7}{'avg P cov':>10}{'median dELPD':>13}{'median s':>9}{'fallback':>9}"
             f"{'converged':>10}"]
    for key in dict.fromkeys((r["effect"], _size(r), _design(r)) for r in rows):
        name, size, label = key
        rs = [r for r in rows if (r["effect"], _size(r), _design(r)) == key]
        n = len(rs)
        sel = [r["selected"] for r in rs]
        fallback = np.mean(["emcee" in r["engines"] for r in rs])
        med_t = np.median([r["time_s"] for r in rs])
        pcov = np.mean([r["P_covered"] for r in rs])
        # rows written before the model average existed have no avg P cov
        avg = [r["P_covered_avg"] for r in rs if "P_covered_avg" in r]
        acov = f"{np.mean(avg):>10.2f}" if avg else f"{'-':>10}"
        conv = _converged(rs)
        if name == "null":
            false = np.mean([s is not None for s in sel])
            lines.append(f"{'null':<16}{'-':>8}{n:>4}{'-':>7}{false:>7.2f}{'-':>9}{pcov:>7.2f}"
                         f"{acov}{'-':>13}{med_t:>9.0f}{fallback:>9.2f}{conv}{label}")
            continue
        found = [r["found"] for r in rs]
        wrong = np.mean([s is not None and not f for s, f in zip(sel, found, strict=True)])
        cov = [r["size_covered"] for r in rs if r["found"]]
        lines.append(f"{name:<16}{size:>8.3g}{n:>4}{np.mean(found):>7.2f}{wrong:>7.2f}"
                     f"{(np.mean(cov) if cov else np.nan):>9.2f}{pcov:>7.2f}{acov}"
                     f"{np.median([r['delta_elpd'] for r in rs]):>13.1f}{med_t:>9.0f}"
                     f"{fallback:>9.2f}{conv}{label}")
    return lines


def _converged(rows):
    """Converged fits over all fits of the rows, e.g. ``139/140`` (``-`` for rows written
    before fits were counted)."""
    counted = [r for r in rows if "n_fits" in r]
    if not counted:
        return f"{'-':>10}"
    return f"{sum(r['n_converged'] for r in counted):>6}/{sum(r['n_fits'] for r in counted):<3}"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20, help="data sets per effect (>= 20)")
    parser.add_argument("--effects", default=None,
                        help="comma-separated subset of the effects and 'null' (default: all)")
    parser.add_argument("--surrogate", default=None, help="k/(PR) table (default: shipped)")
    parser.add_argument("--candidates", default=None,
                        help="comma-separated effects criticize fits (default: every effect); "
                             "a subset makes a design search on large data sets affordable, and "
                             "is recorded in each row")
    parser.add_argument("--draws", type=int, default=1000, help="importance draws per round")
    parser.add_argument("--first-seed", type=int, default=1000)
    parser.add_argument("--size", type=float, nargs="+", default=None,
                        help="effect sizes to simulate instead of the realistic one (a power "
                             "curve); with a single effect in --effects")
    parser.add_argument("--P-range-kPa", type=float, nargs=2, default=PAPER_DESIGN["P_range_kPa"],
                        metavar=("LO", "HI"), help="bulged-cell pressures, log-uniform (default 1 25)")
    parser.add_argument("--n-bulged", type=int, default=PAPER_DESIGN["n_bulged"])
    parser.add_argument("--n-intact", type=int, default=PAPER_DESIGN["n_intact"])
    parser.add_argument("--n-sessions", type=int, default=None,
                        help="assign the cells to N measurement sessions (the calibration "
                             "effect needs them; a null run with sessions checks that it is "
                             "not invented)")
    parser.add_argument("--R-c-err-nm", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                        help="range of the simulated R_c errors [nm] (default: the simulator's "
                             "15-25 nm; the bundled example has 8-12)")
    parser.add_argument("--skip-unsimulable", action="store_true",
                        help="leave out (and name) data sets the simulator cannot draw, e.g. a "
                             "heavy-tailed stiffness below zero, instead of refusing the run")
    parser.add_argument("--json", default=None, help="write every outcome to this file")
    parser.add_argument("--summarize", nargs="+", default=None, metavar="ROWS.jsonl",
                        help="print the rates of outcomes saved earlier (one JSON row per line, "
                             "as printed by a run) and run nothing")
    provenance.add_output_options(parser)
    args = parser.parse_args(argv)
    if args.smoke:  # one data set each of radius_spread and null, 12 + 8 cells, one candidate
        args.n, args.draws, args.n_bulged, args.n_intact = 1, 200, 12, 8
        args.effects = args.effects or "radius_spread,null"
        args.candidates = args.candidates or "radius_spread"
    provenance.tee_stdout(args, "criticism_power.txt")
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    if args.summarize:
        rows = [json.loads(line) for path in args.summarize
                for line in Path(path).read_text().splitlines() if line.startswith("{")]
        print("\n".join(summarize(rows)))
        return
    design = {"n_bulged": args.n_bulged, "n_intact": args.n_intact,
              "P_range_kPa": list(args.P_range_kPa)}
    if args.n_sessions:
        design["n_sessions"] = args.n_sessions
    if args.R_c_err_nm:
        design["R_c_err_nm"] = list(args.R_c_err_nm)
    table = surrogate.load(args.surrogate)
    names = (args.effects.split(",") if args.effects else effects.effect_names() + ["null"])
    settings = CriticismSettings(
        n_draws=args.draws, n_rep=700, max_refits=3,
        effects=tuple(args.candidates.split(",")) if args.candidates else None,
        n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                                 max_steps=4000, progress=False)
    if args.smoke:  # few replicates, short chains
        settings = dataclasses.replace(settings, n_rep=50, ess_min=20, max_refits=0, n_ensembles=2,
                                       tol=5, check_every=20, max_steps=200, flag_draws=20)
    print(f"surrogate: {getattr(table, 'path', None)}")
    if args.size is not None and (len(names) != 1 or names[0] == "null"):
        parser.error("--size needs exactly one effect in --effects (not null)")
    # fail now, not after hours, on a size or design the model cannot simulate
    skipped = set()
    for name in names:
        for size in args.size or [None]:
            drawn = size if size is not None or name == "null" else effects.get_effect(name).realistic_size
            for seed in range(args.first_seed, args.first_seed + args.n):
                try:
                    _simulate(name, seed, table, drawn, design)
                except ValueError as err:
                    if not args.skip_unsimulable:
                        parser.error(f"{name} (size {drawn}): data set {seed} cannot be "
                                     f"simulated with the design {design}: {err}")
                    print(f"# skipped: {name} (size {drawn}), data set {seed}: {err}", flush=True)
                    skipped.add((name, size, seed))
    rows = []
    for name in names:
        for size in args.size or [None]:
            for i in range(args.n):
                if (name, size, args.first_seed + i) in skipped:
                    continue
                r = one(name, args.first_seed + i, table, settings, size, design)
                r["provenance"] = record
                rows.append(r)
                print(json.dumps(r), flush=True)
            print("\n".join(summarize(rows)), flush=True)
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    print("\n".join(summarize(rows)))


if __name__ == "__main__":
    main()
