"""Tests of turgorbayes.inference.mode (posterior mode and Laplace covariance).

References are closed forms: on a Gaussian log density the mode is its mean and the inverse
Hessian its covariance exactly (central differences of a quadratic are exact up to rounding).
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.inference import mode

MEAN = np.array([1.5, -2.0, 30.0])
COV = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.3], [0.0, 0.3, 4.0]])


class Gaussian:
    """Vectorized log density of N(MEAN, COV) (up to a constant)."""

    name = "gaussian"
    prec = np.linalg.inv(COV)

    def log_posterior(self, u):
        d = np.atleast_2d(u) - MEAN
        return -0.5 * np.einsum("wi,ij,wj->w", d, self.prec, d)

    def to_u(self, values):
        return np.atleast_2d(values["u"])


@pytest.mark.parametrize("method", ["BFGS", "Nelder-Mead"])
def test_find_mode_of_a_gaussian_is_its_mean(method):
    # reference: the mode of N(MEAN, COV) is MEAN
    u = mode.find_mode(Gaussian(), MEAN + np.array([0.3, -0.2, 2.0]), method=method)
    assert_allclose(u, MEAN, atol=0.05 if method == "BFGS" else 1e-3)


def test_hessian_cov_and_inverse_hessian_of_a_gaussian_are_its_covariance():
    # reference: -d^2 log N / du^2 = COV^-1 exactly; both inversions return COV
    H = mode.hessian(Gaussian(), MEAN)
    assert_allclose(H, np.linalg.inv(COV), rtol=1e-5, atol=1e-5)
    assert_allclose(mode.inverse_hessian(H), COV, rtol=1e-5, atol=1e-7)
    assert_allclose(mode.hessian_cov(Gaussian(), MEAN), COV, rtol=1e-5, atol=1e-7)
    u_map, cov = mode.laplace(Gaussian(), {"u": MEAN + 0.1})
    assert_allclose(u_map, MEAN, atol=0.05)
    assert_allclose(cov, COV, rtol=1e-3, atol=1e-6)


def test_inverse_hessian_falls_back_to_the_diagonal_and_clipping_bounds_the_variance():
    # not positive definite: eigenvalues 3 and -1; documented fallbacks
    H = np.array([[1.0, 2.0], [2.0, 1.0]])
    assert_allclose(mode.inverse_hessian(H), np.diag([1.0, 1.0]))  # 1/diag(H)
    assert_allclose(mode.inverse_hessian(np.diag([4.0, -1.0])), np.diag([0.25, 1e-2]))
    # clipped: the concave-up direction (1, -1)/sqrt2 gets eigenvalue 1e-3 -> variance 1e3
    cov = mode.clipped_inverse(H)
    v = np.array([1.0, -1.0]) / np.sqrt(2)
    assert_allclose(v @ cov @ v, 1e3, rtol=1e-12)


def test_strict_hessian_outside_the_domain_raises_and_bad_method_is_rejected():
    class HalfLine(Gaussian):
        def log_posterior(self, u):
            u = np.atleast_2d(u)
            return np.where(u[:, 0] >= MEAN[0], super().log_posterior(u), -np.inf)

    with pytest.raises(ValueError, match="leaves the region"):
        mode.hessian(HalfLine(), MEAN)
    with np.errstate(invalid="ignore"):  # inf - inf in the stencil
        assert not np.all(np.isfinite(mode.hessian(HalfLine(), MEAN, strict=False)))
    with pytest.raises(ValueError, match="non-finite log posterior"):
        mode.find_mode(HalfLine(), MEAN - 1.0)
    with pytest.raises(ValueError, match="method must be"):
        mode.find_mode(Gaussian(), MEAN, method="newton")


class Spike(Gaussian):
    """N(MEAN, COV) lowered by 100 everywhere except exactly at START: a start that is not the
    mode, from which no line search finds a better point."""

    START = MEAN + 1.0

    def log_posterior(self, u):
        u = np.atleast_2d(u)
        return super().log_posterior(u) - 100.0 * np.any(u != self.START, axis=1)


def test_a_mode_search_that_cannot_improve_its_start_warns():
    # the gradient at START is that of the Gaussian (the spike sits on one point), far from 0,
    # yet every step is 100 nats lower: the search returns START, which is not a mode
    with pytest.warns(mode.ModeSearchWarning, match="did not improve on its start"):
        u = mode.find_mode(Spike(), Spike.START)
    assert_allclose(u, Spike.START)
    res = mode.mode_search(Spike(), Spike.START)
    assert not res.success and "gradient norm" in res.message
    # at the true mode no improvement is possible either, but the gradient is 0: no warning
    assert mode.mode_search(Gaussian(), MEAN).success


class Saddle(Gaussian):
    """-log density 0.5 u'Hu with H = [[1, 2], [2, 1]] (eigenvalues 3 and -1)."""

    H = np.array([[1.0, 2.0], [2.0, 1.0]])
    name = "saddle"

    def log_posterior(self, u):
        u = np.atleast_2d(u)
        return -0.5 * np.einsum("wi,ij,wj->w", u, self.H, u)


def test_clipped_eigenvalues_are_counted_warned_and_recorded():
    # reference: H has unit diagonal, so its scaled eigenvalues are 3 and -1: one is clipped
    # to the floor 1e-3, the smallest was -1
    with pytest.warns(RuntimeWarning, match=r"saddle: 1 eigenvalue\(s\) .*\(smallest -1\)"):
        mode.hessian_cov(Saddle(), np.zeros(2))
    cov, clip = mode.clipped_inverse(Saddle.H, return_clipping=True)
    assert (clip.n_clipped, clip.floor) == (1, mode.CLIP_FLOOR)
    assert_allclose(clip.smallest, -1.0, atol=1e-12)
    fit = mode.laplace_fit(Saddle(), np.zeros(2))
    rec = fit.record()
    assert rec["hessian_clipped"]["n_eigenvalues"] == 1 and "clipped" in rec["notes"][-1]
    # a Gaussian needs no clipping: nothing recorded
    assert mode.laplace_fit(Gaussian(), MEAN).record()["hessian_clipped"]["n_eigenvalues"] == 0
