r"""Orthotropic logarithmic-strain law with true (Cauchy) stress, for the wall model.

The wall model (docs/physics.md, Wall law; Deng et al. 2011 supplement) measures stress as true
stress, force per *current* area, and strain as natural strain ``ln(lambda)``; its modulus is
the tangent :math:`E_\perp = d\sigma_\mathrm{true}/d\ln\lambda`. The law implemented here has
exactly that property in every material direction:

.. math::

    \boldsymbol\sigma = \mathbf R\,\bigl[\mathbb D : \ln\mathbf U\bigr]\,\mathbf R^T,
    \qquad \mathbf F = \mathbf R\mathbf U,

with :math:`\mathbb D` the small-strain orthotropic stiffness in the material axes
(1 = circumferential, 2 = axial or meridional, 3 = normal to the wall). For a stretch
:math:`\lambda` along a material axis with the other stresses zero and :math:`\nu = 0`:
:math:`\sigma = E\ln\lambda` (true stress linear in natural strain, at any strain), so a
cylinder of wall thickness t inflates as

.. math::

    P\,R_\mathrm{in} = E_\perp t \ln(R/R_0) \quad (\nu = 0),

the constant-modulus case of the supplement's :math:`E_\perp\,dR/R = d(PR)/t`. St
Venant-Kirchhoff instead gives :math:`\sigma = E\lambda(\lambda^2-1)/2`, whose tangent is
:math:`E(1+3\epsilon)` at strain :math:`\epsilon`, i.e. 30% stiffer than :math:`E_\perp` at
x = 0.1, which would make the FE's inflation number mean something else than the inference's.
A Kirchhoff-stress Hencky law (:math:`\tau = \mathbb D:\ln\mathbf V`, the hyperelastic one)
gives :math:`\sigma = E\ln\lambda/J`, again not the wall model. The law here is Cauchy-elastic
(objective, path-independent stress, but not derivable from a strain energy when the
stretches are not coaxial with the material axes), so its consistent tangent is not
symmetric; the solvers used are general LU solvers.

Stiffness in the material axes: normal compliances :math:`1/E_i` and
:math:`-\nu/\sqrt{E_iE_j}` (one Poisson parameter, symmetric compliance, isotropic when all
:math:`E_i` are equal; positive definite for -1 < nu < 0.5), shear moduli
:math:`G_{ij} = \sqrt{E_iE_j}/(2(1+\nu))` (Huber's estimate for orthotropic plates; the paper
does not state its shear modulus), :math:`E_3 = E_\perp` through the wall.

In the total-Lagrangian kernels the law is used through the second Piola-Kirchhoff stress
:math:`\mathbf S = J\,\mathbf U^{-1}(\mathbb D:\ln\mathbf U)\mathbf U^{-1}`, a function of
:math:`\mathbf C = \mathbf F^T\mathbf F` alone, and its derivative with respect to the Green
strain, evaluated with the Daleckii-Krein formula for derivatives of matrix functions.
"""

import numpy as np

__all__ = ["LAWS", "orthotropic_stiffness", "stress_and_tangent", "svk_stress_and_tangent"]

# Voigt order of symmetric tensors: 11, 22, 33, 12, 23, 13 (engineering shear strains).
_VOIGT = ((0, 0), (1, 1), (2, 2), (0, 1), (1, 2), (0, 2))


def orthotropic_stiffness(E1, E2, E3, nu):
    """Small-strain stiffness (6x6 Voigt, engineering shear) in the material axes.

    Parameters
    ----------
    E1, E2, E3 : float [Pa]
        Young's moduli along the circumferential, axial and normal material axes.
    nu : float [-]
        Poisson parameter (see the module docstring for the orthotropic generalization).
    """
    E = np.array([E1, E2, E3], dtype=float)
    root = np.sqrt(np.outer(E, E))
    compliance = np.where(np.eye(3, dtype=bool), 1.0 / E[:, None], -nu / root)
    D = np.zeros((6, 6))
    D[:3, :3] = np.linalg.inv(compliance)
    D[3, 3], D[4, 4], D[5, 5] = (root[0, 1], root[1, 2], root[0, 2])
    D[3:, 3:] /= 2.0 * (1.0 + nu)
    return D


def _to_voigt_strain(A):
    """Tensor (..., 3, 3) -> engineering Voigt vector (..., 6)."""
    return np.stack([A[..., 0, 0], A[..., 1, 1], A[..., 2, 2],
                     2 * A[..., 0, 1], 2 * A[..., 1, 2], 2 * A[..., 0, 2]], axis=-1)


def _from_voigt_stress(v):
    """Voigt stress vector (..., 6) -> symmetric tensor (..., 3, 3)."""
    T = np.empty(v.shape[:-1] + (3, 3))
    for k, (i, j) in enumerate(_VOIGT):
        T[..., i, j] = v[..., k]
        T[..., j, i] = v[..., k]
    return T


def _to_voigt_stress(T):
    return np.stack([T[..., i, j] for i, j in _VOIGT], axis=-1)


def _log_divided_differences(c):
    """Matrix of (ln c_a - ln c_b)/(c_a - c_b), with 1/c_a on and near the diagonal."""
    ca, cb = c[..., :, None], c[..., None, :]
    r = (ca - cb) / cb
    small = np.abs(r) < 1e-4
    safe = np.where(small, 1.0, r)
    direct = np.log1p(safe) / (safe * cb)
    series = (1.0 - r / 2.0 + r**2 / 3.0 - r**3 / 4.0) / cb
    return np.where(small, series, direct)


def _inv_sqrt_divided_differences(c):
    """Matrix of (c_a^-1/2 - c_b^-1/2)/(c_a - c_b) in a cancellation-free form."""
    s = np.sqrt(c)
    sa, sb = s[..., :, None], s[..., None, :]
    return -1.0 / (sa * sb * (sa + sb))


def _unit_strain_directions():
    """H = dC for the six unit engineering Green-strain directions, shape (6, 3, 3)."""
    H = np.zeros((6, 3, 3))
    for k, (i, j) in enumerate(_VOIGT):
        if i == j:
            H[k, i, i] = 2.0  # dC = 2 dE, dE_ii = 1
        else:
            H[k, i, j] = H[k, j, i] = 1.0  # 2 dE_ij = 1 (engineering shear)
    return H


_H = _unit_strain_directions()


def stress_and_tangent(E, D, want_tangent=True):
    """Second Piola-Kirchhoff stress and its Green-strain tangent for the Cauchy-Hencky law.

    Parameters
    ----------
    E : ndarray, shape (..., 3, 3)
        Green strain :math:`(\\mathbf C - \\mathbf I)/2` in the material axes (passed instead of
        C so that tiny strains keep their relative precision).
    D : ndarray, shape (6, 6) [Pa]
        Small-strain stiffness in the material axes (:func:`orthotropic_stiffness`).
    want_tangent : bool
        False skips the tangent (about 85 % of the cost; for residual-only evaluations).

    Returns
    -------
    S : ndarray, shape (..., 3, 3) [Pa]
        Second Piola-Kirchhoff stress.
    tangent : ndarray, shape (..., 6, 6) [Pa] or None
        :math:`\\partial S_I/\\partial E_J` in Voigt notation (engineering shear in J); not
        symmetric in general. None if ``want_tangent`` is False.
    """
    e, V = np.linalg.eigh(E)
    c = 1.0 + 2.0 * e
    Vt = np.swapaxes(V, -1, -2)
    J = np.sqrt(np.prod(c, axis=-1))
    L = V @ (0.5 * np.log1p(2.0 * e)[..., :, None] * Vt)
    Ui = V @ (c[..., :, None] ** -0.5 * Vt)
    T = _from_voigt_stress(_to_voigt_strain(L) @ D.T)
    TUi = T @ Ui
    S = J[..., None, None] * (Ui @ TUi)
    if not want_tangent:
        return S, None

    # directional derivatives along the six unit strains, all at once (axis -3 = direction)
    Hp = Vt[..., None, :, :] @ _H @ V[..., None, :, :]  # H in the eigenbasis
    dL = V[..., None, :, :] @ (0.5 * _log_divided_differences(c)[..., None, :, :] * Hp) @ Vt[..., None, :, :]
    dUi = V[..., None, :, :] @ (_inv_sqrt_divided_differences(c)[..., None, :, :] * Hp) @ Vt[..., None, :, :]
    dJ_over_J = 0.5 * np.einsum("...kaa,...a->...k", Hp, 1.0 / c)
    dT = _from_voigt_stress(_to_voigt_strain(dL) @ D.T)
    A = dUi @ TUi[..., None, :, :]
    dS = (dJ_over_J[..., None, None] * S[..., None, :, :]
          + J[..., None, None, None] * (A + np.swapaxes(A, -1, -2)
                                        + Ui[..., None, :, :] @ dT @ Ui[..., None, :, :]))
    tangent = np.swapaxes(_to_voigt_stress(dS), -1, -2)  # [..., I, J] = dS_I / dE_J
    return S, tangent


def svk_stress_and_tangent(E, D, want_tangent=True):
    """St Venant-Kirchhoff law ``S = D : E`` (comparison only: its true-stress tangent grows
    with strain, :math:`d\\sigma/d\\ln\\lambda = E(3\\lambda^2-1)\\lambda/2` uniaxially).

    Same signature as :func:`stress_and_tangent`.
    """
    S = _from_voigt_stress(_to_voigt_strain(E) @ D.T)
    return S, (np.broadcast_to(D, E.shape[:-2] + (6, 6)) if want_tangent else None)


#: Wall laws by name: ``"log"`` (default, the wall model) and ``"svk"`` (comparison).
LAWS = {"log": stress_and_tangent, "svk": svk_stress_and_tangent}
