"""FE model against closed-form and published shell results (coarser meshes than studies/)."""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.fem.anchors import (
    PINCHED_CYLINDER_REFERENCE,
    pinched_cylinder,
    sphere_point_stiffness,
    vella_stiffness,
)


def test_pinched_cylinder_matches_lindberg_olson_cowper():
    # Lindberg, Olson & Cowper (1969): w E t / F = 164.24 (thin-shell benchmark), within 3%
    assert_allclose(pinched_cylinder(h_min=5.0, h_max=25.0), PINCHED_CYLINDER_REFERENCE, rtol=0.03)


def test_vella_closed_form_is_continuous_at_tau_one():
    # both branches tend to k0 pi/2 (sqrt(1-t^2)/arccos t -> 1 as t -> 1), so the formula
    # evaluated just below and above tau = 1 must agree with (pi/2) 8 sqrt(BY)/R
    E, t, R = 20e6, 6e-9, 500e-9
    root = E * t**2 / np.sqrt(12.0)
    k0 = 8 * root / R
    P1 = 4 * root / R**2
    lo, _ = vella_stiffness(P1 * (1 - 1e-6), R, t, E)
    hi, _ = vella_stiffness(P1 * (1 + 1e-6), R, t, E)
    assert_allclose([lo, hi], k0 * np.pi / 2, rtol=1e-3)


@pytest.mark.parametrize("tau", [0.0, 0.45, 0.85, 1.8, 4.0])
def test_pressurized_sphere_point_stiffness_matches_vella(tau):
    # Vella et al., J. R. Soc. Interface 9, 448 (2012): shallow-shell point-load stiffness,
    # within 3%; load spread over a patch of radius t (point-like: the bending length is
    # 29 nm), R = 500 nm, t = 6 nm, E = 20 MPa, nu = 0
    E, t, R = 20e6, 6e-9, 500e-9
    P = 4 * tau * (E * t**2 / np.sqrt(12.0)) / R**2
    out = sphere_point_stiffness(P, R, t, E, h_min=2e-9, h_max=80e-9, load_radius=t)
    assert_allclose(out["k"], out["k_vella"], rtol=0.03)
