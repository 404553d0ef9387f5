"""Cost of locating the wall models' domain ends: one halving per model call, or four.

``WallGrid`` finds where a tabulated wall model stops being defined (the FE table's edge) by
20 halvings of a grid interval. The outer-membrane wall solves for its state on every call,
with a fixed cost per call, so the halvings dominated a likelihood evaluation (64 % of a
criticism run's profile, 2026-11-26). Splitting the bracket into 16 per call gives the same
end in 5 calls instead of 20. This script times the ``outer_membrane`` likelihood of 32
walkers both ways, side by side, and prints the largest difference of the log-likelihood.

Usage::

    python studies/wall_grid_bisection.py [--repeats 5] [--seed 1000] [--smoke]
"""

import argparse
import time

import numpy as np

from turgorbayes import effects, provenance, surrogate
from turgorbayes.inference import pressure_grid
from turgorbayes.simulation import cells as synthetic


def _timed(model, u, halvings, repeats):
    """Best-of-``repeats`` time of the pointwise log-likelihood with ``halvings`` per call."""
    default = pressure_grid.WallGrid.halvings_per_call
    pressure_grid.WallGrid.halvings_per_call = halvings
    try:
        best = np.inf
        for _ in range(repeats):
            t0 = time.perf_counter()
            ll = model.pointwise_log_likelihood(u)
            best = min(best, time.perf_counter() - t0)
    finally:
        pressure_grid.WallGrid.halvings_per_call = default
    return best, ll


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--seed", type=int, default=1000)
    args = provenance.add_output_options(parser).parse_args()
    sizes = {}  # the paper's 72 + 42 cells
    if args.smoke:  # one timing each way of 8 + 6 cells
        args.repeats, sizes = 1, {"n_bulged": 8, "n_intact": 6}
    provenance.tee_stdout(args, "wall_grid_bisection.txt")
    print(provenance.header_line(), flush=True)
    table = surrogate.load()
    e = effects.get_effect("outer_membrane")
    cells, _ = synthetic.simulate_cells(**sizes, seed=args.seed, surrogate=table,
                                        effects=[e.injection(0.026)])
    model = effects.ExtendedModel(cells, table, ["outer_membrane"])
    rng = np.random.default_rng(args.seed)
    u = model.to_u(model.start_values({"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9,
                                       "P_phys": 29e3}))[0]
    u = u + 0.3 * rng.standard_normal((32, u.size))  # spread: some walls reach the table edge
    t1, ll1 = _timed(model, u, 1, args.repeats)
    t4, ll4 = _timed(model, u, 4, args.repeats)
    both = np.isfinite(ll1) & np.isfinite(ll4)
    print(f"outer_membrane likelihood, 32 walkers x {cells.R_c.size} cells, best of "
          f"{args.repeats}: one halving per call {t1:.3f} s, four per call {t4:.3f} s, "
          f"ratio {t4 / t1:.2f}")
    print(f"finite in both: {both.sum()} of {both.size}, same finiteness: "
          f"{bool(np.all(np.isfinite(ll1) == np.isfinite(ll4)))}, largest |difference| "
          f"{np.max(np.abs(ll1[both] - ll4[both])):.2e} nats")


if __name__ == "__main__":
    main()
