"""criticism.loo.posterior_covariance, the covariance a leave-one-out refit's importance
sampler starts from (docs/statistics.md, "Exact leave-one-out refits")."""

from types import SimpleNamespace

import numpy as np
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes.criticism.loo import posterior_covariance

#: A correlated two-parameter Gaussian: the target whose covariance the weighted draws carry.
TARGET_COV = np.array([[1.0, 0.8], [0.8, 2.0]])


def _weighted(n, seed):
    """Draws of a wide, uncorrelated normal proposal weighted to the target (self-normalized)."""
    rng = np.random.default_rng(seed)
    proposal = stats.multivariate_normal(np.zeros(2), 4 * np.eye(2))
    u = proposal.rvs(n, random_state=rng)
    log_w = stats.multivariate_normal(np.zeros(2), TARGET_COV).logpdf(u) - proposal.logpdf(u)
    return SimpleNamespace(u=u, log_w=log_w - np.logaddexp.reduce(log_w), cov=np.eye(2))


def test_the_weighted_draws_give_the_target_covariance():
    # reference: the target's covariance (closed form); 20,000 draws with ESS ~ 8,000: the
    # Monte Carlo error of each entry is ~0.04
    cov = posterior_covariance(_weighted(20_000, 1))
    assert_allclose(cov, TARGET_COV, atol=0.12)


def test_too_few_effective_draws_keep_the_laplace_covariance():
    # reference: the rule (ESS <= 10 per parameter): 15 draws cannot give a covariance
    post = _weighted(15, 2)
    assert posterior_covariance(post) is post.cov
