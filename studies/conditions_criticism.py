"""What ``criticize`` says on two-condition experiments: without an effect (how often it
names one anyway) and with one planted in every condition (how often it names it).

Arguments: EFFECT FIRST_SEED STOP_SEED, EFFECT a registered effect planted at its realistic
size in both conditions, or ``none``. Each data set:
:func:`turgorbayes.simulation.conditions.simulate_conditions` with wt at 29 kPa (the paper's
72 bulged + 42 intact cells) and treated at 22 kPa (42 intact cells), the paper's wall shared,
data seed = criticism seed; criticized with every applicable candidate at the settings of
tests/criticism/test_criticism.py (1000 importance draws, 700 replicates). One JSON line per
data set (the verdict's status, the effect selected, the baseline checks flagged, whether the
headline's P_phys of the reference condition covers 29 kPa, the time), then a ``RATE`` line.
docs/effects.md, "Several conditions".

``--checks-only DESIGN FIRST_SEED STOP_SEED``: only the baseline's predictive checks (the
criticism's first step), on ``conditions`` data (as above, no effect) or on ``single`` data of
the same size (72 bulged + 84 intact cells at 29 kPa, no condition column): how often a check
flags data without an effect, with conditions and without. One line per data set (the checks
flagged), then a ``RATE`` line with the count per check.

Run: .venv/bin/python studies/conditions_criticism.py none 1 9 \\
         > studies/results/conditions_criticism_null.jsonl
     .venv/bin/python studies/conditions_criticism.py --checks-only single 1 31 \\
         > studies/results/conditions_criticism_checks_single.txt
"""

import argparse
import collections
import dataclasses
import json
import time

from turgorbayes import effects, provenance
from turgorbayes import surrogate as sm
from turgorbayes.inference import models
from turgorbayes.inference.engine import fit_posterior
from turgorbayes.provenance import header_line
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation import conditions as sc
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize, model_class, predictive_checks

SETTINGS = CriticismSettings(
    n_draws=1000, n_rep=700, max_refits=3, retry_factor=1,
    n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                             max_steps=4000, progress=False, flag_draws=50)
P_REF_KPA = 29.0
#: A smoke run: 8 bulged + 6 intact cells (wt), 6 intact (treated); one candidate, few draws.
SMOKE_DESIGN = {"n_intact": 6, "n_bulged": {"wt": 8}}
SMOKE_SETTINGS = dataclasses.replace(SETTINGS, n_draws=200, n_rep=50, ess_min=20, n_ensembles=2,
                                     tol=5, check_every=20, max_steps=200, flag_draws=20,
                                     max_refits=0, effects=("radius_spread",))


def one(effect, seed, table, smoke=False):
    """Criticize one simulated experiment; its outcome as a dict."""
    planted = [] if effect == "none" else [
        effects.get_effect(effect).injection(effects.get_effect(effect).realistic_size)]
    cells, _ = sc.simulate_conditions({"wt": 29e3, "treated": 22e3}, seed=seed,
                                      surrogate=table, effects=planted,
                                      **(SMOKE_DESIGN if smoke else {}))
    t = time.time()
    settings = SMOKE_SETTINGS if smoke else SETTINGS
    d = criticism_dict(criticize(cells, table, seed=seed, settings=settings))
    P = d["parameters"][d["headline"]]["P_phys_kPa"]
    return {"effect": effect, "seed": seed, "status": d["verdict"]["status"],
            "selected": d["selected_effect"],
            "flagged_checks": [c["name"] for c in d["checks"] if c["flagged"]],
            "P_ref_covered": bool(P["q05"] <= P_REF_KPA <= P["q95"]),
            "seconds": round(time.time() - t)}


def main(effect, first, stop, smoke=False):
    table = sm.load()
    rows = []
    for seed in range(first, stop):
        rows.append(one(effect, seed, table, smoke))
        print(json.dumps(rows[-1]), flush=True)
    named = sum(r["selected"] is not None and (effect == "none" or effect
                                               in effects.parse_model_name(r["selected"]))
                for r in rows)
    print(f"RATE {effect}: {'an effect named' if effect == 'none' else 'named'} {named}/"
          f"{len(rows)}; P_phys of wt covered {sum(r['P_ref_covered'] for r in rows)}/"
          f"{len(rows)}")


def flagged_checks(design, seed, table):
    """The baseline checks that flag one data set without an effect (``design`` is
    ``"conditions"`` or ``"single"``)."""
    if design == "single":
        cells, _ = synthetic.simulate_cells(72, 84, seed=seed, surrogate=table)
    else:
        cells, _ = sc.simulate_conditions({"wt": 29e3, "treated": 22e3}, seed=seed,
                                          surrogate=table)
    model = model_class(cells)(cells, table, [])
    guess = model.start_values(models.PaperWLS(cells, table).fit().estimate)
    post = fit_posterior(model, guess, seed, SETTINGS)
    checks, _ = predictive_checks(post, seed, SETTINGS)
    return [c["name"] for c in checks if c["flagged"]]


def checks_only(design, first, stop):
    table = sm.load()
    count, any_flag = collections.Counter(), 0
    for seed in range(first, stop):
        flagged = flagged_checks(design, seed, table)
        count.update(flagged)
        any_flag += bool(flagged)
        print(f"{design} seed {seed}: flagged {flagged}", flush=True)
    print(f"RATE {design}: a check flagged {any_flag}/{stop - first}; per check {dict(count)}")


def _arguments():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--checks-only", metavar="DESIGN", choices=("conditions", "single"),
                        help="only the baseline's predictive checks on DESIGN data")
    parser.add_argument("effect", nargs="?", help="EFFECT (or none) planted; not with --checks-only")
    parser.add_argument("first", type=int, nargs="?")
    parser.add_argument("stop", type=int, nargs="?")
    args = provenance.add_output_options(parser).parse_args()
    if args.checks_only and args.stop is None:  # DESIGN FIRST STOP: the numbers shift left
        args.effect, args.first, args.stop = None, int(args.effect), args.first
    if args.smoke and args.first is None:  # one data set with radius_spread planted
        args.effect, args.first, args.stop = args.effect or "radius_spread", 1, 2
    if args.first is None or args.stop is None:
        parser.error("give EFFECT FIRST_SEED STOP_SEED or --checks-only DESIGN FIRST_SEED STOP_SEED")
    return args


if __name__ == "__main__":
    args = _arguments()
    provenance.tee_stdout(args, "conditions_criticism.txt")
    print(header_line(), flush=True)
    if args.checks_only:
        checks_only(args.checks_only, args.first, args.stop)
    else:
        main(args.effect, args.first, args.stop, args.smoke)
