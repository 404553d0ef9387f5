"""Triquadratic (27-node) Lagrange hexahedron and its 9-node faces on the reference cube.

The shape functions are tensor products of the 1D quadratic Lagrange polynomials on the
nodes -1, 0, 1 of [-1, 1]; local node ``(a, b, c)`` (``a`` along the first reference
coordinate, ``c`` along the third) has local index ``9 a + 3 b + c``. This is the same space as
scikit-fem's ``ElementHex2``; the ordering is our own because the meshes here are structured
tensor grids. Integration uses the 3x3x3 Gauss rule (27 points), which integrates the
stiffness of an affine element exactly and is what ``intorder=5`` gives in scikit-fem.
"""

import numpy as np

__all__ = ["GAUSS_1D", "face_basis", "gauss_points_3d", "gauss_points_2d", "hex27_basis"]

#: 3-point Gauss-Legendre rule on [-1, 1]: (points, weights).
GAUSS_1D = np.polynomial.legendre.leggauss(3)


def _lagrange2(xi):
    """Values and derivatives of the three quadratic Lagrange polynomials at points ``xi``.

    Returns two arrays of shape ``(3, len(xi))`` for the nodes -1, 0, 1.
    """
    xi = np.asarray(xi, dtype=float)
    val = np.array([0.5 * xi * (xi - 1.0), 1.0 - xi**2, 0.5 * xi * (xi + 1.0)])
    der = np.array([xi - 0.5, -2.0 * xi, xi + 0.5])
    return val, der


def gauss_points_3d():
    """The 27-point tensor Gauss rule on [-1, 1]^3: points ``(27, 3)`` and weights ``(27,)``."""
    p, w = GAUSS_1D
    pts = np.stack(np.meshgrid(p, p, p, indexing="ij"), axis=-1).reshape(-1, 3)
    wts = np.einsum("i,j,k->ijk", w, w, w).ravel()
    return pts, wts


def gauss_points_2d():
    """The 9-point tensor Gauss rule on [-1, 1]^2: points ``(9, 2)`` and weights ``(9,)``."""
    p, w = GAUSS_1D
    pts = np.stack(np.meshgrid(p, p, indexing="ij"), axis=-1).reshape(-1, 2)
    return pts, np.outer(w, w).ravel()


def hex27_basis(points):
    """Shape functions of the 27-node hexahedron at reference points.

    Parameters
    ----------
    points : array_like, shape (n, 3)
        Points of the reference cube [-1, 1]^3.

    Returns
    -------
    N : ndarray, shape (n, 27)
        Shape function values.
    dN : ndarray, shape (n, 27, 3)
        Derivatives with respect to the three reference coordinates.
    """
    points = np.atleast_2d(points)
    v = [_lagrange2(points[:, d]) for d in range(3)]
    (v0, d0), (v1, d1), (v2, d2) = v
    N = np.einsum("an,bn,cn->nabc", v0, v1, v2).reshape(-1, 27)
    dN = np.stack(
        [
            np.einsum("an,bn,cn->nabc", d0, v1, v2).reshape(-1, 27),
            np.einsum("an,bn,cn->nabc", v0, d1, v2).reshape(-1, 27),
            np.einsum("an,bn,cn->nabc", v0, v1, d2).reshape(-1, 27),
        ],
        axis=-1,
    )
    return N, dN


def face_basis(points):
    """Shape functions of the 9-node quadrilateral face (index ``3 a + b``) at 2D points.

    Returns values ``(n, 9)`` and derivatives ``(n, 9, 2)``.
    """
    points = np.atleast_2d(points)
    (v0, d0), (v1, d1) = _lagrange2(points[:, 0]), _lagrange2(points[:, 1])
    N = np.einsum("an,bn->nab", v0, v1).reshape(-1, 9)
    dN = np.stack(
        [np.einsum("an,bn->nab", d0, v1).reshape(-1, 9), np.einsum("an,bn->nab", v0, d1).reshape(-1, 9)],
        axis=-1,
    )
    return N, dN
