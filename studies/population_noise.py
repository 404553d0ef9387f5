"""How much the plug-in population's estimation noise moves the posterior, by bootstrap, against
refits with an independent data set's population.

For each data set (``--scale`` times the paper's 72 bulged + 42 intact cells, the hard-edged
log-uniform design unless ``--design`` says otherwise, seeds from ``--first-seed``): the
Laplace fit of the baseline, then ``Sigma_g`` of
:mod:`turgorbayes.inference.population_noise` from ``--n-boot`` bootstrap populations. A row
records, per parameter, ``sqrt(Sigma_g)`` over the Laplace sd (the shift's sd in posterior sds;
the 90 % interval of the carried posterior is ``sqrt(1 + r^2)`` times wider) and, for the
first ``--exact`` bootstrap populations, the linear shift beside an exact refit of the mode.

``--independent ROWS.jsonl`` (rows of ``latent_population_cost.py --arms independent``) and
``--coverage-rows ROWS.jsonl`` (the plug-in's rows of ``coverage.py`` on the same seeds) print
the comparison: the sd of the z-score's change between the data set's own population and an
independent one, over ``sqrt(2)`` (two independent estimates), against the bootstrap's RMS.

Run: .venv/bin/python studies/population_noise.py --scale 20 --n 30 \
         --out studies/results/population_noise_20x.jsonl
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np

from turgorbayes import effects, provenance, surrogate
from turgorbayes.inference import mode, models, population_noise
from turgorbayes.simulation import cells as synthetic

PARAMS = ("gamma", "E0t", "R0", "P_phys")


def one(seed, table, scale, design, n_boot, n_exact, sizes=None):
    n_bulged, n_intact = sizes or (72 * scale, 42 * scale)
    cells, _ = synthetic.simulate_cells(n_bulged, n_intact, seed=seed, surrogate=table,
                                        design_kwargs={"P_distribution": design})
    model = effects.ExtendedModel(cells, table, [])
    guess = models.PaperWLS(cells, table).fit().estimate
    lap = mode.laplace_fit(model, model.to_u(model.start_values(guess))[0])
    sd = np.sqrt(np.diag(lap.cov))
    t0 = time.perf_counter()
    pops, shifts = population_noise.bootstrap_shifts(model, lap.u_map, lap.cov, seed, n_boot)
    seconds = time.perf_counter() - t0
    row = {"seed": seed, "scale": scale, "design": design, "n_boot": n_boot,
           "seconds_bootstrap": round(seconds, 1),
           "shift_sd": dict(zip(PARAMS, (shifts.std(axis=0, ddof=1) / sd)[:4].tolist(),
                                strict=True)),
           "shift_mean": dict(zip(PARAMS, (shifts.mean(axis=0) / sd)[:4].tolist(), strict=True))}
    exact = []
    for pop, lin in zip(pops[:n_exact], shifts[:n_exact], strict=False):
        with population_noise.using_population(model, pop):
            refit = mode.mode_search(model, lap.u_map).u
        exact.append({"linear": (lin / sd).tolist(), "exact": ((refit - lap.u_map) / sd).tolist()})
    row["exact"] = exact
    return row


def read(path):
    with open(path) as fh:
        return [json.loads(line) for line in fh if line.strip()]


def report(rows, independent=None, coverage_rows=None):
    lines = [f"{len(rows)} data sets at {rows[0]['scale']}x ({rows[0]['design']}), "
             f"{rows[0]['n_boot']} bootstrap populations each; median "
             f"{np.median([r['seconds_bootstrap'] for r in rows]):.1f} s for the bootstrap"]
    ex = [e for r in rows for e in r["exact"]]
    if ex:
        diff = [np.max(np.abs(np.subtract(e["linear"], e["exact"]))) for e in ex]
        lines.append(f"linear shift against exact mode refit, largest difference over the "
                     f"parameters: median {np.median(diff):.4f}, 95th percentile "
                     f"{np.percentile(diff, 95):.4f}, largest {np.max(diff):.4f} posterior sds "
                     f"over {len(ex)} populations")
    head = f"{'parameter':<10}{'bootstrap RMS':>14}{'widening':>10}"
    pair = None
    if independent and coverage_rows:
        own = {r["seed"]: r for r in read(coverage_rows)}
        pair = [(r, own[r["seed"]]) for r in read(independent) if r["seed"] in own]
        seeds = {r["seed"] for r in rows}
        pair = [(a, b) for a, b in pair if a["seed"] in seeds]
        head += f"{'independent sd(dz)/sqrt2':>26}  (over {len(pair)} common seeds)"
    lines.append(head)
    for p in PARAMS:
        rms = np.sqrt(np.mean([r["shift_sd"][p] ** 2 for r in rows]))
        line = f"{p:<10}{rms:>14.3f}{np.sqrt(1 + rms ** 2):>10.3f}"
        if pair:
            dz = [a["independent"][p]["z"] - b[p]["z_post"] for a, b in pair]
            line += f"{np.std(dz, ddof=1) / np.sqrt(2):>26.3f}"
        lines.append(line)
    return lines


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scale", type=int, default=20)
    parser.add_argument("--design", choices=synthetic.P_DISTRIBUTIONS, default="loguniform")
    parser.add_argument("--n", type=int, default=30)
    parser.add_argument("--first-seed", type=int, default=1000)
    parser.add_argument("--n-boot", type=int, default=population_noise.N_BOOTSTRAP)
    parser.add_argument("--exact", type=int, default=0,
                        help="bootstrap populations per data set also refitted exactly")
    parser.add_argument("--out", default=None,
                        help="JSON-lines file (default: population_noise.jsonl in --output-dir, or in "
                             "studies/results with --update)")
    provenance.add_output_options(parser)
    parser.add_argument("--independent", default=None)
    parser.add_argument("--coverage-rows", default=None)
    parser.add_argument("--summarize", action="store_true", help="only print the table")
    args = parser.parse_args()
    sizes = None  # the paper's cells times --scale
    if args.smoke:  # one data set of 12 + 8 cells, 5 bootstrap populations, one refitted exactly
        args.n, args.n_boot, args.exact, sizes = 1, 5, 1, (12, 8)
    args.out = args.out or str(provenance.study_path(args, "population_noise.jsonl"))
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    if not args.summarize:
        table = surrogate.load()
        done = {r["seed"] for r in read(args.out)} if Path(args.out).exists() else set()
        for seed in range(args.first_seed, args.first_seed + args.n):
            if seed in done:
                continue
            row = one(seed, table, args.scale, args.design, args.n_boot, args.exact, sizes)
            with open(args.out, "a") as fh:
                fh.write(json.dumps(dict(row, provenance=record)) + "\n")
            print(seed, {p: round(v, 3) for p, v in row["shift_sd"].items()}, flush=True)
    print("\n".join(report(read(args.out), args.independent, args.coverage_rows)))


if __name__ == "__main__":
    main()
