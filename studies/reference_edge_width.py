"""How much the edge profile of the "true population" reference moves the wall parameters.

``latent_population_cost.py`` gives the fit the design's log-uniform population with its edges
ramped over 0.03 in ln P (so the 8-node Gauss-Hermite rule of the baseline sees a smooth
density). This script fits the same data sets (log-uniform 1-25 kPa, ``--scale`` times the
paper's cells, seeds from ``--first-seed``) with that population written as the logistic box of
:mod:`turgorbayes.effects.pressure_range` at fixed edges and edge widths ``--widths``, through
the extension path of the likelihood (16-node rule checked against the 8-node one, a dense rule
where they differ), and prints the mean z per width and the paired change between the last and
the first width.

Run: .venv/bin/python studies/reference_edge_width.py --scale 20 --n 12 --widths 0.03 0.005 \
         > studies/results/reference_edge_width.txt
"""

import argparse
import dataclasses

import numpy as np

from turgorbayes import criticism, effects, provenance, surrogate
from turgorbayes.effects.base import Effect
from turgorbayes.effects.pressure_range import log_density
from turgorbayes.inference import models
from turgorbayes.physics.parameters import BASELINE
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import sbc
from turgorbayes.workflows.criticize import CriticismSettings

PARAMS = BASELINE  # gamma, E0t, R0, P_phys
TRUTH = synthetic.TRUTHS["paper"]
#: A smoke run's posterior settings: few draws, short chains.
SMOKE_SETTINGS = {"n_draws": 200, "ess_min": 20, "n_ensembles": 2, "tol": 5, "check_every": 20,
                  "max_steps": 200}


class FixedBox(Effect):
    """The design's population as a logistic box with fixed edges (no parameters)."""

    name = "fixed_box"

    def __init__(self, width):
        self.width = width
        self.lo, self.span = np.log(synthetic.DEFAULT_P_RANGE[0]), np.log(
            synthetic.DEFAULT_P_RANGE[1] / synthetic.DEFAULT_P_RANGE[0])

    def apply(self, ctx, v):
        ctx.latent_log_pdf = lambda log_P: log_density(log_P, self.lo, self.span, self.width)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=int, default=20)
    ap.add_argument("--n", type=int, default=12)
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--widths", type=float, nargs="+", default=[0.03, 0.005])
    args = provenance.add_output_options(ap).parse_args()
    nb, ni, settings = 72 * args.scale, 42 * args.scale, CriticismSettings()
    if args.smoke:  # two data sets of 12 + 8 cells, short chains
        args.n, nb, ni = 2, 12, 8
        settings = dataclasses.replace(settings, **SMOKE_SETTINGS)
    provenance.tee_stdout(args, "reference_edge_width.txt")
    print(provenance.header_line(), flush=True)
    table = surrogate.load()
    z = []
    for seed in range(args.first_seed, args.first_seed + args.n):
        cells, _ = synthetic.simulate_cells(nb, ni, seed=seed,
                                            truth=TRUTH, surrogate=table)
        guess = models.PaperWLS(cells, table).fit().estimate
        row = []
        for w in args.widths:
            model = effects.ExtendedModel(cells, table, [FixedBox(w)])
            post = criticism.fit_posterior(model, model.start_values(guess), seed, settings)
            s = sbc.truth_summary(model, post, TRUTH, PARAMS)
            row.append([s[p]["z"] for p in PARAMS])
        z.append(row)
        print(f"seed {seed}: z per width {np.round(row, 2).tolist()}", flush=True)
    z = np.array(z)
    se = z.std(axis=0, ddof=1) / np.sqrt(args.n)
    for i, w in enumerate(args.widths):
        print(f"width {w}: mean z " + ", ".join(
            f"{p} {m:+.2f} +- {s:.2f}" for p, m, s in zip(PARAMS, z[:, i].mean(0), se[i],
                                                          strict=True)))
    d = z[:, -1] - z[:, 0]
    print(f"width {args.widths[-1]} minus {args.widths[0]} (paired): " + ", ".join(
        f"{p} {m:+.3f} +- {s:.3f}" for p, m, s in
        zip(PARAMS, d.mean(0), d.std(0, ddof=1) / np.sqrt(args.n), strict=True)))


if __name__ == "__main__":
    main()
