"""Model criticism: find what the baseline gets wrong, name the cause, fit it, measure the gain.

:func:`criticize` (``turgorbayes criticize``) checks the baseline fit, fits every effect of
:mod:`turgorbayes.effects` as an extension, compares them by leave-one-out and selects one by a
stated rule. Modules: :mod:`~.workflow`, :mod:`~.posterior` (importance sampling and emcee),
:mod:`~.loo`, :mod:`~.selection`, :mod:`~.checks`, :mod:`~.stacking`. See ``docs/effects.md``.
"""

from turgorbayes.criticism import checks, stacking
from turgorbayes.criticism.loo import compare, exact_loo, gain_probability, psis_loo
from turgorbayes.criticism.posterior import (
    K_MAX,
    Posterior,
    fit_posterior,
    importance_posterior,
    mcmc_posterior,
)
from turgorbayes.criticism.selection import (
    DELTA_ELPD_MIN,
    DELTA_ELPD_WEAK,
    P_GAIN_MIN,
    cause_sentence,
    select,
)
from turgorbayes.criticism.workflow import (
    CRITICISM_KEYS,
    CriticismResult,
    CriticismSettings,
    criticism_dict,
    criticize,
    predictive_checks,
)
from turgorbayes.inference.mode import find_mode, hessian_cov, laplace

__all__ = [
    "CRITICISM_KEYS",
    "DELTA_ELPD_MIN",
    "DELTA_ELPD_WEAK",
    "K_MAX",
    "P_GAIN_MIN",
    "CriticismResult",
    "CriticismSettings",
    "Posterior",
    "cause_sentence",
    "checks",
    "compare",
    "criticism_dict",
    "criticize",
    "exact_loo",
    "find_mode",
    "fit_posterior",
    "gain_probability",
    "hessian_cov",
    "importance_posterior",
    "laplace",
    "mcmc_posterior",
    "predictive_checks",
    "psis_loo",
    "select",
    "stacking",
]
