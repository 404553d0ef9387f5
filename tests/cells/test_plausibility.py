"""Tests of the physical plausibility check at the door (turgorbayes.cells.plausibility, read_cells).

References are independent of the code: each refused file is the bundled example (simulated at
the paper's values, so every value is plausible) with one column scaled by a known unit factor
(1 um = 1000 nm, 1 pN/nm = 1 mN/m = 0.001 N/m, ...); the expected line is the scaled row's
physical line, counted from the file with the csv module.
"""

import csv

import numpy as np
import pytest
from click.testing import CliRunner

from turgorbayes.cells import plausibility
from turgorbayes.cells.plausibility import UnusualValueWarning
from turgorbayes.cells.table import CellData, example_path, read_cells
from turgorbayes.cli import main
from turgorbayes.cli.validate import validate
from turgorbayes.errors import DataError

RADII = ["Rc_nm", "Rc_err_nm", "Rb_nm", "Rb_err_nm", "hb_nm"]


def _example():
    lines = example_path().read_text().splitlines()
    comments = [s for s in lines if s.startswith("#")]
    rows = list(csv.reader(s for s in lines if not s.startswith("#")))
    return comments, rows[0], rows[1:]


def scaled(tmp_path, columns, factor, cell_ids=None):
    """The example with ``columns`` times ``factor`` (on ``cell_ids`` only, if given).

    Returns the path and the physical line of each scaled cell (comments + header + row).
    """
    comments, header, rows = _example()
    lines = {}
    for i, row in enumerate(rows):
        if cell_ids is not None and row[0] not in cell_ids:
            continue
        for c in columns:
            j = header.index(c)
            if row[j]:
                row[j] = repr(float(row[j]) * factor)
        lines[row[0]] = len(comments) + 2 + i
    path = tmp_path / "cells.csv"
    with path.open("w", newline="") as f:
        f.write("\n".join(comments) + "\n")
        csv.writer(f, lineterminator="\n").writerows([header, *rows])
    return path, lines


def first_cell(group, above=None):
    """cell_id of the first cell of ``group`` (with k_c above ``above`` N/m, if given)."""
    _, header, rows = _example()
    for row in rows:
        if row[1] == group and (above is None or float(row[header.index("kc_N_per_m")]) > above):
            return row[0]
    raise LookupError(group)


# (columns, factor, message pattern): every unit slip scaled on all cells
SLIPS = {
    "radii in um": (RADII, 1e-3, r"Rc_nm: .* below the 50-5000 nm.*looks like um, the column "
                                 r"is nm"),
    "radii in m": (RADII, 1e-9, r"Rc_nm: .* below .*looks like m, the column is nm"),
    "k_b in pN/nm": (["kb_N_per_m", "kb_err_N_per_m"], 1e3,
                     r"kb_N_per_m: .* above the 1e-05-1 N/m.*looks like pN/nm"),
    "k_c in mN/m": (["kc_N_per_m", "kc_err_N_per_m"], 1e3,
                    r"kc_N_per_m: .* above .*looks like pN/nm = mN/m"),
    "k_c in N/mm": (["kc_N_per_m", "kc_err_N_per_m"], 1e-3,
                    r"kc_N_per_m: .* below the 1e-05-1 N/m.*looks like N/mm"),
    "k_b in N/mm": (["kb_N_per_m", "kb_err_N_per_m"], 1e-3, r"kb_N_per_m: .* below .*N/mm"),
    "h_b in um": (["hb_nm"], 1e-3, r"hb_nm: .* below the 5-5000 nm.*looks like um"),
    "h_b in Angstrom": (["hb_nm"], 10.0, r"hb_nm: h_b = .* not smaller than R_b"),
    "R_b in Angstrom, h_b in nm": (["Rb_nm", "Rb_err_nm"], 0.1, r"hb_nm: h_b = .* not smaller"),
    "R_c error in percent": (["Rc_err_nm"], 100.0, r"Rc_err_nm: .*larger than the value"),
    "k_c error in another unit": (["kc_err_N_per_m"], 1e-3,
                                  r"kc_err_N_per_m: .*below 0.1% of the value"),
}


@pytest.mark.parametrize("slip", list(SLIPS))
def test_unit_slip_is_refused_naming_the_slip_and_the_first_line(tmp_path, slip):
    columns, factor, pattern = SLIPS[slip]
    path, lines = scaled(tmp_path, columns, factor)
    with pytest.raises(DataError, match=pattern) as info:
        read_cells(path)
    # every row was scaled: the first data row (line after 5 comments and the header) is named
    assert info.value.line == min(lines.values()) == 7
    assert str(path) in str(info.value) and "line 7" in str(info.value)


def test_single_corrupted_bulge_stiffness_is_refused_naming_its_line(tmp_path):
    # b004 has k_b = 3.68e-4 N/m: x1000 is 0.37 N/m, inside the stiffness bounds, but its
    # bulge pressure becomes 1000x the simulated one (P is proportional to k_b).
    path, lines = scaled(tmp_path, ["kb_N_per_m", "kb_err_N_per_m"], 1e3, {"b004"})
    with pytest.raises(DataError, match=r"P_bulge_kPa: .*implies a pressure of .* kPa, outside "
                                        r"the 0.05-1000 kPa.*1000x too high") as info:
        read_cells(path)
    assert info.value.line == lines["b004"] == 10
    assert "1 value(s)" in str(info.value) and "'b004'" in str(info.value)


def test_single_corrupted_intact_stiffness_is_refused_naming_its_line(tmp_path):
    cid = first_cell("intact", above=2e-3)  # x1000 > 1 N/m
    path, lines = scaled(tmp_path, ["kc_N_per_m", "kc_err_N_per_m"], 1e3, {cid})
    with pytest.raises(DataError, match=r"kc_N_per_m: .*looks like pN/nm") as info:
        read_cells(path)
    assert info.value.line == lines[cid] and info.value.column == "kc_N_per_m"


def test_refusal_lists_at_most_five_problems_and_counts_the_rest(tmp_path):
    # R_c and its error in um: one problem per cell (the relative error is unchanged)
    path, lines = scaled(tmp_path, ["Rc_nm", "Rc_err_nm"], 1e-3)
    with pytest.raises(DataError) as info:
        read_cells(path)
    text = str(info.value)
    assert "114 value(s)" in text and "... and 109 more" in text
    assert [f"line {n} " in text for n in range(7, 12)] == [True] * 5
    assert "line 12 " not in text


def test_validate_cli_refuses_with_exit_2(tmp_path, capsys):
    path, _ = scaled(tmp_path, RADII, 1e-3)
    with pytest.raises(SystemExit) as info:
        main(["validate", str(path)])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "line 7" in err and "looks like um" in err and "Traceback" not in err


def test_allow_unusual_reads_with_a_warning_listing_the_values(tmp_path):
    path, lines = scaled(tmp_path, ["kb_N_per_m", "kb_err_N_per_m"], 1e3, {"b004"})
    with pytest.warns(UnusualValueWarning, match=rf"line {lines['b004']} .*'b004'.*P_bulge_kPa"):
        cells = read_cells(path, allow_unusual=True)
    # the value is read as written, not clamped: 1000x the example's
    np.testing.assert_allclose(cells.k_b[3], 1e3 * read_cells(example_path()).k_b[3], rtol=1e-15)


def test_validate_allow_unusual_exits_0_and_lists_the_values(tmp_path):
    path, _ = scaled(tmp_path, RADII, 1e-3)
    result = CliRunner().invoke(validate, [str(path), "--allow-unusual"])
    assert result.exit_code == 0, result.output
    # R_c of 114 cells, R_b and h_b of 72 bulged cells (errors scaled alike: no error problem;
    # the implied pressure is not checked on rows whose inputs are already refused)
    assert "warning: 258 value(s) no bacterium can have" in result.output
    assert "looks like um" in result.output
    assert "OK: the file is valid, with the unusual values above (--allow-unusual)." in result.output


def test_bundled_example_and_simulated_data_pass(table):
    from turgorbayes.simulation import cells as synthetic

    assert plausibility.check(read_cells(example_path())) == []
    cells, _ = synthetic.simulate_cells(seed=101, truth=synthetic.PAPER_TRUTH, surrogate=table)
    assert plausibility.check(cells) == []


def _one_cell(**values):
    base = dict(R_c=[500e-9], R_c_err=[10e-9], k_c=[0.01], k_c_err=[0.001], R_b=[500e-9],
                R_b_err=[20e-9], k_b=[0.002], k_b_err=[0.0002], h_b=[100e-9])
    base.update({k: [v] for k, v in values.items()})
    return CellData(cell_id=["c"], group=["bulged"], **base)


def test_bounds_are_closed_and_problems_carry_row_column_value():
    # exactly on the bounds of docs/data_format.md: plausible
    assert plausibility.check(_one_cell(R_c=50e-9, R_c_err=0.05e-9)) == []
    assert plausibility.check(_one_cell(R_c=5e-6, R_c_err=5e-6)) == []
    assert plausibility.check(_one_cell(k_c=1.0, k_c_err=0.1)) == []
    [p] = plausibility.check(_one_cell(R_c=49e-9, R_c_err=1e-9))
    assert (p.row, p.cell_id, p.column) == (0, "c", "Rc_nm")
    np.testing.assert_allclose(p.value, 49.0, rtol=1e-12)  # in the CSV unit, nm
    # h_b = R_b is refused (the cone would reach the cell body)
    [p] = plausibility.check(_one_cell(h_b=500e-9))
    assert p.column == "hb_nm" and "not smaller than R_b" in p.reason


def test_implied_pressure_matches_the_bulge_formula():
    from turgorbayes.physics.bulge import reduced_stiffness

    # k_b chosen so that P = k_b / (R_b khat(h/R)) is 2000 kPa (docs/physics.md, bulge model)
    k_b = 2e6 * 500e-9 * float(reduced_stiffness(0.2))
    [p] = plausibility.check(_one_cell(k_b=k_b, k_b_err=0.1 * k_b))
    assert p.column == "P_bulge_kPa"
    np.testing.assert_allclose(p.value, 2000.0, rtol=1e-9)


def test_a_larger_cell_is_not_called_a_unit_slip(tmp_path):
    # Reference: b001's R_c is 481.2 nm (the bundled example); x20 is 9624 nm, a mammalian
    # cell's radius, 1.9x above the 5 um bound: 9624 Angstrom would be 962.4 nm, inside the
    # bounds, but nothing says the column is in Angstrom
    path, _ = scaled(tmp_path, ["Rc_nm"], 20.0, {"b001"})
    with pytest.raises(DataError, match=r"Rc_nm: 9624 nm is above .*larger than any bacterium")\
            as info:
        read_cells(path)
    assert "Angstrom" not in str(info.value) and "looks like" not in str(info.value)
    # x2000 is 0.96 mm, beyond any cell (50 um): then the slip is named, 962400 pm = 962.4 nm
    path, _ = scaled(tmp_path, ["Rc_nm"], 2000.0, {"b001"})
    with pytest.raises(DataError, match=r"Rc_nm: 9\.624e\+05 nm .*looks like pm"):
        read_cells(path)
