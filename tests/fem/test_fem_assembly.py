"""Element kernels: the assembled tangent is the derivative of the internal force."""

from types import SimpleNamespace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.fem.assembly import Discretization, internal_force_and_tangent
from turgorbayes.fem.element import hex27_basis
from turgorbayes.fem.material import orthotropic_stiffness


def _curved_element():
    """One 27-node hexahedron of a curved shell (unit radius, thickness 0.04, node order of
    :func:`hex27_basis`)."""
    r = np.stack(np.meshgrid(*3 * [[-1.0, 0.0, 1.0]], indexing="ij"), -1).reshape(-1, 3)
    N, _ = hex27_basis(r)
    assert_allclose(N, np.eye(27), atol=1e-14)  # r really are the nodes, in this order
    theta, z, rad = 0.2 * r[:, 0], 0.3 * r[:, 1], 1.0 + 0.02 * r[:, 2]
    X = np.stack([rad * np.sin(theta), z, rad * np.cos(theta)], -1)  # right-handed (det J > 0)
    return SimpleNamespace(X=X, elements=np.arange(27)[None])


@pytest.mark.parametrize("law", ["log", "svk"])
def test_tangent_matches_central_differences_of_internal_force(rng, law):
    # Reference: the directional derivative of the internal force by central differences
    # (step 1e-7 of a displacement with strains of a few per cent), for the full element.
    disc = Discretization.from_mesh(_curved_element())
    D = orthotropic_stiffness(20e6, 8e6, 15e6, 0.3)
    u = 0.01 * rng.normal(size=(27, 3))
    _, K = internal_force_and_tangent(disc, u, D, law=law)
    for _ in range(3):
        du = rng.normal(size=(27, 3))
        eps = 1e-7
        fp, _ = internal_force_and_tangent(disc, u + eps * du, D, False, law)
        fm, _ = internal_force_and_tangent(disc, u - eps * du, D, False, law)
        fd = (fp - fm).reshape(-1) / (2 * eps)
        assert_allclose(K[0] @ du.reshape(-1), fd, rtol=1e-6, atol=1e-7 * np.abs(fd).max())
