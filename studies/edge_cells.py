"""Which cells carry the spread of the z-scores? Correlations with the data's own noise.

Reads the rows of ``studies/coverage.py`` (log-uniform design), re-simulates each data set
from its seed (the simulator is deterministic given the seed) and correlates each parameter's
posterior z-score with features of that data set's noise, known here because the truth is:

* the summed bulge-error z, ``sum((ln P_hat - ln P)/s)/sqrt(n)``, of the cells below 1.5 kPa
  and of those above 20 kPa;
* how far inside the true range the bulges' maximum-likelihood edges fall
  (``turgorbayes.inference.population.fitted_box``).

Run: .venv/bin/python studies/edge_cells.py studies/results/coverage_is_loguniform_20x_v2.jsonl \
         studies/results/coverage_is_loguniform_20x_seeds1100.jsonl
"""

import argparse
import json
from pathlib import Path

import numpy as np

from turgorbayes import provenance, surrogate
from turgorbayes.inference import observations, population
from turgorbayes.simulation import cells as synthetic

PARAMS = ("gamma", "E0t", "R0", "P_phys")
#: The rows a smoke run reads when given none (the tracked coverage run at the paper's size).
SMOKE_ROWS = Path(__file__).resolve().parent / "results" / "coverage_is_loguniform_1x.jsonl"
FEATURES = ("bulge z, cells < 1.5 kPa", "bulge z, cells > 20 kPa", "ML lower edge inside",
            "ML upper edge inside")


def features(seed, scale, table):
    """The noise features of one data set (module docstring)."""
    n_b, n_i = 72 * scale, 42 * scale
    cells, _ = synthetic.simulate_cells(n_b, n_i, seed=seed, surrogate=table,
                                        design_kwargs={"P_distribution": "loguniform"})
    obs = observations.observations_from_cells(cells)
    # the same stream as simulate_cells: the design is drawn first
    design = synthetic.draw_design(np.random.default_rng(seed), n_b, n_i)
    log_P = np.log(design.P[:n_b])
    z = (obs.log_P_bulge - log_P) / obs.sd_log_P_bulge
    low, high = log_P < np.log(1500.0), log_P > np.log(20000.0)
    lo, hi = np.log(synthetic.DEFAULT_P_RANGE)
    _, (e_lo, e_hi) = population.fitted_box(obs.log_P_bulge, obs.sd_log_P_bulge, obs.population)
    return [z[low].sum() / np.sqrt(low.sum()), z[high].sum() / np.sqrt(high.sum()),
            e_lo - lo, hi - e_hi]


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rows", nargs="*", help="studies/coverage.py rows (JSON lines)")
    provenance.add_output_options(ap)
    args = ap.parse_args()
    if args.smoke:  # the first three rows
        args.rows = args.rows or [str(SMOKE_ROWS)]
    if not args.rows:
        ap.error("give the rows of studies/coverage.py")
    provenance.tee_stdout(args, "edge_cells.txt")
    print(provenance.header_line(), flush=True)
    rows = [json.loads(x) for f in args.rows for x in open(f) if x.strip()]
    rows = [r for r in rows if r["converged"] and r["design"] == "loguniform"][:3 if args.smoke else None]
    scales = {r["scale"] for r in rows}
    if len(scales) != 1:
        raise SystemExit(f"rows of one scale, please (got {sorted(scales)})")
    table = surrogate.load()
    f = np.array([features(r["seed"], r["scale"], table) for r in rows])
    z = np.array([[r[p]["z_post"] for p in PARAMS] for r in rows])
    print(f"{len(rows)} data sets at {scales.pop()}x; correlation of each parameter's z with")
    print(f"{'feature':<26}" + "".join(f"{p:>8}" for p in PARAMS) + f"{'mean':>9}{'sd':>8}")
    for j, name in enumerate(FEATURES):
        corr = [np.corrcoef(f[:, j], z[:, i])[0, 1] for i in range(len(PARAMS))]
        print(f"{name:<26}" + "".join(f"{c:>+8.2f}" for c in corr)
              + f"{f[:, j].mean():>+9.4f}{f[:, j].std():>8.4f}")


if __name__ == "__main__":
    main()
