"""Synthetic curves at realistic noise, written by afmformats and read back, give k_c, k_b,
h_b and the bulge pressure of the force law they were drawn from.

Truths: the laws' own parameters (k_c is the secant of ``cell_force`` at R_c/20 by
construction; the bulge pressure P and depth h_b are chosen, k_b = F(h_b)/h_b is evaluated
from the closed-form law). Realistic noise: the thermal limit sqrt(kT k) = 6.7 pN of the
paper's 0.011 N/m cantilever (the real JPK curve ha_001 has 9.7 pN on a 0.031 N/m lever,
0.86 x its thermal limit).
"""

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.curves import reduce_curve
from turgorbayes.curves.combine import combine_stiffness
from turgorbayes.physics import bulge
from turgorbayes.simulation.curves import bulge_force

N_CURVES = 3


def _combined(results):
    assert all(r.ok for r in results), [r.detail for r in results]
    return combine_stiffness([r.k for r in results], [r.k_err for r in results],
                             [r.depth for r in results])


@pytest.mark.parametrize(("k_c", "R_c_nm"), [(0.017, 540.0), (0.006, 480.0), (0.03, 600.0)])
def test_cell_stiffness_recovered_within_2_percent(tmp_path, k_c, R_c_nm, write_cell_curve):
    R_c = R_c_nm * 1e-9
    results, contacts = [], []
    for j in range(N_CURVES):
        path = tmp_path / f"c{j}.tab"
        curve = write_cell_curve(path, k_c, R_c, seed=100 * j + int(R_c_nm))
        res = reduce_curve(path, "cell", R_c)
        results.append(res)
        contacts.append((res.contact_height - curve.contact_height, res.contact_err))
    k, k_err, depth = _combined(results)
    assert_allclose(depth, R_c / 20, rtol=1e-12)  # read at R_c/20 exactly
    assert abs(k / k_c - 1) < 0.02, (k / k_c - 1, k_err / k)
    # the reported error is honest to a factor: the miss is within 3 reported sd
    assert abs(k - k_c) < 3 * k_err
    for miss, err in contacts:  # contact point: sub-2 nm, within 4 reported sd
        assert abs(miss) < 2e-9 and abs(miss) < 4 * err + 0.2e-9, (miss, err)


@pytest.mark.parametrize(("P_kPa", "R_b_nm", "h_over_Rb"), [(10.0, 500.0, 0.22), (5.0, 700.0, 0.2),
                                                            (20.0, 450.0, 0.25)])
def test_bulge_stiffness_depth_and_pressure_recovered(tmp_path, P_kPa, R_b_nm, h_over_Rb,
                                                       write_bulge_curve):
    P, R_b = P_kPa * 1e3, R_b_nm * 1e-9
    h_b = h_over_Rb * R_b
    k_b = float(bulge_force(h_b, P, R_b)) / h_b
    results = []
    for j in range(N_CURVES):
        write_bulge_curve(tmp_path / f"b{j}.tab", P, R_b, h_b, seed=7 + j)
        results.append(reduce_curve(tmp_path / f"b{j}.tab", "bulge", R_b))
    k, k_err, depth = _combined(results)
    assert abs(k / k_b - 1) < 0.02, k / k_b - 1
    assert abs(depth / h_b - 1) < 0.02, depth / h_b - 1
    P_est = float(bulge.pressure_from_bulge(k, R_b, depth))
    assert abs(P_est / P - 1) < 0.03, P_est / P - 1


def test_noise_free_curve_is_recovered_to_the_sampling_limit(tmp_path, write_cell_curve):
    """Without noise the only errors are the 0.5 nm sampling and the file's 8 digits."""
    from turgorbayes.simulation.curves import Acquisition

    quiet = Acquisition(noise_sd=1e-15)
    R_c, k_c = 500e-9, 0.017
    write_cell_curve(tmp_path / "c.tab", k_c, R_c, 1, quiet)
    res = reduce_curve(tmp_path / "c.tab", "cell", R_c)
    assert res.ok, res.detail
    assert_allclose(res.k, k_c, rtol=2e-3)


def test_calibration_override_rescales_force(tmp_path, write_cell_curve):
    """A spring constant twice the file's doubles every force; k read must double (the law's
    k_c was drawn at the file's calibration), within the noise."""
    R_c, k_c = 540e-9, 0.017
    write_cell_curve(tmp_path / "c.tab", k_c, R_c, 3)
    plain = reduce_curve(tmp_path / "c.tab", "cell", R_c)
    doubled = reduce_curve(tmp_path / "c.tab", "cell", R_c, spring_constant=0.022)
    assert plain.ok and doubled.ok
    # same deflections, forces x2: h is unchanged, so F(h)/h doubles
    assert_allclose(doubled.k / plain.k, 2.0, rtol=0.02)
    assert_allclose(doubled.spring_constant, 0.022)


def test_threshold_method_is_biased_late(tmp_path, write_cell_curve):
    """The simpler method's contact comes after the true one (the force must first climb to
    3 sd), so its k_c is too high: the benchmark's reason to default to the power law."""
    from turgorbayes.curves import ReductionSettings

    R_c, k_c = 540e-9, 0.017
    curve = write_cell_curve(tmp_path / "c.tab", k_c, R_c, 5)
    res = reduce_curve(tmp_path / "c.tab", "cell", R_c, ReductionSettings(method="threshold"))
    assert res.ok
    assert res.contact_height < curve.contact_height  # heights fall: later = lower
    assert res.k > 1.05 * k_c
    assert np.isnan(res.exponent)
