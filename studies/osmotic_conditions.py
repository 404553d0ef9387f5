"""Two conditions, each measured as an osmotic series: the turgor contrast and the E0t ratio.

Each data set: two conditions simulated with :func:`turgorbayes.simulation.conditions.simulate_conditions`
and an osmotic series per condition (``--levels`` mOsm added to a 300 mOsm growth medium x
``--per-level`` intact cells, no bulged cells, the default errors): the reference ``wt`` with
the paper's wall and ``treated`` with its E0t times ``--E0t-factor`` (default 0.7), the same
turgor (29 kPa) and the same true ``b`` (drawn from its prior Beta(6, 14) per data set). Fitted
with :class:`turgorbayes.inference.osmotic_conditions.OsmoticConditionsModel` by the posterior
engine with importance sampling (emcee where it is unreliable: the engine's ladder).

Measured: how often the 90 % interval of the turgor contrast ``P_phys[treated] - P_phys[wt]``
covers 0 (the truth) and that of the ratio ``E0t[treated] / E0t[wt]`` covers the factor,
and their median widths. One JSON line per data set, then a ``RATE`` line; split a run with
``--first-seed``/``--n`` and join the files with ``--join``. docs/statistics.md, "Osmotic
series", "Conditions".

Run: nice .venv/bin/python studies/osmotic_conditions.py --first-seed 1 --n 100 [--update]
"""

import argparse
import json
import time

import numpy as np

from turgorbayes import surrogate as sm
from turgorbayes.inference.engine import Settings, fit_posterior
from turgorbayes.inference.osmotic import B_PRIOR
from turgorbayes.inference.osmotic_conditions import (
    OsmoticConditionsModel,
    series_condition_set,
    series_designs,
)
from turgorbayes.inference.posterior import weighted_stats
from turgorbayes.provenance import add_output_options, header_line, study_path
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation.conditions import simulate_conditions

#: As studies/osmotic_series.py but emcee capped at 4000 steps and no longer re-run (the
#: rest-radius ridge of a series makes some posteriors slow to mix: such a fit is recorded
#: as not converged and the RATE line counts both ways).
SETTINGS = Settings(engine="importance", n_draws=2000, progress=False, retry_factor=1,
                    n_walkers=16, n_ensembles=4, tol=30, max_steps=4000)
TRUTH = synthetic.PAPER_TRUTH
#: A smoke run: one experiment of 2 levels x 8 cells per condition, few draws, chains of 40 steps.
SMOKE_SETTINGS = Settings(engine="importance", n_draws=200, progress=False, retry_factor=1,
                          n_walkers=16, n_ensembles=2, tol=5, check_every=20, max_steps=40,
                          ess_min=20)


def simulate(seed, table, added, per_level, factor, b_true):
    """One experiment: ``wt`` (the paper's wall) and ``treated`` (E0t x ``factor``), both at
    29 kPa, each an osmotic series of intact cells."""
    series = {"added": added, "b": b_true}
    return simulate_conditions({"wt": TRUTH.P_phys, "treated": TRUTH.P_phys},
                               n_intact=per_level * len(added), n_bulged={}, truth=TRUTH,
                               seed=seed, surrogate=table,
                               walls={"treated": {"E0t": factor * TRUTH.E0t}}, series=series)


def contrasts(model, post, seed):
    """The turgor contrast [kPa] and the E0t ratio: weighted 5/50/95 % quantiles."""
    v = post.physical(np.random.default_rng(seed))
    cs = model.conditions
    ref, other = cs.ref, 1 - cs.ref
    dP = (v[cs.variable("P_phys", other)] - v[cs.variable("P_phys", ref)]) / 1e3
    ratio = v[cs.variable("E0t", other)] / v[cs.variable("E0t", ref)]
    return {name: weighted_stats(x, post.weights) for name, x in
            (("dP_kPa", dP), ("E0t_ratio", ratio), ("gamma", v["gamma"]), ("b", v["b"]))}


def one(seed, table, added, per_level, factor, settings=SETTINGS):
    """Fit one simulated experiment; the 90 % intervals and whether they cover the truth."""
    b_true = float(B_PRIOR.sample(np.random.default_rng([seed, 52])))
    cells, _ = simulate(seed, table, added, per_level, factor, b_true)
    cs = series_condition_set(cells)
    model = OsmoticConditionsModel(cells, table, cs, series_designs(cells, cs))
    t = time.time()
    guess = model.start_values(model.least_squares().fit().estimate)
    post = fit_posterior(model, guess, seed, settings, pointwise=False)
    s = contrasts(model, post, seed)
    truth = {"dP_kPa": 0.0, "E0t_ratio": factor, "gamma": TRUTH.gamma, "b": b_true}
    q = {n: [round(s[n][k], 5) for k in ("q05", "q50", "q95")] for n in s}
    return {"seed": seed, "levels_added": list(added), "per_level": per_level,
            "truth": truth, **q,
            "covered": {n: bool(s[n]["q05"] <= truth[n] <= s[n]["q95"]) for n in s},
            "engine": post.engine, "converged": bool(post.converged),
            "seconds": round(time.time() - t, 1)}


def rate(rows):
    """The ``RATE`` line: coverage of both contrasts and their median 90 % widths."""
    n = len(rows)

    def cov(k):
        c = sum(r["covered"][k] for r in rows)
        return f"{c}/{n} ({100 * c / n:.1f} %)"

    def conv(k):
        ok = [r for r in rows if r["converged"]]
        return f"{sum(r['covered'][k] for r in ok)}/{len(ok)}"

    def width(k):
        return np.median([r[k][2] - r[k][0] for r in rows])

    return (f"RATE {n} experiments (2 conditions x osmotic series, equal turgor, treated E0t x "
            f"{rows[0]['truth']['E0t_ratio']:g}): 90 % interval of the turgor contrast covers 0 "
            f"in {cov('dP_kPa')}, median width {width('dP_kPa'):.2f} kPa; of the E0t ratio "
            f"covers the truth in {cov('E0t_ratio')}, median width {width('E0t_ratio'):.3f}; "
            f"gamma covered {cov('gamma')}, b {cov('b')}; among the converged fits: turgor "
            f"contrast {conv('dP_kPa')}, E0t ratio {conv('E0t_ratio')}; converged "
            f"{sum(r['converged'] for r in rows)}/{n} (engines: "
            f"{', '.join(sorted({r['engine'] for r in rows}))}); median "
            f"{np.median([r['seconds'] for r in rows]):.1f} s per fit")


def join(paths, out):
    """Join split runs' rows into ``out`` with one ``RATE`` line."""
    rows = [json.loads(line) for p in paths for line in open(p)
            if line.startswith('{"seed"')]
    rows.sort(key=lambda r: r["seed"])
    with open(out, "w") as f:
        print(header_line(), file=f)
        for r in rows:
            print(json.dumps(r), file=f)
        print(rate(rows), file=f)
    print(rate(rows))
    print(f"wrote {out}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--n", type=int, default=20, help="experiments")
    parser.add_argument("--levels", default="0,50,100,150", help="mOsm added, comma-separated")
    parser.add_argument("--per-level", type=int, default=30)
    parser.add_argument("--E0t-factor", dest="factor", type=float, default=0.7)
    parser.add_argument("--tag", default="")
    parser.add_argument("--join", nargs="+", default=None, metavar="JSONL",
                        help="join these split runs' files into osmotic_conditions.jsonl")
    add_output_options(parser)
    args = parser.parse_args()
    settings = SETTINGS
    if args.smoke:  # see SMOKE_SETTINGS
        args.n, args.levels, args.per_level, settings = 1, "0,150", 8, SMOKE_SETTINGS
    if args.join:
        return join(args.join, study_path(args, "osmotic_conditions.jsonl"))
    added = tuple(float(x) for x in args.levels.split(","))
    tag = f"_{args.tag}" if args.tag else ""
    path = study_path(args, f"osmotic_conditions{tag}.jsonl")
    table = sm.load()
    rows = []
    with open(path, "w") as f:
        print(header_line(), file=f, flush=True)
        for seed in range(args.first_seed, args.first_seed + args.n):
            rows.append(one(seed, table, added, args.per_level, args.factor, settings))
            print(json.dumps(rows[-1]), file=f, flush=True)
            print(json.dumps(rows[-1]), flush=True)
        print(rate(rows), file=f)
    print(rate(rows))
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
