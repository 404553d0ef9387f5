"""Is each cell's likelihood correctly specified? The information equality at the mode.

For a correctly specified model of independent cells, the covariance of the per-cell scores
``J = sum_i s_i s_i^T`` equals the negative Hessian ``H`` at the mode, so the sandwich
covariance ``H^-1 J H^-1`` equals the model's ``H^-1``; a misspecified cell density (a wrong
error model) makes them differ by a factor that does not shrink with the number of cells
(White 1982). This script simulates data sets (log-uniform design, ``--scale`` times the
paper's cells, seeds from ``--first-seed``), finds the baseline's mode and Laplace covariance,
takes the per-cell scores by central differences of the pointwise log-likelihood (steps of
1e-3 posterior sds) and prints sqrt(sandwich variance / model variance) per parameter. Values
near 1 say the per-cell densities are right; what couples the cells (the latent population
estimated from all bulges) is held fixed and is not tested.

Run: .venv/bin/python studies/information_equality.py --scale 20 --n 8
"""

import argparse

import numpy as np

from turgorbayes import criticism, provenance, surrogate
from turgorbayes.inference import models
from turgorbayes.simulation import cells as synthetic


def ratio(seed, scale, table):
    cells, _ = synthetic.simulate_cells(72 * scale, 42 * scale, seed=seed, surrogate=table)
    model = models.BaselineModel(cells, table)
    guess = models.PaperWLS(cells, table).fit().estimate
    u, cov = criticism.laplace(model, {k: guess[k] for k in model.names})
    d, h = u.size, 1e-3 * np.sqrt(np.diag(cov))
    U = np.repeat(u[None], 2 * d, axis=0)
    U[2 * np.arange(d), np.arange(d)] += h
    U[2 * np.arange(d) + 1, np.arange(d)] -= h
    ll = model.pointwise_log_likelihood(U)
    scores = (ll[0::2] - ll[1::2]).T / (2 * h)  # (n_cells, d)
    sandwich = cov @ (scores.T @ scores) @ cov
    return np.sqrt(np.diag(sandwich) / np.diag(cov)), model.names


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale", type=int, default=20)
    ap.add_argument("--n", type=int, default=8)
    ap.add_argument("--first-seed", type=int, default=1000)
    args = provenance.add_output_options(ap).parse_args()
    if args.smoke:  # the paper's cell numbers (scale 1), two data sets (the SE needs two)
        args.scale, args.n = 1, 2
    provenance.tee_stdout(args, "information_equality.txt")
    print(provenance.header_line(), flush=True)
    table = surrogate.load()
    rows = []
    for seed in range(args.first_seed, args.first_seed + args.n):
        r, names = ratio(seed, args.scale, table)
        rows.append(r)
        print(f"seed {seed}: " + ", ".join(f"{p} {v:.3f}" for p, v in zip(names, r, strict=True)),
              flush=True)
    rows = np.array(rows)
    print(f"{args.n} data sets at {args.scale}x: sqrt(sandwich / model variance), mean +- SE: "
          + ", ".join(f"{p} {m:.3f} +- {s:.3f}" for p, m, s in
                      zip(names, rows.mean(0), rows.std(0, ddof=1) / np.sqrt(args.n), strict=True)))


if __name__ == "__main__":
    main()
