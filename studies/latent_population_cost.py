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

``--df-factor F`` deconvolves the plug-in with ``F`` times the package's number of spline
functions (:func:`turgorbayes.inference.population.spline_functions`; not capped at
``MAX_DF``): a more flexible family, to separate the family's smoothing (which more functions
reduce) from the estimate's noise.

Run: .venv/bin/python studies/latent_population_cost.py --design loguniform --scale 10 \
         --n 20 --out studies/results/latent_population_cost.jsonl
"""

import argparse
import json
import time

import numpy as np

from turgorbayes import criticism, effects, provenance, surrogate
from turgorbayes.criticism.stacking import weighted_stats
from turgorbayes.effects.pressure_range import PressureRange
from turgorbayes.inference import models, observations, population
from turgorbayes.inference.models import with_population
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import sbc
from turgorbayes.workflows.criticize import CriticismSettings

PARAMS = ("gamma", "E0t", "R0", "P_phys")
TRUTH = synthetic.TRUTHS["paper"]
#: A smoke run: one data set of 24 bulged + 14 intact cells, few draws, short chains.
SMOKE_CELLS = (24, 14)
SMOKE_SETTINGS = CriticismSettings(n_draws=200, ess_min=20, n_ensembles=2, tol=5, check_every=20,
                                   max_steps=200)


def true_population(design, plug_in):
    """The population the design draws from, on a grid covering the plug-in's support."""
    lo, hi = np.log(synthetic.DEFAULT_P_RANGE)
    if design == "lognormal":  # synthetic.draw_design: mean (lo + hi)/2, sd (hi - lo)/4
        return population.NormalPopulation(mu=(lo + hi) / 2, tau=(hi - lo) / 4)
    return population.ramped_box(plug_in, lo, hi)


def _summary(model, post):
    return sbc.truth_summary(model, post, TRUTH, PARAMS)


def _plug_in(model, df_factor):
    """The model's plug-in population, deconvolved with ``df_factor`` times its functions."""
    if df_factor == 1:
        return model
    obs = model.obs
    df = int(round(df_factor * population.spline_functions(obs.log_P_bulge.size)))
    return with_population(
        model, population.deconvolve_family(obs.log_P_bulge, obs.sd_log_P_bulge, df=df))


#: Seed offset of the independent data set whose bulges give the ``independent`` arm's population.
INDEPENDENT_OFFSET = 10**6


def independent_population(model, seed, table, design, scale):
    """The plug-in deconvolved from the bulges of another data set of the same design (seed
    ``seed + INDEPENDENT_OFFSET``), on the model's grid: the same estimator, its noise
    independent of this data set's."""
    other, _ = synthetic.simulate_cells(72 * scale, 42 * scale, seed=seed + INDEPENDENT_OFFSET,
                                        truth=TRUTH, surrogate=table,
                                        design_kwargs={"P_distribution": design})
    obs = observations.observations_from_cells(other)
    df = population.spline_functions(obs.log_P_bulge.size)
    return population.deconvolve(obs.log_P_bulge, obs.sd_log_P_bulge, df=df,
                                 grid=model.obs.population.grid)


def one(seed, table, design, scale, df_factor=1.0, reference="known", arms=("plug_in", "known"),
        smoke=False):
    n_cells = SMOKE_CELLS if smoke else (72 * scale, 42 * scale)
    settings = SMOKE_SETTINGS if smoke else CriticismSettings()
    cells, _ = synthetic.simulate_cells(*n_cells, seed=seed, truth=TRUTH,
                                        surrogate=table, design_kwargs={"P_distribution": design})
    guess = models.PaperWLS(cells, table).fit().estimate
    row = {"seed": seed, "design": design, "scale": scale, "df_factor": df_factor}
    if reference != "known":
        row["reference"] = reference
    for kind in arms:
        model = effects.ExtendedModel(cells, table,
                                      [PressureRange()] if kind == "range" else [])
        if kind == "plug_in":
            model = _plug_in(model, df_factor)
        if kind == "known":
            if reference == "edges":
                known, row["edges"] = population.fitted_box(
                    model.obs.log_P_bulge, model.obs.sd_log_P_bulge, model.obs.population)
            else:
                known = true_population(design, model.obs.population)
            model = with_population(model, known)
        if kind == "independent":
            model = with_population(model, independent_population(model, seed, table, design,
                                                                  scale))
        t0 = time.perf_counter()
        post = criticism.fit_posterior(model, model.start_values(guess), seed, settings)
        row[kind] = _summary(model, post)
        row[kind]["seconds"] = round(time.perf_counter() - t0, 1)
        if kind == "range":
            phys = model.to_physical(post.u)
            row[kind]["hyper"] = {p: weighted_stats(phys[p], post.weights)["mean"]
                                  for p in ("P_lo", "span", "w_edge")}
    return row


def bootstrap_row(seed, table, design, scale, df_factor, n_boot):
    """z-scores of ``n_boot`` fits with the plug-in deconvolved from resampled bulges."""
    cells, _ = synthetic.simulate_cells(72 * scale, 42 * scale, seed=seed, truth=TRUTH,
                                        surrogate=table, design_kwargs={"P_distribution": design})
    guess = models.PaperWLS(cells, table).fit().estimate
    rng = np.random.default_rng(seed)
    boot = []
    for _ in range(n_boot):
        model = _plug_in(effects.ExtendedModel(cells, table, []), df_factor)
        obs, grid = model.obs, model.obs.population.grid
        idx = rng.integers(0, obs.log_P_bulge.size, obs.log_P_bulge.size)
        df = int(round(df_factor * population.spline_functions(obs.log_P_bulge.size)))
        pop = population.deconvolve(obs.log_P_bulge[idx], obs.sd_log_P_bulge[idx], df=df,
                                    grid=grid)
        model = with_population(model, pop)
        post = criticism.fit_posterior(model, model.start_values(guess), seed,
                                       CriticismSettings())
        boot.append(_summary(model, post))
    return {"seed": seed, "design": design, "scale": scale, "df_factor": df_factor,
            "bootstrap": boot}


def bootstrap_report(rows):
    lines = [f"{len(rows)} data sets, {len(rows[0]['bootstrap'])} bootstrap fits each",
             f"{'parameter':<9}{'rms sd of z over bootstrap':>28}"]
    for p in PARAMS:
        sd = [np.std([b[p]["z"] for b in r["bootstrap"]], ddof=1) for r in rows]
        lines.append(f"{p:<9}{np.sqrt(np.mean(np.square(sd))):>28.2f}")
    return lines


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


def report_arms(rows, arms=("plug_in", "known", "range")):
    """Mean z per arm (with its standard error) and the paired differences from the plug-in."""
    lines = [f"{len(rows)} data sets; mean z +- SE per arm; paired difference from the plug-in"
             " (mean +- SE)"]
    for p in PARAMS:
        z = {a: np.array([r[a][p]["z"] for r in rows]) for a in arms}
        se = {a: z[a].std(ddof=1) / np.sqrt(z[a].size) for a in arms}
        parts = [f"{a} {z[a].mean():+.2f}+-{se[a]:.2f}" for a in arms]
        for a in arms[1:]:
            d = z[a] - z[arms[0]]
            parts.append(f"{a}-{arms[0]} {d.mean():+.2f}+-{d.std(ddof=1) / np.sqrt(d.size):.2f}")
        lines.append(f"{p:<7} " + "  ".join(parts))
    cover = {a: np.mean([r[a][p]["cover90"] for r in rows for p in PARAMS]) for a in arms}
    lines.append("90 % intervals covering, all parameters pooled: "
                 + ", ".join(f"{a} {c:.2f}" for a, c in cover.items()))
    lines.append("seconds per fit (median): " + ", ".join(
        f"{a} {np.median([r[a]['seconds'] for r in rows]):.0f}" for a in arms))
    return lines


def coverage_pair_lines(rows, coverage_rows, arm):
    """``arm``'s z-scores against the plug-in's of ``studies/coverage.py --engine importance``
    on the same data sets (the same fits as this script's plug-in arm, to every digit)."""
    plug = {r["seed"]: r for r in coverage_rows if r["converged"]}
    rows = [r for r in rows if r[arm]["converged"] and r["seed"] in plug]
    lines = [f"{len(rows)} data sets; {arm} against the plug-in (coverage rows, same seeds)",
             f"{'parameter':<9}{'sd z plug-in':>13}{arm:>13}{'cover90 plug-in':>17}{arm:>13}"
             f"{'sd of dz':>10}"]
    for p in PARAMS:
        za = np.array([plug[r["seed"]][p]["z_post"] for r in rows])
        zb = np.array([r[arm][p]["z"] for r in rows])
        ca = np.mean([plug[r["seed"]][p]["cover90"] for r in rows])
        cb = np.mean([r[arm][p]["cover90"] for r in rows])
        lines.append(f"{p:<9}{za.std(ddof=1):>13.2f}{zb.std(ddof=1):>13.2f}{ca:>17.2f}{cb:>13.2f}"
                     f"{(zb - za).std(ddof=1):>10.2f}")
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--design", choices=("lognormal", "loguniform"), default="loguniform")
    ap.add_argument("--scale", type=int, default=1)
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=1000)
    ap.add_argument("--seeds", type=int, nargs="+", default=None)
    ap.add_argument("--df-factor", type=float, default=1.0)
    ap.add_argument("--bootstrap", type=int, default=0)
    ap.add_argument("--population", choices=("known", "edges"), default="known",
                    help="the reference the plug-in is compared with")
    ap.add_argument("--arms", nargs="+", default=["plug_in", "known"],
                    choices=("plug_in", "known", "range", "independent"),
                    help="fits per data set: the plug-in population, the reference "
                         "(--population), the hierarchical population with free edges "
                         "(turgorbayes.effects.pressure_range), the plug-in estimated from an "
                         "independent data set's bulges (is the data's double use the cause?)")
    ap.add_argument("--out", default=None,
                    help="JSON-lines file (default: latent_population_cost.jsonl in --output-dir, or in "
                         "studies/results with --update)")
    provenance.add_output_options(ap)
    ap.add_argument("--summarize", action="store_true", help="print the table of --out only")
    ap.add_argument("--coverage-rows", nargs="+", default=None, metavar="ROWS.jsonl",
                    help="with --summarize and one arm: compare it with the plug-in's z-scores "
                         "in these studies/coverage.py rows")
    args = ap.parse_args()
    if args.smoke:  # one data set (see one()), a new file in --output-dir
        args.seeds, args.bootstrap = args.seeds or [args.first_seed], 0
        args.out = args.out or str(provenance.study_path(args, "latent_population_cost.jsonl"))
        open(args.out, "w").close()
    args.out = args.out or str(provenance.study_path(args, "latent_population_cost.jsonl"))
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    if not args.summarize:
        table = surrogate.load()
        seeds = args.seeds or range(args.first_seed, args.first_seed + args.n)
        with open(args.out, "a") as f:
            for seed in seeds:
                if args.bootstrap:
                    row = bootstrap_row(seed, table, args.design, args.scale, args.df_factor,
                                        args.bootstrap)
                    print(seed, [[round(b[p]["z"], 2) for p in PARAMS]
                                 for b in row["bootstrap"]], flush=True)
                else:
                    row = one(seed, table, args.design, args.scale, args.df_factor,
                              args.population, args.arms, args.smoke)
                    print(seed, {k: [round(row[k][p]["z"], 2) for p in PARAMS]
                                 for k in args.arms}, flush=True)
                f.write(json.dumps(dict(row, provenance=record)) + "\n")
                f.flush()
    with open(args.out) as f:
        rows = [json.loads(line) for line in f if line.strip()]
    rows = [r for r in rows if r["design"] == args.design and r["scale"] == args.scale
            and r.get("df_factor", 1.0) == args.df_factor
            and ("bootstrap" in r) == bool(args.bootstrap)
            and r.get("reference", "known") == args.population]
    if args.coverage_rows:
        cov = [json.loads(x) for f in args.coverage_rows for x in open(f) if x.strip()]
        print("\n".join(coverage_pair_lines(rows, cov, args.arms[0])))
    elif "range" in args.arms or "independent" in args.arms:
        rows = [r for r in rows if all(a in r for a in args.arms)]
        print("\n".join(report_arms(rows, tuple(args.arms))))
    else:
        print("\n".join(bootstrap_report(rows) if args.bootstrap else report(rows)))


if __name__ == "__main__":
    main()
