"""Tests of the tau_R prior from real E. coli widths (turgorbayes.inference.width_prior)."""

import gzip
import hashlib
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose
from scipy import stats

from turgorbayes.inference import width_prior as wp

# The source's files, vendored unchanged with their licence (tests/data/.../SOURCE.md).
DATA_DIR = Path(__file__).resolve().parents[1] / "data" / "ecoli_width_mother_machine"


def _write(path, widths, gz=True, column="width"):
    text = f",id,{column}\n" + "".join(f"c{i},c{i},{w}\n" for i, w in enumerate(widths))
    if gz:
        with gzip.open(path, "wt") as f:
            f.write(text)
    else:
        path.write_text(text)
    return path


def test_summary_by_hand(tmp_path):
    # widths 1, 2, 3, 4, 10 [um] (by hand): mean 4, sd (ddof 1) = sqrt(50/4) = 3.5355, median 3,
    # |w - 3| = 2, 1, 0, 1, 7 -> MAD 1; ln w: median ln 3, |ln w - ln 3| -> median ln(3/2).
    path = _write(tmp_path / "a_complete_cells.csv.gz", [1, 2, 3, 4, 10])
    s = wp.width_spread_summary([path])["a_complete_cells.csv.gz"]
    assert s["n_cells"] == 5
    assert_allclose(s["cv"], np.sqrt(12.5) / 4, rtol=1e-12)
    assert_allclose(s["cv_mad"], wp.MAD_TO_SD * 1 / 3, rtol=1e-12)
    assert_allclose(s["mad_log"], wp.MAD_TO_SD * np.log(1.5), rtol=1e-12)
    assert_allclose(s["sd_log"], np.std(np.log([1, 2, 3, 4, 10]), ddof=1), rtol=1e-12)
    assert_allclose(s["median_width_um"], 3.0)


def test_robust_spread_recovers_lognormal_truth_despite_outliers(tmp_path, rng):
    # 20,000 lognormal widths with log-sd 0.05 plus 2 % gross segmentation failures (x 1.6): the
    # MAD-based log spread must stay near 0.05 (sampling sd ~ 0.05 * 1.17/sqrt(2e4) ~ 4e-4, plus a
    # ~2 % contamination bias), the plain sd must not.
    w = np.exp(np.log(0.55) + 0.05 * rng.standard_normal(20_000))
    w[:400] *= 1.6
    s = wp.width_spread_summary([_write(tmp_path / "b.csv", w, gz=False)])["b.csv"]
    assert_allclose(s["mad_log"], 0.05, rtol=0.05)
    assert s["sd_log"] > 0.08


def test_prior_puts_the_stated_mass_below_the_bound():
    # scipy's half-normal CDF is the independent reference: P(tau_R < bound) = 0.95.
    assert_allclose(stats.halfnorm.cdf(wp.TAU_R_UPPER_BOUND, scale=wp.TAU_R_PRIOR_SCALE), 0.95, rtol=1e-12)
    assert_allclose(wp.TAU_R_PRIOR.sd, wp.TAU_R_PRIOR_SCALE)
    # the bound is the largest robust log spread among the recorded files
    assert_allclose(wp.TAU_R_UPPER_BOUND, max(v["mad_log"] for v in wp.WIDTH_SPREAD_MEASURED.values()))
    assert_allclose(wp.tau_R_prior_scale(1.0, 0.6826894921370859), 1.0, rtol=1e-9)  # 1-sigma mass


def test_bad_inputs(tmp_path):
    with pytest.raises(FileNotFoundError, match="width data file not found"):
        wp.width_spread_summary([tmp_path / "missing.csv.gz"])
    with pytest.raises(ValueError, match="no 'width' column"):
        wp.width_spread_summary([_write(tmp_path / "c.csv.gz", [0.5, 0.6], column="diameter")])
    with pytest.raises(ValueError, match=r"fewer than 2 positive widths \(1\)"):
        wp.width_spread_summary([_write(tmp_path / "d.csv.gz", [0.5, "", -1])])
    with pytest.raises(ValueError, match="at least one file"):
        wp.width_spread_summary([])
    with pytest.raises(ValueError, match=r"mass_below must lie in \(0, 1\), got 1.5"):
        wp.tau_R_prior_scale(0.07, 1.5)


def test_recorded_constants_match_the_data():
    # The module keeps only numbers; recompute them from the real files (4 significant digits
    # recorded, so rtol 1e-3) and check the files are the ones the numbers came from.
    files = sorted(DATA_DIR.glob("*_complete_cells*.csv.gz"))
    assert {f.name for f in files} == set(wp.WIDTH_SPREAD_MEASURED)
    summary = wp.width_spread_summary(files)
    for name, recorded in wp.WIDTH_SPREAD_MEASURED.items():
        got = summary[name]
        assert got["sha256"] == recorded["sha256"]
        assert got["n_cells"] == recorded["n_cells"]
        for key in ("median_width_um", "cv", "cv_mad", "sd_log", "mad_log"):
            assert_allclose(got[key], recorded[key], rtol=1e-3, err_msg=f"{name}: {key}")
    # the README's statement: width CV about 5-7 % (7.5 % for the Taheri file's plain CV)
    assert all(0.045 < v["cv"] < 0.076 for v in summary.values())


def test_default_data_dir_finds_the_width_files():
    # in a clone as on the project machine: a folder holding the very files the numbers came from
    folder = wp.default_width_data_dir()
    assert folder is not None
    files = sorted(folder.glob("*_complete_cells*.csv.gz"))
    assert {f.name: hashlib.sha256(f.read_bytes()).hexdigest() for f in files} == \
        {name: v["sha256"] for name, v in wp.WIDTH_SPREAD_MEASURED.items()}
