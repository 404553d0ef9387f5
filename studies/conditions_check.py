"""Flag rate of the criticism's ``conditions_R_c_k_c`` check: two conditions whose walls
differ (treated's E0t RATIO times wt's) or are shared (RATIO 1).

Arguments: RATIO N_BULGED N_INTACT FIRST_SEED STOP_SEED. Each data set:
:func:`turgorbayes.simulation.conditions.simulate_conditions` with wt at 29 kPa and treated at
22 kPa, N_BULGED bulged and N_INTACT intact cells in each, the paper's wall (treated's E0t
times RATIO), data seeds FIRST_SEED ... STOP_SEED - 1, data seed = criticism seed; the baseline with
conditions fitted by the criticism's engine and the predictive checks run
(:func:`turgorbayes.workflows.criticize.predictive_checks`) with the criticism's settings at
700 replicates (those of tests/criticism/test_criticism.py). One line per data set (F, p,
flagged, the other flagged checks), then ``RATE``. docs/effects.md, "Several conditions".

Run: .venv/bin/python studies/conditions_check.py 1.4 36 20 1 21 \\
         >> studies/results/conditions_check.txt
"""

import argparse
import dataclasses
import time

from turgorbayes import provenance
from turgorbayes import surrogate as sm
from turgorbayes.inference import models
from turgorbayes.inference.engine import fit_posterior
from turgorbayes.provenance import header_line
from turgorbayes.simulation import conditions as sc
from turgorbayes.workflows.criticize import CriticismSettings, model_class, predictive_checks

NAME = "conditions_R_c_k_c"
#: The criticism's settings of a smoke run: few draws and replicates, short chains.
SMOKE_SETTINGS = {"n_draws": 200, "n_rep": 50, "ess_min": 20, "n_ensembles": 2, "tol": 5,
                  "check_every": 20, "max_steps": 200, "flag_draws": 20}


def main(ratio, n_bulged, n_intact, first, stop, smoke=False):
    table = sm.load()
    settings = CriticismSettings(
        n_draws=1000, n_rep=700, max_refits=0, retry_factor=1,
        n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                                 max_steps=4000, progress=False)
    if smoke:
        settings = dataclasses.replace(settings, **SMOKE_SETTINGS)
    flags = []
    for seed in range(first, stop):
        t = time.time()
        cells, _ = sc.simulate_conditions(
            {"wt": 29e3, "treated": 22e3}, n_intact=n_intact,
            n_bulged={"wt": n_bulged, "treated": n_bulged}, seed=seed, surrogate=table,
            walls={"treated": {"E0t": 0.026 * ratio}} if ratio != 1 else None)
        model = model_class(cells)(cells, table, [])
        guess = model.start_values(models.PaperWLS(cells, table).fit().estimate)
        post = fit_posterior(model, guess, seed, settings)
        checks, _ = predictive_checks(post, seed, settings)
        c = {x["name"]: x for x in checks}[NAME]
        others = [x["name"] for x in checks if x["flagged"] and x["name"] != NAME]
        flags.append(c["flagged"])
        print(f"ratio {ratio} nb {n_bulged} seed {seed}: F {c['statistic']:.2f} p "
              f"{c['p_value']:.4f} flagged {c['flagged']} others {others} "
              f"{time.time() - t:.0f}s", flush=True)
    print(f"RATE ratio {ratio} nb {n_bulged} ni {n_intact}: {sum(flags)}/{len(flags)}")


def _arguments(smoke_values):
    """RATIO N_BULGED N_INTACT FIRST_SEED STOP_SEED (``smoke_values`` with ``--smoke``)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, kind in (("ratio", float), ("n_bulged", int), ("n_intact", int), ("first", int),
                       ("stop", int)):
        parser.add_argument(name, type=kind, nargs="?")
    args = provenance.add_output_options(parser).parse_args()
    values = [args.ratio, args.n_bulged, args.n_intact, args.first, args.stop]
    if args.smoke:
        values = [v if v is not None else s for v, s in zip(values, smoke_values, strict=True)]
    elif None in values:
        parser.error("give RATIO N_BULGED N_INTACT FIRST_SEED STOP_SEED")
    return args, values


if __name__ == "__main__":
    args, values = _arguments([1.4, 8, 6, 1, 2])  # smoke: one data set of 8 + 6 cells each
    provenance.tee_stdout(args, "conditions_check.txt", append=True)
    print(header_line())
    main(*values, smoke=args.smoke)
