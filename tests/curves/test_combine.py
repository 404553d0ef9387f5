"""Combining several curves of one cell: the plain mean and its Birge-scaled error."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.curves.combine import combine_stiffness


def test_equal_weights_closed_form():
    # Reference, by hand: mean (1 + 2 + 4)/3 = 7/3; internal variance (0.01 + 0.25 + 1)/9 = 0.14;
    # chi^2 = (4/3)^2/0.01 + (1/3)^2/0.25 + (5/3)^2/1 = 181.0, Birge^2 = 90.5;
    # error sqrt(90.5 * 0.14) = 3.5595; depths (10 + 20 + 30)/3 = 20
    k, err, depth = combine_stiffness([1.0, 2.0, 4.0], [0.1, 0.5, 1.0], [10.0, 20.0, 30.0])
    assert_allclose((k, err, depth), (7 / 3, np.sqrt(181.0 / 2 * 0.14), 20.0), rtol=1e-12)


def test_inverse_variance_closed_form():
    # Reference, by hand: weights 1, 1 (errors 1, 1) -> mean 2; chi^2 = 1 + 1 = 2 over 1 dof
    # -> Birge^2 = 2; internal error 1/sqrt(2), external 1
    k, err, _ = combine_stiffness([1.0, 3.0], [1.0, 1.0], weights="inverse_variance")
    assert_allclose((k, err), (2.0, 1.0), rtol=1e-12)
    # consistent curves: the internal error (sum 1/sigma^2)^-1/2 = (1 + 1/4)^-1/2
    k, err, _ = combine_stiffness([1.0, 1.1], [1.0, 2.0], weights="inverse_variance")
    assert_allclose((k, err), ((1.0 + 1.1 / 4) / 1.25, 1.25 ** -0.5), rtol=1e-12)


def test_errors_that_follow_the_reading_do_not_bias_the_plain_mean():
    # Simulated truth: 20,000 cells of three curves, k_i ~ N(1, 0.3), each reported with an
    # error of 30 % of its own reading (the contact-point part of a soft cell's error). The
    # plain mean is unbiased (sd of the average 0.3/sqrt(3)/sqrt(20000) = 0.0012); weights
    # 1/err^2 favour the low readings and come out well below 1.
    rng = np.random.default_rng(5)
    k = 1.0 + 0.3 * rng.standard_normal((20000, 3))
    k = k[(k > 0).all(axis=1)]
    plain = [combine_stiffness(row, 0.3 * row)[0] for row in k]
    weighted = [combine_stiffness(row, 0.3 * row, weights="inverse_variance")[0] for row in k]
    assert abs(np.mean(plain) - 1.0) < 4 * 0.3 / np.sqrt(3 * len(k))
    assert np.mean(weighted) < 0.9


def test_unknown_weights_are_refused():
    with pytest.raises(ValueError, match="weights must be one of"):
        combine_stiffness([1.0], [0.1], weights="median")
