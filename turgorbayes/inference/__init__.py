"""Inference: the statistical model of the cells and its posterior.

* :mod:`~turgorbayes.inference.likelihood`: the per-cell likelihood, latent bulge pressures
  integrated out;
* :mod:`~turgorbayes.inference.population`: the population density of the latent pressures;
* :mod:`~turgorbayes.inference.priors`, :mod:`~turgorbayes.inference.width_prior`: priors;
* :mod:`~turgorbayes.inference.models`: the baseline model and the paper's weighted least
  squares;
* :mod:`~turgorbayes.inference.sampling`, :mod:`~turgorbayes.inference.diagnostics`: emcee
  and ArviZ;
* :mod:`~turgorbayes.inference.table_check`: how much of a posterior leans on the FE table's
  unreliable corner.

The statistical model is described in ``docs/statistics.md``.
"""
