r"""Surface loads: the turgor pressure as a follower load, and nodal area weights.

A :class:`Surface` holds scikit-fem basis arrays at the Gauss points of the mesh's inner or
outer facets (docs/fem.md). The pressure acts on the current inner surface, normal to it. With
:math:`\mathbf e_1, \mathbf e_2` unit tangents of the reference surface (``e_1 x e_2``
pointing away from the cavity) and :math:`\mathbf t_\alpha = \mathbf F\mathbf e_\alpha`,

.. math::

    f_a = P \int N_a\, (\mathbf t_1\times\mathbf t_2)\, dA,
    \qquad
    \frac{\partial f_a}{\partial u_b}
        = P\int N_a \bigl([\mathbf t_1]_\times N_{b,2} - [\mathbf t_2]_\times N_{b,1}\bigr)\,dA,

with :math:`N_{b,\alpha} = \nabla N_b\cdot\mathbf e_\alpha` and
:math:`[\mathbf a]_\times\mathbf v = \mathbf a\times\mathbf v`.
"""

from dataclasses import dataclass

import numpy as np
from skfem import CellBasis, ElementHex2
from skfem.quadrature import get_quadrature
from skfem.refdom import RefQuad

from turgorbayes.fem.mesh import INTORDER

__all__ = ["Surface", "node_areas", "pressure_load"]


def _cross_matrix(a):
    z = np.zeros(a.shape[:-1])
    return np.stack([np.stack([z, -a[..., 2], a[..., 1]], -1),
                     np.stack([a[..., 2], z, -a[..., 0]], -1),
                     np.stack([-a[..., 1], a[..., 0], z], -1)], -2)


def _unit(v):
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


@dataclass(frozen=True, eq=False)
class Surface:
    """Facet data of one surface of a shell mesh at its 9 Gauss points per face.

    Attributes
    ----------
    nodes : ndarray (n_f, 9)
        Model nodes of each face.
    N : ndarray (n_f, 9 q, 9 a)
        Values of the face nodes' shape functions.
    dN : ndarray (n_f, 9 q, 9 a, 2) [1/m]
        Their derivatives along the unit tangents ``e_1``, ``e_2``.
    tangents : ndarray (n_f, 9 q, 2, 3)
        ``e_1``, ``e_2`` with ``e_1 x e_2`` pointing away from the cavity.
    dA : ndarray (n_f, 9 q) [m^2]
        Gauss weight times surface Jacobian.
    """

    nodes: np.ndarray
    N: np.ndarray
    dN: np.ndarray
    tangents: np.ndarray
    dA: np.ndarray

    @classmethod
    def from_facets(cls, mesh, facets):
        """The surface of boundary ``facets`` of a :class:`turgorbayes.fem.mesh.ShellMesh`.

        The facets must lie on one face ``zeta = const`` of their elements (all the same face
        of the reference cube, as in the structured meshes here). The basis is scikit-fem's
        ``CellBasis`` at the face's Gauss points (``get_quadrature(RefQuad, INTORDER)`` lifted
        onto that face): ``FacetBasis`` would locate them by inverting the curved element
        map by Newton's method, which does not converge in the thin, degenerate pole elements.
        ``e_1 x e_2`` points along increasing ``zeta``, away from the cavity.
        """
        param = mesh.param_mesh
        elements = param.f2t[0, facets]
        axis, value = _reference_face(param, facets, elements)
        pts2, wts = get_quadrature(RefQuad, INTORDER)
        pts = np.insert(pts2, axis, value, axis=0)  # (3, 9) on the reference face
        basis = CellBasis(mesh.basis.mesh, ElementHex2(), quadrature=(pts, wts), elements=elements)
        val = np.stack([np.asarray(phi[0]) for phi in basis.basis], axis=-1)  # (f, q, 27)
        grad = np.stack([phi[0].grad for phi in basis.basis], axis=-1)  # (3, f, q, 27)
        on_face = np.abs(val).max(axis=1) > 1e-6  # the other 18 shape functions vanish there
        if np.any(on_face.sum(axis=1) != 9):
            raise RuntimeError("a facet does not carry exactly 9 of its element's DOFs")
        local = np.nonzero(on_face)[1].reshape(-1, 9)
        take = lambda a: np.take_along_axis(a, local[:, None, :], axis=-1)  # noqa: E731
        DF = np.transpose(basis.mapping.DF(pts, tind=elements), (2, 3, 0, 1))  # (f, q, 3, 3)
        i, j = [k for k in range(3) if k != axis]
        area = np.cross(DF[..., :, i], DF[..., :, j])  # surface Jacobian times its normal
        dzeta = np.transpose(param.mapping().DF(pts, tind=elements), (2, 3, 0, 1))[..., 2, axis]
        # orient along dX/dzeta (the parameter map is a box map: zeta depends on this axis only)
        outward = np.sum(area * DF[..., :, axis], axis=-1) * dzeta
        away = _unit(area) * np.sign(outward)[..., None]
        helper = np.where(np.abs(away[..., :1]) < 0.9, [1.0, 0.0, 0.0], [0.0, 1.0, 0.0])
        e1 = _unit(np.cross(away, helper))
        e2 = np.cross(away, e1)  # e1 x e2 = away
        g = np.stack([take(grad[k]) for k in range(3)], axis=-1)  # (f, q, 9, 3)
        dN = np.stack([g @ e1[..., :, None], g @ e2[..., :, None]], axis=-1)[..., 0, :]
        dofs = np.take_along_axis(basis.element_dofs.T, local, axis=1)
        return cls(nodes=mesh.node_of_dof[dofs], N=take(val), dN=dN,
                   tangents=np.stack([e1, e2], axis=-2),
                   dA=np.linalg.norm(area, axis=-1) * wts)


def _reference_face(param, facets, elements):
    """Axis and coordinate (0 or 1) of the reference cube's face carrying ``facets``."""
    zeta = param.p[2, param.facets[:, facets]].mean(axis=0)
    for axis in range(3):
        for value in (0.0, 1.0):
            centre = np.full((3, 1), 0.5)
            centre[axis] = value
            z = param.mapping().F(centre, tind=elements)[2, :, 0]
            if np.allclose(z, zeta, rtol=0.0, atol=1e-9 * np.ptp(param.p[2])):
                return axis, value
    raise RuntimeError("the facets are not one face of the reference cube in every element")


def pressure_load(surface, u_nodes, P, want_tangent=True):
    """Nodal forces of a follower pressure and their derivative (for the residual's tangent).

    Parameters
    ----------
    surface : Surface
        The loaded surface (the cavity on the far side of ``e_1 x e_2``).
    u_nodes : ndarray (n_nodes, 3) [m]
        Current displacements.
    P : float [Pa]

    Returns
    -------
    f : ndarray (n_f, 9, 3) [N]
        Face load vectors.
    dfdu : ndarray (n_f, 27, 27) or None
        Derivative of ``f`` (row ``3 a + i``) with respect to the face's node displacements.
    """
    uf = u_nodes[surface.nodes]  # (f, a, i)
    t = surface.tangents + np.einsum("fai,fqak->fqki", uf, surface.dN)  # F e_k
    t1, t2 = t[:, :, 0], t[:, :, 1]
    scale = P * surface.dA
    f = np.einsum("fq,fqa,fqi->fai", scale, surface.N, np.cross(t1, t2))
    if not want_tangent:
        return f, None
    A = (np.einsum("fqij,fqb->fqibj", _cross_matrix(t1), surface.dN[..., 1])
         - np.einsum("fqij,fqb->fqibj", _cross_matrix(t2), surface.dN[..., 0]))
    dfdu = np.einsum("fq,fqa,fqibj->faibj", scale, surface.N, A).reshape(-1, 27, 27)
    return f, dfdu


def node_areas(surface, n_nodes):
    """Reference surface area carried by each node: ``A_a = int N_a dA`` [m^2]."""
    return np.bincount(surface.nodes.ravel(), minlength=n_nodes,
                       weights=np.einsum("fq,fqa->fa", surface.dA, surface.N).ravel())
