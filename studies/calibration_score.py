"""Which part of the baseline is inconsistent? The mean score at the truth, cell by cell.

A consistent estimator solves an estimating equation whose expectation vanishes at the truth.
This script simulates one very large data set (``--blocks`` times the paper's 72 bulged and 42
intact cells) at known parameters, evaluates every cell's log-likelihood at the truth and at
the truth +- a small step in each sampler coordinate (central differences: the per-cell
score ``s_i``), and turns the mean score into the asymptotic bias of the estimator,
``b = I^-1 E[s]`` with ``I`` the per-block Fisher information ``E[s s^T]``. In units of the
posterior sd at ``k`` times the paper's cell count the bias is

    z(k) = sqrt(k) * b_j / sqrt((I^-1)_jj),

the part of the Laplace/MCMC z-score that grows with the experiment (a finite-sample shift
shrinks like 1/sqrt(k) and is not in it). Its standard error is about sqrt(k / blocks).

It separates the candidate causes by swapping one ingredient at a time:

* ``--prior``: the latent-pressure prior of the likelihood (``deconvolved``: estimated from the
  same bulge estimates, the default; ``oracle``: the simulation's own log-uniform population;
  or any other prior the package knows);
* ``--bulge exact``: replace every bulge estimate by ``ln P_true + s_i N(0, 1)``, exactly the
  likelihood's Gaussian-in-ln-P error model (``simulated``: the simulator's lognormal k_b and
  R_b errors read through the bulge formula, what a lab measures).

With ``--prior oracle --bulge exact`` the model is exactly the simulator's, and z(k) must
vanish within its standard error (the check of this method).

Run: .venv/bin/python studies/calibration_score.py --blocks 400 --prior deconvolved oracle
"""

import argparse
import dataclasses

import numpy as np

from turgorbayes import provenance, surrogate
from turgorbayes.inference import likelihood, models, observations, population
from turgorbayes.simulation import cells as synthetic

PARAMS = ("gamma", "E0t", "R0", "P_phys")
STEP = 1e-3  # central-difference step in the sampler coordinates (log for E0t, R0, P_phys)


def oracle_population(P_range=synthetic.DEFAULT_P_RANGE, flank=0.03, n=800):
    """The simulation's log-uniform population of bulge pressures on a fine grid.

    Flat inside ``P_range``; Gaussian flanks of sd ``flank`` outside (a hard step would make
    the cubic interpolation of ``ln g`` ring).
    """
    lo, hi = np.log(P_range)
    grid = np.linspace(lo - 10 * flank, hi + 10 * flank, n)
    outside = np.maximum(0.0, np.maximum(lo - grid, grid - hi))
    log_mass = -0.5 * (outside / flank) ** 2
    return population.GridPopulation(grid, log_mass - np.log(np.sum(np.exp(log_mass))))


def build_model(cells, truths, table, prior, bulge, seed, nodes=likelihood.DEFAULT_NODES,
                df=None, relative_errors=observations.DEFAULT_RELATIVE_ERRORS):
    latent = "flat" if prior == "oracle" or df else prior
    model = models.BaselineModel(cells, table, latent="flat", n_nodes=nodes)  # obs replaced
    obs = observations.observations_from_cells(cells, latent=latent,
                                               relative_errors=relative_errors)
    if df and prior == "deconvolved":
        obs = dataclasses.replace(obs, population=population.deconvolve(
            obs.log_P_bulge, obs.sd_log_P_bulge, df=df))
    if bulge == "exact":
        P_true = np.array(truths["cells"]["P_kPa"], float)[obs.bulged] * 1e3
        rng = np.random.default_rng(seed + 1)
        log_P = np.log(P_true) + obs.sd_log_P_bulge * rng.standard_normal(P_true.size)
        obs = dataclasses.replace(obs, log_P_bulge=log_P)
        if prior != "oracle":  # the prior is estimated from the (new) bulge estimates
            obs = dataclasses.replace(obs, population=observations.latent_population(
                log_P, obs.sd_log_P_bulge, latent))
    if prior == "oracle":
        obs = dataclasses.replace(obs, population=oracle_population())
    model.obs = obs
    model.lik = likelihood.CellLikelihood(obs, table, n_nodes=nodes)
    return model


def scores(model, u0):
    """``(n_cells, 4)`` per-cell scores at ``u0`` by central differences."""
    out = []
    for j in range(u0.size):
        du = np.zeros_like(u0)
        du[j] = STEP
        ll = model.pointwise_log_likelihood(np.stack([u0 + du, u0 - du]))
        out.append((ll[0] - ll[1]) / (2 * STEP))
    return np.stack(out, axis=1)


def bias_z(s, blocks, k):
    """``z(k)`` per parameter and its bootstrap-free standard error (module docstring)."""
    total = s.sum(axis=0)
    fisher = s.T @ s - np.outer(total, total) / s.shape[0]  # centred: robust to the bias itself
    inv = np.linalg.inv(fisher / blocks)
    b = inv @ (total / blocks)
    z = np.sqrt(k) * b / np.sqrt(np.diag(inv))
    return z, np.sqrt(k / blocks) * np.ones_like(z)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blocks", type=int, default=400)
    parser.add_argument("--seed", type=int, default=7000)
    parser.add_argument("--prior", nargs="+", default=["deconvolved", "oracle"])
    parser.add_argument("--bulge", nargs="+", default=["simulated", "exact"])
    parser.add_argument("--truth", choices=sorted(synthetic.TRUTHS), default="paper")
    parser.add_argument("--k", type=int, nargs="+", default=[1, 10, 20, 100])
    parser.add_argument("--df", type=int, default=None,
                        help="B-spline functions of the deconvolved population (default: the "
                             "package's)")
    parser.add_argument("--relative-errors", choices=observations.RELATIVE_ERRORS,
                        default=observations.DEFAULT_RELATIVE_ERRORS,
                        help="how the likelihood reads the relative errors (k_c, k_b, R_b): "
                             "each group's RMS (pooled, the default) or each cell's own")
    parser.add_argument("--nodes", type=int, default=likelihood.DEFAULT_NODES,
                        help="Gauss-Hermite nodes per bulged cell")
    parser.add_argument("--reported", choices=["observed", "true"], default="observed",
                        help="error columns of the simulated file: relative error x observed "
                             "value (the package's convention) or x true value (error bars "
                             "independent of the noise)")
    provenance.add_output_options(parser)
    args = parser.parse_args()
    if args.smoke:  # one block of the paper's cells, one prior and bulge reading
        args.blocks, args.prior, args.bulge, args.k = 1, ["deconvolved"], ["simulated"], [1]
    provenance.tee_stdout(args, "calibration_score.txt")
    print(provenance.header_line(), flush=True)
    table = surrogate.load()
    truth = synthetic.TRUTHS[args.truth]
    cells, truths = synthetic.simulate_cells(72 * args.blocks, 42 * args.blocks, truth=truth,
                                             seed=args.seed, surrogate=table,
                                             errors=synthetic.ErrorModel(reported=args.reported))
    print(f"# {args.blocks} x the paper's cells (seed {args.seed}, truth {args.truth}, "
          f"{args.nodes} nodes, errors reported from the {args.reported} values"
          f", relative errors {args.relative_errors}); "
          f"z(k): asymptotic bias in posterior sds at k x the paper's cells")
    print(f"{'prior':>12} {'bulge':>9} {'param':>7} "
          + " ".join(f"{'z(' + str(k) + ')':>8}" for k in args.k) + "   +- (se at largest k)")
    for prior in args.prior:
        for bulge in args.bulge:
            model = build_model(cells, truths, table, prior, bulge, args.seed, args.nodes, args.df,
                                args.relative_errors)
            u0 = model.to_u({p: getattr(truth, p) for p in model.names})[0]
            s = scores(model, u0)
            for k_i, k in enumerate(args.k):
                z, se = bias_z(s, args.blocks, k)
                if k_i == 0:
                    rows = np.empty((len(args.k), z.size))
                rows[k_i] = z
            for j, p in enumerate(PARAMS):
                print(f"{prior:>12} {bulge:>9} {p:>7} "
                      + " ".join(f"{rows[i, j]:+8.2f}" for i in range(len(args.k)))
                      + f"   {se[j]:.2f}", flush=True)


if __name__ == "__main__":
    main()
