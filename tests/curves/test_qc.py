"""Each quality-control status is triggered by a curve made to fail that way, and an accepted
curve of the same kind passes (so every check can fail both ways)."""

import functools
from types import SimpleNamespace

import numpy as np
import pytest

from turgorbayes.curves import STATUSES, reduce_curve
from turgorbayes.curves.pipeline import low_signal_cells
from turgorbayes.curves.reduce import ReductionSettings
from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, Acquisition, cell_force, synthetic_curve, write_curve

R_C, K_C = 540e-9, 0.017
QUIET = Acquisition(noise_sd=2e-12)


def _cell(path, depth, acquisition=DEFAULT_ACQUISITION, **kw):
    law = functools.partial(cell_force, k_c=K_C, h_ref=R_C / 20)
    write_curve(synthetic_curve(law, depth, acquisition, seed=11, **kw), path)
    return path


def _status(path, target="cell", **kw):
    res = reduce_curve(path, target, R_C, **kw)
    assert res.status in STATUSES
    return res


def test_good_curve_is_ok(tmp_path):
    res = _status(_cell(tmp_path / "c.tab", 2 * R_C / 20))
    assert res.ok and res.detail == ""


def test_unreadable_file(tmp_path):
    bad = tmp_path / "c.tab"
    bad.write_text("# BEGIN METADATA\n# {\n# END METADATA\nnot\tnumbers\n")
    res = _status(bad)
    assert res.status == "unreadable_file" and np.isnan(res.k)
    other = tmp_path / "c.xyz"
    other.write_text("1 2 3\n")
    assert _status(other).status == "unreadable_file"


def test_calibration_missing_unless_the_manifest_gives_it(tmp_path):
    law = functools.partial(cell_force, k_c=K_C, h_ref=R_C / 20)
    curve = synthetic_curve(law, 2 * R_C / 20, Acquisition(), seed=1)
    write_curve(curve, tmp_path / "c.tab", calibration=False)
    assert _status(tmp_path / "c.tab").status == "calibration_missing"
    assert _status(tmp_path / "c.tab", sensitivity=50e-9).status == "calibration_missing"
    assert _status(tmp_path / "c.tab", spring_constant=0.011).ok


def test_no_contact(tmp_path):
    path = tmp_path / "c.tab"
    write_curve(synthetic_curve(lambda h: 0.0 * np.asarray(h), 50e-9, Acquisition(), seed=2), path)
    res = _status(path)
    assert res.status == "no_contact", res.detail


def test_baseline_too_short(tmp_path):
    path = _cell(tmp_path / "c.tab", 2 * R_C / 20, Acquisition(free_length=10e-9), contact_jitter=0.0)
    res = _status(path)
    assert res.status == "baseline_too_short", res.detail


def test_baseline_too_noisy(tmp_path):
    # the force reaches ~1 nN at 2 R_c/20; 0.25 nN of noise is 0.25 of it (limit 0.2)
    path = _cell(tmp_path / "c.tab", 2 * R_C / 20, Acquisition(noise_sd=0.25e-9))
    res = _status(path)
    assert res.status == "baseline_too_noisy", res.detail


def test_contact_too_close_to_end(tmp_path):
    # 3 nm of indentation: about 15 points of piezo travel past contact (need 30)
    path = _cell(tmp_path / "c.tab", 3e-9, QUIET)
    res = _status(path, target="bulge")
    assert res.status == "contact_too_close_to_end", res.detail


def test_coarse_sampling_is_not_called_contact_near_the_end(tmp_path):
    # 108 nm of indentation (4 R_c/20) sampled every 5 nm of piezo travel: the window at
    # 27 nm +- 30 % spans 16 nm of indentation, about 41 nm of piezo travel (dh/dz =
    # k/(k + k_c) = 0.39), so about 8 points (need 10), while 55 points lie past contact
    # (need 30) and 160 in the free travel (the baseline needs >= 50 before the contact guess)
    coarse = Acquisition(noise_sd=2e-12, rate=1e-6 / 5e-9, free_length=800e-9)
    res = _status(_cell(tmp_path / "c.tab", 4 * R_C / 20, coarse))
    assert res.status == "coarse_sampling", res.detail
    assert "piezo step 5 nm" in res.detail
    # the same depth at the default 0.5 nm step is fine
    assert _status(_cell(tmp_path / "d.tab", 4 * R_C / 20, QUIET)).ok


def test_too_shallow_for_R_over_20(tmp_path):
    path = _cell(tmp_path / "c.tab", 0.8 * R_C / 20, QUIET)
    res = _status(path)
    assert res.status == "too_shallow", res.detail
    # the same curve read as a bulge (deepest point) is fine
    assert _status(path, target="bulge").ok


def test_unknown_target_is_a_programming_error(tmp_path):
    with pytest.raises(ValueError, match="target must be one of"):
        reduce_curve(tmp_path / "c.tab", "membrane", R_C)


def test_stiffness_within_the_noise_is_undetermined(tmp_path):
    # a soft cell: 0.2 mN/m gives 5.4 pN at R_c/20 = 27 nm against 6.7 pN of thermal noise;
    # indented to 8 R_c/20 the force rises ~50 pN, so the baseline checks pass and only the
    # reading at R_c/20 is within the noise
    law = functools.partial(cell_force, k_c=2e-4, h_ref=R_C / 20)
    path = tmp_path / "soft.tab"
    write_curve(synthetic_curve(law, 8 * R_C / 20, DEFAULT_ACQUISITION, seed=3), path)
    res = _status(path)
    assert res.status == "stiffness_undetermined", (res.status, res.detail)
    assert "pN against a baseline noise of" in res.detail and np.isnan(res.k)
    # the rule's premise, seen with the rule switched off: the error exceeds the value
    loose = _status(path, settings=ReductionSettings(max_relative_error=np.inf))
    assert loose.accepted and loose.k_err > loose.k


def test_a_soft_curve_that_reads_low_is_kept_but_not_ok(tmp_path):
    # The rule judges the error against the deep secant, not against the reading: a rule on
    # k_err / k keeps the curves that happen to read high and biased accepted soft cells by
    # +24 % (docs/curves.md, Quality control). Reference: this curve's truth, 0.4 mN/m (10.8 pN
    # at R_c/20, 1.6x the 6.7 pN noise); noise seed 27 makes it read low, at about 0.22 of
    # the truth with an error of about 0.48 of the truth, larger than the reading itself. So
    # it is kept in its cell's mean (accepted) but not called ok: status imprecise
    law = functools.partial(cell_force, k_c=4e-4, h_ref=R_C / 20)
    path = tmp_path / "low.tab"
    write_curve(synthetic_curve(law, 6 * R_C / 20, DEFAULT_ACQUISITION, seed=27), path)
    res = _status(path)
    assert res.k_err > res.k and res.k < 0.5 * 4e-4 and res.k_err < 4e-4
    assert res.accepted and not res.ok and res.status == "imprecise", (res.status, res.detail)
    assert f"an error of {res.k_err / res.k:.0%} of the reading itself" in res.detail


def test_a_curve_whose_error_is_below_its_value_is_ok(tmp_path):
    # Reference: the paper's cell, 0.017 N/m, 459 pN at R_c/20 against 6.7 pN of noise: its
    # error is a few per cent of the reading
    res = _status(_cell(tmp_path / "c.tab", 2 * R_C / 20))
    assert res.k_err < res.k and res.ok and res.accepted and res.status == "ok"


def test_low_signal_cells_are_named(tmp_path):
    # Reference: the synthetic laws' own forces at R_c/20 against the 6.7 pN noise: the soft
    # cell gives 5.4 pN (under 3x), the paper's cell 0.017 N/m x 27 nm = 459 pN
    soft_law = functools.partial(cell_force, k_c=2e-4, h_ref=R_C / 20)
    write_curve(synthetic_curve(soft_law, 8 * R_C / 20, DEFAULT_ACQUISITION, seed=3),
                tmp_path / "soft.tab")
    loose = ReductionSettings(max_relative_error=np.inf)
    results = [_status(tmp_path / "soft.tab", settings=loose),
               _status(_cell(tmp_path / "stiff.tab", 2 * R_C / 20), settings=loose),
               _status(tmp_path / "soft.tab", target="bulge", settings=loose)]
    assert all(r.accepted for r in results)
    rows = [SimpleNamespace(target="cell", cell_id="soft"), SimpleNamespace(target="cell", cell_id="stiff"),
            SimpleNamespace(target="bulge", cell_id="bulge-only")]
    assert low_signal_cells(rows, results) == ["soft"]
    assert low_signal_cells(rows, results, ratio=1e-3) == []


def test_a_left_out_cell_gives_the_reasons_of_the_missing_target_only():
    # a bulged cell whose bulge curves are all rejected (no_contact) and one of whose two
    # cell-body curves is rejected for another reason (baseline_too_noisy): the reason names
    # the bulge curves' status only (it mixed both before)
    from turgorbayes.curves.pipeline import _left_out_reason

    def pair(target, status):
        return (SimpleNamespace(target=target),
                SimpleNamespace(accepted=status == "ok", status=status))

    pairs = [pair("cell", "ok"), pair("cell", "baseline_too_noisy"), pair("bulge", "no_contact"),
             pair("bulge", "no_contact")]
    assert _left_out_reason(pairs, kc=(0.01, 0.001), kb=None, bulged=True) == (
        "every bulge curve rejected (no_contact)")
    assert _left_out_reason(pairs[2:] + pairs[1:2], kc=None, kb=None, bulged=True) == (
        "every cell-body curve rejected (baseline_too_noisy)")


def test_a_binary_curve_file_is_one_line_naming_it_and_no_traceback(tmp_path, capfd):
    # Reference: a readable curve with bytes that are not UTF-8 appended after its header
    # (afmformats recognizes the .tab header, then fails to decode the data and logs its
    # traceback, once per reading: the curves run printed it twice)
    path = _cell(tmp_path / "c.tab", 2 * R_C / 20)
    with open(path, "ab") as f:
        f.write(b"\xff\xfe\x81\x00")
    res = _status(path)
    err = capfd.readouterr().err
    assert res.status == "unreadable_file" and "c.tab is not text of the .tab format" in res.detail
    assert "Traceback" not in err and "UnicodeDecodeError" not in err
    assert "\n" not in res.detail
