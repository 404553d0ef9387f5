"""The wall law: true stress linear in natural strain, exact tangent, objectivity."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.linalg import logm
from scipy.spatial.transform import Rotation

from turgorbayes.fem.material import orthotropic_stiffness, stress_and_tangent


def _cauchy(F, D, want_tangent=True):
    E = 0.5 * (F.T @ F - np.eye(3))
    S, tangent = stress_and_tangent(E[None], D, want_tangent)
    assert (tangent is None) is not want_tangent
    return F @ S[0] @ F.T / np.linalg.det(F)


@pytest.mark.parametrize("want_tangent", [True, False])  # the residual-only path too
@pytest.mark.parametrize("lam", [0.8, 1.05, 1.65, 2.5])
def test_uniaxial_true_stress_is_modulus_times_log_stretch(lam, want_tangent):
    # docs/physics.md, Wall law: sigma_true = E ln(lambda) with E the tangent d sigma / d ln lambda
    # (nu = 0: the other directions are unloaded and do not deform)
    D = orthotropic_stiffness(20e6, 9e6, 15e6, 0.0)
    for axis, E in enumerate((20e6, 9e6, 15e6)):
        F = np.eye(3)
        F[axis, axis] = lam
        sigma = _cauchy(F, D, want_tangent)
        assert_allclose(sigma[axis, axis], E * np.log(lam), rtol=1e-12)
        assert_allclose(np.delete(sigma.ravel(), 4 * axis), 0.0, atol=1e-9 * E)


def test_stress_equals_rotated_stiffness_times_log_strain(rng):
    # definition sigma = R (D : ln U) R^T with ln U from scipy's independent logm
    D = orthotropic_stiffness(20e6, 9e6, 20e6, 0.3)
    A = rng.normal(size=(3, 3))
    U = np.eye(3) + 0.2 * (A + A.T)
    R = Rotation.from_rotvec(rng.normal(size=3)).as_matrix()
    L = logm(U).real
    Lv = np.array([L[0, 0], L[1, 1], L[2, 2], 2 * L[0, 1], 2 * L[1, 2], 2 * L[0, 2]])
    T = D @ Lv
    T = np.array([[T[0], T[3], T[5]], [T[3], T[1], T[4]], [T[5], T[4], T[2]]])
    assert_allclose(_cauchy(R @ U, D), R @ T @ R.T, rtol=1e-9, atol=1e-9 * np.abs(T).max())


def test_tangent_matches_central_differences(rng):
    # the Daleckii-Krein tangent against finite differences of the stress itself
    D = orthotropic_stiffness(20e6, 6e6, 20e6, 0.2)
    F = np.eye(3) + 0.3 * rng.normal(size=(3, 3))
    E = 0.5 * (F.T @ F - np.eye(3))
    _, tangent = stress_and_tangent(E[None], D)
    pairs = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))
    fd = np.zeros((6, 6))
    eps = 1e-7
    for k, (i, j) in enumerate(pairs):
        dE = np.zeros((3, 3))
        dE[i, j] = dE[j, i] = 1.0 if i == j else 0.5
        Sp, _ = stress_and_tangent((E + eps * dE)[None], D)
        Sm, _ = stress_and_tangent((E - eps * dE)[None], D)
        dS = (Sp[0] - Sm[0]) / (2 * eps)
        fd[:, k] = [dS[a, b] for a, b in pairs]
    assert_allclose(tangent[0], fd, rtol=1e-6, atol=1e-6 * np.abs(fd).max())


def test_small_strain_limit_is_orthotropic_hooke():
    # at E = 0 the tangent is the stiffness matrix; its inverse is the stated compliance
    E1, E2, E3, nu = 20e6, 9e6, 20e6, 0.3
    D = orthotropic_stiffness(E1, E2, E3, nu)
    _, tangent = stress_and_tangent(np.zeros((1, 3, 3)), D)
    assert_allclose(tangent[0], D, rtol=1e-12)
    C = np.linalg.inv(D)
    assert_allclose([C[0, 0], C[1, 1], C[0, 1]], [1 / E1, 1 / E2, -nu / np.sqrt(E1 * E2)], rtol=1e-12)
    assert_allclose(1 / C[3, 3], np.sqrt(E1 * E2) / (2 * (1 + nu)), rtol=1e-12)
