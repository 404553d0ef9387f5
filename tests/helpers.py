"""Helpers shared by test files: a toy Gaussian posterior.

Imported as ``from helpers import ...`` (pytest puts ``tests/`` on the path: ``pythonpath``
in pyproject.toml). Fixtures stay in the conftest files; what is here is plain code that
several test files call with their own arguments.
"""

import numpy as np

__all__ = ["GAUSSIAN_COV", "GAUSSIAN_MEAN", "GaussianModel"]

#: Mean and covariance of the toy posterior the engine and criticism tests sample.
GAUSSIAN_MEAN = np.array([1.0, -2.0, 0.5])
GAUSSIAN_COV = np.array([[1.0, 0.8, 0.0], [0.8, 1.0, 0.3], [0.0, 0.3, 0.5]])


class GaussianModel:
    """A toy model: posterior N(mean, cov) in sampler coordinates = physical values (u = x),
    split into ``n`` equal pointwise terms; flat prior; no derived quantities.

    It has the interface of the posterior engine (:mod:`turgorbayes.inference.engine`):
    ``log_prior``, ``pointwise_log_likelihood``, ``log_posterior``, ``to_u``, ``to_physical``
    and ``derived``.
    """

    name = "toy"
    names = ("x0", "x1", "x2")

    def __init__(self, mean, cov, n=5):
        self.mean, self.prec, self.n = np.asarray(mean), np.linalg.inv(cov), n
        self.obs = type("obs", (), {"n_cells": n})()
        self.ndim = len(mean)

    def log_prior(self, u):
        return np.zeros(len(np.atleast_2d(u)))

    def pointwise_log_likelihood(self, u):
        d = np.atleast_2d(u) - self.mean
        q = -0.5 * np.einsum("ij,jk,ik->i", d, self.prec, d)
        return np.repeat(q[:, None] / self.n, self.n, axis=1)

    def log_posterior(self, u):
        return self.pointwise_log_likelihood(u).sum(axis=1)

    def to_u(self, values):
        return np.atleast_2d([values[n] for n in self.names])

    def to_physical(self, u):
        u = np.atleast_2d(u)
        return {n: u[:, i] for i, n in enumerate(self.names)}

    def derived(self, u, rng):
        return {}

