"""Is the baseline estimator biased? Laplace fits on data sets with many more cells.

A posterior that under-covers can be too narrow (its sd too small) or shifted (a bias that
does not shrink with the number of cells). This script separates the two cheaply: it
simulates ``--n`` data sets at the paper's values with ``--scale`` times the paper's cell
counts (72 bulged, 42 intact), finds the posterior mode and Laplace covariance of the
baseline model (no MCMC), and prints, per parameter, the mean and sd over data sets of
``z = (mode - truth)/sd_laplace``. A correctly specified, unbiased model gives mean z ~ 0 and
sd z ~ 1 at every scale; a bias grows like sqrt(scale) in z. It also prints how often the
Laplace intervals mode +- 1.645 sd and +- 1 sd cover the truth (nominal 90 % and 68 %); on the
100 data sets of ``studies/coverage.py`` these z agree with the MCMC posterior's
(correlation 1.000, slope 1.01), so they estimate the posterior's coverage cheaply.

Run: .venv/bin/python studies/calibration_bias.py --n 20 --scale 1 10 [--latent flat]
[--bulge-error-factor 0.1]
"""

import argparse
import dataclasses

import numpy as np

from turgorbayes import criticism, provenance, surrogate
from turgorbayes.inference import likelihood, models, observations, population
from turgorbayes.simulation import cells as synthetic

PARAMS = ("gamma", "E0t", "R0", "P_phys")


def _log_uniform(P_range=(1e3, 25e3), n=400):
    """The simulation's population of bulge pressures (synthetic.draw_design's default)."""
    lo, hi = np.log(P_range)
    grid = np.linspace(lo - 0.5, hi + 0.5, n)
    # flat inside, Gaussian flanks of sd 0.05 outside: the population's log-density is
    # interpolated by a cubic spline, which rings (spurious mass) on a hard step
    outside = np.maximum(0.0, np.maximum(lo - grid, grid - hi))
    log_mass = -0.5 * (outside / 0.05) ** 2
    return population.GridPopulation(grid, log_mass - np.log(np.sum(np.exp(log_mass))))


def z_scores(seed, scale, table, truth=synthetic.PAPER_TRUTH, bulge_error_factor=1.0,
             oracle=False, n_nodes=likelihood.DEFAULT_NODES, latent=observations.DEFAULT_LATENT,
             relative_errors=observations.DEFAULT_RELATIVE_ERRORS):
    e = synthetic.ErrorModel()
    errors = synthetic.ErrorModel(
        k_b_log_sd=tuple(bulge_error_factor * v for v in e.k_b_log_sd),
        R_b_log_sd=tuple(bulge_error_factor * v for v in e.R_b_log_sd))
    cells, _ = synthetic.simulate_cells(n_bulged=72 * scale, n_intact=42 * scale, seed=seed,
                                        truth=truth, surrogate=table, errors=errors)
    model = models.BaselineModel(cells, table, n_nodes=n_nodes, latent=latent)
    if relative_errors != observations.DEFAULT_RELATIVE_ERRORS:
        obs = observations.observations_from_cells(cells, latent=latent,
                                                   relative_errors=relative_errors)
        model.obs = obs
        model.lik = likelihood.CellLikelihood(obs, table, n_nodes=n_nodes, P0=model.lik.P0)
    if oracle:
        model.obs = model.lik.obs = dataclasses.replace(model.obs, population=_log_uniform())
    guess = models.PaperWLS(cells, table).fit().estimate
    u_map, cov = criticism.laplace(model, {k: guess[k] for k in model.names})
    u_true = model.to_u({p: getattr(truth, p) for p in model.names})[0]
    # sampler coordinates (log for E0t, R0, P_phys): z is invariant to that choice at the mode
    return (u_map - u_true) / np.sqrt(np.diag(cov))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20)
    parser.add_argument("--scale", type=int, nargs="+", default=[1, 10])
    parser.add_argument("--first-seed", type=int, default=5000)
    parser.add_argument("--bulge-error-factor", type=float, default=1.0,
                        help="Multiply the bulge (k_b, R_b) errors: small values make the "
                             "bulge pressures nearly exact (tests the latent-pressure part).")
    parser.add_argument("--latent", choices=[*observations.LATENT_PRIORS, "oracle"],
                        default=observations.DEFAULT_LATENT,
                        help="Latent-pressure prior of the baseline (turgorbayes.inference.likelihood); "
                             "'oracle': the simulation's own log-uniform population (a "
                             "diagnostic: what a perfectly known population gives).")
    parser.add_argument("--truth", choices=sorted(synthetic.TRUTHS), default="paper")
    parser.add_argument("--relative-errors", choices=observations.RELATIVE_ERRORS,
                        default=observations.DEFAULT_RELATIVE_ERRORS,
                        help="stiffness and bulge errors as the likelihood reads them: each "
                             "group's RMS relative error (pooled) or each cell's own")
    parser.add_argument("--nodes", type=int, default=likelihood.DEFAULT_NODES,
                        help="Gauss-Hermite nodes of the latent-pressure quadrature per cell.")
    provenance.add_output_options(parser)
    args = parser.parse_args()
    if args.smoke:  # two data sets (an sd) at the paper's size
        args.n, args.scale = 2, [1]
    provenance.tee_stdout(args, "calibration_bias.txt")
    print(provenance.header_line(), flush=True)
    latent = "flat" if args.latent == "oracle" else args.latent
    table = surrogate.load()
    print(f"{'scale':>5} {'parameter':>9} {'mean z':>8} {'sd z':>6} {'cov90':>7} {'cov68':>7}  "
          f"(n = {args.n} data sets, "
          f"truth {args.truth}, bulge errors x {args.bulge_error_factor:g}, latent prior {args.latent}, "
          f"{args.relative_errors} relative errors, "
          f"{args.nodes} nodes)")
    for scale in args.scale:
        z = np.array([z_scores(s, scale, table, truth=synthetic.TRUTHS[args.truth],
                                bulge_error_factor=args.bulge_error_factor,
                                        oracle=args.latent == "oracle", n_nodes=args.nodes,
                                        latent=latent, relative_errors=args.relative_errors)
                      for s in range(args.first_seed, args.first_seed + args.n)])
        for i, p in enumerate(PARAMS):
            # Laplace-interval coverage: the 90 % / 68 % intervals mode +- 1.645 / 1.0 sd
            c90, c68 = np.mean(np.abs(z[:, i]) < 1.645), np.mean(np.abs(z[:, i]) < 1.0)
            print(f"{scale:5d} {p:>9} {z[:, i].mean():+8.2f} {z[:, i].std(ddof=1):6.2f} "
                  f"{100 * c90:6.1f}% {100 * c68:6.1f}%", flush=True)


if __name__ == "__main__":
    main()
