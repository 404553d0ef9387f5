"""Helpers shared by test files: a toy Gaussian posterior and a grid of intact-cell readings.

Imported as ``from helpers import ...`` (pytest puts ``tests/`` on the path: ``pythonpath``
in pyproject.toml). Fixtures stay in the conftest files; what is here is plain code that
several test files call with their own arguments.
"""

import numpy as np

from turgorbayes.cells.table import CellData
from turgorbayes.physics import forward

__all__ = ["GAUSSIAN_COV", "GAUSSIAN_MEAN", "GaussianModel", "grid_axis", "intact_grid"]

#: Mean and covariance of the toy posterior the engine and criticism tests sample.
GAUSSIAN_MEAN = np.array([1.0, -2.0, 0.5])
GAUSSIAN_COV = np.array([[1.0, 0.8, 0.0], [0.8, 1.0, 0.3], [0.0, 0.3, 0.5]])


class GaussianModel:
    """A toy model: posterior N(mean, cov) in sampler coordinates = physical values (u = x),
    split into ``n`` equal pointwise terms; flat prior; no derived quantities.

    It has the interface of the posterior engine (:mod:`turgorbayes.inference.engine`):
    ``log_prior``, ``pointwise_log_likelihood``, ``log_posterior``, ``to_u``, ``to_physical``
    and ``derived``, and the model interface's optional hooks that the screens read.
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

    # the model interface's optional hooks (turgorbayes.inference.models.BaselineModel)
    conditions = None

    def flag_cells(self, draws, cell_ids, n_draws, screen):
        return None

    def flagged_cells(self, values, cell_ids, gross=False):
        return None


def grid_axis(m, lo, hi, n, tail=0):
    """Nodes about the model value ``m``.

    Parameters
    ----------
    m : float
        The model's value.
    lo, hi : float
        ``n`` uniform nodes over ``[lo m, hi m]``.
    n : int
    tail : int
        Geometric nodes on each side, out to ``m e^-5`` and ``m e^5`` (0: none).

    Returns
    -------
    ndarray
        Increasing nodes.
    """
    return np.r_[m * np.geomspace(np.exp(-5.0), lo, tail, endpoint=False),
                 np.linspace(lo * m, hi * m, n),
                 m * np.geomspace(hi, np.exp(5.0), tail + 1)[1:]]


def intact_grid(table, truth, R_axis=(0.6, 1.4, 161), k_axis=(0.02, 2.5, 181), tail=40):
    """One bulged cell and a grid of hypothetical intact readings about the model's, for
    checking that a density over an intact cell's (R_c, k_c) integrates to 1.

    Parameters
    ----------
    table : Surrogate
        The k/(PR) table.
    truth : dict
        ``gamma``, ``E0t``, ``R0``, ``P_phys``: the model's reading ``(R_c, k_c)`` is that of
        a cell at ``P_phys`` (reference pressure 5 kPa).
    R_axis, k_axis : tuple of (float, float, int)
        ``(lo, hi, n)`` of :func:`grid_axis` for ``R_c`` and ``k_c``. The defaults are fine
        about the model's reading and, with ``tail``, geometric out to factors e^+-5 (a
        gross-error reading's lognormal, log-sd 1, has 6e-7 of its mass beyond).
    tail : int
        Geometric nodes beyond each end of both axes (:func:`grid_axis`; 0: a plain grid).

    Returns
    -------
    cells : CellData
        The bulged cell ``b``, then one intact cell per node pair, ``R_c`` varying slowest,
        with 20 nm radius errors and 12 % relative stiffness errors (as reported).
    Rg, kg : ndarray
        The axes: the intact cells' density reshapes to ``(Rg.size, kg.size)``.
    """
    R, k = forward.cell_radius_and_stiffness(truth["P_phys"], truth["gamma"], truth["E0t"],
                                             truth["R0"], 5e3, table)
    Rg = grid_axis(R, *R_axis, tail=tail)
    kg = grid_axis(k, *k_axis, tail=tail)
    RR, KK = (a.ravel() for a in np.meshgrid(Rg, kg, indexing="ij"))
    n = RR.size
    nan = np.full(n, np.nan)
    cells = CellData(cell_id=["b"] + [f"i{j}" for j in range(n)],
                     group=["bulged"] + ["intact"] * n, R_c=np.r_[R, RR],
                     R_c_err=np.full(n + 1, 20e-9), k_c=np.r_[k, KK],
                     k_c_err=0.12 * np.r_[k, KK],  # a 12 % relative error, as reported
                     R_b=np.r_[500e-9, nan], R_b_err=np.r_[40e-9, nan], k_b=np.r_[1e-3, nan],
                     k_b_err=np.r_[1e-4, nan], h_b=np.r_[100e-9, nan])
    return cells, Rg, kg
