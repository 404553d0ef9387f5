"""How often ``criticize`` selects ``osmoadaptation`` on simulated osmotic series, and how often
it names it (or anything) on series without it.

Arguments: CASE FIRST_SEED STOP_SEED, CASE one of ``timed`` (osmoadaptation planted through
per-cell times after the shift drawn uniformly in 5-20 min, recovery time constant 10 min:
``Osmoadaptation.timed_injection(600)``, the ``minutes_after_shift`` column written),
``timed_null`` (the same times written, no recovery), ``shared`` (one recovery fraction 0.5,
no column) or ``null`` (neither). Each data set:
:func:`turgorbayes.simulation.osmotic.simulate_osmotic_series`, levels 0, 50, 100, 150 mOsm
added to a 300 mOsm growth medium, 30 intact cells per level, no bulged cells, the paper's wall
at 29 kPa; data seed = criticism seed; criticized at the settings of
tests/criticism/test_criticism.py (1000 importance draws, 700 replicates, emcee capped at 4000
steps) with the candidates of ``--effects`` (default: every applicable one). One JSON line per
data set (verdict status, selected model, osmoadaptation's gain and whether it passed the rule,
its size's 90 % interval and whether it covers the truth, seconds), then a ``RATE`` line.
docs/effects.md, "osmoadaptation".

Run: .venv/bin/python studies/osmoadaptation_selection.py --summarize RESULT.jsonl ...
     .venv/bin/python studies/osmoadaptation_selection.py timed 1 21 \
        --effects osmoadaptation,discrepancy --max-refits 0 [--update]
"""

import argparse
import dataclasses
import json
import sys
import time

import numpy as np

from turgorbayes import effects
from turgorbayes import surrogate as sm
from turgorbayes.provenance import add_output_options, header_line, study_path
from turgorbayes.simulation.osmotic import simulate_osmotic_series
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

SETTINGS = CriticismSettings(
    n_draws=1000, n_rep=700, max_refits=3, retry_factor=1,
    n_walkers=12, n_ensembles=4, tol=25, check_every=50,
    max_steps=4000, progress=False, flag_draws=50)
ADDED = (0.0, 50.0, 100.0, 150.0)
N_INTACT = 120
#: A smoke run: one ``timed`` series of 8 cells per level, osmoadaptation the only candidate,
#: no refits, few draws and replicates, chains of 40 steps.
SMOKE_N_INTACT = 32
SMOKE_SETTINGS = {"n_draws": 200, "n_rep": 50, "ess_min": 20, "n_ensembles": 2, "tol": 5,
                  "check_every": 20, "max_steps": 40, "flag_draws": 20, "max_refits": 0}
TAU_S, MINUTES, FRACTION = 600.0, (5.0, 20.0), 0.5
#: case -> (injection, the planted size's key in summary.json and its truth, or None)
CASES = {"timed": ("timed", ("tau_rec_s", TAU_S)),
         "timed_null": ("timed_zero", None),
         "shared": ("shared", ("f_rec", FRACTION)),
         "null": (None, None)}


def _injections(kind):
    osmo = effects.get_effect("osmoadaptation")
    return {None: (), "timed": (osmo.timed_injection(TAU_S, MINUTES),),
            "timed_zero": (osmo.timed_injection(np.inf, MINUTES),),
            "shared": (osmo.injection(FRACTION),)}[kind]


def one(case, seed, table, candidates=None, max_refits=None, smoke=False):
    """Criticize one simulated series; its outcome as a dict (``max_refits`` None: the
    settings' 3; ``smoke``: :data:`SMOKE_SETTINGS` on :data:`SMOKE_N_INTACT` cells)."""
    kind, truth = CASES[case]
    cells, _ = simulate_osmotic_series(ADDED, n_intact=SMOKE_N_INTACT if smoke else N_INTACT,
                                       n_bulged=0, seed=seed, surrogate=table,
                                       effects=_injections(kind))
    t = time.time()
    settings = dataclasses.replace(SETTINGS, effects=candidates)
    if max_refits is not None:
        settings = dataclasses.replace(settings, max_refits=max_refits)
    if smoke:
        settings = dataclasses.replace(settings, **SMOKE_SETTINGS)
    d = criticism_dict(criticize(cells, table, seed=seed, settings=settings))
    cand = next((c for c in d["candidates"] if c["effect"] == "osmoadaptation"), None)
    row = {"case": case, "seed": seed, "status": d["verdict"]["status"],
           "selected": d["selected_effect"],
           "baseline_converged": d["baseline_convergence"]["converged"],
           "osmoadaptation": None, "seconds": round(time.time() - t)}
    if cand is not None and cand["failed"] is None:
        est = next(iter(cand["estimate"].values()))
        row["osmoadaptation"] = {
            "delta_elpd": round(cand["delta_elpd"], 2), "se": round(cand["delta_se"], 2),
            "converged": cand["convergence"]["converged"],
            "size_90": [round(est["q05"], 4), round(est["q95"], 4)],
            "covers_truth": (None if truth is None
                             else bool(est["q05"] <= truth[1] <= est["q95"]))}
    return row


def rate_line(case, rows):
    """The ``RATE`` line of a case's rows."""
    n = len(rows)
    osmo = sum("osmoadaptation" in (r["selected"] or "") for r in rows)
    other = sum(bool(r["selected"]) and "osmoadaptation" not in r["selected"] for r in rows)
    explained = sum(r["status"] == "explained" and "osmoadaptation" in (r["selected"] or "")
                    for r in rows)
    gain = sum(bool(r["osmoadaptation"]) and r["osmoadaptation"]["delta_elpd"] > 4 for r in rows)
    unconverged = sum(bool(r["osmoadaptation"]) and not r["osmoadaptation"]["converged"]
                      for r in rows)
    statuses = {s: sum(r["status"] == s for r in rows) for s in sorted({r["status"] for r in rows})}
    return (f"RATE {case}: osmoadaptation selected {osmo}/{n} (explained {explained}/{n}); "
            f"another effect selected {other}/{n}; osmoadaptation gains > 4 nats {gain}/{n}, "
            f"its posterior not converged {unconverged}/{n}; statuses {statuses}")


def summarize(paths):
    """``--summarize FILE ...``: the RATE line of each result file's rows (a run stopped
    before its last seed has no RATE line of its own)."""
    out = []
    for path in paths:
        rows = [json.loads(x) for x in open(path) if x.startswith("{")]
        out.append(f"{rate_line(rows[0]['case'], rows)} (rows of {path})")
    return out


def main():
    if sys.argv[1:2] == ["--summarize"]:
        print("\n".join(summarize(sys.argv[2:])))
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("case", choices=sorted(CASES), nargs="?")
    parser.add_argument("first", type=int, nargs="?")
    parser.add_argument("stop", type=int, nargs="?")
    parser.add_argument("--effects", default=None,
                        help="comma-separated candidates (default: every applicable one)")
    parser.add_argument("--max-refits", type=int, default=None,
                        help="exact LOO refits per model (default 3; 0: high Pareto k cells "
                             "are counted, not refitted: the series model's refits on data with "
                             "recovery fall back to emcee, minutes each)")
    parser.add_argument("--suffix", default="", help="added to the result file's name")
    add_output_options(parser)
    args = parser.parse_args()
    if args.smoke:  # one timed series (see one()), osmoadaptation the only candidate
        args.case, args.first, args.stop = args.case or "timed", 1, 2
        args.effects = args.effects or "osmoadaptation"
    if args.stop is None:
        parser.error("CASE FIRST STOP are required (but with --smoke)")
    candidates = tuple(args.effects.split(",")) if args.effects else None
    table = sm.load()
    path = study_path(args, f"osmoadaptation_selection_{args.case}{args.suffix}.jsonl")
    rows = []
    with open(path, "w") as f:
        print(header_line(), file=f, flush=True)
        for seed in range(args.first, args.stop):
            rows.append(one(args.case, seed, table, candidates, args.max_refits, args.smoke))
            print(json.dumps(rows[-1]), file=f, flush=True)
            print(json.dumps(rows[-1]), flush=True)
        line = rate_line(args.case, rows)
        print(line, file=f)
    print(line)
    print(f"wrote {path}", file=sys.stderr)


if __name__ == "__main__":
    main()
