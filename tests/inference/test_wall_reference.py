"""The wall stated at its reference turgor: the same law, and the Jacobian of the change of
sampler coordinates (turgorbayes.inference.wall_reference; docs/statistics.md, "Osmotic series:
coordinates")."""

import numpy as np
import pytest

from turgorbayes.inference import models
from turgorbayes.inference.coordinates import Coordinates
from turgorbayes.inference.wall_reference import reference_from_wall, wall_from_reference
from turgorbayes.physics import wall

P0 = 5e3
GAMMAS = np.array([0.0, 0.4, 1.0, 1.22, 2.5])


@pytest.mark.parametrize("P", [11e3, 29e3])
def test_the_law_stated_at_the_reference_is_the_same_law(P):
    # The law is a trajectory of d(P R) = E_perp t(P) d ln R (docs/physics.md): through the
    # point (R_ref, P) with E_perp t there, pressure_at_radius is the same function of R.
    E0t, R0 = 0.05 * (1 + GAMMAS), 464.2e-9  # every wall bears 29 kPa (max >= 41.5 kPa)
    E_ref, R_ref = reference_from_wall(P, GAMMAS, E0t, R0, P0)
    R = np.array([470e-9, 520e-9, 540e-9])[:, None]
    np.testing.assert_allclose(wall.pressure_at_radius(R, GAMMAS, E_ref, R_ref, P),
                               wall.pressure_at_radius(R, GAMMAS, E0t, R0, P0), rtol=1e-11)
    back_E, back_R, _ = wall_from_reference(P, GAMMAS, E_ref, R_ref, P0)
    np.testing.assert_allclose(back_E, E0t, rtol=1e-13)
    np.testing.assert_allclose(back_R, R0, rtol=1e-12)


def test_jacobian_matches_a_difference_of_the_solved_radius():
    # dR0/dR_ref by the implicit function theorem against a central difference of the
    # independently solved radius (step 1e-5: truncation ~1e-10, root error ~1e-9).
    E, R, P, h = 0.08 * (1 + GAMMAS), 540e-9, 29e3, 1e-5
    _, _, d = wall_from_reference(P, GAMMAS, E, R, P0)
    fd = (wall.radius_at_pressure(P0, GAMMAS, E, R * (1 + h), P)
          - wall.radius_at_pressure(P0, GAMMAS, E, R * (1 - h), P)) / (2 * h * R)
    np.testing.assert_allclose(d, fd, rtol=1e-7)


def test_states_off_the_rising_branch_have_no_wall():
    # A strain P R/(E t) of 1 or more is past the pressure maximum: no wall there.
    E0t, R0, d = wall_from_reference(29e3, 1.0, [0.01, 0.02], 540e-9, P0)
    assert np.isnan(E0t[0]) and np.isnan(R0[0]) and np.isnan(d[0])  # 29e3 * 540e-9 > 0.01
    assert np.isfinite(R0[1])


class _Referenced(models.BaselineModel):
    wall_references = (("gamma", "E0t", "R0", "P_phys"),)

    def __init__(self):
        self.P0 = P0


def _plain_log_prior(v):
    return sum(p.prior.log_density_u(p.prior.to_u(v[p.name]))
               for p in models.BASELINE_PARAMETERS)


def test_log_prior_carries_the_full_jacobian_determinant():
    # The prior stays on (gamma, E0t, R0, P_phys): log p(u) = log p(x(u)) + ln|det dx_u/du|,
    # with the determinant from a 4x4 central-difference Jacobian of the whole map (not the
    # triangular shortcut the code uses).
    model = _Referenced()
    x = {"gamma": np.array([0.6, 1.22, 2.0]), "E0t": np.array([0.03, 0.026, 0.01]),
         "R0": np.array([450e-9, 464.2e-9, 480e-9]), "P_phys": np.array([20e3, 29e3, 40e3])}
    u = model.to_u(x)
    back = model.to_physical(u)
    for k in x:
        np.testing.assert_allclose(back[k], x[k], rtol=1e-11)
    plain = Coordinates()
    for w in range(3):
        J, h = np.empty((4, 4)), 1e-6
        for j in range(4):
            e = np.zeros(4)
            e[j] = h * max(abs(u[w, j]), 1.0)
            up = plain.to_u(model.to_physical(u[w] + e))[0]
            down = plain.to_u(model.to_physical(u[w] - e))[0]
            J[:, j] = (up - down) / (2 * e[j])
        expected = _plain_log_prior({k: a[w] for k, a in x.items()}) + np.log(abs(np.linalg.det(J)))
        assert model.log_prior(u[w])[0] == pytest.approx(float(expected), abs=1e-6)


def test_coordinates_without_a_wall_have_zero_prior_density():
    model = _Referenced()
    u = model.to_u({"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3})[0]
    bad = u.copy()
    bad[1] = np.log(29e3 * 600e-9 * 0.5)  # E_ref t below P R: a strain above 1
    bad[2] = 600.0
    assert model.log_prior(bad)[0] == -np.inf
    assert np.isfinite(model.log_prior(u)[0])


def test_a_turgor_beyond_the_wall_has_no_reference_state():
    # A linear wall (gamma = 0) with E0t = 0.026 N/m bears at most 22.5 kPa (max_pressure).
    E_ref, R_ref = reference_from_wall([20e3, 29e3], 0.0, 0.026, 464.2e-9, P0)
    assert np.isfinite(R_ref[0]) and np.isnan(R_ref[1])
