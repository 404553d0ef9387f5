"""Throughput of the vectorized analytic physics (10^6 evaluations each), printed side by side.

Run: .venv/bin/python studies/physics_speed.py
"""

import argparse
import time

import numpy as np

from turgorbayes import provenance
from turgorbayes.physics import bulge, wall

N = 10**6


def _time(fn, repeat=3):
    best = np.inf
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return best


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args = provenance.add_output_options(parser).parse_args()
    n, repeat = (10**3, 1) if args.smoke else (N, 3)  # smoke: 1e3 evaluations, timed once
    provenance.tee_stdout(args, "physics_speed.txt")
    print(provenance.header_line(), flush=True)
    rng = np.random.default_rng(0)
    P = rng.uniform(1e3, 3e4, n)
    R_b = rng.uniform(3e-7, 7e-7, n)
    y = rng.uniform(0.05, 0.4, n)
    F = bulge.reduced_force(y) * P * R_b**2
    k_b = F / (y * R_b)
    rows = [
        ("bulge.indentation_depth (closed form)", lambda: bulge.indentation_depth(F, P, R_b)),
        ("bulge.pressure_from_bulge (inversion)", lambda: bulge.pressure_from_bulge(k_b, R_b, y * R_b)),
        ("wall.pressure_at_radius (explicit)", lambda: wall.pressure_at_radius(R_b + 2e-7, 1.22, 0.026, 464.2e-9)),
        ("wall.radius_at_pressure (root search)", lambda: wall.radius_at_pressure(P, 1.22, 0.026, 464.2e-9)),
        ("wall.anisotropy", lambda: wall.anisotropy(P, 1.22, 0.026, 464.2e-9)),
    ]
    times = [(name, _time(fn, repeat)) for name, fn in rows]
    base = times[0][1]
    print(f"{'function':42s} {'s / 1e6':>8s} {'1e6 evals/s':>12s} {'x closed form':>14s}")
    for name, t in times:
        print(f"{name:42s} {t:8.3f} {n / t / 1e6:12.2f} {t / base:14.2f}")


if __name__ == "__main__":
    main()
