"""The pressure_error effect with the latent population fixed at sigma = 0 ("before") and
taken at the fitted extra scatter ("after"): bias, coverage, cost, interpolation error.

Why: the latent-pressure population is estimated from the bulge estimates ``ln P_hat_i`` with
their reported sds ``s_i``. Under ``pressure_error`` the estimates scatter by
``sqrt(s_i^2 + sigma_P^2)``; a population deconvolved with ``s_i`` alone already holds
``sigma_P``, which the widened bulge sd then counts a second time
(turgorbayes.inference.population, "Extra scatter"). "after" is the package's model
(``DeconvolvedPopulation`` at ``sigma_P``; the normal population's ``tau^2 - sigma_P^2``);
"before" is the same model with the population replaced by its ``sigma = 0`` member as a plain
``GridPopulation`` (a known ``NormalPopulation`` for ``--latent population``), which ignores the
extra scatter: exactly the likelihood of the package before the change (checked bit for bit
against the previous source on 128 walkers at sigma_P = 0, 0.1, 0.3).

Per data set (``synthetic.simulate_cells(seed=s)``, the paper's 72 bulged + 42 intact cells,
``pressure_error`` injected at sigma_P = 0.3, true P_phys = 29 kPa) both models are fitted by
``criticism.fit_posterior`` (Laplace + importance sampling, 1000 draws, emcee if that does not
converge). Printed: (1) the spacing of the sigma rows against the population deconvolved
directly at mid-row (marginal log-likelihood of the 72 estimates, nats); (2) mean and sd over
data sets of the sigma_P posterior median, the paired shift after - before, 90 % interval
coverage of sigma_P and of P_phys; (3) CPU time of one pointwise log-likelihood call of the
pressure_error model (128 walkers around sigma_P = 0.3), before and after, interleaved.

Usage::

    python studies/pressure_error_double_counting.py [--seeds 1-20] \
        [--latent deconvolved population] > studies/results/pressure_error_double_counting.txt
"""

import argparse
import dataclasses
import time

import numpy as np
from scipy import special

from turgorbayes import __version__, criticism, effects, provenance, surrogate
from turgorbayes.inference import likelihood, models, observations, population
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings

TRUE_SIGMA_P = 0.3
TRUE_P_PHYS_KPA = 29.0
#: A smoke run's posterior settings: few draws, short chains.
SMOKE_SETTINGS = {"n_draws": 200, "ess_min": 20, "n_ensembles": 2, "tol": 5, "check_every": 20,
                  "max_steps": 200}


def data(seed, table, sizes=(72, 42)):
    """Cells of one data set (``sizes``: bulged, intact) with pressure_error at its true size."""
    inj = [effects.get_effect("pressure_error").injection(TRUE_SIGMA_P)]
    return synthetic.simulate_cells(*sizes, seed=seed, surrogate=table, effects=inj)[0]


def fixed_population(pop):
    """The population at sigma = 0, independent of the extra scatter (the old treatment)."""
    if isinstance(pop, population.DeconvolvedPopulation):
        return population.GridPopulation(pop.grid, pop.log_mass)
    if isinstance(pop, population.NormalPopulation):
        return population.NormalPopulation(pop.mu, pop.tau)
    return pop


def model_for(cells, table, latent, before):
    """The pressure_error model; ``before``: its population fixed at sigma = 0."""
    model = effects.ExtendedModel(cells, table, ["pressure_error"], latent=latent)
    if before:
        model.obs = dataclasses.replace(model.obs, population=fixed_population(model.obs.population))
        lik = model.lik
        model.lik = likelihood.CellLikelihood(model.obs, table, n_nodes=lik.n_nodes, P0=lik.P0,
                                              grid_step=lik.grid_step, adapt=lik.adapt)
    return model


def fit(model, cells, table, seed, settings=None):
    """Posterior summary ``{sigma_P: (q05, q50, q95), P_phys_kPa: ...}`` and convergence."""
    start = model.start_values(models.PaperWLS(cells, table).fit().estimate)
    post = criticism.fit_posterior(model, start, seed, settings or CriticismSettings(n_draws=1000))
    s = post.summary(np.random.default_rng(seed))
    out = {k: (s[k]["q05"], s[k]["q50"], s[k]["q95"]) for k in ("sigma_P", "P_phys_kPa")}
    mode = model.to_physical(post.u_map)
    out["mode"] = (float(mode["sigma_P"][0]), float(mode["P_phys"][0]) / 1e3)
    return out, post.converged, post.engine


def interpolation_error(cells_list, steps=(0.025, 0.05, 0.1, 0.2), top=0.6):
    """Largest |marginal log-likelihood of the estimates| difference [nats] between the
    mixture of two rows and the population deconvolved directly at mid-row (sigma <= top)."""
    rows = []
    for step in steps:
        worst = 0.0
        for cells in cells_list:
            obs = observations.observations_from_cells(cells)
            x, s = obs.log_P_bulge, obs.sd_log_P_bulge
            fam = population.deconvolve_family(x, s, sigmas=np.round(np.arange(0, 1 + 1e-9, step), 10))
            mids = (fam.sigmas[:-1] + fam.sigmas[1:]) / 2
            for mid in mids[mids <= top]:
                direct = population.deconvolve(x, np.hypot(s, mid), df=fam.df, grid=fam.grid)
                sd = np.hypot(s, mid)[:, None]
                kernel = -0.5 * ((x[:, None] - fam.grid) / sd) ** 2 - np.log(sd)
                diff = (special.logsumexp(kernel + fam.log_mass_at(mid), axis=1)
                        - special.logsumexp(kernel + direct.log_mass, axis=1)).sum()
                worst = max(worst, abs(diff))
        rows.append((step, worst))
    return rows


def cost(cells, table, repeats=15):
    """Median CPU seconds of one pointwise log-likelihood call, 128 walkers, before/after."""
    rng = np.random.default_rng(0)
    out = {}
    models_ = {b: model_for(cells, table, "deconvolved", b) for b in (True, False)}
    start = models_[False].start_values(models.PaperWLS(cells, table).fit().estimate)
    start["sigma_P"] = TRUE_SIGMA_P
    u0 = models_[False].to_u(start)[0]
    U = u0 + 0.02 * rng.standard_normal((128, u0.size))
    times = {b: [] for b in models_}
    for m in models_.values():
        m.pointwise_log_likelihood(U)  # first call: the family's rows are deconvolved here
    for _ in range(repeats):
        for b, m in models_.items():
            t = time.process_time()
            m.pointwise_log_likelihood(U)
            times[b].append(time.process_time() - t)
    for b in models_:
        out["before" if b else "after"] = float(np.median(times[b]))
    t = time.process_time()
    _ = observations.observations_from_cells(cells).population.rows
    out["family_build"] = time.process_time() - t
    return out


def parse_seeds(text):
    lo, _, hi = text.partition("-")
    return list(range(int(lo), int(hi or lo) + 1))


def summarize(records, latent):
    print(f"\n# (2) latent prior {latent}: {len(records)} data sets, truth sigma_P = {TRUE_SIGMA_P}, "
          f"P_phys = {TRUE_P_PHYS_KPA} kPa")
    print(f"{'treatment':>9} {'med sigma_P':>11} {'sd':>6} {'cov90 sigma_P':>13} "
          f"{'med P_phys':>10} {'sd':>5} {'cov90 P_phys':>12} {'converged':>9}")
    med = {}
    for tag in ("before", "after"):
        rec = [r[tag] for r in records]
        sig = np.array([r[0]["sigma_P"] for r in rec])
        pp = np.array([r[0]["P_phys_kPa"] for r in rec])
        med[tag] = sig[:, 1]
        cov_s = np.mean((sig[:, 0] <= TRUE_SIGMA_P) & (TRUE_SIGMA_P <= sig[:, 2]))
        cov_p = np.mean((pp[:, 0] <= TRUE_P_PHYS_KPA) & (TRUE_P_PHYS_KPA <= pp[:, 2]))
        conv = sum(r[1] for r in rec)
        print(f"{tag:>9} {sig[:, 1].mean():>11.4f} {sig[:, 1].std(ddof=1):>6.4f} {cov_s:>13.2f} "
              f"{pp[:, 1].mean():>10.2f} {pp[:, 1].std(ddof=1):>5.2f} {cov_p:>12.2f} "
              f"{conv:>5}/{len(rec)}")
    width = {k: np.mean([r["after"][0][k][2] - r["after"][0][k][0] for r in records])
             for k in ("sigma_P", "P_phys_kPa")}
    modes = {tag: np.array([r[tag][0]["mode"] for r in records]) for tag in ("before", "after")}
    shifts = {"sigma_P median": med["after"] - med["before"],
              "sigma_P mode": modes["after"][:, 0] - modes["before"][:, 0],
              "P_phys mode [kPa]": modes["after"][:, 1] - modes["before"][:, 1]}
    print("paired shift after - before (modes: deterministic; medians: also importance-sampling "
          "noise):")
    for name, d in shifts.items():
        print(f"  {name:>18}: mean {d.mean():+.4f}, sd {d.std(ddof=1):.4f}, "
              f"min {d.min():+.4f}, max {d.max():+.4f}")
    print(f"  mean 90 % interval width (after): sigma_P {width['sigma_P']:.3f}, "
          f"P_phys {width['P_phys_kPa']:.2f} kPa; mean sigma_P mode before "
          f"{modes['before'][:, 0].mean():.4f}, after {modes['after'][:, 0].mean():.4f}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", default="1-20")
    ap.add_argument("--latent", nargs="+", default=["deconvolved", "population"])
    a = provenance.add_output_options(ap).parse_args()
    sizes, settings, steps, repeats = (72, 42), None, (0.025, 0.05, 0.1, 0.2), 15
    if a.smoke:  # two data sets of 12 + 8 cells, short chains, one row spacing, one timing
        a.seeds, sizes, steps, repeats = "1-2", (12, 8), (0.2,), 1
        settings = CriticismSettings(**SMOKE_SETTINGS)
    provenance.tee_stdout(a, "pressure_error_double_counting.txt")
    print(provenance.header_line(), flush=True)
    table = surrogate.load()
    seeds = parse_seeds(a.seeds)
    t_start = time.process_time()
    print(f"# turgorbayes {__version__}; pressure_error injected at sigma_P = {TRUE_SIGMA_P}, "
          f"seeds {seeds[0]}-{seeds[-1]}; SIGMA_GRID step "
          f"{population.SIGMA_GRID[1]:.3f} up to {population.SIGMA_GRID[-1]:.2f}")
    print("\n# (1) sigma-row spacing: max |mixture - direct deconvolution at mid-row| of the "
          "marginal log-likelihood of the 72 estimates [nats], data sets "
          f"{seeds[:3]}, mid-rows <= 0.6")
    for step, worst in interpolation_error([data(s, table, sizes) for s in seeds[:3]], steps):
        print(f"step {step:.3f}: {worst:.4f}")
    for latent in a.latent:
        records = []
        for s in seeds:
            cells = data(s, table, sizes)
            rec = {}
            for tag, before in (("before", True), ("after", False)):
                rec[tag] = fit(model_for(cells, table, latent, before), cells, table, 1,
                               settings)
            records.append(rec)
            b, f = rec["before"][0]["sigma_P"][1], rec["after"][0]["sigma_P"][1]
            mb, mf = rec["before"][0]["mode"][0], rec["after"][0]["mode"][0]
            print(f"  seed {s:3d}: sigma_P median before {b:.4f} after {f:.4f} (mode {mb:.4f} / "
                  f"{mf:.4f}); P_phys "
                  f"{rec['before'][0]['P_phys_kPa'][1]:.2f} / {rec['after'][0]['P_phys_kPa'][1]:.2f} kPa; "
                  f"engines {rec['before'][2]}/{rec['after'][2]}", flush=True)
        summarize(records, latent)
    c = cost(data(seeds[0], table, sizes), table, repeats)
    print("\n# (3) CPU s per pointwise log-likelihood call of the pressure_error model, "
          "128 walkers (median of 15, interleaved)")
    print(f"before {c['before']:.4f}  after {c['after']:.4f}  ratio {c['after'] / c['before']:.2f}; "
          f"building the family's 20 extra rows once: {c['family_build']:.2f} s")
    print(f"\n# total CPU {time.process_time() - t_start:.0f} s")


if __name__ == "__main__":
    main()
