"""What the plug-in latent population costs: the same data sets fitted with the deconvolved
population estimated from the bulges (the package's) and with the true population known.

The bulged cells' true ln P are drawn from a known density (``--design lognormal``: normal in
ln P; ``loguniform``: uniform over ln 1-25 kPa, given to the fit with its edges ramped over
0.03 in ln P so the latent quadrature sees a smooth density). Each data set (seeds given, or
``--n`` from ``--first-seed``) is fitted twice by the criticism's posterior engine (Laplace +
PSIS importance sampling, emcee where that fails), and the change of each parameter's z-score
``(posterior mean - truth)/sd`` is printed: its RMS over data sets is the extra scatter, in
posterior sds, that the plug-in adds and the posterior does not carry (a 90 % interval then
covers ``P(|z| < 1.645/sqrt(1 + rms^2))``). Rows are appended to ``--out`` (JSON lines).

Run: .venv/bin/python benchmarks/latent_population_cost.py --design loguniform --scale 10 \
         --n 20 --out benchmarks/results/latent_population_cost.jsonl
"""

import argparse
import dataclasses
import json

import numpy as np
from scipy import special

from turgorbayes import criticism, effects, surrogate, synthetic
from turgorbayes.criticism.stacking import weighted_stats
from turgorbayes.inference import models, population
from turgorbayes.inference.likelihood import CellLikelihood

PARAMS = ("gamma", "E0t", "R0", "P_phys")
TRUTH = synthetic.TRUTHS["paper"]
#: Width [ln P] of the ramp that smooths the log-uniform design's edges for the latent quadrature.
EDGE = 0.03


def true_population(design, plug_in):
    """The population the design draws from, on a grid covering the plug-in's support."""
    lo, hi = np.log(synthetic.DEFAULT_P_RANGE)
    if design == "lognormal":  # synthetic.draw_design: mean (lo + hi)/2, sd (hi - lo)/4
        return population.NormalPopulation(mu=(lo + hi) / 2, tau=(hi - lo) / 4)
    grid = np.arange(min(plug_in.support[0], lo - 1), max(plug_in.support[1], hi + 1), 0.02)
    ln_g = special.log_expit((grid - lo) / EDGE) + special.log_expit((hi - grid) / EDGE)
    return population.GridPopulation(grid, ln_g - special.logsumexp(ln_g))


def _summary(model, post):
    phys = model.to_physical(post.u)
    out = {"converged": bool(post.converged)}
    for p in PARAMS:
        t, st = getattr(TRUTH, p), weighted_stats(phys[p], post.weights)
        out[p] = {"cover90": bool(st["q05"] < t < st["q95"]),
                  "z": float((st["mean"] - t) / st["sd"]), "sd": st["sd"]}
    return out


def one(seed, table, design, scale):
    cells, _ = synthetic.simulate_cells(72 * scale, 42 * scale, seed=seed, truth=TRUTH,
                                        surrogate=table, design_kwargs={"P_distribution": design})
    guess = models.PaperWLS(cells, table).fit().estimate
    row = {"seed": seed, "design": design, "scale": scale}
    for kind in ("plug_in", "known"):
        model = effects.ExtendedModel(cells, table, [])
        if kind == "known":
            known = true_population(design, model.obs.population)
            model.obs = dataclasses.replace(model.obs, population=known)
            model.lik = CellLikelihood(model.obs, table, n_nodes=model.lik.n_nodes,
                                       P0=model.lik.P0)
        post = criticism.fit_posterior(model, model.start_values(guess), seed,
                                       criticism.CriticismSettings())
        row[kind] = _summary(model, post)
    return row


def report(rows):
    lines = [f"{len(rows)} data sets; z change = z(known population) - z(plug-in)",
             f"{'parameter':<9}{'rms dz':>8}{'cover90 plug-in':>17}{'known':>7}"
             f"{'sd ratio':>10}"]
    for p in PARAMS:
        dz = np.array([r["known"][p]["z"] - r["plug_in"][p]["z"] for r in rows])
        ratio = np.median([r["known"][p]["sd"] / r["plug_in"][p]["sd"] for r in rows])
        c = [np.mean([r[k][p]["cover90"] for r in rows]) for k in ("plug_in", "known")]
        lines.append(f"{p:<9}{np.sqrt(np.mean(dz**2)):>8.2f}{c[0]:>17.3f}{c[1]:>7.3f}"
                     f"{ratio:>10.3f}")
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", choices=("lognormal", "loguniform"), default="loguniform")
    ap.add_argument("--scale", type=int, default=1)
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--seeds", type=int, nargs="+", default=None)
    ap.add_argument("--out", default="benchmarks/results/latent_population_cost.jsonl")
    ap.add_argument("--summarize", action="store_true", help="print the table of --out only")
    args = ap.parse_args()
    if not args.summarize:
        table = surrogate.load()
        seeds = args.seeds or range(args.first_seed, args.first_seed + args.n)
        with open(args.out, "a") as f:
            for seed in seeds:
                row = one(seed, table, args.design, args.scale)
                f.write(json.dumps(row) + "\n")
                f.flush()
                print(seed, {k: [round(row[k][p]["z"], 2) for p in PARAMS]
                             for k in ("plug_in", "known")}, flush=True)
    with open(args.out) as f:
        rows = [json.loads(line) for line in f if line.strip()]
    rows = [r for r in rows if r["design"] == args.design and r["scale"] == args.scale]
    print("\n".join(report(rows)))


if __name__ == "__main__":
    main()
