"""Speed of the fit: paper_wls vs a converged baseline posterior, likelihood throughput, scaling.

On one simulated data set at the paper's values (72 bulged + 42 intact cells), in one run:

(a) ``paper_wls``: the weighted least-squares fit, timed end to end as ``turgorbayes fit
    --model paper_wls`` does it (``results.fit_cells``), and the bare optimizer alone;
(b) ``baseline``: a converged posterior (every ensemble > 50 autocorrelation times, and
    R-hat < 1.01 and ESS_bulk >= 1000 for gamma, E0t, R0, P_phys), timed end to end;

then the ratio b/a (target <= 20), likelihood evaluations per second (one evaluation = one
walker's log posterior, all cells, latent pressures integrated), and the growth of the fit
time with the number of cells (114 ... 10,000; target: linear).

Run: .venv/bin/python studies/fit_speed.py [--max-cells 11400] [--json out.json]
"""

import argparse
import json
import time

import numpy as np

from turgorbayes import provenance, surrogate
from turgorbayes.inference import models
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows import fit as results

#: A smoke run's sampler: short chains, a few bootstrap populations.
SMOKE_SAMPLER = {"n_walkers": 12, "n_ensembles": 2, "tol": 5, "check_every": 20, "max_steps": 40,
                 "max_draws_per_chain": 50, "population_noise_bootstrap": 4}


def _simulate(n_cells, table, seed):
    n_bulged = round(n_cells * 72 / 114)
    cells, _ = synthetic.simulate_cells(n_bulged, n_cells - n_bulged, seed=seed,
                                        surrogate=table)
    return cells


def _evals_per_second(cells, table, n_walkers=32, repeat=20):
    model = models.BaselineModel(cells, table)
    rng = np.random.default_rng(0)
    u0 = model.to_u({"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3})
    u = u0 + 0.01 * rng.standard_normal((n_walkers, 4))
    model.log_posterior(u)
    t = time.perf_counter()
    for _ in range(repeat):
        model.log_posterior(u)
    dt = (time.perf_counter() - t) / repeat
    return n_walkers / dt, dt


def _check(result):
    d = result.chain_diag
    names = ("gamma", "E0t", "R0", "P_phys")
    ok = result.converged and all(d[n]["r_hat"] < 1.01 and d[n]["ess_bulk"] >= 1000
                                  for n in names)
    return ok, {n: (round(d[n]["r_hat"], 4), round(d[n]["ess_bulk"])) for n in names}


def ratio_benchmark(table, seed, n_cells=114, sampler=None):
    cells = _simulate(n_cells, table, seed)
    t = time.perf_counter()
    models.PaperWLS(cells, table).fit()
    t_opt = time.perf_counter() - t
    wls = results.fit_cells(cells, "paper_wls", seed=seed, surrogate=table,
                            settings=results.FitSettings(progress=False))
    settings = results.FitSettings(progress=False, **(sampler or {}))
    base = results.fit_cells(cells, "baseline", seed=seed, surrogate=table, settings=settings)
    ok, diag = _check(base)
    return {
        "paper_wls_fit_s": wls.timing_s, "paper_wls_optimizer_s": t_opt,
        "baseline_s": base.timing_s, "ratio_b_over_a": base.timing_s / wls.timing_s,
        "ratio_b_over_optimizer": base.timing_s / t_opt,
        "baseline_meets_target": ok, "r_hat_ess_bulk": diag,
        "baseline_steps": base.sampler["n_steps"],
        "walkers": f"{settings.n_ensembles} x {settings.n_walkers}",
        "tau": base.sampler["tau"],
    }


def scaling_benchmark(table, sizes, seed, sampler=None):
    rows = []
    for n in sizes:
        cells = _simulate(n, table, seed)
        rate, per_call = _evals_per_second(cells, table)
        settings = results.FitSettings(**{"progress": False, "max_draws_per_chain": 200,
                                          **(sampler or {})})
        res = results.fit_cells(cells, "baseline", seed=seed, surrogate=table,
                                settings=settings)
        rows.append({"n_cells": n, "evals_per_s": rate, "s_per_call_32_walkers": per_call,
                     "fit_s": res.timing_s, "steps": res.sampler["n_steps"],
                     "converged": res.converged,
                     "max_tau": max(res.sampler["tau"].values())})
        print(f"  n = {n:6d}: {rate:9.0f} evals/s, fit {res.timing_s:8.1f} s, "
              f"{res.sampler['n_steps']} steps, converged {res.converged}", flush=True)
    n = np.array([r["n_cells"] for r in rows], float)
    t = np.array([r["fit_s"] for r in rows])
    if len(rows) >= 2:
        slope = np.polyfit(np.log(n), np.log(t), 1)[0]
        per_step = np.array([r["fit_s"] / r["steps"] for r in rows])
        slope_step = np.polyfit(np.log(n), np.log(per_step), 1)[0]
    else:
        slope = slope_step = float("nan")
    return rows, float(slope), float(slope_step)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--max-cells", type=int, default=11400)
    parser.add_argument("--seed", type=int, default=2011)
    parser.add_argument("--json", default=None)
    args = provenance.add_output_options(parser).parse_args()
    sizes = [s for s in (114, 1140, 11400) if s <= args.max_cells]
    n_ratio, sampler = 114, None
    if args.smoke:  # 20 cells for the ratio, 20 and 30 for the scaling, short chains
        n_ratio, sizes, sampler = 20, [20, 30], SMOKE_SAMPLER
    provenance.tee_stdout(args, "fit_speed.txt")
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    table = surrogate.load()
    print(f"surrogate: {table.path} (sha256 {table.sha256[:12]})")
    print("(a) paper_wls vs (b) converged baseline, 72 + 42 cells at the paper's values")
    ratio = ratio_benchmark(table, args.seed, n_ratio, sampler)
    for k, v in ratio.items():
        print(f"  {k:26s} {v}")
    rate, per_call = _evals_per_second(_simulate(114, table, args.seed), table)
    print(f"likelihood: {rate:.0f} walker evaluations/s ({per_call * 1e3:.1f} ms per call of "
          "32 walkers, 114 cells, latent pressures integrated)")
    print("scaling with the number of cells (fit to convergence, default sampler):")
    rows, slope, slope_step = scaling_benchmark(table, sizes, args.seed, sampler)
    print(f"  log-log slope of fit time vs cells: {slope:.2f}; of time per step: "
          f"{slope_step:.2f} (1 = linear)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"ratio": ratio, "evals_per_s": rate, "scaling": rows,
                       "slope_time": slope, "slope_time_per_step": slope_step, "provenance": record}, fh,
                      indent=1)


if __name__ == "__main__":
    main()
