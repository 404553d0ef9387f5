"""Simulation-based calibration of the baseline (turgorbayes.workflows.sbc): rank histograms and p-values.

Runs ``--n`` replications at each ``--scale`` (times the paper's 72 bulged + 42 intact cells),
of the baseline or (``--effect NAME``) the baseline plus an effect whose size is drawn from its
prior and planted in the data, prints the chi-square uniformity p-value of the ranks and the
mean/sd of the mode's z per parameter, appends the ranks to ``studies/results/sbc.jsonl``
and draws the rank histograms of every row in the file into ``docs/figures/sbc_ranks.png``.

Run: .venv/bin/python studies/sbc.py --n 200 --scale 1 [--scale 10 --n 100]
[--engine importance|mcmc] [--effect radius_spread] [--plot-only]
[--merge CHUNKS.jsonl]  (one row from chunks run with --first-seed 0, 50, ...)
[--population known --results studies/results/sbc_population.jsonl]

``--population known`` is a diagnostic: every replication's fit is given the simulator's own
population of bulge pressures (log-uniform over 1-25 kPa, edges ramped over 0.03 in ln P as in
``latent_population_cost.py``) instead of the plug-in deconvolved from its bulges, so that a
tilt the plug-in causes disappears (docs/validation.md, "Simulation-based calibration").
"""

import argparse
import json
import pathlib

import numpy as np

from turgorbayes import __version__, provenance, surrogate
from turgorbayes.inference import models, population
from turgorbayes.progress import progress as show_progress
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import sbc

RESULTS = pathlib.Path(__file__).parent / "results" / "sbc.jsonl"
FIGURE = pathlib.Path(__file__).parent.parent / "docs" / "figures" / "sbc_ranks.png"


def known_population(model_cls):
    """``model_cls`` fitted with the simulator's population of bulge pressures."""
    lo, hi = np.log(synthetic.DEFAULT_P_RANGE)

    class Known(model_cls):
        def __init__(self, cells, table, **kwargs):
            super().__init__(cells, table, **kwargs)
            models.with_population(self, population.ramped_box(self.obs.population, lo, hi))

    Known.__name__ = f"{model_cls.__name__}KnownPopulation"
    return Known


def run(args):
    table = surrogate.load()
    for scale in args.scale:
        model = sbc.sbc_model(effects=args.effect or ()) \
            if args.effect or args.engine == "importance" else sbc.sbc_model()
        if args.population == "known":
            model = known_population(model)
        r = sbc.run_sbc(table, args.n, first_seed=args.first_seed,
                        n_cells=args.n_cells or (72 * scale, 42 * scale), n_draws=args.draws,
                        engine=args.engine, model_cls=model, progress=lambda reps: show_progress(
                            reps, desc="SBC", unit="replication"))
        p = r.p_values()
        print(f"scale {scale}: {args.n} replications ({len(r.unconverged)} left out, not "
              f"converged: {list(r.unconverged)}), {args.draws} draws ({args.engine}), "
              f"effects {args.effect or 'none'}")
        for j, name in enumerate(r.names):
            print(f"  {name:>7}: chi-square p = {p[j]:.3f}, mode z mean {r.z[:, j].mean():+.2f} "
                  f"sd {r.z[:, j].std(ddof=1):.2f}", flush=True)
        with pathlib.Path(args.results).open("a") as f:
            f.write(json.dumps({"version": __version__, "provenance": provenance.run_record(),
                                "scale": scale, "engine": args.engine,
                                "population": args.population,
                                "effects": list(args.effect or []),
                                "unconverged": list(r.unconverged),
                                "n_draws": r.n_draws, "names": list(r.names),
                                "seeds": r.seeds.tolist(), "ranks": r.ranks.tolist(),
                                "z": np.round(r.z, 4).tolist(),
                                "p_values": [float(v) for v in p]}) + "\n")


def merge(chunks, results):
    """Append to ``results`` one row per setting (scale, engine, effects, draws) of the rows in
    the file ``chunks`` (runs split by ``--first-seed``), the p-values recomputed over all."""
    rows = [json.loads(line) for line in pathlib.Path(chunks).read_text().splitlines()
            if line.strip()]
    groups = {}
    for row in rows:
        key = (row["scale"], row["engine"], tuple(row["effects"]), row["n_draws"])
        groups.setdefault(key, []).append(row)
    with pathlib.Path(results).open("a") as f:
        for group in groups.values():
            out = dict(group[0])
            for k in ("seeds", "ranks", "z", "unconverged"):
                out[k] = [v for row in group for v in row[k]]
            if len(set(out["seeds"])) != len(out["seeds"]):
                raise SystemExit(f"{chunks}: a seed appears in two chunks")
            out["chunk_provenance"] = [row.get("provenance") for row in group]
            out["provenance"] = provenance.run_record()
            out["p_values"] = [float(v) for v in
                               sbc.rank_uniformity(out["ranks"], out["n_draws"])]
            print(f"merged {len(group)} chunks: {len(out['seeds'])} replications, p = "
                  f"{np.round(out['p_values'], 3).tolist()}")
            f.write(json.dumps(out) + "\n")


def plot(results=RESULTS, figure=FIGURE):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [json.loads(line) for line in pathlib.Path(results).read_text().splitlines()
            if line.strip()]
    n_cols = max(len(row["names"]) for row in rows)
    fig, axes = plt.subplots(len(rows), n_cols, figsize=(2.6 * n_cols, 2.2 * len(rows)),
                             squeeze=False)
    for ax_row, row in zip(axes, rows, strict=True):
        for ax in ax_row[len(row["names"]):]:
            ax.axis("off")
        ranks, n_draws = np.array(row["ranks"]), row["n_draws"]
        n_bins = 20 if (n_draws + 1) % 20 == 0 and len(ranks) >= 100 else 10
        expected = len(ranks) / n_bins
        band = 1.96 * np.sqrt(expected * (1 - 1 / n_bins))  # binomial 95 % band per bin
        for ax, name, col, p in zip(ax_row[:len(row["names"])], row["names"], ranks.T,
                                    row["p_values"], strict=True):
            ax.hist(col, bins=np.linspace(0, n_draws + 1, n_bins + 1), color="0.6")
            ax.axhspan(expected - band, expected + band, color="C0", alpha=0.2, lw=0)
            model = "+".join(row.get("effects") or []) or "baseline"
            if row.get("population", "plug_in") != "plug_in":
                model += f", {row['population']} pop."
            ax.set_title(f"{name}, {model}\n{row['scale']}x, {row.get('engine', 'laplace')}: "
                         f"p = {p:.2f}", fontsize=8)
            ax.set_yticks([])
    for ax in axes[-1]:
        ax.set_xlabel(f"rank of the truth among {rows[-1]['n_draws']} draws")
    fig.tight_layout()
    figure = pathlib.Path(figure)
    figure.parent.mkdir(exist_ok=True)
    fig.savefig(figure, dpi=120)
    print(f"wrote {figure}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=200)
    parser.add_argument("--scale", type=int, nargs="+", default=[1])
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--draws", type=int, default=99)
    parser.add_argument("--engine", choices=sbc.ENGINES, default="laplace")
    parser.add_argument("--effect", action="append", default=None,
                        help="fit (and plant, at a size drawn from its prior) this effect too")
    parser.add_argument("--population", choices=("plug_in", "known"), default="plug_in",
                        help="the fit's population of bulge pressures: the package's plug-in "
                             "or (a diagnostic) the simulator's own")
    parser.add_argument("--results", default=None,
                        help="JSON-lines file of the rows (default: sbc.jsonl in --output-dir, "
                             f"or {RESULTS} with --update)")
    parser.add_argument("--figure", default=None,
                        help="rank histograms of --results (default: sbc_ranks.png in "
                             f"--output-dir, or {FIGURE} with --update)")
    provenance.add_output_options(parser)
    parser.add_argument("--plot-only", action="store_true")
    parser.add_argument("--merge", metavar="CHUNKS.jsonl", default=None,
                        help="append the rows of a run split into chunks as one row each")
    args = parser.parse_args()
    args.n_cells = None  # the paper's cells times --scale
    if args.smoke:  # ten replications (the fewest the rank test bins) of 12 + 8 cells, 19 draws;
        # the run, a merge and the plot
        args.n, args.draws, args.scale, args.n_cells = 10, 19, [1], (12, 8)
    args.results = args.results or str(provenance.study_path(args, RESULTS.name))
    args.figure = args.figure or str(FIGURE if args.update
                                     else provenance.study_path(args, FIGURE.name))
    print(provenance.header_line(), flush=True)
    if args.merge:
        merge(args.merge, args.results)
    elif not args.plot_only:
        run(args)
    if args.smoke:  # the --merge step on the run's own rows, as one chunk
        merge(args.results, provenance.study_path(args, "sbc_merged.jsonl"))
    plot(args.results, args.figure)


if __name__ == "__main__":
    main()
