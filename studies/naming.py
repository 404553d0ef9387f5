"""Does ``criticize`` name the cause where the data tell it? In-library effects at their
realistic size, every candidate present (docs/statistics.md, "Naming a cause the generic
description also fits").

For each effect of ``--effects`` (default the six of the open-world-II target: radius_spread,
pressure_error, bad_curves, wall_softening, calibration, turgor_spread) and ``null``, simulate
``--n`` data sets of the paper's design (72 bulged + 42 intact cells; calibration in 6
sessions, radius_spread with 8-12 nm radius errors, as in the open-world study), seeds
``--first-seed`` ..., run :func:`turgorbayes.workflows.criticize.criticize` with the command's
default settings and every applicable candidate, and record the verdict, the model it adopts,
how the named effect was told from the generic description (``identified_by``: ``loo``, the
selection rule; ``bayes_factor``, the marginal likelihood; or neither), the log Bayes factor,
and whether the quoted P_phys covers the truth. Data sets run seed by seed across the effects,
so a stopped run is balanced; rows are appended to ``naming.jsonl`` in ``--output-dir`` (or
the tracked results with ``--update``).

Targets (open-world II): ``explained`` with the right name (or its family) in >= 0.8 of each
effect; ``no_misfit`` in >= 0.9 of nulls.

Run: .venv/bin/python studies/naming.py [--n 20] [--effects a,b] [--first-seed 1000]
         [--output-dir DIR | --update] [--smoke]
     .venv/bin/python studies/naming.py --summarize ROWS.jsonl [...]
"""

import argparse
import json
import time
from pathlib import Path

from turgorbayes import effects, provenance, surrogate
from turgorbayes.simulation.planted import planted_cells
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

TRUE_P_PHYS_KPA = 29.0
TARGETS = ("radius_spread", "pressure_error", "bad_curves", "wall_softening", "calibration",
           "turgor_spread")
def right_name(effect, selected):
    """The adopted model holds the simulated effect or one of its family."""
    if effect == "null" or not selected:
        return False
    fam = effects.get_effect(effect).family
    names = effects.parse_model_name(selected)
    return effect in names or bool(fam) and any(effects.get_effect(n).family == fam
                                                 for n in names)


def one(name, seed, table, settings, n_cells=(72, 42), candidates=None):
    cells = planted_cells(name, seed, table, *n_cells)
    names = tuple(n for n in candidates or effects.effect_names()
                  if not effects.get_effect(n).not_applicable_reason(cells))
    t0 = time.perf_counter()
    res = criticize(cells, table, seed=seed, settings=CriticismSettings(
        **{**settings, "effects": names}))
    d = criticism_dict(res)
    v, params = d["verdict"], d["parameters"]
    generic = next((c for c in res.candidates if "vs_selected" in c), None)
    vs = generic["vs_selected"] if generic else {}
    bf = vs.get("bayes_factor") or {}
    P = params[d["headline"]]["P_phys_kPa"]
    return {"effect": name, "seed": seed, "status": v["status"], "selected": v["selected"],
            "right_name": right_name(name, v["selected"]),
            "identified_by": generic.get("identified_by") if generic else None,
            "generic": generic["effect"] if generic else None,
            "generic_gain_over_selected": vs.get("delta_elpd"), "generic_gain_se": vs.get("se"),
            "log_bf": bf.get("log_bf"), "log_bf_se": bf.get("se"),
            "bf_methods": bf.get("methods"), "remaining_checks": v["remaining_checks"],
            "headline": d["headline"], "P_headline": [P["q05"], P["q50"], P["q95"]],
            "P_covered": bool(P["q05"] <= TRUE_P_PHYS_KPA <= P["q95"]),
            "time_s": round(time.perf_counter() - t0, 1)}


def summarize(rows):
    lines = ["| effect | n | explained, right name | explained, other | partly | unexplained | "
             "no_misfit | by LOO | by Bayes factor | median ln BF | P cov (quoted) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    by = {}
    for r in rows:
        by.setdefault(r["effect"], []).append(r)
    for name, rs in by.items():
        n = len(rs)

        def count(f, rs=rs):
            return sum(bool(f(r)) for r in rs)

        bfs = sorted(r["log_bf"] for r in rs if r["log_bf"] is not None)
        med = f"{bfs[len(bfs) // 2]:.1f}" if bfs else "-"
        lines.append(
            f"| {name} | {n} | {count(lambda r: r['status'] == 'explained' and r['right_name'])}"
            f" | {count(lambda r: r['status'] == 'explained' and not r['right_name'])} | "
            f"{count(lambda r: r['status'] == 'partly_explained')} | "
            f"{count(lambda r: r['status'] == 'unexplained')} | "
            f"{count(lambda r: r['status'] == 'no_misfit')} | "
            f"{count(lambda r: r['status'] == 'explained' and r['identified_by'] == 'loo')} | "
            f"{count(lambda r: r['status'] == 'explained' and r['identified_by'] == 'bayes_factor')}"
            f" | {med} | {count(lambda r: r['P_covered'])}/{n} |")
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20, help="data sets per effect")
    parser.add_argument("--effects", default=",".join(TARGETS + ("null",)))
    parser.add_argument("--first-seed", type=int, default=1000)
    parser.add_argument("--summarize", nargs="+", default=None, metavar="ROWS.jsonl")
    provenance.add_output_options(parser)
    args = parser.parse_args()
    if args.summarize:
        rows = [json.loads(line) for p in args.summarize for line in Path(p).read_text()
                .splitlines() if line.startswith("{")]
        print("\n".join(summarize(rows)))
        return
    table = surrogate.load()
    settings, n_cells, candidates = {"progress": False}, (72, 42), None
    names = args.effects.split(",")
    if args.smoke:  # one data set, few draws, the effect and the generic candidate
        args.n, names = 1, ["radius_spread"]
        candidates = ("radius_spread", "discrepancy")
        settings.update(n_draws=300, n_rep=50, max_refits=0, flag_draws=20)
    path = provenance.study_path(args, "naming.jsonl")
    record = provenance.run_record()
    rows = []
    with path.open("a") as f:
        for seed in range(args.first_seed, args.first_seed + args.n):
            for name in names:
                row = one(name, seed, table, settings, n_cells, candidates)
                f.write(json.dumps({**row, "provenance": record}) + "\n")
                f.flush()
                rows.append(row)
                print(f"{name} seed {seed}: {row['status']} ({row['selected']}, "
                      f"{row['identified_by']}, ln BF {row['log_bf']}) {row['time_s']} s",
                      flush=True)
    print("\n".join(summarize(rows)))


if __name__ == "__main__":
    main()
