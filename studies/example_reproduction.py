"""How often does a data set drawn like the bundled example reproduce the paper's table?

The bundled example (``turgorbayes/data/example_cells.json``) is simulated at the paper's
values with a 3.5 % cell-to-cell radius spread (``radius_spread``, tau_R = 0.035) and per-cell
R_c errors of 8-12 nm. The aim is that ``fit`` on it reproduce the paper's table within the
published uncertainties. This script draws ``--n`` data sets exactly like the example (only
the seed differs), finds the baseline (or ``--extension``) posterior's mode and Laplace sd (no MCMC; on the 100
data sets of ``studies/coverage.py`` Laplace z agree with MCMC's, correlation 1.000), and
prints per parameter: the mean and sd over data sets of (mode - truth), the mean Laplace sd,
Laplace 90 % coverage, and the fraction of data sets whose mode lies within the published
1-sigma uncertainty of the published value (and within the combined sqrt(sd^2 + sd_pub^2)).
The truth is the published table, so the last columns answer the question directly.

Run: .venv/bin/python studies/example_reproduction.py --n 40 [--first-seed 3000]
"""

import argparse
import json
from pathlib import Path

import numpy as np

from turgorbayes import criticism, effects, provenance, surrogate
from turgorbayes.inference import models
from turgorbayes.report.fit import PUBLISHED_TABLE
from turgorbayes.simulation import cells as synthetic

PARAMS = {"gamma": ("gamma", 1.0), "E0t": ("E0t_N_per_m", 1.0), "R0": ("R0_nm", 1e9),
          "P_phys": ("P_phys_kPa", 1e-3)}
EXAMPLE = Path(__file__).resolve().parents[1] / "turgorbayes" / "data" / "example_cells.json"


def example_settings():
    """Generator settings of the bundled example, read from its sidecar."""
    side = json.loads(EXAMPLE.read_text())
    p = side["parameters"]
    truth = synthetic.Truth(gamma=p["gamma"], E0t=p["E0t_N_per_m"], R0=p["R0_nm"] * 1e-9,
                            P_phys=p["P_phys_kPa"] * 1e3)
    errors = synthetic.ErrorModel(R_c_sd=tuple(v * 1e-9 for v in side["errors"]["R_c_sd_nm"]))
    injections = [effects.get_effect(e["effect"]).injection(e["size"]) for e in side["effects"]]
    return truth, errors, injections, side["seed"]


def mode_and_sd(seed, truth, errors, injections, table, extension=()):
    """Posterior mode and Laplace sd of the four global parameters, in summary units."""
    cells, _ = synthetic.simulate_cells(seed=seed, truth=truth, errors=errors, surrogate=table,
                                        effects=injections)
    guess = models.PaperWLS(cells, table).fit().estimate
    if extension:
        model = effects.ExtendedModel(cells, table, list(extension))
        start = model.start_values(guess)
    else:
        model = models.BaselineModel(cells, table)
        start = {k: guess[k] for k in model.names}
    u_map, cov = criticism.laplace(model, start)
    # sd in physical units from Laplace draws (the sampler coordinates are transformed)
    draws = model.to_physical(np.random.default_rng(seed).multivariate_normal(u_map, cov, 4000))
    mode = model.to_physical(u_map[None])
    out = {}
    for name in PARAMS:
        _, scale = PARAMS[name]
        out[name] = (float(np.ravel(mode[name])[0]) * scale, float(np.std(draws[name])) * scale)
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=40)
    parser.add_argument("--first-seed", type=int, default=3000)
    parser.add_argument("--extension", nargs="*", default=(),
                        help="Fit the baseline extended by these effects instead (e.g. "
                             "radius_spread): does the extension restore coverage?")
    provenance.add_output_options(parser)
    args = parser.parse_args()
    if args.smoke:  # the example and two data sets drawn like it
        args.n = 2
    provenance.tee_stdout(args, "example_reproduction.txt")
    print(provenance.header_line(), flush=True)
    table = surrogate.load()
    truth, errors, injections, example_seed = example_settings()
    seeds = [example_seed, *range(args.first_seed, args.first_seed + args.n)]
    fits = []
    for s in seeds:
        fits.append(mode_and_sd(s, truth, errors, injections, table, args.extension))
        print(f"seed {s}: " + "  ".join(f"{k} {v[0]:.4g} +- {v[1]:.2g}" for k, v in fits[-1].items()),
              flush=True)
    example, rest = fits[0], fits[1:]
    print(f"\n{args.n} data sets drawn like the bundled example (seeds {args.first_seed}-"
          f"{args.first_seed + args.n - 1}), "
          f"{' + '.join(['baseline', *args.extension])} mode and Laplace sd; truth = published value")
    print(f"{'parameter':>10} {'published':>14} {'mean bias':>10} {'sd of mode':>10} "
          f"{'mean sd':>8} {'cov90':>6} {'within pub sd':>13} {'within comb.':>12} {'example':>16}")
    joint_pub, joint_comb = np.ones(args.n, bool), np.ones(args.n, bool)
    for name, (key, _) in PARAMS.items():
        pub, pub_sd = PUBLISHED_TABLE[key]
        m = np.array([f[name][0] for f in rest])
        sd = np.array([f[name][1] for f in rest])
        within = np.abs(m - pub) <= pub_sd
        comb = np.abs(m - pub) <= np.hypot(sd, pub_sd)
        joint_pub &= within
        joint_comb &= comb
        cov90 = np.mean(np.abs(m - pub) < 1.645 * sd)
        ex_m, ex_sd = example[name]
        print(f"{key:>10} {pub:>8.4g}+-{pub_sd:<5.2g} {np.mean(m - pub):+10.3g} {np.std(m, ddof=1):10.3g} "
              f"{np.mean(sd):8.3g} {cov90:6.2f} {np.mean(within):13.2f} {np.mean(comb):12.2f} "
              f"{ex_m:>9.4g}+-{ex_sd:.2g}")
    print(f"all four within published sd: {np.mean(joint_pub):.2f}; within combined: "
          f"{np.mean(joint_comb):.2f}")


if __name__ == "__main__":
    main()
