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

Run: .venv/bin/python benchmarks/conditions_check.py 1.4 36 20 1 21 \\
         >> benchmarks/results/conditions_check.txt
"""

import sys
import time

from turgorbayes import surrogate as sm
from turgorbayes.inference import models
from turgorbayes.inference.engine import fit_posterior
from turgorbayes.provenance import header_line
from turgorbayes.simulation import conditions as sc
from turgorbayes.workflows.criticize import CriticismSettings, model_class, predictive_checks

NAME = "conditions_R_c_k_c"


def main(ratio, n_bulged, n_intact, first, stop):
    table = sm.load()
    settings = CriticismSettings(
        n_draws=1000, n_rep=700, max_refits=0, retry_factor=1,
        n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                                 max_steps=4000, progress=False)
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


if __name__ == "__main__":
    print(header_line())
    a = sys.argv[1:]
    main(float(a[0]), int(a[1]), int(a[2]), int(a[3]), int(a[4]))
