"""Throughput of the k/(PR) surrogate interpolator (target: >= 1e6 evaluations/s).

Uses the shipped table if it exists, else a synthetic 13 x 5 table of a smooth closed form
(the evaluation cost does not depend on the values). Also times the alternative the brief
named, scipy's RegularGridInterpolator(method="cubic") on the same dense grid, to justify
the choice of RectBivariateSpline. Run: .venv/bin/python studies/surrogate_speed.py [--smoke]
"""

import argparse
import time

import numpy as np
import xarray as xr
from scipy.interpolate import RegularGridInterpolator

from turgorbayes import provenance
from turgorbayes.surrogate import FILE_FORMAT, Surrogate, default_path, load

N = 10**6
#: Evaluations per timed call of a smoke run (one call each).
SMOKE_N = 10**4


def synthetic():
    x = np.geomspace(0.01, 0.5, 13)
    ratio = np.array([0.3, 0.4, 0.5, 0.7, 1.0])
    x_act = np.tile(x * (1 + x), (5, 1))
    k = (0.6 + 0.5 * np.sqrt(ratio[:, None])) / np.sqrt(x_act + 0.02)
    ds = xr.Dataset({"k_over_PR": (("ratio", "x"), k), "k_linear_over_PR": (("ratio", "x"), k),
                     "x_actual": (("ratio", "x"), x_act)}, coords={"ratio": ratio, "x": x},
                    attrs={"file_format": FILE_FORMAT})
    return Surrogate.from_dataset(ds)


def rate(fn, *args, repeat=5, n=N):
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(*args)
        best = min(best, time.perf_counter() - t0)
    return n / best


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args = provenance.add_output_options(parser).parse_args()
    n, repeat = (SMOKE_N, 1) if args.smoke else (N, 5)
    provenance.tee_stdout(args, "surrogate_speed.txt")
    print(provenance.header_line(), flush=True)
    s = load() if default_path().is_file() else synthetic()
    print(f"table: {s!r}")
    rng = np.random.default_rng(0)
    (xlo, xhi), (rlo, rhi) = s.domain["x"], s.domain["ratio"]
    x = np.exp(rng.uniform(np.log(xlo), np.log(xhi), n))
    r = rng.uniform(rlo, rhi, n)
    print(f"s(x, ratio, warn=False)      {rate(lambda: s(x, r, warn=False), repeat=repeat, n=n):12.3e} eval/s")
    print(f"s.linear(x, ratio)           {rate(lambda: s.linear(x, r, warn=False), repeat=repeat, n=n):12.3e} eval/s")
    print(f"s.dlog_dlogx(x, ratio)       {rate(lambda: s.dlog_dlogx(x, r, warn=False), repeat=repeat, n=n):12.3e}"
          " eval/s")
    x_out = x.copy()
    x_out[::10] = 2 * xhi  # 10 % outside: the masked path
    print(f"s(...) with 10% outside      {rate(lambda: s(x_out, r, warn=False), repeat=repeat, n=n):12.3e} eval/s")
    spline = s._k.spline
    dense = np.linspace(*s._k.log_x_range, 256)
    lr = np.log(s.grid["ratio"])
    rgi = RegularGridInterpolator((dense, lr), spline(dense, lr), method="cubic")
    pts = np.column_stack([np.log(x), np.log(r)])[: n // 10]
    t0 = time.perf_counter()
    rgi(pts)
    print(f"RegularGridInterpolator cubic {n // 10 / (time.perf_counter() - t0):12.3e} eval/s "
          "(alternative, not used)")


if __name__ == "__main__":
    main()
