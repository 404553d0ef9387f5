"""Structured 27-node hexahedral meshes of thin shells (capsule, cylinder, sphere octant).

A shell mesh is scikit-fem's ``MeshHex2`` of a box grid in two surface parameters
``(p1, p2)`` and the thickness coordinate ``zeta`` in [-t/2, t/2], mapped node by node onto
the shell (node = mid-surface point + zeta * unit normal), so mid-edge nodes sit at
parametric midpoints and the elements are curved, isoparametric to second order. Element
boundaries come from a size function growing linearly away from the refined spots
(:func:`graded_breaks`). Coincident nodes (the pole of a capsule's end cap, the seam of a
half capsule) are merged into one node of the model's numbering (docs/fem.md).
"""

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from skfem import CellBasis, ElementHex2, MeshHex1, MeshHex2

__all__ = [
    "INTORDER",
    "ShellMesh",
    "capsule_quadrant_mesh",
    "cylinder_octant_mesh",
    "graded_breaks",
    "shell_mesh",
    "sphere_octant_mesh",
]

#: Quadrature order of every basis: 3 Gauss points per direction (27 per element, 9 per face),
#: which integrates the stiffness of an affine element exactly.
INTORDER = 5


@dataclass(frozen=True, eq=False)
class ShellMesh:
    """A structured shell mesh of 27-node hexahedra on top of scikit-fem.

    Attributes
    ----------
    X : ndarray, shape (n_nodes, 3) [m]
        Reference node coordinates (coincident scikit-fem DOFs merged).
    elements : ndarray, shape (n_elements, 27)
        Node indices in the local DOF order of ``ElementHex2``.
    basis : skfem.CellBasis
        ``ElementHex2`` on the physical ``MeshHex2`` (27 Gauss points per element).
    param_mesh : skfem.MeshHex2
        The same topology in the parameter space ``(p1, p2, zeta)`` (material directions).
    node_of_dof : ndarray (basis.N,)
        Model node of every scikit-fem DOF.
    inner_facets, outer_facets : ndarray
        Facets of the inner (cavity) and outer surfaces.
    outer_nodes : ndarray
        Nodes of the outer surface (sorted, unique).
    thickness : float [m]
        Wall thickness.
    """

    X: np.ndarray
    elements: np.ndarray
    basis: CellBasis
    param_mesh: MeshHex2
    node_of_dof: np.ndarray
    inner_facets: np.ndarray
    outer_facets: np.ndarray
    outer_nodes: np.ndarray
    thickness: float

    @property
    def n_nodes(self):
        return self.X.shape[0]

    @property
    def n_dofs(self):
        return 3 * self.X.shape[0]


def graded_breaks(length, h_start, h_max, growth, h_end=None):
    """Element boundaries on [0, length] with sizes growing away from refined ends.

    The target size is ``h(s) = min(h_max, h_start + growth s, h_end + growth (length - s))``;
    the number of elements is the integral of ``1/h`` rounded up, and the boundaries are
    equally spaced in that integral, so neighbouring sizes differ smoothly.

    Parameters
    ----------
    length : float [m or rad]
        Length of the interval.
    h_start : float
        Element size at ``s = 0``.
    h_max : float
        Largest element size.
    growth : float [-]
        Increase of the element size per unit distance.
    h_end : float, optional
        Element size at ``s = length`` (no refinement there when None).

    Returns
    -------
    ndarray
        Increasing boundaries, first 0, last ``length``.
    """
    s = np.linspace(0.0, length, 8001)
    h = np.minimum(h_max, h_start + growth * s)
    if h_end is not None:
        h = np.minimum(h, h_end + growth * (length - s))
    inv = 1.0 / h
    cum = np.concatenate([[0.0], np.cumsum(0.5 * (inv[1:] + inv[:-1]) * np.diff(s))])
    n = max(1, int(np.ceil(cum[-1] - 1e-9)))
    return np.interp(np.linspace(0.0, cum[-1], n + 1), cum, s)


def _merge_coincident(X, tol):
    """Map every node to one representative of its cluster of coincident nodes."""
    tree = cKDTree(X)
    rep = np.arange(len(X))
    for i, j in sorted(tree.query_pairs(tol)):
        rep[j] = min(rep[j], rep[i])
    while True:  # chains of pairs: follow representatives to the root
        nxt = rep[rep]
        if np.array_equal(nxt, rep):
            break
        rep = nxt
    keep, new_index = np.unique(rep, return_inverse=True)
    return X[keep], new_index


def shell_mesh(surface, breaks1, breaks2, thickness, n_thick):
    """Build a :class:`ShellMesh` from a parametrized mid-surface.

    Parameters
    ----------
    surface : callable
        ``surface(p1, p2) -> (points, normals)`` for arrays of parameters, returning mid-surface
        points [m] and unit normals (pointing away from the cavity), each of shape
        ``p1.shape + (3,)``.
    breaks1, breaks2 : array_like
        Element boundaries in the two surface parameters.
    thickness : float [m]
        Wall thickness.
    n_thick : int
        Number of elements through the thickness.
    """
    zeta = np.linspace(-0.5 * thickness, 0.5 * thickness, n_thick + 1)
    param = MeshHex2.from_mesh(MeshHex1.init_tensor(np.asarray(breaks1), np.asarray(breaks2), zeta))
    mid, normal = surface(param.doflocs[0], param.doflocs[1])
    X = mid + param.doflocs[2][:, None] * normal
    mesh = MeshHex2(doflocs=np.ascontiguousarray(X.T), t=param.t)
    basis = CellBasis(mesh, ElementHex2(), intorder=INTORDER)
    X, node_of_dof = _merge_coincident(basis.doflocs.T, 1e-6 * thickness)
    tol = 1e-6 * thickness
    inner = param.facets_satisfying(lambda p: np.abs(p[2] + 0.5 * thickness) < tol, True)
    outer = param.facets_satisfying(lambda p: np.abs(p[2] - 0.5 * thickness) < tol, True)
    return ShellMesh(X=X, elements=node_of_dof[basis.element_dofs.T], basis=basis,
                     param_mesh=param, node_of_dof=node_of_dof, inner_facets=inner,
                     outer_facets=outer,
                     outer_nodes=np.unique(node_of_dof[basis.get_dofs(outer).all()]),
                     thickness=float(thickness))


def _capsule_surface(R, half_length):
    def surface(s, phi):
        beta = np.clip((s - half_length) / R, 0.0, None)
        on_cap = s > half_length
        x = np.where(on_cap, half_length + R * np.sin(beta), s)
        rho = np.where(on_cap, R * np.cos(beta), R)
        pts = np.stack([x, rho * np.sin(phi), rho * np.cos(phi)], axis=-1)
        nx = np.where(on_cap, np.sin(beta), 0.0)
        nr = np.where(on_cap, np.cos(beta), 1.0)
        normals = np.stack([nx, nr * np.sin(phi), nr * np.cos(phi)], axis=-1)
        return pts, normals

    return surface


def capsule_quadrant_mesh(R, length, thickness, h_min, h_max, growth, h_bottom, n_thick=1,
                          half=False, h_min_axial=None):
    """Quarter of a capsule (cylinder + hemispherical caps): ``x >= 0``, ``y >= 0``.

    The axis is x, the mid-length plane is ``x = 0``; ``p1`` is the meridional arc length from
    mid-length to the cap pole and ``p2`` the angle from the crest (``z = +R``, where the
    indenter acts) to the bottom line (``z = -R``, on the substrate). Elements are of size
    ``h_min`` at the crest, ``h_bottom`` along the bottom line and grow to ``h_max``.

    Parameters
    ----------
    R : float [m]
        Mid-surface radius.
    length : float [m]
        Length of the cylindrical part (the caps are added to it).
    thickness : float [m]
    h_min, h_max, h_bottom : float [m]
        Element sizes (arc length) at the crest, far away, and along the bottom line.
    growth : float [-]
        Size increase per unit distance.
    n_thick : int
    half : bool
        Mesh the half capsule ``x >= 0`` instead (crest angle 0 to 360 degrees, the seam
        merged), for checking the quadrant's symmetry conditions.
    h_min_axial : float [m], optional
        Meridional (axial) element size at the crest, if not ``h_min`` (an axially soft wall
        stretches its crest elements when inflated: see
        :attr:`turgorbayes.fem.CapsuleConfig.axial_stretch_mesh`).
    """
    half_length = 0.5 * length
    s_end = half_length + 0.5 * np.pi * R
    b1 = graded_breaks(s_end, h_min if h_min_axial is None else h_min_axial, h_max, growth)
    # the side line (crest angle 90 degrees, z = 0) is a mesh line: z = 0 is a symmetry plane
    # of the inflation, held there while the pressure is applied
    quarter = 0.5 * np.pi * R
    top = graded_breaks(quarter, h_min, h_max, growth)
    bottom = quarter - graded_breaks(quarter, h_bottom, h_max, growth)[::-1]
    b2 = np.concatenate([top, quarter + bottom[1:]]) / R
    if half:
        b2 = np.concatenate([b2, 2.0 * np.pi - b2[::-1][1:]])
    return shell_mesh(_capsule_surface(R, half_length), b1, b2, thickness, n_thick)


def cylinder_octant_mesh(R, length, thickness, h_min, h_max, growth, n_thick=1):
    """One eighth of an open cylinder: ``0 <= x <= length/2``, crest angle 0 to 90 degrees.

    Refined at the crest point ``(0, 0, R)`` (where the pinching load acts).
    """
    b1 = graded_breaks(0.5 * length, h_min, h_max, growth)
    b2 = graded_breaks(0.5 * np.pi * R, h_min, h_max, growth) / R
    return shell_mesh(_capsule_surface(R, 0.5 * length), b1, b2, thickness, n_thick)


def _sphere_surface(R):
    def surface(u, v):
        # square -> quarter disk (elliptical grid map), then azimuthal-equidistant onto the
        # octant: the edges u = 1, v = 1 land on the equator, u = 0 on x = 0, v = 0 on y = 0.
        X = u * np.sqrt(1.0 - 0.5 * v**2)
        Y = v * np.sqrt(1.0 - 0.5 * u**2)
        rho = np.hypot(X, Y)
        theta = 0.5 * np.pi * rho
        sin_over_rho = 0.5 * np.pi * np.sinc(0.5 * rho)
        n = np.stack([sin_over_rho * X, sin_over_rho * Y, np.cos(theta)], axis=-1)
        return R * n, n

    return surface


def sphere_octant_mesh(R, thickness, h_min, h_max, growth, n_thick=1):
    """One eighth of a sphere (x, y, z >= 0), refined at the pole ``(0, 0, R)``.

    The mesh is a single structured patch (square mapped to the quarter disk), so there is no
    degenerate element at the pole where the load acts.
    """
    quarter = 0.5 * np.pi * R  # arc length from the pole to the equator
    b = graded_breaks(quarter, h_min, h_max, growth) / quarter
    return shell_mesh(_sphere_surface(R), b, b, thickness, n_thick)
