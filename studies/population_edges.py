"""How much the position of the bulge pressures' range tells about gamma, and how well the
bulges place it.

1. Each data set (log-uniform design, ``--scale`` times the paper's cells, seeds from
   ``--first-seed``) is fitted (the criticism's engine) with the true log-uniform population
   (edges ramped over 0.03 in ln P, as in ``latent_population_cost.py``) and with its edges
   moved inward by the given amounts; the mean change of gamma's z is printed.
2. The two edges are fitted by maximum marginal likelihood to the bulge estimates alone, and
   to the true ln P plus ideal Gaussian noise of the same sds; their mean error is printed
   (a finite-sample bias of an edge estimate shows in both).

Run: .venv/bin/python studies/population_edges.py --scale 10 --n 8 \
         > studies/results/population_edges.txt
"""

import argparse
import dataclasses

import numpy as np

from turgorbayes import criticism, effects, provenance, surrogate
from turgorbayes.inference import models, population
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import sbc
from turgorbayes.workflows.criticize import CriticismSettings

TRUTH = synthetic.TRUTHS["paper"]
#: A smoke run's posterior settings: few draws, short chains.
SMOKE_SETTINGS = {"n_draws": 200, "ess_min": 20, "n_ensembles": 2, "tol": 5, "check_every": 20,
                  "max_steps": 200}

#: (lower, upper) edge moves [ln P], inward positive.
MOVES = ((0.0, 0.0), (0.015, 0.015), (0.0, 0.03), (0.03, 0.0))


def gamma_z(cells, table, pop, seed, guess, settings):
    model = effects.ExtendedModel(cells, table, [])
    model = models.with_population(model, pop(model.obs.population))
    post = criticism.fit_posterior(model, model.start_values(guess), seed, settings)
    return sbc.truth_summary(model, post, TRUTH)["gamma"]["z"]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=int, default=10)
    ap.add_argument("--n", type=int, default=8)
    ap.add_argument("--first-seed", type=int, default=1000)
    args = provenance.add_output_options(ap).parse_args()
    nb, ni, settings = 72 * args.scale, 42 * args.scale, CriticismSettings()
    if args.smoke:  # two data sets of 12 + 8 cells, short chains
        args.n, nb, ni = 2, 12, 8
        settings = dataclasses.replace(settings, **SMOKE_SETTINGS)
    provenance.tee_stdout(args, "population_edges.txt")
    print(provenance.header_line(), flush=True)
    table = surrogate.load()
    lo, hi = np.log(synthetic.DEFAULT_P_RANGE)
    z, edge_err = [], []
    for seed in range(args.first_seed, args.first_seed + args.n):
        cells, truths = synthetic.simulate_cells(nb, ni, seed=seed, truth=TRUTH,
                                                 surrogate=table,
                                                 design_kwargs={"P_distribution": "loguniform"})
        guess = models.PaperWLS(cells, table).fit().estimate
        row = [gamma_z(cells, table, lambda p, a=a, b=b: population.ramped_box(p, lo + a, hi - b), seed, guess,
                       settings)
               for a, b in MOVES]
        z.append(row)
        obs = effects.ExtendedModel(cells, table, []).obs
        x, s = obs.log_P_bulge, obs.sd_log_P_bulge
        ideal = (np.log(np.asarray(truths["cells"]["P_kPa"][:nb], float) * 1e3)
                 + s * np.random.default_rng(seed).standard_normal(nb))
        fits = [population.fitted_box(v, s, obs.population)[1] for v in (x, ideal)]
        edge_err.append([fits[0][0] - lo, hi - fits[0][1], fits[1][0] - lo, hi - fits[1][1]])
        print(f"seed {seed}: gamma z {np.round(row, 2).tolist()}", flush=True)
    z, e = np.array(z), np.array(edge_err)
    d = z - z[:, :1]
    print(f"\n{args.n} data sets at {args.scale}x the paper's cells (log-uniform 1-25 kPa)")
    print("edges moved inward (lower, upper) [ln P] -> mean gamma z, change from the true "
          "edges (mean +- SE)")
    for (a, b), col, dc in zip(MOVES, z.T, d.T, strict=True):
        print(f"  ({a:.3f}, {b:.3f}): z {col.mean():+.2f}, change {dc.mean():+.2f} +- "
              f"{dc.std(ddof=1) / np.sqrt(len(dc)):.2f}")
    se = e.std(axis=0, ddof=1) / np.sqrt(len(e))
    print("maximum-likelihood edges, inward error [ln P] (mean +- SE): from the bulges: lower "
          f"{e[:, 0].mean():+.4f} +- {se[0]:.4f}, upper {e[:, 1].mean():+.4f} +- {se[1]:.4f}; "
          f"true ln P + ideal Gaussian noise: lower {e[:, 2].mean():+.4f} +- {se[2]:.4f}, "
          f"upper {e[:, 3].mean():+.4f} +- {se[3]:.4f}")


if __name__ == "__main__":
    main()
