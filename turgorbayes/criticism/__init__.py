"""Model criticism: the parts that find what the baseline gets wrong and measure a gain.

Modules: :mod:`~.checks` (posterior predictive checks), :mod:`~.loo` (leave-one-out),
:mod:`~.selection` (the stated rule that names a cause), :mod:`~.stacking`, :mod:`~.verdict`;
the posteriors come from :mod:`turgorbayes.inference.engine`, the one engine of fit, criticism
and SBC (``turgorbayes.criticism.posterior`` is that module, deprecated). The workflow that runs them in order
(``turgorbayes criticize``: check the baseline fit, fit every effect of
:mod:`turgorbayes.effects` as an extension, compare, select) is
:func:`turgorbayes.workflows.criticize.criticize`, one layer up: nothing here imports it.
See ``docs/effects.md``.

``turgorbayes.criticism.criticize``, ``CriticismSettings``, ``CriticismResult``,
``criticism_dict``, ``CRITICISM_KEYS`` and ``predictive_checks`` still work, imported on use
from :mod:`turgorbayes.workflows.criticize` with a ``DeprecationWarning``; they are removed
in 0.4.0.
"""

from turgorbayes._moved import deprecated_attributes
from turgorbayes.criticism import checks, stacking
from turgorbayes.criticism.loo import compare, exact_loo, gain_probability, psis_loo
from turgorbayes.criticism.selection import (
    DELTA_ELPD_MIN,
    DELTA_ELPD_WEAK,
    P_GAIN_MIN,
    cause_sentence,
    select,
)
from turgorbayes.inference.engine import (
    K_MAX,
    Posterior,
    fit_posterior,
    importance_posterior,
    mcmc_posterior,
)
from turgorbayes.inference.mode import find_mode, hessian_cov, laplace

#: Names that moved to :mod:`turgorbayes.workflows.criticize` (deprecated here; removed in 0.4.0).
_MOVED_NAMES = dict.fromkeys(("CRITICISM_KEYS", "CriticismResult", "CriticismSettings",
                              "criticism_dict", "criticize", "predictive_checks"),
                             "turgorbayes.workflows.criticize")
__getattr__ = deprecated_attributes(__name__, _MOVED_NAMES)

__all__ = [
    "DELTA_ELPD_MIN",
    "DELTA_ELPD_WEAK",
    "K_MAX",
    "P_GAIN_MIN",
    "Posterior",
    "cause_sentence",
    "checks",
    "compare",
    "exact_loo",
    "find_mode",
    "fit_posterior",
    "gain_probability",
    "hessian_cov",
    "importance_posterior",
    "laplace",
    "mcmc_posterior",
    "psis_loo",
    "select",
    "stacking",
]
