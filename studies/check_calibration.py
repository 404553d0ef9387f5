"""Are the posterior predictive checks calibrated under a correct extended model? Simulate data
with one effect at its realistic size (the open-world designs), fit the model with exactly
that effect (its own posterior engine, as ``criticize`` fits a candidate), run the check
battery on it and count what is flagged. A correct model should be flagged anywhere in at most
``FAMILY_ALPHA`` = 5 % of data sets (Bonferroni over the battery; posterior predictive
p-values are, if anything, conservative: Meng, Ann. Stat. 22, 1142, 1994). The baseline on null
data is the reference row; ``null_in_sessions`` is null data measured in 6 sessions (the
``session`` checks run), and ``baseline:NAME`` fits the baseline to NAME's data (the checks'
power against that effect).

Run: .venv/bin/python studies/check_calibration.py [--n 10] [--effects a,b] [--first-seed 1000]
         [--output-dir DIR | --update] [--smoke]   ->  check_calibration.jsonl
"""

import argparse
import json
import time

from turgorbayes import provenance, surrogate
from turgorbayes.inference.engine import fit_posterior
from turgorbayes.simulation.cells import simulate_cells
from turgorbayes.simulation.planted import planted_cells
from turgorbayes.workflows.criticism_screens import predictive_checks
from turgorbayes.workflows.criticism_setup import CriticismSettings, criticism_model

TARGETS = ("null", "radius_spread", "pressure_error", "bad_curves", "wall_softening",
           "calibration", "turgor_spread")


#: Sessions of the ``null_in_sessions`` data (as the calibration effect's realistic design).
N_SESSIONS = 6


def one(name, seed, table, settings):
    data = name.split(":")[-1]
    if data == "null_in_sessions":
        cells = simulate_cells(72, 42, seed=seed, surrogate=table, n_sessions=N_SESSIONS)[0]
    else:
        cells = planted_cells(data, seed, table)
    names = [] if data in ("null", "null_in_sessions") or name.startswith("baseline:") else [data]
    t0 = time.perf_counter()
    guess = criticism_model(cells, table, [], settings).least_squares().fit().estimate
    model = criticism_model(cells, table, names, settings)  # as criticize fits a candidate
    post = fit_posterior(model, model.start_values(guess), seed, settings)
    checks, _ = predictive_checks(post, seed, settings)
    return {"effect": name, "seed": seed, "engine": post.engine, "converged": post.converged,
            "flagged": [c["name"] for c in checks if c["flagged"]],
            "p_values": {c["name"]: round(c["p_value"], 5) for c in checks},
            "time_s": round(time.perf_counter() - t0, 1)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=10)
    parser.add_argument("--effects", default=",".join(TARGETS))
    parser.add_argument("--first-seed", type=int, default=1000)
    provenance.add_output_options(parser)
    args = parser.parse_args()
    names = args.effects.split(",")
    settings = CriticismSettings(progress=False)
    if args.smoke:
        args.n, names = 1, ["radius_spread"]
        settings = CriticismSettings(progress=False, n_draws=300, n_rep=200, max_refits=0)
    table, record = surrogate.load(), provenance.run_record()
    counts = {}
    with provenance.study_path(args, "check_calibration.jsonl").open("a") as f:
        for seed in range(args.first_seed, args.first_seed + args.n):
            for name in names:
                row = one(name, seed, table, settings)
                f.write(json.dumps({**row, "provenance": record}) + "\n")
                f.flush()
                c = counts.setdefault(name, [0, 0])
                c[0] += bool(row["flagged"])
                c[1] += 1
                print(f"{name} seed {seed}: flagged {row['flagged']} ({row['time_s']} s)",
                      flush=True)
    for name, (k, n) in counts.items():
        print(f"{name}: a check flagged under the true model in {k}/{n}")


if __name__ == "__main__":
    main()
