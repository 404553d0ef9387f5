"""Calibration of the baseline posterior: how often do 90 % and 68 % intervals cover the truth?

Simulates ``--n`` data sets (``--scale`` times 72 bulged + 42 intact cells, the paper's values
unless ``--truth`` says otherwise, bulge pressures log-uniform over 1-25 kPa (hard edges) or
``--design lognormal`` (smooth), data seeds 1000, 1001, ...), fits each with the baseline model
and records whether the central 90 % and 68 % posterior intervals of gamma, E0t, R0 and P_phys
contain the truth; beside it the same for the published method (paper_wls, estimate -+ 1.645
and 1 standard errors, pressures plugged in). ``--engine mcmc`` (default) is the CLI's emcee
fit to convergence; ``--engine importance`` the criticism's Laplace + importance sampling
(emcee where that does not converge), cheap enough for hundreds of data sets and checked
against MCMC on the same seeds (``--compare A.jsonl B.jsonl`` prints the per-seed agreement of
the two engines' z-scores). Target: 90 % intervals cover 87-93 %, 68 % intervals 63-73 %.
``--pool A.jsonl B.jsonl ...`` prints one table over blocks of the same setting run on disjoint
seeds (each block's own line first). Rows that share seeds share most of their random numbers
even across designs and truths (the simulator's noise streams are the same, shifted by a few
draws), so only disjoint seeds count as independent evidence; ``--compare`` on two settings'
files shows how strongly (docs/validation.md, "Over designs and truths"). Both engines carry
the plug-in population's estimation noise as ``fit`` does
(:mod:`turgorbayes.inference.population_noise`) unless ``--no-population-noise``; rows say
which (rows without the key did not), and ``--pool`` refuses to mix them.
Results are appended to a JSON-lines file as they come (rerunning resumes), and the table is
printed at the end with Clopper-Pearson 95 % intervals.

Run: .venv/bin/python studies/coverage.py --n 100 --design lognormal \
         --out studies/results/coverage_lognormal.jsonl
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np
from scipy import stats

from turgorbayes import __version__, criticism, effects, provenance, surrogate
from turgorbayes.criticism.stacking import weighted_quantiles
from turgorbayes.inference import models, population_noise
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import fit as results
from turgorbayes.workflows.criticize import CriticismSettings

PARAMS = ("gamma", "E0t", "R0", "P_phys")
TRUTHS = synthetic.TRUTHS
#: The sampler's settings of a smoke run: short chains, a few bootstrap populations.
SMOKE_SAMPLER = {"n_walkers": 12, "n_ensembles": 2, "tol": 5, "check_every": 20, "max_steps": 40,
                 "max_draws_per_chain": 50, "population_noise_bootstrap": 4}


def _draws(cells, table, seed, engine, settings):
    """Posterior draws ``{name: (S,)}``, weights, converged, the paper_wls fit."""
    if engine == "mcmc":
        res = results.fit_cells(cells, "baseline", seed=seed, surrogate=table, settings=settings)
        draws = {p: np.asarray(res.draws[p]).ravel() for p in PARAMS}
        return draws, np.ones(draws["gamma"].size), res.converged, res.wls
    model = effects.ExtendedModel(cells, table, [])
    wls = models.PaperWLS(cells, table).fit()
    post = criticism.fit_posterior(model, model.start_values(wls.estimate), seed,
                                   CriticismSettings())
    u = post.u
    if settings.population_noise:  # as fit_cells does (turgorbayes.inference.population_noise)
        sigma_g = population_noise.shift_covariance(model, post.u_map, post.cov, seed,
                                                    settings.population_noise_bootstrap)
        u = population_noise.carry(u, sigma_g, np.random.default_rng([seed, 3]))
    phys = model.to_physical(u)
    return {p: phys[p] for p in PARAMS}, post.weights, post.converged, wls


def one(seed, truth, table, settings, design="loguniform", scale=1, engine="mcmc"):
    cells, _ = synthetic.simulate_cells(n_bulged=72 * scale, n_intact=42 * scale, seed=seed,
                                        truth=truth, surrogate=table,
                                        design_kwargs={"P_distribution": design})
    t = time.perf_counter()
    draws, w, converged, wls = _draws(cells, table, seed, engine, settings)
    row = {"seed": seed, "converged": bool(converged), "time_s": time.perf_counter() - t,
           "design": design, "scale": scale, "engine": engine, "version": __version__,
           "population_noise": bool(settings.population_noise)}
    for p in PARAMS:
        true = getattr(truth, p)
        lo, l68, h68, hi = weighted_quantiles(draws[p], w, [0.05, 0.16, 0.84, 0.95])
        mean = np.sum(w * draws[p]) / np.sum(w)
        sd = np.sqrt(np.sum(w * (draws[p] - mean) ** 2) / np.sum(w))
        est, se = wls.estimate[p], wls.sd[p]
        row[p] = {"cover90": bool(lo < true < hi), "cover68": bool(l68 < true < h68),
                  "wls_cover90": bool(abs(est - true) < 1.6448536 * se),
                  "wls_cover68": bool(abs(est - true) < se),
                  "z_post": float((mean - true) / sd),
                  "z_wls": float((est - true) / se)}
    return row


def _ci(k, n):
    """Clopper-Pearson 95 % interval of a binomial proportion."""
    lo = stats.beta.ppf(0.025, k, n - k + 1) if k > 0 else 0.0
    hi = stats.beta.ppf(0.975, k + 1, n - k) if k < n else 1.0
    return lo, hi


def _rate(k, n):
    lo, hi = _ci(k, n)
    return f"{k / n:6.1%} [{lo:5.1%}, {hi:5.1%}]"


def table_lines(rows):
    """The coverage table over the converged fits of ``rows``."""
    n_all = len(rows)
    rows = [r for r in rows if r["converged"]]
    n = len(rows)
    if not n:  # no rates (a smoke run's short chains)
        return [f"{n_all} data sets, none converged"]
    lines = [f"{n_all} data sets, {n} converged (coverage over converged fits); "
             f"median fit {np.median([r['time_s'] for r in rows]):.0f} s",
             f"{'parameter':10s} {'baseline 90%':>22s} {'baseline 68%':>22s} "
             f"{'paper_wls 90%':>22s} {'wls 68%':>8s} {'mean z post':>11s} {'sd z':>5s} "
             f"{'mean z wls':>10s}"]
    for p in PARAMS:
        k = sum(r[p]["cover90"] for r in rows)
        kw = sum(r[p]["wls_cover90"] for r in rows)
        k68 = sum(r[p]["cover68"] for r in rows)
        kw68 = sum(r[p]["wls_cover68"] for r in rows)
        z = [r[p]["z_post"] for r in rows]
        lines.append(
            f"{p:10s} {_rate(k, n)} {_rate(k68, n)} {_rate(kw, n)} {kw68 / n:8.1%} "
            f"{np.mean(z):+11.2f} {np.std(z):5.2f} "
            f"{np.mean([r[p]['z_wls'] for r in rows]):+10.2f}")
    return lines


def compare_lines(a_rows, b_rows):
    """Per-seed agreement of two engines' posterior z-scores on the same data sets."""
    b = {r["seed"]: r for r in b_rows}
    common = [(r, b[r["seed"]]) for r in a_rows if r["seed"] in b]
    lines = [f"{len(common)} data sets fitted by both: {a_rows[0]['engine']} vs "
             f"{b_rows[0]['engine']}",
             f"{'parameter':10s} {'corr z':>7s} {'mean |dz|':>9s} {'max |dz|':>9s} "
             f"{'same cover90':>12s}"]
    for p in PARAMS:
        za = np.array([x[p]["z_post"] for x, _ in common])
        zb = np.array([y[p]["z_post"] for _, y in common])
        same = np.mean([x[p]["cover90"] == y[p]["cover90"] for x, y in common])
        lines.append(f"{p:10s} {np.corrcoef(za, zb)[0, 1]:7.3f} {np.mean(abs(za - zb)):9.3f} "
                     f"{np.max(abs(za - zb)):9.3f} {same:12.2f}")
    return lines


def read_rows(path):
    """The rows of a JSON-lines file of this script."""
    return [json.loads(x) for x in Path(path).read_text().splitlines() if x.strip()]


def pool_lines(blocks):
    """The table over several files of one setting on disjoint seeds, each file's 90 % line
    first; refuses blocks of different settings or with a seed in common."""
    # rows written before the population noise was carried (2026-11-27) did not carry it
    settings = {(r["design"], r["scale"], r["engine"], r.get("population_noise", False))
                for rows in blocks.values() for r in rows}
    # rows written before the truth was recorded do not say it; their file names do
    truths = {r["truth"] for rows in blocks.values() for r in rows if "truth" in r}
    if len(settings) != 1 or len(truths) > 1:
        raise SystemExit(f"--pool: the files mix settings {sorted(settings)}, truths {truths}")
    seen, lines = {}, []
    for name, rows in blocks.items():
        for r in rows:
            if r["seed"] in seen:
                raise SystemExit(f"--pool: seed {r['seed']} is in {seen[r['seed']]} and {name}")
            seen[r["seed"]] = name
        conv = [r for r in rows if r["converged"]]
        seeds = [r["seed"] for r in rows]
        lines.append(f"{name}: seeds {min(seeds)}-{max(seeds)}, {len(conv)} converged; 90 %: "
                     + " / ".join(f"{sum(r[p]['cover90'] for r in conv) / len(conv):.1%}"
                                  for p in PARAMS))
    return lines + table_lines([r for rows in blocks.values() for r in rows])


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=50)
    parser.add_argument("--truth", choices=sorted(TRUTHS), default="paper")
    parser.add_argument("--design", choices=synthetic.P_DISTRIBUTIONS, default="loguniform")
    parser.add_argument("--scale", type=int, default=1, help="times the paper's cell counts")
    parser.add_argument("--engine", choices=("mcmc", "importance"), default="mcmc")
    parser.add_argument("--out", default="studies/coverage.jsonl")
    parser.add_argument("--first-seed", type=int, default=1000)
    parser.add_argument("--compare", nargs=2, default=None, metavar=("A.jsonl", "B.jsonl"),
                        help="print the agreement of two runs on their common seeds and exit")
    parser.add_argument("--pool", nargs="+", default=None, metavar="ROWS.jsonl",
                        help="print one table over blocks of one setting on disjoint seeds "
                             "and exit")
    parser.add_argument("--no-population-noise", action="store_true",
                        help="fit with the plug-in population held fixed (the package before "
                             "2026-11-27)")
    provenance.add_output_options(parser)
    args = parser.parse_args()
    if args.smoke:  # one data set, short chains, a new file in --output-dir
        args.n, args.out = 1, provenance.study_path(args, "coverage.jsonl")
        args.out.unlink(missing_ok=True)
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    if args.pool:
        print("\n".join(pool_lines({f: read_rows(f) for f in args.pool})))
        return
    if args.compare:
        a, b = (read_rows(f) for f in args.compare)
        print("\n".join(compare_lines(a, b)))
        return
    table = surrogate.load()
    out = Path(args.out)
    done = {row["seed"]: row for row in read_rows(out)} if out.is_file() else {}
    settings = results.FitSettings(**{"progress": False, "max_draws_per_chain": 500,
                                      "population_noise": not args.no_population_noise,
                                      **(SMOKE_SAMPLER if args.smoke else {})})
    truth = TRUTHS[args.truth]
    rows = []
    for seed in range(args.first_seed, args.first_seed + args.n):
        if seed not in done:
            done[seed] = one(seed, truth, table, settings, args.design, args.scale, args.engine)
            done[seed]["truth"] = args.truth
            with out.open("a") as fh:
                fh.write(json.dumps(dict(done[seed], provenance=record)) + "\n")
            r = done[seed]
            print(f"seed {seed}: {r['time_s']:.0f} s, converged {r['converged']}, covered "
                  + " ".join(f"{p}={'y' if r[p]['cover90'] else 'N'}" for p in PARAMS),
                  flush=True)
        rows.append(done[seed])
    print(f"truth: {args.truth} {truth}; design {args.design}; {args.scale}x the paper's cells; "
          f"engine {args.engine}")
    print("\n".join(table_lines(rows)))


if __name__ == "__main__":
    main()
