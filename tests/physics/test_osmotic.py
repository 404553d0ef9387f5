"""The osmotic balance of turgorbayes.physics.osmotic against closed forms and independent
numerics (docs/physics.md, "Osmotic shifts of the medium")."""

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy.optimize import brentq

from turgorbayes.physics import osmotic, wall

R0 = 464.2e-9
P0 = 5e3


def test_van_t_hoff_pressure_per_mosm():
    # R T at 25 C: 8.314462618 J/(mol K) x 298.15 K = 2478.957 J/mol; 1 mOsm = 1 mol/m^3
    assert_allclose(osmotic.osmotic_pressure(1.0), 2478.957, rtol=1e-6)
    assert_allclose(osmotic.osmotic_pressure(2.0, 310.15), 2 * 8.314462618 * 310.15, rtol=1e-12)


@pytest.mark.parametrize("gamma, E0t", [(0.0, 0.1), (0.5, 0.026), (1.0, 0.026), (1.22, 0.026),
                                        (2.0, 0.026)])
@pytest.mark.parametrize("length_model", osmotic.LENGTH_MODELS)
def test_solver_inverts_the_explicit_medium_of_a_strain(gamma, E0t, length_model):
    # medium_at_strain is the balance solved for c_out (explicit); the solver must give back
    # the strain, hyper- and hypo-osmotic alike
    s = np.linspace(-0.1, 0.3, 9)
    c = osmotic.medium_at_strain(s, 29e3, gamma, E0t, R0, c_ref=300.0, b=0.3,
                                 length_model=length_model)
    ok = np.isfinite(c) & (c >= 0)
    assert ok.sum() >= 3
    st = osmotic.turgor_after_shift(29e3, gamma, E0t, R0, c_ref=300.0, c_out=c[ok], b=0.3,
                                    length_model=length_model)
    assert_allclose(st["s"], s[ok], atol=1e-10)
    assert not st["plasmolysed"].any()


def _linear_wall_strain(P, E0t):
    """gamma = 0: P R = P0 R0 + E0t s (docs/physics.md, Wall law), solved by brentq."""
    return brentq(lambda s: P * R0 * np.exp(s) - P0 * R0 - E0t * s, -0.5, 0.5, xtol=1e-15)


def test_buffering_of_a_linear_wall_of_fixed_length_has_a_closed_form():
    # gamma = 0, fixed length: d(PR) = E0t dR/R, so dP/ds = E0t/R - P and d ln V/dP =
    # 2/(E0t/R - P); beta = 1/(1 + (P + RT c)/(1 - b) d ln V/dP)
    E0t, P, c, b = 0.1, 29e3, 300.0, 0.3
    R = R0 * np.exp(_linear_wall_strain(P, E0t))
    pi_in = P + osmotic.osmotic_pressure(c)
    expected = 1 / (1 + pi_in / (1 - b) * 2 / (E0t / R - P))
    got = osmotic.buffering_factor(P, 0.0, E0t, R0, c_out=c, b=b, length_model="fixed")
    assert_allclose(got, expected, rtol=1e-9)


@pytest.mark.parametrize("length_model", osmotic.LENGTH_MODELS)
@pytest.mark.parametrize("b", [0.1, 0.3, 0.5])
def test_buffering_factor_matches_finite_differences_of_the_solver(length_model, b):
    # the analytic derivative against central differences of the solved turgor (step 1e-3 mOsm
    # about the reference medium: truncation ~1e-8 relative)
    h = 1e-3
    st = osmotic.turgor_after_shift(29e3, 1.22, 0.026, R0, c_ref=300.0,
                                    c_out=np.array([300.0 - h, 300.0 + h]), b=b,
                                    length_model=length_model)
    fd = -(st["P"][1] - st["P"][0]) / osmotic.osmotic_pressure(2 * h)
    got = osmotic.buffering_factor(29e3, 1.22, 0.026, R0, c_out=300.0, b=b,
                                   length_model=length_model)
    assert_allclose(got, fd, rtol=1e-5)
    assert 0 < got < 1


def test_rigid_wall_takes_the_whole_step_in_turgor():
    # a wall 4e5 x the paper's stiffness barely moves: P = P_ref - RT (c_out - c_ref); the
    # volume's share is (P + RT c)/(1 - b) d ln V/dP ~ 780 kPa/0.7 x 3 R0/E0t ~ 1.6e-4
    st = osmotic.turgor_after_shift(29e3, 0.0, 1e4, R0, c_ref=300.0, c_out=305.0, b=0.3)
    assert_allclose(st["P"], 29e3 - osmotic.osmotic_pressure(5.0), rtol=5e-4)
    soft = osmotic.turgor_after_shift(29e3, 0.0, 1e2, R0, c_ref=300.0, c_out=305.0, b=0.3)
    assert soft["P"] > 29e3 - osmotic.osmotic_pressure(5.0) * 0.99  # a softer one buffers


def test_plasmolysis_of_a_linear_wall_starts_where_the_cytoplasm_matches_the_medium():
    # gamma = 0, fixed length: the wall's rest strain is s0 = -p (P R = P0 R0 + E0t s = 0);
    # turgor reaches 0 when c_out = c_in(s0) = c_in,ref (1 - b)/(exp(2 (s0 - s_ref)) - b)
    E0t, P, c, b = 0.1, 29e3, 300.0, 0.3
    s_ref, s0 = _linear_wall_strain(P, E0t), -P0 * R0 / E0t
    c_in = c + P / osmotic.osmotic_pressure(1.0)
    onset = c_in * (1 - b) / (np.exp(2 * (s0 - s_ref)) - b)
    st = osmotic.turgor_after_shift(P, 0.0, E0t, R0, c_ref=c, b=b, length_model="fixed",
                                    c_out=np.array([onset * (1 - 1e-4), onset * (1 + 1e-4),
                                                    2 * onset]))
    assert list(st["plasmolysed"]) == [False, True, True]
    assert 0 < st["P"][0] < 200.0  # a few hundred Pa just before the onset
    assert_allclose(st["P"][1:], 0.0)
    assert_allclose(st["R_c"][1:], R0 * np.exp(s0), rtol=1e-12)  # the wall at rest


def test_volume_slope_matches_finite_differences():
    # d ln V/ds of the wall length model against central differences of ln V (step 1e-6)
    s = np.array([-0.05, 0.05, 0.15])
    for gamma in (0.5, 1.0, 1.22):
        lv, slope = osmotic.log_volume_and_slope(s, gamma, 0.026, R0)
        hi, _ = osmotic.log_volume_and_slope(s + 1e-6, gamma, 0.026, R0)
        lo, _ = osmotic.log_volume_and_slope(s - 1e-6, gamma, 0.026, R0)
        assert_allclose(slope, (hi - lo) / 2e-6, rtol=1e-6)


def test_wall_length_model_is_the_wall_law_at_half_the_tension():
    # the axial strain at circumferential tension tau is the circumferential strain the wall
    # has at tension tau/2 (docs/physics.md): ln V = 2 s + S(tau/2) - S(1/2), with S the
    # inverse of the explicit tension law, here found by brentq on log_tension_ratio
    p, gamma, s = P0 * R0 / 0.026, 1.22, 0.12
    tau = np.exp(wall.log_tension_ratio(s, p, gamma))

    def strain(t):
        return brentq(lambda x: wall.log_tension_ratio(x, p, gamma) - np.log(t), -3, 0.5,
                      xtol=1e-15)

    lv, _ = osmotic.log_volume_and_slope(s, gamma, 0.026, R0)
    assert_allclose(lv, 2 * s + strain(tau / 2) - strain(0.5), atol=1e-10)


def test_paper_values_give_a_strong_buffer():
    # at the paper's wall, 29 kPa in 300 mOsm and b = 0.3 a step of the medium is taken up
    # mostly by the volume: about a tenth of it by turgor (docs/physics.md quotes 0.100)
    beta = osmotic.buffering_factor(29e3, 1.22, 0.026, R0, c_out=300.0, b=0.3)
    assert 0.09 < beta < 0.11


def test_unknown_length_model_is_refused():
    with pytest.raises(ValueError, match="length model must be one of wall, fixed"):
        osmotic.log_volume_and_slope(0.0, 1.22, 0.026, R0, length_model="isotropic")
