"""Tests of ``turgorbayes validate``: exit codes, the error message, the summary's numbers.

References: hand-typed files with known column ranges; bulge pressures chosen first and turned
into k_b with the bulge model's forward direction, so the summary must report the chosen values.
"""

import re
import subprocess
import sys

import numpy as np
import pytest
from click.testing import CliRunner

from turgorbayes.cells.summary import bulge_pressures, validation_summary
from turgorbayes.cells.table import read_cells
from turgorbayes.cli.validate import validate

HEADER = (
    "cell_id,group,Rc_nm,Rc_err_nm,kc_N_per_m,kc_err_N_per_m,"
    "Rb_nm,Rb_err_nm,kb_N_per_m,kb_err_N_per_m,hb_nm"
)


def run_cli(*args):
    """The command line as a user runs it, in a fresh interpreter (``python -m turgorbayes``)."""
    return subprocess.run(
        [sys.executable, "-m", "turgorbayes", *args],
        capture_output=True, text=True, timeout=300, check=False,
    )


def write(path, *lines):
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return path


def test_bad_file_exits_2_with_the_loader_message_and_no_traceback(tmp_path):
    path = write(
        tmp_path / "bad.csv",
        "# provenance",
        HEADER,
        "c1,intact,550,11,0.018,0.002,,,,,",
        "c2,intact,5x0,11,0.018,0.002,,,,,",
    )
    result = run_cli("validate", str(path))
    assert result.returncode == 2
    # Line 4 counted by eye: comment (1), header (2), c1 (3), c2 (4).
    assert result.stderr.startswith(f"error: {path}, line 4, column Rc_nm: '5x0' is not a number")
    assert "Traceback" not in result.stderr + result.stdout
    assert result.stdout == ""


def test_missing_file_exits_2_without_traceback(tmp_path):
    result = run_cli("validate", str(tmp_path / "nowhere.csv"))
    assert result.returncode == 2
    assert "does not exist" in result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_bundled_example_is_valid_and_has_72_bulged_42_intact():
    result = run_cli("validate")
    assert result.returncode == 0, result.stderr
    assert "cells     114: 72 bulged, 42 intact" in result.stdout
    assert "OK: the file is valid." in result.stdout
    assert "warning" not in result.stdout


def _numbers(line):
    return [float(x) for x in line.split()[-3:]]


def _row(lines, label):
    matches = [ln for ln in lines if ln.strip().startswith(label)]
    assert len(matches) == 1, (label, lines)
    return matches[0]


def test_summary_reports_counts_ranges_and_bulge_pressures(tmp_path):
    from turgorbayes.physics.bulge import reduced_stiffness

    P_true = np.array([2e3, 20e3, 10e3])  # [Pa], chosen
    R_b = np.array([450e-9, 500e-9, 550e-9])
    h_b = np.array([90e-9, 100e-9, 121e-9])
    k_b = reduced_stiffness(h_b / R_b) * P_true * R_b
    rows = [
        f"b{i},bulged,{rc},10,0.01,0.001,{R_b[i] * 1e9:.17g},10,{float(k_b[i])!r},1e-4,{h_b[i] * 1e9:.17g}"
        for i, rc in enumerate([400, 600, 500])
    ]
    # h_b = 5 R_b is beyond the bulge model's deepest reach (1 + cot(pi/12) = 4.73 R_b).
    rows.append("bad1,bulged,450,10,0.01,0.001,500,10,0.001,1e-4,2500")
    rows += ["i1,intact,530,11,0.017,0.002,,,,,", "i2,intact,560,11,0.019,0.002,,,,,"]
    # h_b >= R_b is refused at the door; allow_unusual lets the summary explain it
    with pytest.warns(UserWarning,
                      match=r"line 6 \(cell_id 'bad1'\), hb_nm: h_b = 2500 nm is not smaller"):
        cells = read_cells(write(tmp_path / "cells.csv", "# test", HEADER, *rows),
                           allow_unusual=True)
    lines = validation_summary(cells)
    assert _row(lines, "cells").endswith("6: 4 bulged, 2 intact")
    # Ranges typed from the rows above.
    np.testing.assert_allclose(_numbers(_row(lines, "Rc_nm (bulged)")), [400, 475, 600], rtol=1e-12)
    np.testing.assert_allclose(_numbers(_row(lines, "Rc_nm (intact)")), [530, 545, 560], rtol=1e-12)
    np.testing.assert_allclose(_numbers(_row(lines, "kc_N_per_m (intact)")), [0.017, 0.018, 0.019],
                               rtol=1e-12)
    np.testing.assert_allclose(_numbers(_row(lines, "hb_nm")), [90, 110.5, 2500], rtol=1e-12)
    # Pressures [kPa]: the chosen truths, printed to 4 significant digits.
    np.testing.assert_allclose(_numbers(_row(lines, "P from bulge")), [2, 10, 20], rtol=5e-4)
    assert "1 bulged cell(s) without a physical pressure" in "\n".join(lines)
    assert re.search(r"^\s+bad1: .*h/R_b must be <", "\n".join(lines), re.MULTILINE)
    P, reasons = bulge_pressures(cells)
    np.testing.assert_allclose(P[:3], P_true, rtol=1e-9)
    assert np.isnan(P[3]) and list(reasons) == ["bad1"]


@pytest.mark.parametrize(
    ("rows", "warning"),
    [
        (["i1,intact,550,11,0.018,0.002,,,,,"], r"warning: no bulged cells .*calibrate"),
        (["b1,bulged,550,11,0.018,0.002,500,10,0.001,1e-4,100"], r"warning: no intact cells"),
    ],
)
def test_validate_warns_but_accepts(tmp_path, rows, warning):
    path = write(tmp_path / "one.csv", HEADER, *rows)
    result = CliRunner().invoke(validate, [str(path)])
    assert result.exit_code == 0, result.output
    assert re.search(warning, result.output)
    assert "OK: the file is valid." in result.output


def test_a_large_table_is_announced_before_it_is_read(tmp_path, monkeypatch):
    # Reference: the example file's own line count (str.splitlines), with the threshold
    # lowered to it; the announcement must come before read_cells starts
    from turgorbayes.cells.table import example_path
    from turgorbayes.cli import validate as validate_module

    text = example_path().read_text(encoding="utf-8")
    data = tmp_path / "cells.csv"
    data.write_text(text, encoding="utf-8")
    said = []
    calls = []
    monkeypatch.setattr(validate_module, "LARGE_TABLE_ROWS", len(text.splitlines()))
    real_read = validate_module.read_cells
    monkeypatch.setattr(validate_module, "read_cells",
                        lambda *a, **k: calls.append(list(said)) or real_read(*a, **k))
    validate_module.load_cells(data, echo=said.append)
    assert calls == [[f"reading {data} ({len(text.splitlines())} lines)..."]]
    # one line fewer than the threshold: nothing said
    said.clear()
    monkeypatch.setattr(validate_module, "LARGE_TABLE_ROWS", len(text.splitlines()) + 1)
    validate_module.load_cells(data, echo=said.append)
    assert said == []
