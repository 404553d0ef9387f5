"""How often ``criticize`` adopts ``own_wall`` (a condition's own wall stiffness) on
two-condition experiments with bulged cells in both conditions, and what its contrasts say.

Arguments: CASE FIRST_SEED STOP_SEED, CASE one of ``softer`` (treated's E0t x 0.7),
``stiffer`` (x 1.3) or ``shared`` (one wall). Each data set:
:func:`turgorbayes.simulation.conditions.simulate_conditions` with wt and treated both at
29 kPa (equal turgor), 40 bulged + 42 intact cells each, the paper's wall for wt; data seed =
criticism seed; criticized with every applicable candidate at the settings of
tests/criticism/test_criticism.py (1000 importance draws, 700 replicates). One JSON line per
data set (verdict status, selected model, whether the check conditions_R_c_k_c flagged, the
adopted model's and the model average's P_phys contrast and E0t ratio with whether their
90 % intervals cover the truths 0 kPa and the planted ratio), then a ``RATE`` line.
docs/effects.md, "own_wall".

Run: .venv/bin/python studies/own_wall_candidate.py softer 1 21 [--update]
     .venv/bin/python studies/own_wall_candidate.py --summarize RESULT.jsonl ...
     [--effects own_wall,discrepancy,turgor_spread,pressure_error --suffix _four]
(every candidate takes 10-13 min a data set with a wall that differs, where several fall back
to emcee; four candidates, the competitors of a wall of a condition's own, about 1 min)
"""

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

from turgorbayes import surrogate as sm
from turgorbayes.provenance import add_output_options, header_line, study_path
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation import conditions as sc
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

SETTINGS = CriticismSettings(
    n_draws=1000, n_rep=700, max_refits=3, retry_factor=1,
    n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                             max_steps=4000, progress=False, flag_draws=50)
#: A smoke run: one ``softer`` experiment of 12 bulged + 8 intact cells per condition, own_wall
#: the only candidate, no refits, few draws and replicates, chains of 40 steps.
SMOKE_CELLS = {"n_intact": 8, "n_bulged": {"wt": 12, "treated": 12}}
SMOKE_SETTINGS = {"n_draws": 200, "n_rep": 50, "ess_min": 20, "n_ensembles": 2, "tol": 5,
                  "check_every": 20, "max_steps": 40, "flag_draws": 20, "max_refits": 0}
RATIO = {"softer": 0.7, "stiffer": 1.3, "shared": 1.0}
P_KPA = 29.0


def _contrasts(entries, ratio):
    """The P_phys difference and E0t ratio of treated (None where not a contrast) and
    whether their 90 % intervals cover the truths."""
    out = {}
    for c in entries or []:
        if c["quantity"] == "P_phys_kPa":
            d = c["difference"]
            out["P_diff"] = [round(d[k], 3) for k in ("q05", "q50", "q95")]
            out["P_covered"] = bool(d["q05"] <= 0.0 <= d["q95"])
            out["P_direction"] = bool(max(c["prob_greater"], 1 - c["prob_greater"]) > 0.95)
        if c["quantity"] == "E0t_N_per_m":
            r = c["ratio"]
            out["E0t_ratio"] = [round(r[k], 3) for k in ("q05", "q50", "q95")]
            out["ratio_covered"] = bool(r["q05"] <= ratio <= r["q95"])
    return out


def one(case, seed, table, candidates=None, smoke=False):
    """Criticize one simulated experiment; its outcome as a dict (``smoke``:
    :data:`SMOKE_CELLS` and :data:`SMOKE_SETTINGS`)."""
    ratio = RATIO[case]
    walls = {} if ratio == 1.0 else {"treated": {"E0t": ratio * synthetic.PAPER_TRUTH.E0t}}
    design = SMOKE_CELLS if smoke else {"n_intact": 42, "n_bulged": {"wt": 40, "treated": 40}}
    cells, _ = sc.simulate_conditions({"wt": P_KPA * 1e3, "treated": P_KPA * 1e3}, seed=seed,
                                      surrogate=table, walls=walls, **design)
    t = time.time()
    settings = dataclasses.replace(SETTINGS, effects=candidates)
    if smoke:
        settings = dataclasses.replace(settings, **SMOKE_SETTINGS)
    d = criticism_dict(criticize(cells, table, seed=seed, settings=settings))
    cond = d["verdict"]["conditions"]
    return {"case": case, "seed": seed, "status": d["verdict"]["status"],
            "selected": d["selected_effect"],
            "check_flagged": cond["check"]["flagged"],
            "adopted": _contrasts(cond["contrasts"]["adopted"], ratio),
            "model_average": _contrasts(cond["contrasts"]["model_average"], ratio),
            "seconds": round(time.time() - t)}


def summarize(paths):
    """One line per result file: the rates of its rows."""
    lines = []
    for path in paths:
        rows = [json.loads(line) for line in open(path) if line.startswith("{")]
        n = len(rows)
        statuses = {}
        for r in rows:
            statuses[r["status"]] = statuses.get(r["status"], 0) + 1
        count = {k: sum(bool(r[which].get(key, False)) for r in rows)
                 for k, (which, key) in {"P_adopted": ("adopted", "P_covered"),
                                         "dir_adopted": ("adopted", "P_direction"),
                                         "P_average": ("model_average", "P_covered"),
                                         "dir_average": ("model_average", "P_direction"),
                                         "ratio": ("adopted", "ratio_covered")}.items()}
        with_ratio = sum("ratio_covered" in r["adopted"] for r in rows)
        lines.append(
            f"{Path(path).name}: {n} data sets; own_wall adopted "
            f"{sum('own_wall' in (r['selected'] or '') for r in rows)}/{n}; check flagged "
            f"{sum(bool(r['check_flagged']) for r in rows)}/{n}; P_phys contrast covers 0: "
            f"adopted {count['P_adopted']}/{n}, model average {count['P_average']}/{n}; claims a "
            f"direction: adopted {count['dir_adopted']}/{n}, model average "
            f"{count['dir_average']}/{n}; E0t ratio covers the truth {count['ratio']}/"
            f"{with_ratio} (where own_wall adopted); statuses {statuses}")
    return lines


def main():
    if sys.argv[1:2] == ["--summarize"]:
        print("\n".join(summarize(sys.argv[2:])))
        return
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("case", choices=sorted(RATIO), nargs="?")
    parser.add_argument("first", type=int, nargs="?")
    parser.add_argument("stop", type=int, nargs="?")
    parser.add_argument("--effects", default=None,
                        help="comma-separated candidates (default: every applicable one)")
    parser.add_argument("--suffix", default="", help="added to the result file's name")
    add_output_options(parser)
    args = parser.parse_args()
    if args.smoke:  # one softer experiment (see one()), own_wall the only candidate
        args.case, args.first, args.stop = args.case or "softer", 1, 2
        args.effects = args.effects or "own_wall"
    if args.stop is None:
        parser.error("CASE FIRST STOP are required (but with --smoke)")
    candidates = tuple(args.effects.split(",")) if args.effects else None
    table = sm.load()
    path = study_path(args, f"own_wall_candidate_{args.case}{args.suffix}.jsonl")
    rows = []
    with open(path, "w") as f:
        print(header_line(), file=f, flush=True)
        for seed in range(args.first, args.stop):
            rows.append(one(args.case, seed, table, candidates, args.smoke))
            print(json.dumps(rows[-1]), file=f, flush=True)
            print(json.dumps(rows[-1]), flush=True)
        n = len(rows)
        own = sum("own_wall" in (r["selected"] or "") for r in rows)
        line = (f"RATE {args.case}: own_wall adopted {own}/{n}; check flagged "
                f"{sum(bool(r['check_flagged']) for r in rows)}/{n}; adopted P_phys contrast "
                f"covers 0 {sum(r['adopted'].get('P_covered', False) for r in rows)}/{n}, claims "
                f"a direction {sum(r['adopted'].get('P_direction', False) for r in rows)}/{n}; "
                f"model average covers 0 "
                f"{sum(r['model_average'].get('P_covered', False) for r in rows)}/{n}, claims a "
                f"direction {sum(r['model_average'].get('P_direction', False) for r in rows)}/{n}")
        print(line, file=f)
    print(line)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
