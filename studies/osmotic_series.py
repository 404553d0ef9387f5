"""Turgor without bulged cells: osmotic series of intact cells, calibration and design.

Each data set: :func:`turgorbayes.simulation.osmotic.simulate_osmotic_series` (the paper's wall,
P_phys 29 kPa in a 300 mOsm growth medium, the default errors), fitted with the osmotic model
(:class:`turgorbayes.inference.osmotic.OsmoticModel`) by the posterior engine with importance
sampling (emcee where it is unreliable: the engine's ladder). Modes:

* ``calibration``: 90 % interval coverage of P_phys, gamma, E0t, R0 and b, the truth of b drawn
  from its prior (Beta(6, 14)) for each data set; ``--levels`` and ``--per-level`` set the
  design (default 0,50,100,150 mOsm added x 30 intact cells);
* ``bulges``: the same simulated cells, 72 bulged + the series: P_phys's 90 % width from the
  series alone (no bulged cell), the bulge design (the bulged cells and the growth medium's
  intact cells, the baseline) and both together;
* ``designs``: the median 90 % width and sd of P_phys for series designs (levels x cells),
  against the paper's +- 3 kPa;
* ``wrong_b``: the truth of b at ``--b-true`` while the prior stays Beta(6, 14): P_phys's bias
  in posterior sds and coverage (the cost of a wrong prior);
* ``buffering``: the buffering factor dP/d(RT c_out) at the paper's values (no fit);
* ``pool``: the RATE line over result files of one mode run in parts (``--files A B ...``,
  e.g. two blocks of seeds run side by side), written to ``osmotic_series_<mode>_pooled.txt``.

One JSON line per data set, then a ``RATE`` line. docs/validation.md, "Turgor without bulged
cells".

Run: nice .venv/bin/python studies/osmotic_series.py calibration --first-seed 1 --n 200 [--update]
"""

import argparse
import json
import time

import numpy as np

from turgorbayes import surrogate as sm
from turgorbayes.inference import models
from turgorbayes.inference.engine import Settings, fit_posterior
from turgorbayes.inference.osmotic import B_PRIOR, OsmoticModel, osmotic_design
from turgorbayes.inference.posterior import weighted_stats
from turgorbayes.physics import osmotic
from turgorbayes.provenance import add_output_options, header_line, run_record, study_path
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation.osmotic import DEFAULT_GROWTH_MEDIUM, simulate_osmotic_series

SETTINGS = Settings(engine="importance", n_draws=2000, progress=False, retry_factor=3,
                    n_walkers=16, n_ensembles=4, tol=30, max_steps=8000)
#: A smoke run: one calibration series of 2 levels x 8 cells, few draws, chains of 40 steps.
SMOKE_SETTINGS = Settings(engine="importance", n_draws=200, progress=False, retry_factor=1,
                          n_walkers=16, n_ensembles=2, tol=5, check_every=20, max_steps=40,
                          ess_min=20)
TRUTH = synthetic.PAPER_TRUTH
NAMES = {"P_phys": 1e3, "gamma": 1.0, "E0t": 1.0, "R0": 1e-9, "b": 1.0}


def _posterior(model, seed, settings=SETTINGS):
    """The posterior of ``model`` from its least-squares start and its summaries (SI / unit)."""
    guess = model.start_values(model.least_squares().fit().estimate)
    post = fit_posterior(model, guess, seed, settings, pointwise=False)
    values = post.physical(np.random.default_rng(seed))
    out = {n: weighted_stats(values[n], post.weights) for n in model.names}
    return post, {n: {k: v / NAMES.get(n, 1.0) for k, v in s.items()} for n, s in out.items()}


def _q(s):
    return [round(s[k], 5) for k in ("q05", "q50", "q95")]


def one_series(seed, table, added, per_level, b_true, settings=SETTINGS):
    """Fit one simulated series; the truths, the 90 % intervals and the engine."""
    cells, truths = simulate_osmotic_series(added, n_intact=per_level * len(added), truth=TRUTH,
                                            seed=seed, b=b_true, surrogate=table)
    model = OsmoticModel(cells, table, osmotic_design(cells))
    t = time.time()
    post, s = _posterior(model, seed, settings)
    truth = {"P_phys": TRUTH.P_phys / 1e3, "gamma": TRUTH.gamma, "E0t": TRUTH.E0t,
             "R0": TRUTH.R0 * 1e9, "b": b_true}
    return {"seed": seed, "levels_added": list(added), "per_level": per_level,
            "truth": truth, **{n: _q(s[n]) for n in model.names},
            "P_phys_sd": round(s["P_phys"]["sd"], 4),
            "covered": {n: bool(s[n]["q05"] <= truth[n] <= s[n]["q95"]) for n in model.names},
            "z": {n: round((s[n]["mean"] - truth[n]) / s[n]["sd"], 3) for n in model.names},
            "engine": post.engine, "converged": bool(post.converged),
            "seconds": round(time.time() - t, 1)}


def one_bulges(seed, table, added, per_level, b_true, settings=SETTINGS):
    """P_phys from the series alone, the bulge design, and both, on the same simulated cells."""
    cells, _ = simulate_osmotic_series(added, n_intact=per_level * len(added), n_bulged=72,
                                       truth=TRUTH, seed=seed, b=b_true, surrogate=table)
    growth = np.asarray([c == f"{DEFAULT_GROWTH_MEDIUM:g}" for c in cells.extra["medium_mOsm"]])
    fits = {"series": cells.take(~np.asarray(cells.is_bulged)),
            "bulges": cells.take(growth), "both": cells}
    out = {"seed": seed, "levels_added": list(added), "per_level": per_level, "b": b_true}
    t = time.time()
    for label, data in fits.items():
        design = osmotic_design(data)
        model = (OsmoticModel(data, table, design) if design.n_levels > 1 else
                 models.BaselineModel(data.take(np.arange(len(data))), table))
        post, s = _posterior(model, seed, settings)
        out[label] = {"P_phys": _q(s["P_phys"]), "sd": round(s["P_phys"]["sd"], 4),
                      "n_bulged": data.n_bulged, "n_intact": data.n_intact,
                      "engine": post.engine, "converged": bool(post.converged)}
    out["seconds"] = round(time.time() - t, 1)
    return out


def _rate_calibration(rows, names):
    n = len(rows)
    cov = ", ".join(f"{k} {sum(r['covered'][k] for r in rows)}/{n}"
                    f" ({100 * np.mean([r['covered'][k] for r in rows]):.1f} %)" for k in names)
    width = np.median([r["P_phys"][2] - r["P_phys"][0] for r in rows])
    sec = np.median([r["seconds"] for r in rows])
    z = np.mean([r["z"]["P_phys"] for r in rows])
    return (f"RATE {n} series: 90 % intervals cover the truth: {cov}; P_phys median 90 % width "
            f"{width:.2f} kPa, mean z of P_phys {z:+.2f}; converged {sum(r['converged'] for r in rows)}"
            f"/{n} (engines: {', '.join(sorted({r['engine'] for r in rows}))}); median "
            f"{sec:.1f} s per fit")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("mode", choices=("calibration", "bulges", "designs", "wrong_b",
                                         "buffering", "pool"), nargs="?")
    parser.add_argument("--files", nargs="*", default=(),
                        help="pool: the result files (.jsonl) of one mode to pool")
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--n", type=int, default=20, help="data sets (per design)")
    parser.add_argument("--levels", default="0,50,100,150", help="mOsm added, comma-separated")
    parser.add_argument("--per-level", type=int, default=30)
    parser.add_argument("--b-true", type=float, default=None,
                        help="the true b (default: drawn from the prior per data set)")
    parser.add_argument("--designs", default="0,100:10;0,100:30;0,50,100:10;0,50,100,150:10;"
                                              "0,50,100,150:30",
                        help="designs: LEVELS:PER_LEVEL separated by ';'")
    parser.add_argument("--tag", default="")
    add_output_options(parser)
    args = parser.parse_args()
    settings = SETTINGS
    if args.smoke:  # see SMOKE_SETTINGS
        args.mode = args.mode or "calibration"
        args.n, args.levels, args.per_level, settings = 1, "0,150", 8, SMOKE_SETTINGS
        args.designs = "0,150:8"
    if args.mode is None:
        parser.error("the mode is required (but with --smoke)")
    if args.mode == "pool":
        return _pool(args)
    table = sm.load()
    if args.mode == "buffering":
        return _buffering(args)
    added = tuple(float(x) for x in args.levels.split(","))
    tag = f"_{args.tag}" if args.tag else ""
    path = study_path(args, f"osmotic_series_{args.mode}{tag}.jsonl")
    rows = []
    with open(path, "w") as f:
        print(header_line(), file=f, flush=True)
        designs = ([(tuple(float(x) for x in d.split(":")[0].split(",")), int(d.split(":")[1]))
                    for d in args.designs.split(";")] if args.mode == "designs"
                   else [(added, args.per_level)])
        for lev, per in designs:
            for seed in range(args.first_seed, args.first_seed + args.n):
                b_true = (args.b_true if args.b_true is not None else
                          float(B_PRIOR.sample(np.random.default_rng([seed, 52]))))
                fn = one_bulges if args.mode == "bulges" else one_series
                rows.append(fn(seed, table, lev, per, b_true, settings))
                print(json.dumps(rows[-1]), file=f, flush=True)
                print(json.dumps(rows[-1]), flush=True)
        for line in _rates(args.mode, rows, designs):
            print(line, file=f)
            print(line)
    print(f"wrote {path}")


def _rates(mode, rows, designs):
    if mode in ("calibration", "wrong_b"):
        return [_rate_calibration(rows, ("P_phys", "gamma", "E0t", "R0", "b"))]
    if mode == "bulges":
        n = len(rows)
        parts = []
        for k in ("series", "bulges", "both"):
            w = np.median([r[k]["P_phys"][2] - r[k]["P_phys"][0] for r in rows])
            c = sum(r[k]["P_phys"][0] <= TRUTH.P_phys / 1e3 <= r[k]["P_phys"][2] for r in rows)
            parts.append(f"{k} median 90 % width {w:.2f} kPa, covers {c}/{n}")
        return [f"RATE {n} data sets, P_phys: " + "; ".join(parts)]
    lines = []
    for lev, per in designs:
        sub = [r for r in rows if tuple(r["levels_added"]) == lev and r["per_level"] == per]
        w = np.median([r["P_phys"][2] - r["P_phys"][0] for r in sub])
        sd = np.median([r["P_phys_sd"] for r in sub])
        c = sum(r["covered"]["P_phys"] for r in sub)
        lines.append(f"RATE design {','.join(f'{x:g}' for x in lev)} mOsm added x {per} intact "
                     f"cells: P_phys median sd {sd:.2f} kPa (paper +- 3), median 90 % width "
                     f"{w:.2f} kPa, covers {c}/{len(sub)}")
    return lines


def _pool(args):
    """One RATE line over the rows of several result files of one mode (distinct seeds)."""
    rows, modes, sources = [], set(), []
    for name in args.files:
        part = [json.loads(line) for line in open(name) if line.startswith("{")]
        modes.add(next(m for m in ("calibration", "wrong_b", "bulges", "designs") if m in name))
        rows += part
        sources.append(f"{name.rsplit('/', 1)[-1]} ({len(part)} rows)")
    if len(modes) != 1:
        raise SystemExit(f"pool: give result files of one mode, got {sorted(modes)}")
    mode = modes.pop()
    seeds = [(r["seed"], tuple(r["levels_added"]), r["per_level"]) for r in rows]
    if len(set(seeds)) != len(seeds):
        raise SystemExit("pool: the files share seeds; pool disjoint blocks only")
    designs = sorted({(tuple(r["levels_added"]), r["per_level"]) for r in rows})
    path = study_path(args, f"osmotic_series_{mode}_pooled.txt")
    with open(path, "w") as f:
        print(header_line(), file=f)
        print("pooled: " + ", ".join(sources), file=f)
        for line in _rates(mode, rows, designs):
            print(line, file=f)
            print(line)
    print(f"wrote {path}")


def _buffering(args):
    """The buffering factor at the paper's values, for both length models and a few b."""
    path = study_path(args, "osmotic_series_buffering.json")
    rows = []
    for length_model in osmotic.LENGTH_MODELS:
        for b in (0.2, 0.3, 0.4):
            beta = float(osmotic.buffering_factor(
                TRUTH.P_phys, TRUTH.gamma, TRUTH.E0t, TRUTH.R0, c_out=DEFAULT_GROWTH_MEDIUM, b=b,
                length_model=length_model))
            rows.append({"length_model": length_model, "b": b, "buffering": round(beta, 4),
                         "kPa_per_mOsm_step": round(beta * osmotic.osmotic_pressure(1.0) / 1e3,
                                                    4)})
    added = np.array([0.0, 50.0, 100.0, 150.0])
    st = osmotic.turgor_after_shift(TRUTH.P_phys, TRUTH.gamma, TRUTH.E0t, TRUTH.R0,
                                    c_ref=DEFAULT_GROWTH_MEDIUM,
                                    c_out=DEFAULT_GROWTH_MEDIUM + added, b=0.3)
    record = {"provenance": run_record(), "parameters": {
        "gamma": TRUTH.gamma, "E0t_N_per_m": TRUTH.E0t, "R0_nm": TRUTH.R0 * 1e9,
        "P_phys_kPa": TRUTH.P_phys / 1e3, "growth_medium_mOsm": DEFAULT_GROWTH_MEDIUM,
        "temperature_K": osmotic.T_DEFAULT},
        "turgor_per_mOsm_kPa": round(float(osmotic.osmotic_pressure(1.0)) / 1e3, 5),
        "buffering": rows,
        "series_b0.3_wall": {"added_mOsm": added.tolist(),
                             "P_kPa": np.round(st["P"] / 1e3, 3).tolist(),
                             "R_c_nm": np.round(st["R_c"] * 1e9, 2).tolist()}}
    path.write_text(json.dumps(record, indent=1) + "\n")
    for r in rows:
        print(json.dumps(r))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
