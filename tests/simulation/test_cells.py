"""Tests of the synthetic data generator (turgorbayes.simulation.cells) and ``turgorbayes simulate``.

References: the bulge model's own inversion (pressure_from_bulge) and the wall module for
noise-free data, the stated error distributions (standardized residuals must be N(0, 1)),
the stated design distributions (K-S against log-uniform / uniform), and the CSV loader.
"""

import json

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes.cells.table import read_cells
from turgorbayes.cli import main
from turgorbayes.physics import bulge, wall
from turgorbayes.simulation import cells as synthetic


def test_noise_free_data_follow_the_physics(table):
    truth = synthetic.Truth(gamma=0.8, E0t=0.03, R0=470e-9, P_phys=22e3)
    cells, truths = synthetic.simulate_cells(30, 10, truth, seed=4, surrogate=table, noise=False)
    P = np.array(truths["cells"]["P_kPa"]) * 1e3
    b = cells.is_bulged
    # the bulge model, inverted independently, returns the true pressures
    assert_allclose(bulge.pressure_from_bulge(cells.k_b[b], cells.R_b[b], cells.h_b[b]), P[b],
                    rtol=1e-9)
    # radii from the wall module's root finder
    assert_allclose(cells.R_c, wall.radius_at_pressure(P, truth.gamma, truth.E0t, truth.R0),
                    rtol=1e-10)
    assert_allclose(P[~b], 22e3)
    # stiffness = (k/PR)(x, ratio) P R from the table, x and ratio from the wall module
    x = P * cells.R_c / wall.perp_modulus_times_thickness(P, truth.gamma, truth.E0t)
    k = table(x, wall.anisotropy(P, truth.gamma, truth.E0t, truth.R0)) * P * cells.R_c
    assert_allclose(cells.k_c, k, rtol=1e-9)


def test_errors_are_the_reported_ones(table, rng):
    # with many cells, (observed - true)/reported error is N(0, 1) for every observable
    n = 3000
    cells, truths = synthetic.simulate_cells(n, n, seed=int(rng.integers(1 << 31)),
                                             surrogate=table)
    c = truths["cells"]
    b = cells.is_bulged
    z = {
        "R_c": (cells.R_c - np.array(c["R_c_true_nm"]) * 1e-9) / cells.R_c_err,
        # k_c_err is the relative error times the observed value: sd = (err/obs) x true
        "k_c": (cells.k_c - np.array(c["k_c_true_N_per_m"]))
        / (cells.k_c_err / cells.k_c * np.array(c["k_c_true_N_per_m"])),
        "R_b": np.log(cells.R_b[b] / (np.array(c["R_b_nm"], float)[b] * 1e-9))
        / (cells.R_b_err[b] / cells.R_b[b]),
    }
    k_b_true = bulge.reduced_stiffness(np.array(c["h_over_Rb"], float)[b]) * (
        np.array(c["P_kPa"])[b] * 1e3) * (np.array(c["R_b_nm"], float)[b] * 1e-9)
    z["k_b"] = np.log(cells.k_b[b] / k_b_true) / (cells.k_b_err[b] / cells.k_b[b])
    for name, v in z.items():
        assert stats.kstest(v, "norm").pvalue > 1e-3, name
    # error sizes as documented: R_c 15-25 nm, k_c 9-15 %
    assert 15e-9 <= cells.R_c_err.min() and cells.R_c_err.max() <= 25e-9
    rel = cells.k_c_err / cells.k_c
    assert 0.09 <= rel.min() and rel.max() <= 0.15


def test_design_distributions(table):
    cells, truths = synthetic.simulate_cells(2000, 5, seed=8, surrogate=table)
    P = np.array(truths["cells"]["P_kPa"][:2000]) * 1e3
    # log-uniform over 1-25 kPa
    u = (np.log(P) - np.log(1e3)) / (np.log(25e3) - np.log(1e3))
    assert stats.kstest(u, "uniform").pvalue > 1e-3
    x = np.array(truths["cells"]["h_over_Rb"][:2000])
    assert stats.kstest((x - 0.17) / 0.10, "uniform").pvalue > 1e-3
    R_b = np.array(truths["cells"]["R_b_nm"][:2000])
    assert_allclose(np.median(R_b), 500, rtol=0.02)
    assert_allclose(np.std(np.log(R_b)), 0.2, rtol=0.05)


def test_same_seed_same_data(table):
    a, _ = synthetic.simulate_cells(10, 5, seed=3, surrogate=table)
    b, _ = synthetic.simulate_cells(10, 5, seed=3, surrogate=table)
    c, _ = synthetic.simulate_cells(10, 5, seed=4, surrogate=table)
    assert np.array_equal(a.k_c, b.k_c) and np.array_equal(a.R_b, b.R_b, equal_nan=True)
    assert not np.array_equal(a.k_c, c.k_c)


def test_bad_counts_are_rejected():
    with pytest.raises(ValueError, match="n_bulged must be an integer >= 0, got -1"):
        synthetic.draw_design(np.random.default_rng(0), n_bulged=-1)
    with pytest.raises(ValueError, match="n_intact must be a positive integer, got 0"):
        synthetic.draw_design(np.random.default_rng(0), n_intact=0)


def test_simulate_cli_writes_labelled_csv_and_sidecar(table, tmp_path):
    out = tmp_path / "sim.csv"
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--out", str(out), "--n-bulged", "12", "--n-intact", "7",
              "--seed", "5", "--gamma", "1.0", "--P-phys-kPa", "31"])
    assert exit_info.value.code == 0
    cells = read_cells(out)
    assert (cells.n_bulged, cells.n_intact) == (12, 7)
    assert "SIMULATED" in cells.comments[0]
    side = json.loads(out.with_suffix(".json").read_text())
    assert side["simulated"] and side["seed"] == 5
    assert side["parameters"]["gamma"] == 1.0 and side["parameters"]["P_phys_kPa"] == 31.0
    # the file's pressures are the sidecar's: bulge inversion returns them
    P = np.array(side["cells"]["P_kPa"][:12]) * 1e3
    P_hat = bulge.pressure_from_bulge(cells.k_b[:12], cells.R_b[:12], cells.h_b[:12])
    assert np.all(np.abs(np.log(P_hat / P)) < 1.0)  # within measurement noise


def test_simulate_cli_rc_error_range(table, tmp_path, capsys):
    # the reported R_c errors are drawn uniformly in the requested range (8-12 nm), the comment
    # line says so, and the R_c residuals against the sidecar's true radii scale with them
    out = tmp_path / "sim.csv"
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--out", str(out), "--seed", "4", "--Rc-err-nm", "8", "12"])
    assert exit_info.value.code == 0
    cells = read_cells(out)
    err = np.asarray(cells.R_c_err) * 1e9
    assert err.min() >= 8 and err.max() <= 12 and err.max() - err.min() > 3
    assert any("R_c 8-12 nm" in c for c in cells.comments)
    truth = json.loads(out.with_suffix(".json").read_text())
    z = (np.asarray(cells.R_c) * 1e9 - np.array(truth["cells"]["R_c_true_nm"])) / err
    assert 0.75 < np.std(z) < 1.25  # 114 standard normal draws: sd within +-25 % (5 sigma)
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--out", str(out), "--Rc-err-nm", "12", "8"])
    assert exit_info.value.code == 2
    assert "--Rc-err-nm LO HI needs LO <= HI, got 12 8" in capsys.readouterr().err


def test_simulate_cli_bulge_pressure_range(table, tmp_path, capsys):
    # Reference: the requested design. Bulged-cell true pressures are log-uniform over
    # 0.5-2 kPa: all 72 inside, spread over the range (P(min > 0.6 kPa) = (1 - ln1.2/ln4)^72
    # ~ 4e-5), the median near the geometric mean 1 kPa, and the range is recorded.
    out = tmp_path / "sim.csv"
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--out", str(out), "--seed", "3", "--P-range-kPa", "0.5", "2"])
    assert exit_info.value.code == 0
    truth = json.loads(out.with_suffix(".json").read_text())
    P = np.array(truth["cells"]["P_kPa"][:72])
    assert P.min() >= 0.5 and P.max() <= 2.0
    assert P.min() < 0.6 and P.max() > 1.7
    assert 0.75 < np.median(P) < 1.33  # log-median within 0.29 of ln 1 (sd of the median ~0.08)
    assert truth["bulge_pressure_range_kPa"] == [0.5, 2.0]
    assert any("log-uniform over 0.5-2 kPa" in c for c in read_cells(out).comments)
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--out", str(out), "--P-range-kPa", "2", "2"])
    assert exit_info.value.code == 2
    assert "--P-range-kPa LO HI needs LO < HI, got 2 2" in capsys.readouterr().err


def test_simulate_cli_effect_outside_fe_table(table, tmp_path, capsys):
    # Reference: a bound by hand. Below P0 the radius is below R0 = 464.2 nm and the envelope's
    # E_perp t is at least Y_om, so at P <= 0.1 kPa with Y_om = 0.05 N/m the inflation number
    # P R_c/(E_perp t) <= 100 * 464.2e-9 / 0.05 = 0.00093, below the FE table's lowest x (0.001):
    # every bulged cell falls outside the table, and the error must say so (not a bare
    # "undefined"), with the cell's pressure, and exit 2.
    out = tmp_path / "sim.csv"
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--out", str(out), "--seed", "1", "--P-range-kPa", "0.05", "0.1",
              "--effect", "outer_membrane", "--effect-size", "0.05"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "simulated cell 0 at P = " in err
    assert "outside the finite-element surrogate table (x in [0.001" in err
    assert not out.exists()


def test_lognormal_design(table):
    # reference: closed form of the requested population: ln P ~ N((ln 1e3 + ln 25e3)/2,
    # (ln 25e3 - ln 1e3)/4), i.e. median 5 kPa and 95.4 % of the cells inside 1-25 kPa
    cells, truths = synthetic.simulate_cells(2000, 5, seed=8, surrogate=table,
                                             design_kwargs={"P_distribution": "lognormal"})
    lnP = np.log(np.array(truths["cells"]["P_kPa"][:2000]) * 1e3)
    mu, sd = np.log(5e3), np.log(25) / 4
    assert stats.kstest((lnP - mu) / sd, "norm").pvalue > 1e-3
    assert truths["bulge_pressure_distribution"] == "lognormal"
    assert any("lognormal, median 5 kPa" in c for c in cells.comments)
    assert np.all(np.isfinite(cells.k_c)) and np.all(np.isfinite(cells.R_c))
    with pytest.raises(ValueError, match="P_distribution must be one of"):
        synthetic.draw_design(np.random.default_rng(0), P_distribution="normal")


def test_simulate_cli_lognormal_pressures(table, tmp_path):
    # reference: the requested design (median 5 kPa: the sample median of 72 lognormal draws
    # with log-sd 0.80 is within 0.3 of ln 5 kPa, se 0.12), recorded in the sidecar and comments
    out = tmp_path / "sim.csv"
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--out", str(out), "--seed", "3", "--P-distribution", "lognormal"])
    assert exit_info.value.code == 0
    truth = json.loads(out.with_suffix(".json").read_text())
    assert truth["bulge_pressure_distribution"] == "lognormal"
    P = np.array(truth["cells"]["P_kPa"][:72])
    assert abs(np.log(np.median(P) / 5.0)) < 0.3
    assert any("lognormal, median 5 kPa" in c for c in read_cells(out).comments)


def test_simulate_warns_when_an_effect_declares_the_default_radius_errors_misleading(
        table, tmp_path, capsys):
    # reference: radius_spread's declared warning (the default 15-25 nm errors already give the
    # paper's 20 nm scatter); given errors, or an effect without a warning, print none
    out = str(tmp_path / "sim.csv")
    for args, warned in ((["--effect", "radius_spread", "--effect-size", "0.02"], True),
                         (["--effect", "radius_spread", "--effect-size", "0.02", "--Rc-err-nm", "8",
                           "12"], False),
                         (["--effect", "bad_curves", "--effect-size", "0.05"], False)):
        with pytest.raises(SystemExit) as exit_info:
            main(["simulate", "--out", out, "--seed", "1", *args])
        assert exit_info.value.code == 0
        err = capsys.readouterr().err
        assert ("warning: --effect radius_spread with the default --Rc-err-nm 15 25" in err) == warned, err
