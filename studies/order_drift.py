"""Does the criticism see a drift with measurement order, and does the ``drift`` effect measure it?

Each data set: :func:`turgorbayes.simulation.cells.simulate_cells` with 64 bulged + 48 intact
cells at P_phys 33 kPa (the paper's wall), every stiffness drifting by ``--drift`` (log ratio
of the last reading to the first; ``0``: a null) over a session in which the cells were measured
in random order (the ``drift`` effect's injection); the rows are then put in measurement order
and the time column dropped (a file in measurement order, no session column). For each data set:
the baseline's predictive checks (the criticism's first step; p-values and flags of
``order_R_c`` and ``order_k_c``), and the ``drift`` model's posterior (importance sampling):
whether its 90 % interval of ``beta_drift`` covers the truth, and the baseline's and the drift
model's P_phys. One JSON line per data set, then a ``RATE`` line. docs/effects.md, "drift".

Run: .venv/bin/python studies/order_drift.py --drift 0.262 --first-seed 1 --n 20 [--update]
"""

import argparse
import dataclasses
import json
import time

import numpy as np

from turgorbayes import effects
from turgorbayes import surrogate as sm
from turgorbayes.cells.order import TIME_COLUMN
from turgorbayes.cells.table import CellData
from turgorbayes.effects import ExtendedModel
from turgorbayes.inference import models
from turgorbayes.inference.engine import fit_posterior
from turgorbayes.provenance import add_output_options, header_line, study_path
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings, predictive_checks

SETTINGS = CriticismSettings(n_draws=1000, n_rep=700, max_refits=0, retry_factor=1,
                             n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                             max_steps=4000, flag_draws=50)
TRUTH = synthetic.Truth(P_phys=33e3)
#: A smoke run: 12 bulged + 8 intact cells, few draws and replicates, short chains.
SMOKE_CELLS = (12, 8)
SMOKE_SETTINGS = dataclasses.replace(SETTINGS, n_draws=200, n_rep=50, ess_min=20, n_ensembles=2,
                                     tol=5, check_every=20, max_steps=200, flag_draws=20)


def data(drift, seed, table, n_cells=(64, 48)):
    """One data set of ``n_cells`` (bulged, intact) in measurement order, without its time
    column."""
    inj = [effects.get_effect("drift").injection(drift)]
    cells, _ = synthetic.simulate_cells(*n_cells, truth=TRUTH, seed=seed, surrogate=table,
                                        effects=inj)
    minutes = np.array([float(t) for t in cells.extra[TIME_COLUMN]])
    cells = cells.take(np.argsort(minutes, kind="stable"))
    extra = {k: v for k, v in cells.extra.items() if k != TIME_COLUMN}
    fields = ("R_c", "R_c_err", "k_c", "k_c_err", "R_b", "R_b_err", "k_b", "k_b_err", "h_b")
    return CellData(cell_id=cells.cell_id, group=cells.group, extra=extra,
                    comments=cells.comments, **{f: getattr(cells, f) for f in fields})


def one(drift, seed, table, smoke=False):
    cells = data(drift, seed, table, *([SMOKE_CELLS] if smoke else []))
    settings = SMOKE_SETTINGS if smoke else SETTINGS
    guess = models.PaperWLS(cells, table).fit().estimate
    t = time.time()
    base = ExtendedModel(cells, table)
    post = fit_posterior(base, base.start_values(guess), seed, settings)
    checks, _ = predictive_checks(post, seed, settings)
    order = {c["name"]: (round(c["p_value"], 4), c["flagged"]) for c in checks
             if c["name"].startswith("order_")}
    model = ExtendedModel(cells, table, ["drift"])
    dpost = fit_posterior(model, model.start_values(guess), seed, settings)
    rng = np.random.default_rng(seed)
    sb, sd = post.summary(rng), dpost.summary(rng)
    beta = sd["beta_drift"]
    return {"drift": drift, "seed": seed, "order_checks": order,
            "flagged": any(f for _, f in order.values()),
            "any_check_flagged": any(c["flagged"] for c in checks),
            "beta_drift": [round(beta[k], 4) for k in ("q05", "q50", "q95")],
            "beta_covered": bool(beta["q05"] <= drift <= beta["q95"]),
            "drift_converged": bool(dpost.converged),
            "P_baseline": [round(sb["P_phys_kPa"][k], 2) for k in ("q05", "q50", "q95")],
            "P_drift": [round(sd["P_phys_kPa"][k], 2) for k in ("q05", "q50", "q95")],
            "seconds": round(time.time() - t, 1)}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--drift", type=float, default=float(np.log(1.3)))
    parser.add_argument("--first-seed", type=int, default=1)
    parser.add_argument("--n", type=int, default=20)
    add_output_options(parser)
    args = parser.parse_args()
    if args.smoke:  # one data set (see one())
        args.n = 1
    table = sm.load()
    path = study_path(args, f"order_drift_{'null' if args.drift == 0 else 'drift'}.jsonl")
    rows = []
    with open(path, "w") as f:
        print(header_line(), file=f, flush=True)
        for seed in range(args.first_seed, args.first_seed + args.n):
            rows.append(one(args.drift, seed, table, args.smoke))
            print(json.dumps(rows[-1]), file=f, flush=True)
            print(json.dumps(rows[-1]), flush=True)
        n = len(rows)
        line = (f"RATE drift {args.drift:.3f}: order check flagged {sum(r['flagged'] for r in rows)}"
                f"/{n}; beta_drift's 90 % interval covers the truth "
                f"{sum(r['beta_covered'] for r in rows)}/{n}; P_phys 90 % covers 33 kPa: baseline "
                f"{sum(r['P_baseline'][0] <= 33 <= r['P_baseline'][2] for r in rows)}/{n}, drift "
                f"model {sum(r['P_drift'][0] <= 33 <= r['P_drift'][2] for r in rows)}/{n}")
        print(line, file=f)
    print(line)
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
