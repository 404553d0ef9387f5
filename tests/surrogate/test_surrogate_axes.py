"""Tests of the FE settings as surrogate axes (turgorbayes.surrogate.axes): the wall thickness
and the indenter's tip radius, one table per setting (``surrogate.load``) and per-point
settings (``correction_factor``, ``forward`` with ``axes``, the effects).

References: the FE records of the shipped correction tables (their own FE points), held-out FE
points (studies/fem_tip_radius.py; a copy of its result file in tests/data/study_results/), and the one-setting table
``surrogate.load(...)`` as the reference of the per-point path (two code paths that share only
the correction tables).
"""

import json
from importlib.resources import files

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes import surrogate
from turgorbayes.physics import forward
from turgorbayes.surrogate import SurrogateError
from turgorbayes.surrogate.axes import AXES

PAPER = (0.0706, 0.457)  # the physiological point (x, E_par/E_perp)


def _installed(axis):
    root = files("turgorbayes") / "data"
    a = AXES[axis]
    return all((root / f).is_file() for f in [*a.files.values(), a.reference_file])


needs_tip = pytest.mark.skipif(not _installed("tip_radius"),
                               reason="tip-radius tables not installed")
AXIS_VALUES = [("thickness", [3.0, 4.2, 7.0, 9.0]),
               pytest.param("tip_radius", [3.0, 5.0, 12.0, 20.0, 30.0], marks=needs_tip)]


def test_own_settings_return_the_main_table_itself():
    base = surrogate.load()
    assert surrogate.load(thickness_nm=6.0, tip_radius_nm=7.5).sha256 == base.sha256
    assert type(surrogate.load(thickness_nm=6.0)) is type(base)


@pytest.mark.parametrize("kwargs, match", [
    ({"thickness_nm": 12.0}, r"wall thickness 12 nm is outside the tabulated range \[3, 9\] nm"),
    ({"tip_radius_nm": 45.0}, r"tip radius 45 nm is outside the tabulated range \[3, 30\] nm"),
    ({"tip_radius_nm": 1.0}, r"tip radius 1 nm is outside the tabulated range \[3, 30\] nm")])
def test_settings_outside_the_tabulated_range_are_refused(kwargs, match):
    if "tip_radius_nm" in kwargs and not _installed("tip_radius"):
        pytest.skip("tip-radius tables not installed")
    with pytest.raises(SurrogateError, match=match):
        surrogate.load(**kwargs)


def test_a_main_table_at_another_setting_is_not_corrected_silently():
    # the 3 nm correction table is itself a table computed at t = 3 nm: correcting it "to
    # 4.5 nm" with corrections relative to 6 nm would be wrong, and is refused
    path = files("turgorbayes") / "data" / AXES["thickness"].files[3e-9]
    with pytest.raises(SurrogateError, match="computed at 3 nm.*relative to 6 nm"):
        surrogate.load(str(path), thickness_nm=4.5)


@pytest.mark.parametrize("axis, values_nm", AXIS_VALUES)
def test_per_point_settings_equal_one_table_per_setting(axis, values_nm, rng):
    # reference: surrogate.load(<axis>=v) for each v (the scalar path); the per-point path
    # (correction_factor, used by the effects for a fitted value per walker) must agree
    base = surrogate.load()
    x = np.exp(rng.uniform(np.log(0.01), np.log(0.3), 40))
    ratio = rng.uniform(0.3, 0.95, 40)
    values = np.repeat(np.array(values_nm) * 1e-9, 10)[:40]
    got = base(x, ratio) * surrogate.correction_factor(base, x, ratio, **{axis: values})
    ref = np.array([surrogate.load(**{f"{axis}_nm": v * 1e9})(xi, ri)
                    for xi, ri, v in zip(x, ratio, values, strict=True)])
    assert_allclose(got, ref, rtol=1e-12)


@pytest.mark.parametrize("axis, values_nm", AXIS_VALUES)
def test_forward_model_with_per_cell_settings(axis, values_nm):
    # reference: the forward model on the one-setting table, cell by cell
    P = np.geomspace(2e3, 30e3, len(values_nm))
    values = np.array(values_nm) * 1e-9
    R, k = forward.cell_radius_and_stiffness(P, 1.22, 0.026, 464.2e-9, axes={axis: values})
    for i, v in enumerate(values_nm):
        R_i, k_i = forward.cell_radius_and_stiffness(
            P[i], 1.22, 0.026, 464.2e-9, surrogate=surrogate.load(**{f"{axis}_nm": v}))
        assert_allclose([R[i], k[i]], [R_i, k_i], rtol=1e-12)


def test_thickness_table_reproduces_its_fe_points():
    # reference: the FE records of the 3 nm sweep and of its 6 nm reference on the same mesh
    # (turgorbayes/data): at an FE point the corrected table is the main table times the FE
    # ratio k(3 nm)/k(6 nm) (interpolation of the correction passes through its nodes)
    from turgorbayes.surrogate.table import open_table

    root = files("turgorbayes") / "data"
    ds = open_table(root / AXES["thickness"].files[3e-9]).transpose("ratio", "x", ...)
    ref = surrogate.table.load(root / AXES["thickness"].reference_file)
    base, thin = surrogate.load(), surrogate.load(thickness_nm=3.0)
    j, i = 1, 3  # ratio 0.4, an interior x
    x, r = float(ds["x_actual"][j, i]), float(ds["ratio"][j])
    fe_ratio = float(ds["k_over_PR"][j, i]) / ref(x, r)
    assert_allclose(thin(x, r) / base(x, r), fe_ratio, rtol=1e-6)


@needs_tip
def test_tip_radius_correction_matches_held_out_fe_points():
    # reference: FE points on the tip tables' mesh that are not nodes of the tables: the
    # physiological point (x 0.0706, ratio 0.457; tips 3, 20, 30 nm, 20 nm not a node of the
    # tip axis either) and two grid-cell midpoints (x 0.021, ratio 0.5; x 0.126, ratio 0.8)
    # (studies/fem_tip_radius.py, studies/results/fem_tip_radius.jsonl): the correction
    # k(tip)/k(7.5 nm) within 0.5 %, the bar for the coarse grid
    rows = [json.loads(line) for line in
            open(_results("fem_tip_radius.jsonl")).read().splitlines()]
    fe = {}
    for r in rows:
        if r["variant"] == "tip_half" and r.get("thickness_nm", 6.0) == 6.0:
            fe.setdefault((r["x_target"], r["ratio"]), {})[r["tip_nm"]] = r["k_over_PR"]
    base, checked = surrogate.load(), 0
    for (x, ratio), k in fe.items():
        for tip in set(k) - {7.5}:
            s = surrogate.load(tip_radius_nm=tip)
            if tip < 7.5 and x > 0.125:
                # the 3 nm sweep buckles under the tip at x = 0.2 (every ratio): its grid cells
                # above x = 0.125 have no value, although this point itself ran smoothly
                assert s.buckled(x, ratio)
                continue
            got = s(x, ratio) / base(x, ratio)
            assert_allclose(got, k[tip] / k[7.5], rtol=5e-3, err_msg=f"{x}, {ratio}, {tip} nm")
            checked += 1
    assert checked == 6


def _results(name):
    """A copy of a study's result file (tests/data/study_results/README.md says whence)."""
    from pathlib import Path

    return Path(__file__).parents[1] / "data" / "study_results" / name


@needs_tip
def test_surrogate_info_shows_every_axis(capsys):
    # reference: the shipped sweeps (surrogates/README.md): thickness 3, 4.5, 9 nm beside the
    # main table's 6 nm; tip radius 3, 15, 30 nm beside its 7.5 nm
    from turgorbayes.cli import main

    with pytest.raises(SystemExit) as info:
        main(["surrogate", "info"])
    out = capsys.readouterr().out
    assert info.value.code == 0
    assert "thickness   6 nm here; tabulated 3, 4.5, 6, 9 nm" in out
    assert "tip_radius  7.5 nm here; tabulated 3, 7.5, 15, 30 nm" in out
    assert "x in [0.001, 0.5867]" in out  # the main table's own axes


@needs_tip
def test_no_corrected_value_where_the_reference_sweep_buckles():
    # reference: the 7.5 nm sweep's FE record at x = 0.49, ratio 0.25, whose force falls by
    # 0.8 % before h = R/20 (surrogate info): its grid cells (x 0.2-0.49, ratio 0.25-0.4) have
    # no unique k, so no tip correction either; outside them the correction is defined
    s = surrogate.load(tip_radius_nm=30.0)
    assert s.buckled(0.3, 0.3) and not surrogate.load().buckled(0.3, 0.3)
    with pytest.warns(RuntimeWarning, match="buckles under the tip"):
        assert np.isnan(s(0.3, 0.3))
    assert np.isfinite(s(0.3, 0.8)) and not s.buckled(0.0706, 0.457)
