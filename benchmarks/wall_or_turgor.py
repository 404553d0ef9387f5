"""Did the treatment change turgor, or the wall? The turgor contrast of two conditions whose
walls may differ, headline (wall prior) against the shared-wall number, on simulated
experiments with known truths.

Each experiment: wt at 29 kPa with the paper's wall; treated with its own turgor and wall.
``--design ref``: 72 bulged cells in wt only (the README's design), 42 intact cells per
condition; ``--design both``: ``--n-bulged-both`` (default 30) bulged cells in each condition
and 42 intact per condition. ``--truths`` lists (E0t ratio, gamma difference, turgor change)
triples, e.g. ``0.7:0:0,1.3:0:0,1:0:-0.25``; ``prior`` draws the wall difference of each
experiment from the fit's own wall prior (the Bayesian calibration check).

Both models are fitted to every experiment with the criticism's posterior engine (Laplace
proposal, PSIS importance sampling, emcee where it fails;
:func:`turgorbayes.inference.engine.fit_posterior`) on
:class:`~turgorbayes.inference.conditions.ConditionsModel`, with the bulge population's noise
carried as ``turgorbayes fit`` carries it: ``wall`` (the headline, wall prior
:data:`~turgorbayes.inference.conditions.WALL_PRIOR` or ``--wall-prior``) and ``shared``
(``--assume-shared-wall``). A JSON line per experiment and model: quantiles of the P_phys
difference and of the treated/wt E0t ratio, whether the truths lie in the 90 % and 68 %
intervals, prob_greater and convergence. The last line summarizes per truth and model:
coverage of the difference (and of the E0t ratio), the rate of a claimed direction
(prob_greater outside [0.05, 0.95]) and the mean 90 % width.

Run: .venv/bin/python benchmarks/wall_or_turgor.py --design ref --n 100 \\
         --truths 0.7:0:0,1.3:0:0,1:0:-0.25 --out benchmarks/results/wall_or_turgor_ref.jsonl
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np

from turgorbayes import provenance, surrogate
from turgorbayes.inference import conditions, engine, models, wall_release
from turgorbayes.inference import population_noise as pop_noise
from turgorbayes.inference.priors import BASELINE_PRIORS
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation import conditions as synthetic_conditions
from turgorbayes.workflows import fit as results

P_REF = 29e3
TRUTH = synthetic.PAPER_TRUTH
DETECT = (0.05, 0.95)
BOUNDS = {"P": (BASELINE_PRIORS["P_phys"].lower, BASELINE_PRIORS["P_phys"].upper),
          "R0": (BASELINE_PRIORS["R0"].lower, BASELINE_PRIORS["R0"].upper)}


def parse_truths(text):
    """``"0.7:0:0,prior"`` -> list of (E0t ratio, gamma difference, turgor change) or
    ``"prior"``."""
    out = []
    for item in text.split(","):
        out.append("prior" if item == "prior" else tuple(float(x) for x in item.split(":")))
    return out


def experiment(seed, truth, design, n_bulged_both, table, wall_prior):
    """Cells of one experiment and its realized truth (E0t ratio, gamma difference, change)."""
    if truth == "prior":
        rng = np.random.default_rng(np.random.SeedSequence([seed, 51]))
        truth = (float(np.exp(rng.normal(0, wall_prior["E0t"]))),
                 float(rng.normal(0, wall_prior["gamma"])), 0.0)
    ratio, dgamma, change = truth
    n_bulged = {"wt": 72} if design == "ref" else {"wt": n_bulged_both, "treated": n_bulged_both}
    walls = {"treated": {"E0t": TRUTH.E0t * ratio, "gamma": TRUTH.gamma + dgamma}}
    cells = synthetic_conditions.simulate_conditions(
        {"wt": P_REF, "treated": P_REF * (1 + change)}, n_intact=42, n_bulged=n_bulged,
        seed=seed, surrogate=table, walls=walls)[0]
    return cells, truth


def posterior(cells, table, wall_prior, seed, fit_settings):
    """Weighted draws of the conditions model (physical values) and convergence: the wall
    prior's model as ``turgorbayes fit`` samples it (a condition with bulged cells samples its
    wall difference; one without is released afterwards, :func:`release`)."""
    cs = conditions.condition_set(cells, wall_prior=wall_prior)
    model = conditions.ConditionsModel(cells, table, cs)
    wls = models.PaperWLS(cells, table).fit()
    post = engine.fit_posterior(model, model.start_values(wls.estimate), seed,
                                engine.Settings.for_criticism(), pointwise=False)
    u = post.u
    if fit_settings.population_noise:
        sigma_g = model.population_shift_covariance(post.u_map, post.cov, seed,
                                                    fit_settings.population_noise_bootstrap)
        u = pop_noise.carry(u, sigma_g, engine.stream_rng(seed, 1003), log_prior=model.log_prior)
    v = model.to_physical(u)
    v.update(model.derived(u, engine.stream_rng(seed, 1000)))
    w = post.weights / np.sum(post.weights)
    if wall_prior and cs.released("E0t", 1):
        new = wall_release.release({"P": v["P_phys__1"], "R0": v["R0__1"], "gamma": v["gamma"],
                                    "E0t": v["E0t"]}, wall_prior, BOUNDS,
                                   engine.stream_rng(seed, 1010), models.P0, table)
        v.update({"P_phys__1": new["P"], "R0__1": new["R0"], "gamma__1": new["gamma"],
                  "E0t__1": new["E0t"]})
        w = w * np.exp(new["log_weight"] - np.max(new["log_weight"]))
        w = w / np.sum(w)
    values = [model.values(v, c) for c in (0, 1)]
    return values, w, post.converged


def score(x, w, truth):
    q = engine.weighted_quantiles(x, w, [0.05, 0.16, 0.5, 0.84, 0.95])
    return {"q05_q16_q50_q84_q95": np.asarray(q).tolist(), "in_90": bool(q[0] <= truth <= q[4]),
            "in_68": bool(q[1] <= truth <= q[3])}


def one(seed, truth, args, table, wall_prior, fit_settings):
    cells, (ratio, dgamma, change) = experiment(seed, truth, args.design, args.n_bulged_both,
                                                table, wall_prior)
    rows = []
    for name, prior in (("wall", wall_prior), ("shared", None)):
        t0 = time.perf_counter()
        (wt, tr), w, ok = posterior(cells, table, prior, seed, fit_settings)
        d = (tr[0] - wt[0]) / 1e3
        row = {"seed": seed, "design": args.design, "model": name,
               "truth": {"E0t_ratio": ratio, "gamma_difference": dgamma, "change": change},
               "truth_label": truth if truth == "prior" else ":".join(f"{x:g}" for x in truth),
               "difference_kPa": score(d, w, P_REF * change / 1e3),
               "prob_greater": float(np.sum(w * (tr[0] > wt[0]))),
               "E0t_ratio": score(tr[2] / wt[2], w, ratio),
               "converged": bool(ok), "seconds": round(time.perf_counter() - t0, 1)}
        rows.append(row)
    return rows


def summarize(rows):
    """Per truth and model: coverage, claimed direction, width."""
    out = {}
    for key in sorted({(r["design"], r["truth_label"], r["model"]) for r in rows}):
        r = [x for x in rows if (x["design"], x["truth_label"], x["model"]) == key]
        n = len(r)

        def rate(vals, n=n):
            p = float(np.mean(vals))
            return [p, float(np.sqrt(p * (1 - p) / n))]

        q = np.array([x["difference_kPa"]["q05_q16_q50_q84_q95"] for x in r])
        out[" ".join(key)] = {
            "n": n, "converged": sum(x["converged"] for x in r),
            "difference_coverage_90": rate([x["difference_kPa"]["in_90"] for x in r]),
            "difference_coverage_68": rate([x["difference_kPa"]["in_68"] for x in r]),
            "direction_claimed": rate([not DETECT[0] <= x["prob_greater"] <= DETECT[1]
                                       for x in r]),
            "prob_greater_above_0.95": rate([x["prob_greater"] > 0.95 for x in r]),
            "prob_greater_below_0.05": rate([x["prob_greater"] < 0.05 for x in r]),
            "mean_width_90_kPa": float(np.mean(q[:, 4] - q[:, 0])),
            "E0t_ratio_coverage_90": rate([x["E0t_ratio"]["in_90"] for x in r]),
            "E0t_ratio_coverage_68": rate([x["E0t_ratio"]["in_68"] for x in r])}
    return out


def read_rows(path):
    return [json.loads(line) for line in Path(path).read_text().splitlines()
            if line.startswith('{"seed"')]


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--design", choices=("ref", "both"), default="ref")
    parser.add_argument("--n-bulged-both", type=int, default=30)
    parser.add_argument("--truths", type=parse_truths, default=parse_truths("0.7:0:0,1.3:0:0"))
    parser.add_argument("--n", type=int, default=20, help="experiments per truth")
    parser.add_argument("--first-seed", type=int, default=5100)
    parser.add_argument("--wall-prior", default=None,
                        help="E0t=SD,gamma=SD (default: the fit's WALL_PRIOR)")
    parser.add_argument("--out", default=None)
    parser.add_argument("--summarize", nargs="+", default=None, metavar="ROWS.jsonl")
    args = parser.parse_args(argv)
    if args.summarize:
        print(json.dumps(summarize([r for p in args.summarize for r in read_rows(p)]), indent=1))
        return
    if args.out is None:
        parser.error("--out is required")
    wall_prior = dict(conditions.WALL_PRIOR)
    if args.wall_prior:
        wall_prior = {k: float(v) for k, v in (i.split("=") for i in args.wall_prior.split(","))}
    table = surrogate.load()
    fit_settings = results.FitSettings(progress=False)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    rows = []
    with out.open("w") as f:
        f.write(provenance.header_line() + "\n")
        for seed in range(args.first_seed, args.first_seed + args.n):
            for truth in args.truths:
                for row in one(seed, truth, args, table, wall_prior, fit_settings):
                    rows.append(row)
                    f.write(json.dumps(row) + "\n")
                    f.flush()
        f.write(json.dumps(summarize(rows)) + "\n")
    print(json.dumps(summarize(rows), indent=1))


if __name__ == "__main__":
    main()
