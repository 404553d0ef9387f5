"""Figure of the coverage study: z-scores of the baseline and of the published method.

Reads the 200 fits of ``studies/coverage.py`` kept in ``studies/results/``
(``coverage_paper.jsonl``, ``coverage_paper_v024.jsonl``) and draws, per parameter, the
histogram of ``z = (estimate - truth)/sd`` of the baseline posterior and of ``paper_wls``
against a standard normal. Described in docs/validation.md, Coverage.

Run: .venv/bin/python studies/plot_coverage.py [--out docs/figures/coverage_z.png]
"""

import argparse
import json
from pathlib import Path

import matplotlib

from turgorbayes import provenance

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from scipy import stats  # noqa: E402

RESULTS = Path(__file__).parent / "results"
FILES = ("coverage_paper.jsonl", "coverage_paper_v024.jsonl")
PARAMS = {"gamma": r"$\gamma$", "E0t": r"$E_0t$", "R0": r"$R_0$", "P_phys": r"$P_\mathrm{phys}$"}


def load(files=FILES, folder=RESULTS):
    """Rows of the coverage runs (one dict per data set) in ``folder``."""
    rows = []
    for name in files:
        with open(Path(folder) / name) as fh:
            rows += [json.loads(line) for line in fh if line.strip()]
    return rows


def draw(rows, out):
    fig, axes = plt.subplots(1, len(PARAMS), figsize=(12, 3), sharey=True)
    bins = np.linspace(-5, 5, 31)
    grid = np.linspace(-5, 5, 201)
    for ax, (name, label) in zip(axes, PARAMS.items(), strict=True):
        z_post = np.array([r[name]["z_post"] for r in rows])
        z_wls = np.array([r[name]["z_wls"] for r in rows])
        cov = np.mean([r[name]["cover90"] for r in rows])
        cov_wls = np.mean([r[name]["wls_cover90"] for r in rows])
        ax.hist(np.clip(z_post, -5, 5), bins, density=True, alpha=0.6, color="C0",
                label=f"baseline (90 % cov. {cov:.0%})")
        ax.hist(np.clip(z_wls, -5, 5), bins, density=True, alpha=0.4, color="C3",
                label=f"paper_wls ({cov_wls:.0%})")
        ax.plot(grid, stats.norm.pdf(grid), "k:", lw=1)
        ax.set_title(label)
        ax.set_xlabel("z = (estimate - truth) / sd")
        ax.legend(fontsize=7, loc="upper left")
    axes[0].set_ylabel("density")
    fig.suptitle(f"{len(rows)} simulated data sets at the paper's values", fontsize=10)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default=str(Path(__file__).parents[1] / "docs/figures/coverage_z.png"))
    parser.add_argument("--results", default=str(RESULTS),
                        help="folder of the coverage runs (default: %(default)s)")
    args = provenance.add_output_options(parser).parse_args()
    if args.smoke:  # the kept runs' first 10 fits, the figure into --output-dir
        args.out = str(provenance.study_path(args, "coverage_z.png"))
    print(provenance.header_line(), flush=True)
    absent = [name for name in FILES if not (Path(args.results) / name).exists()]
    if args.smoke and absent:
        print(f"skipped: the coverage runs {', '.join(absent)} are absent from {args.results}")
        return
    rows = load(FILES, Path(args.results))
    draw(rows[:10] if args.smoke else rows, args.out)
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
