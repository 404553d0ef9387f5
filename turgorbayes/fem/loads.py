r"""Surface loads: the turgor pressure as a follower load, and nodal area weights.

The pressure acts on the current inner surface, normal to it:

.. math::

    f_a = P \int N_a\, (\mathbf x_{,1}\times\mathbf x_{,2})\, d\xi_1 d\xi_2,
    \qquad
    \frac{\partial f_a}{\partial u_b}
        = P\int N_a \bigl([\mathbf x_{,1}]_\times N_{b,2} - [\mathbf x_{,2}]_\times N_{b,1}\bigr)\,d\xi,

with :math:`[\mathbf a]_\times\mathbf v = \mathbf a\times\mathbf v` and the orientation chosen so
that the force points out of the cavity.
"""

import numpy as np

from turgorbayes.fem.element import face_basis, gauss_points_2d

__all__ = ["face_orientation", "node_areas", "pressure_load"]

_PTS, _WTS = gauss_points_2d()
_N, _DN = face_basis(_PTS)


def _cross_matrix(a):
    z = np.zeros(a.shape[:-1])
    return np.stack([np.stack([z, -a[..., 2], a[..., 1]], -1),
                     np.stack([a[..., 2], z, -a[..., 0]], -1),
                     np.stack([-a[..., 1], a[..., 0], z], -1)], -2)


def face_orientation(faces, X, interior_point_of_face):
    """+1 or -1 per face so that ``sign * (x_1 x x_2)`` points away from the cavity.

    ``interior_point_of_face`` gives, per face, a point on the wall side (e.g. the opposite
    node of its element); the cavity is on the other side.
    """
    xf = X[faces]
    t1 = np.einsum("fai,a->fi", xf, _DN[4, :, 0])  # Gauss point 4 = face centre
    t2 = np.einsum("fai,a->fi", xf, _DN[4, :, 1])
    centre = np.einsum("fai,a->fi", xf, _N[4])
    return np.sign(np.sum(np.cross(t1, t2) * (interior_point_of_face - centre), axis=1))


def pressure_load(faces, sign, x_nodes, P, want_tangent=True):
    """Nodal forces of a follower pressure and their derivative (for the residual's tangent).

    Parameters
    ----------
    faces : ndarray (n_f, 9)
    sign : ndarray (n_f,)
        Orientation from :func:`face_orientation`.
    x_nodes : ndarray (n_nodes, 3) [m]
        Current positions.
    P : float [Pa]

    Returns
    -------
    f : ndarray (n_f, 9, 3) [N]
        Face load vectors.
    dfdu : ndarray (n_f, 27, 27) or None
        Derivative of ``f`` (row ``3 a + i``) with respect to the face's node displacements.
    """
    xf = x_nodes[faces]
    t1 = np.einsum("fai,qa->fqi", xf, _DN[:, :, 0])
    t2 = np.einsum("fai,qa->fqi", xf, _DN[:, :, 1])
    scale = P * sign[:, None] * _WTS[None, :]
    f = np.einsum("fq,qa,fqi->fai", scale, _N, np.cross(t1, t2))
    if not want_tangent:
        return f, None
    A = (np.einsum("fqij,qb->fqibj", _cross_matrix(t1), _DN[:, :, 1])
         - np.einsum("fqij,qb->fqibj", _cross_matrix(t2), _DN[:, :, 0]))
    dfdu = np.einsum("fq,qa,fqibj->faibj", scale, _N, A).reshape(-1, 27, 27)
    return f, dfdu


def node_areas(faces, X, n_nodes):
    """Reference surface area carried by each node: ``A_a = int N_a dA`` over the faces [m^2]."""
    xf = X[faces]
    t1 = np.einsum("fai,qa->fqi", xf, _DN[:, :, 0])
    t2 = np.einsum("fai,qa->fqi", xf, _DN[:, :, 1])
    dA = np.linalg.norm(np.cross(t1, t2), axis=-1) * _WTS
    return np.bincount(faces.ravel(), weights=np.einsum("fq,qa->fa", dA, _N).ravel(),
                       minlength=n_nodes)
