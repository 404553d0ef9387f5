"""Inference: the statistical model of the cells and its posterior (``docs/statistics.md``).

* data side: :mod:`~.observations` (bulge-derived pressures and their errors),
  :mod:`~.population` (the population density of the latent pressures, deconvolved from the
  bulges; given ones in :mod:`~.population_densities`, :mod:`~.population_box`),
  :mod:`~.population_noise` (its estimation noise, carried into the posterior);
* the likelihood engine: :mod:`~.likelihood` (per-cell log-likelihood, latent pressures
  integrated out), :mod:`~.pressure_grid` (each walker's wall tabulated in ln P),
  :mod:`~.context` (what a model extension may change in it);
* priors and models: :mod:`~.priors`, :mod:`~.width_prior`, :mod:`~.models` (the baseline and
  the paper's weighted least squares), :mod:`~.conditions` (several conditions: the design in
  :mod:`~.condition_design`, the reported contrasts in :mod:`~.condition_contrasts`);
* posteriors: :mod:`~.engine` (the one posterior engine of fit, criticism and SBC: settings,
  seeds, engines, ladder, convergence rule, :class:`~.engine.Posterior`), :mod:`~.mode` (mode
  and Laplace approximation), :mod:`~.sampling` (emcee),
  :mod:`~.diagnostics` (ArviZ), :mod:`~.table_check` (how much of a posterior leans on the FE
  table's buckled region or beyond its domain).
"""
