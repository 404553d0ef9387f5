"""Bruker Nanoscope force files: refused with the way to read them, and that way works.

turgorbayes does not read Bruker Nanoscope files (``.spm``, ``.pfc``, ``.000``-``.999``):
afmformats has no reader for them and pyfmreader 0.1.3 failed the checks recorded in
docs/curves.md ("Bruker files"). ``read_approach`` stops on them with a ``DataError`` that says
how to export them, and the export recipe of docs/curves.md (NanoScope Analysis ASCII ->
afmformats ``.tab``) is run here on a curve of known stiffness.

No Bruker file is needed: the refusal goes by the file's suffix, before anything is read.
"""

import dataclasses
import functools

import afmformats
import numpy as np
import pytest

from turgorbayes.cli import main
from turgorbayes.curves import reduce_curve
from turgorbayes.curves.load import count_curves, read_approach
from turgorbayes.errors import DataError
from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, cell_force, synthetic_curve, write_curve

# the first line of every Nanoscope file (its ASCII header opens with the force file list)
NANOSCOPE_START = b"\\*Force file list\r\n\\Version: 0x09200000\r\n"
BRUKER_NAMES = ["curve.spm", "map.pfc", "cr00028.000", "DPPC00154.021", "CURVE.SPM"]


def bruker_file(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(NANOSCOPE_START + b"\x00" * 64)
    return path


def assert_says_how_to_read_it(err, path):
    text = str(err)
    assert "\n" not in text  # one line
    assert text.startswith(f"{path}: a Bruker Nanoscope file ({path.suffix}), ")
    assert err.path == str(path)
    for words in ("NanoScope Analysis as ASCII", "afmformats .tab file", "list the .tab file in the manifest",
                  "docs/curves.md, section 'Bruker files'"):
        assert words in text


@pytest.mark.parametrize("name", BRUKER_NAMES)
def test_read_approach_refuses_bruker_files_and_says_how_to_export(tmp_path, name):
    path = bruker_file(tmp_path, name)
    with pytest.raises(DataError) as info:
        read_approach(path)
    assert_says_how_to_read_it(info.value, path)
    with pytest.raises(DataError) as info:  # the manifest counts a file's curves with this
        count_curves(path)
    assert_says_how_to_read_it(info.value, path)


def test_reduce_curve_stops_instead_of_rejecting_the_curve(tmp_path):
    # a rejection would be an 'unreadable_file' row among the results and the run would go on;
    # every Bruker file of a session would be lost that way, so the run stops
    path = bruker_file(tmp_path, "cr00028.000")
    with pytest.raises(DataError, match=r"cr00028\.000: a Bruker Nanoscope file \(\.000\)"):
        reduce_curve(path, "cell", 500e-9)


def test_the_command_line_exits_2_naming_the_file(tmp_path, capsys):
    bruker_file(tmp_path, "cr00028.000")
    manifest = tmp_path / "m.csv"
    manifest.write_text("file,cell_id,target,Rc_nm,Rc_err_nm\ncr00028.000,c1,cell,500,10\n")
    with pytest.raises(SystemExit) as exit_info:
        main(["curves", str(manifest), "--out", str(tmp_path / "cells.csv"), "--no-progress", "--no-figures"])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2
    assert f"{tmp_path / 'cr00028.000'}: a Bruker Nanoscope file (.000)" in err
    assert not (tmp_path / "cells.csv").exists()


def test_only_the_last_suffix_counts(tmp_path):
    # 'cell.000.tab' is an afmformats .tab file (only its stem looks like Bruker's numbering);
    # a two-digit suffix is no Nanoscope suffix and goes to afmformats, which rejects it
    curve = synthetic_curve(functools.partial(cell_force, k_c=0.02, h_ref=25e-9), 50e-9, seed=1)
    write_curve(curve, tmp_path / "cell.000.tab")
    assert read_approach(tmp_path / "cell.000.tab").z.size == curve.data["force"].size
    (tmp_path / "cell.00").write_bytes(NANOSCOPE_START)
    result = reduce_curve(tmp_path / "cell.00", "cell", 500e-9)
    assert result.status == "unreadable_file"


# ----------------------------------------------------- the export recipe of docs/curves.md
def export_recipe(travel_nm, force_nN, k, sens_nm_per_V, out):
    """docs/curves.md, "Bruker files", step 2, as printed there (inputs as function arguments)."""
    data = {"force": force_nN * 1e-9,  # N
            "height (measured)": -travel_nm * 1e-9,  # m; falls as the tip approaches
            "segment": np.zeros(travel_nm.size, dtype=np.uint8)}  # 0: approach
    meta = {"path": str(out), "enum": 0,
            "spring constant": k,  # N/m
            "sensitivity": sens_nm_per_V * 1e-9}  # m/V
    afmformats.AFMForceDistance(data, meta).export_data(out, fmt="tab")


def test_export_recipe_gives_the_curves_calibration_and_stiffness(tmp_path):
    # A cell curve of known secant stiffness k_c at R_c/20 (F = k_c h (h/h_ref)^0.1, so the secant
    # at h_ref is k_c exactly), in the units of a NanoScope export (nm, nN), reversed in time
    # (an export may list the extend from its end), with the calibration of a real header
    # (pyfmreader's test file 20200904_Egel4-Z1.0_00025.spm: \Spring Constant 0.1332,
    # \@Sens. DeflSens 27.39 nm/V), goes through the recipe; the result must be read with that
    # calibration and give the same k_c as the same curve written by afmformats directly.
    k, sens, R_c, k_c = 0.1332, 27.39, 500e-9, 0.02
    acq = dataclasses.replace(DEFAULT_ACQUISITION, spring_constant=k, sensitivity=sens * 1e-9)
    curve = synthetic_curve(functools.partial(cell_force, k_c=k_c, h_ref=R_c / 20), 2 * R_c / 20, acq, seed=3)
    height = curve.data["height (measured)"]
    travel_nm, force_nN = (height[0] - height)[::-1] * 1e9, curve.data["force"][::-1] * 1e9
    export_recipe(travel_nm, force_nN, k, sens, tmp_path / "export.tab")
    write_curve(curve, tmp_path / "direct.tab")

    a = read_approach(tmp_path / "export.tab")
    assert a.spring_constant == k and a.sensitivity == pytest.approx(sens * 1e-9, rel=1e-15)
    assert a.height_column == "height (measured)" and a.z.size == height.size
    # sorted by travel whatever the row order (a time-reversed export starts at its deepest row)
    assert np.all(np.diff(a.z) >= 0) and np.ptp(a.z) == pytest.approx(height[0] - height[-1], rel=1e-6)

    got = reduce_curve(tmp_path / "export.tab", "cell", R_c)
    ref = reduce_curve(tmp_path / "direct.tab", "cell", R_c)
    assert got.ok and ref.ok, (got.detail, ref.detail)
    # both went through a .tab file (8 significant digits): measured 3e-15 relative apart; a
    # wrong unit, sign or calibration in the recipe moves k_c by a factor
    assert got.k == pytest.approx(ref.k, rel=1e-6)
    assert abs(got.k - k_c) < 3 * got.k_err  # and the truth within 3 reported sd (measured -1.2)
    # a manifest sensitivity override rescales the forces (needs the file's sensitivity: the
    # recipe writes it), F = F_file s_new/s_file, so the force rise scales by 1.1
    b = read_approach(tmp_path / "export.tab", sensitivity=1.1 * sens * 1e-9)
    assert np.ptp(b.force) == pytest.approx(1.1 * np.ptp(a.force), rel=1e-12)
