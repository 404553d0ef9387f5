"""Element kernels: the assembled tangent is the derivative of the internal force."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.fem.assembly import Discretization, internal_force_and_tangent
from turgorbayes.fem.loads import Surface, node_areas, pressure_load
from turgorbayes.fem.material import orthotropic_stiffness
from turgorbayes.fem.mesh import shell_mesh, sphere_octant_mesh


def _curved_element():
    """One 27-node hexahedron of a curved shell (unit radius, thickness 0.04)."""

    def surface(theta, z):
        normal = np.stack([np.sin(theta), np.zeros_like(theta), np.cos(theta)], -1)
        return normal + np.stack([np.zeros_like(z), z, np.zeros_like(z)], -1), normal

    mesh = shell_mesh(surface, [-0.2, 0.2], [-0.3, 0.3], 0.04, 1)
    assert mesh.elements.shape == (1, 27)  # one element, all 27 nodes distinct
    return mesh


@pytest.mark.parametrize("law", ["log", "svk"])
def test_tangent_matches_central_differences_of_internal_force(rng, law):
    # Reference: the directional derivative of the internal force by central differences
    # (step 1e-7 of a displacement with strains of a few per cent), for the full element.
    disc = Discretization.from_mesh(_curved_element())
    local = disc.elements[0]  # element rows are in the element's local node order
    D = orthotropic_stiffness(20e6, 8e6, 15e6, 0.3)
    u = 0.01 * rng.normal(size=(27, 3))
    _, K = internal_force_and_tangent(disc, u, D, law=law)
    for _ in range(3):
        du = rng.normal(size=(27, 3))
        eps = 1e-7
        fp, _ = internal_force_and_tangent(disc, u + eps * du, D, False, law)
        fm, _ = internal_force_and_tangent(disc, u - eps * du, D, False, law)
        fd = (fp - fm).reshape(-1) / (2 * eps)
        assert_allclose(K[0] @ du[local].reshape(-1), fd, rtol=1e-6, atol=1e-7 * np.abs(fd).max())


def test_pressure_load_on_sphere_octant_matches_projected_area_and_its_tangent(rng):
    # Closed form: the pressure P on the inner surface of a sphere octant (radius r) pushes
    # it along each axis with P times the quarter disk pi r^2 / 4 (quadratic elements:
    # geometry error well below 1e-4 here); the outer surface is one eighth of 4 pi r^2.
    # The tangent is checked against central differences of the load (step 1e-7).
    R, t, P = 1.0, 0.02, 3.0
    mesh = sphere_octant_mesh(R, t, h_min=0.1, h_max=0.3, growth=0.3)
    inner, outer = Surface.from_facets(mesh, mesh.inner_facets), Surface.from_facets(mesh, mesh.outer_facets)
    u = np.zeros((mesh.n_nodes, 3))
    f, dfdu = pressure_load(inner, u, P)
    assert_allclose(f.sum(axis=(0, 1)), P * np.pi * (R - t / 2) ** 2 / 4, rtol=1e-4)
    assert_allclose(node_areas(outer, mesh.n_nodes).sum(), np.pi * (R + t / 2) ** 2 / 2, rtol=1e-4)
    u = 0.01 * rng.normal(size=u.shape)
    du = rng.normal(size=u.shape)
    _, dfdu = pressure_load(inner, u, P)
    fp, _ = pressure_load(inner, u + 1e-7 * du, P, False)
    fm, _ = pressure_load(inner, u - 1e-7 * du, P, False)
    fd = (fp - fm).reshape(len(fp), -1) / 2e-7
    lin = np.einsum("fab,fb->fa", dfdu, du[inner.nodes].reshape(len(fp), -1))
    assert_allclose(lin, fd, rtol=1e-6, atol=1e-7 * np.abs(fd).max())
