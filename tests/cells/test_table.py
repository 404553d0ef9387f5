"""Tests of the cell-data CSV format: loader errors, SI conversion, exact round trip, immutability.

References are independent of the code under test: the file texts below are written by hand,
expected line numbers are counted on them by eye, and SI values are Python float literals
(the correctly rounded decimal, e.g. 540.7 nm -> 5.407e-7 m).
"""

import dataclasses
import hashlib
import re
from pathlib import Path

import numpy as np
import pytest

from turgorbayes.cells.plausibility import UnusualValueWarning
from turgorbayes.cells.table import BULGE_COLUMNS, REQUIRED_COLUMNS, CellData, read_cells, write_cells
from turgorbayes.errors import DataError

HEADER = (
    "cell_id,group,Rc_nm,Rc_err_nm,kc_N_per_m,kc_err_N_per_m,"
    "Rb_nm,Rb_err_nm,kb_N_per_m,kb_err_N_per_m,hb_nm"
)
B1 = "c1,bulged,540.7,10.8,0.017,0.002,500,10,0.0065,0.00065,100"
B2 = "c2,bulged,480,9.6,0.004,0.0004,520,10.4,0.002,0.0002,104"
I1 = "c3,intact,550,11,0.018,0.002,,,,,"


def text(*lines):
    return "\n".join(lines) + "\n"


def write(tmp_path, content, name="cells.csv"):
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_bytes(content.encode("utf-8"))
    return path


@pytest.fixture
def rng():
    return np.random.default_rng(20111013)


# --------------------------------------------------------------------------- malformed files
# (id, file content, expected 1-based physical line, expected column or None, problem regex)
MALFORMED = [
    ("missing_column", text(HEADER.replace(",kc_err_N_per_m", ""), B1.replace(",0.002,", ",")),
     1, "kc_err_N_per_m", r"missing required column 'kc_err_N_per_m'"),
    ("missing_bulge_column_in_header",
     text(HEADER.replace(",hb_nm", ""), I1[:-1]), 1, "hb_nm", r"missing required column 'hb_nm'"),
    ("duplicate_column", text(HEADER + ",Rc_nm", B1 + ",541"), 1, "Rc_nm",
     r"duplicate column 'Rc_nm' \(header fields 3 and 12\)"),
    ("empty_header_field", text(HEADER + ",", B1 + ","), 1, None, r"header field 12 is empty"),
    ("non_numeric", text(HEADER, B1, B2.replace("480", "48O")), 3, "Rc_nm",
     r"'48O' is not a number"),
    ("decimal_comma_quoted", text(HEADER, B1.replace("0.017", '"0,017"')), 2, "kc_N_per_m",
     r"'0,017' is not a number"),
    ("nan", text(HEADER, B1.replace("0.017", "NaN")), 2, "kc_N_per_m",
     r"'NaN' is not allowed; values must be finite"),
    ("inf", text(HEADER, B1, B2.replace("0.002,0.0002", "inf,0.0002")), 3, "kb_N_per_m",
     r"'inf' is not allowed"),
    ("overflow", text(HEADER, B1.replace("540.7", "1e400")), 2, "Rc_nm",
     r"'1e400' overflows to infinity"),
    ("underflow", text(HEADER, B1.replace("0.017", "1e-400")), 2, "kc_N_per_m",
     r"must be > 0, got 1e-400 \(underflows to 0\)"),
    ("zero_radius", text(HEADER, B1, I1.replace("550", "0")), 3, "Rc_nm", r"must be > 0, got 0"),
    ("negative_stiffness", text(HEADER, B1.replace("0.017", "-0.017")), 2, "kc_N_per_m",
     r"must be > 0, got -0.017"),
    ("zero_error", text(HEADER, B1, B2.replace("10.4", "0.0")), 3, "Rb_err_nm",
     r"must be > 0, got 0.0"),
    ("negative_depth", text(HEADER, B1.replace(",100", ",-100")), 2, "hb_nm",
     r"must be > 0, got -100"),
    ("duplicate_cell_id", text(HEADER, B1, I1, B2.replace("c2", "c1")), 4, "cell_id",
     r"duplicate cell_id 'c1' \(first on line 2, again on line 4\)"),
    ("empty_cell_id", text(HEADER, B1, I1.replace("c3", " ")), 3, "cell_id", r"cell_id is empty"),
    ("unknown_group", text(HEADER, B1, I1.replace("intact", "Intact")), 3, "group",
     r"unknown group 'Intact'; allowed: 'bulged', 'intact'"),
    ("bulged_missing_bulge_field", text(HEADER, B1, B2.replace("0.002,0.0002", ",0.0002")), 3,
     "kb_N_per_m", r"empty value; bulged rows need all of Rb_nm, .*hb_nm"),
    ("intact_with_bulge_field", text(HEADER, B1, I1 + "90"), 3, "hb_nm",
     r"'90' on an intact row; the bulge columns .* must be empty on intact rows"),
    ("missing_required_value", text(HEADER, I1.replace("11,", ",")), 2, "Rc_err_nm",
     r"empty value; every row needs it"),
    ("too_few_fields", text(HEADER, B1, I1[:-1]), 3, None,
     r"row has 10 fields but the header has 11"),
    ("too_many_fields", text(HEADER, B1.replace("0.017", "0,017")), 2, None,
     r"row has 12 fields but the header has 11 .*decimal comma"),
    ("empty_file", "", None, None, r"file is empty; expected a header line"),
    ("only_comments", text("# a", "# b"), None, None, r"file is only comment lines"),
    ("header_only", text("# provenance", HEADER), 2, None, r"no data rows after the header"),
    ("blank_line_between_rows", text(HEADER, B1, "", I1), 3, None,
     r"blank line between data rows"),
    ("blank_line_before_header", text("# note", "", HEADER, B1), 2, None,
     r"blank line where the header should be"),
    ("comment_after_header", text(HEADER, B1, "# " + I1), 3, None,
     r"'#' comment line after the header"),
    ("semicolon_separator", text(HEADER.replace(",", ";"), B1.replace(",", ";")), 1, "cell_id",
     r"missing required column 'cell_id'.*seems to use ';'"),
    # comment lines count: 3 comments, header on line 4, the bad row is line 6
    ("comments_shift_lines", text("# sim", "# seed 0", "#", HEADER, B1, B2.replace("480", "x")),
     6, "Rc_nm", r"'x' is not a number"),
    # Windows line ends and a BOM do not change the physical line count
    ("crlf_bom", b"\xef\xbb\xbf" + text("# c", HEADER, B1, I1.replace("550", "-1")).replace(
        "\n", "\r\n").encode(), 4, "Rc_nm", r"must be > 0, got -1"),
    # a quoted extra field spanning two physical lines pushes the next row to line 5
    ("multiline_quoted_field", text(HEADER + ",note", B1 + ',"two\nlines"', I1 + ",x",
                                    B2.replace("0.004", "zero") + ",y"), 5, "kc_N_per_m",
     r"'zero' is not a number"),
    # an error inside a record spanning lines 2-3 is reported at its first line
    ("error_in_multiline_record", text(HEADER + ",note", B1.replace("540.7", "big") + ',"two\nlines"'),
     2, "Rc_nm", r"'big' is not a number"),
    ("not_utf8", text(HEADER, B1).encode() + b"c9,intact,5\xe90,1,1,1,,,,,\n", 3, None,
     r"not UTF-8 text"),
]


@pytest.mark.parametrize(
    ("content", "line", "column", "problem"),
    [case[1:] for case in MALFORMED],
    ids=[case[0] for case in MALFORMED],
)
def test_malformed_file_names_file_line_and_column(tmp_path, content, line, column, problem):
    path = write(tmp_path, content, name="bad_cells.csv")
    with pytest.raises(DataError, match=problem) as info:
        read_cells(path)
    err = info.value
    assert err.path == str(path)
    assert err.line == line
    assert err.column == column
    message = str(err)
    assert message.startswith(str(path))
    if line is not None:
        assert re.search(rf"\bline {line}\b", message)
    if column is not None:
        assert f"column {column}" in message


def test_malformed_cases_cover_at_least_15_files():
    assert len(MALFORMED) >= 15


def test_error_carries_offending_value(tmp_path):
    path = write(tmp_path, text(HEADER, B1.replace("540.7", "5 40")))
    with pytest.raises(DataError, match=r"'5 40' is not a number") as info:
        read_cells(path)
    assert info.value.value == "5 40"


# --------------------------------------------------------------------------- valid files
def test_si_conversion_is_the_exact_decimal_shift(tmp_path):
    # Reference: Python float literals (correctly rounded decimals) of the values in nm * 1e-9.
    path = write(tmp_path, text(HEADER, B1, B2.replace("480", "4.8e2").replace("104", "1040e-1")))
    cells = read_cells(path)
    assert cells.R_c[0] == 5.407e-7
    assert cells.R_c[1] == 4.8e-7
    assert cells.R_c_err[0] == 1.08e-8
    assert cells.k_c[0] == 0.017
    assert cells.k_b_err[0] == 0.00065
    assert cells.R_b[1] == 5.2e-7
    assert cells.h_b[0] == 1e-7
    assert cells.h_b[1] == 1.04e-7


def test_intact_rows_have_nan_bulge_fields_and_groups_split(tmp_path):
    cells = read_cells(write(tmp_path, text(HEADER, B1, I1, B2)))
    assert cells.cell_id == ("c1", "c3", "c2")
    np.testing.assert_array_equal(cells.is_bulged, [True, False, True])
    assert (cells.n_bulged, cells.n_intact, len(cells)) == (2, 1, 3)
    for name in ("R_b", "R_b_err", "k_b", "k_b_err", "h_b"):
        assert np.isnan(getattr(cells, name)[1])
        assert np.all(np.isfinite(getattr(cells, name)[[0, 2]]))
    bulged, intact = cells.bulged(), cells.intact()
    assert bulged.cell_id == ("c1", "c2") and intact.cell_id == ("c3",)
    np.testing.assert_array_equal(bulged.k_c, [0.017, 0.004])
    np.testing.assert_array_equal(intact.R_c, [5.5e-7])
    assert bulged.sha256 == cells.sha256 and intact.comments == cells.comments


def test_take_accepts_indices_and_masks(tmp_path):
    cells = read_cells(write(tmp_path, text(HEADER, B1, I1, B2)))
    assert cells.take([2, 0]).cell_id == ("c2", "c1")
    assert cells.take(np.array([False, True, True])).cell_id == ("c3", "c2")
    with pytest.raises(ValueError, match=r"boolean mask has shape \(2,\), expected \(3,\)"):
        cells.take([True, False])


def test_order_preserved_not_sorted(tmp_path):
    ids = ["z9", "a1", "m5", "b2"]
    rows = [I1.replace("c3", cid) for cid in ids]
    cells = read_cells(write(tmp_path, text(HEADER, *rows)))
    assert cells.cell_id == tuple(ids)


def test_extra_columns_and_comments_carried(tmp_path):
    content = text(
        "# simulated data",
        "#  seed = 0, \"quoted\"",
        HEADER.replace("cell_id,group", "cell_id,strain,group") + ",date,note",
        B1.replace("c1,bulged", "c1,MG1655,bulged") + ',2011-10-13,"tip slipped, redo"',
        I1.replace("c3,intact", "c3,,intact") + ",2011-10-14, leading space",
    )
    cells = read_cells(write(tmp_path, content))
    assert cells.comments == ("# simulated data", '#  seed = 0, "quoted"')
    assert list(cells.extra) == ["strain", "date", "note"]
    assert cells.extra["strain"] == ("MG1655", "")
    assert cells.extra["note"] == ("tip slipped, redo", " leading space")


def test_accepts_str_and_path_and_hashes_file_bytes(tmp_path):
    path = write(tmp_path, text("# x", HEADER, B1, I1))
    expected = hashlib.sha256(path.read_bytes()).hexdigest()
    from_str, from_path = read_cells(str(path)), read_cells(Path(path))
    assert from_str.sha256 == from_path.sha256 == expected
    assert from_str.path == from_path.path == str(path)


def test_single_group_loads_but_require_both_groups_refuses(tmp_path):
    cells = read_cells(write(tmp_path, text(HEADER, I1)))
    assert (cells.n_bulged, cells.n_intact) == (0, 1)
    with pytest.raises(DataError, match=r"no bulged cells .*calibrate the wall elasticity"):
        cells.require_both_groups()
    only_bulged = read_cells(write(tmp_path, text(HEADER, B1), name="b.csv"))
    with pytest.raises(DataError, match=r"no intact cells .*physiological turgor"):
        only_bulged.require_both_groups()
    both = read_cells(write(tmp_path, text(HEADER, B1, I1), name="both.csv"))
    assert both.require_both_groups() is both


# --------------------------------------------------------------------------- round trip
CANONICAL = text(
    "# simulated data, seed 0",
    "#",
    HEADER + ",note",
    "c1,bulged,540.7,10.8,0.017,0.002,500,10,0.0065,0.00065,100,\"a, b\"",
    "c3,intact,550.25,11,1.5e-05,2e-06,,,,,,",
    "c2,bulged,0.0001,1e-05,12345678.9,1e+16,1e+20,2.5,0.0001,3e-07,1,x",
)


def test_canonical_file_round_trips_byte_identical(tmp_path):
    src = write(tmp_path, CANONICAL, "src.csv")
    # extreme values test the number format; they are no bacterium's (c2's radius of 1e-4 nm)
    with pytest.warns(UnusualValueWarning, match=r"'c2'.*Rc_nm: 0.0001 nm is below"):
        cells = read_cells(src, allow_unusual=True)
    out = write_cells(cells, tmp_path / "out.csv")
    assert out.read_bytes() == CANONICAL.encode()


def test_noncanonical_file_is_written_in_canonical_form(tmp_path):
    # Same data as CANONICAL, written differently: BOM, CRLF, shuffled columns, spaces,
    # trailing zeros, exponents, a needlessly quoted field, trailing blank lines.
    header = ("note,hb_nm,group,cell_id,Rc_nm,Rc_err_nm,kc_N_per_m,kc_err_N_per_m,"
              "Rb_nm,Rb_err_nm,kb_N_per_m,kb_err_N_per_m")
    rows = [
        '"a, b", 100.000 ,bulged,c1,5.407E2,10.80,1.7e-2,.002,500,1e1,0.0065,6.5e-4',
        ",, intact ,c3,550.250,11,0.000015,0.0000020,,,,",
        'x,1,bulged,"c2",1e-4,0.00001,12345678.90,10000000000000000,1E20,2.50,1e-4,0.0000003',
    ]
    messy = "\ufeff" + "\r\n".join(["# simulated data, seed 0", "#", header, *rows, "", ""])
    src = write(tmp_path, messy, "messy.csv")
    with pytest.warns(UnusualValueWarning):
        cells = read_cells(src, allow_unusual=True)
    out = write_cells(cells, tmp_path / "out.csv")
    assert out.read_bytes() == CANONICAL.encode()


def test_random_si_values_survive_write_read_bit_for_bit(tmp_path, rng):
    n = 200
    bulged = rng.random(n) < 0.6

    def draw(lo, hi, on=None):
        v = np.exp(rng.uniform(np.log(lo), np.log(hi), n))
        return v if on is None else np.where(on, v, np.nan)

    cells = CellData(
        cell_id=[f"cell {i}" for i in rng.permutation(n)],
        group=np.where(bulged, "bulged", "intact").tolist(),
        R_c=draw(1e-7, 1e-6), R_c_err=draw(1e-9, 1e-7), k_c=draw(1e-4, 1e-1),
        k_c_err=draw(1e-6, 1e-2), R_b=draw(1e-7, 1e-6, bulged), R_b_err=draw(1e-9, 1e-7, bulged),
        k_b=draw(1e-5, 1e-1, bulged), k_b_err=draw(1e-7, 1e-2, bulged),
        h_b=draw(1e-8, 3e-7, bulged), extra={"tag": [str(i) for i in range(n)]},
        comments=["# random"],
    )
    first = write_cells(cells, tmp_path / "a.csv")
    with pytest.warns(UnusualValueWarning):  # random errors of 0.01 %-1000 % of the value
        back = read_cells(first, allow_unusual=True)
    for name in ("R_c", "R_c_err", "k_c", "k_c_err", "R_b", "R_b_err", "k_b", "k_b_err", "h_b"):
        # Reference: the original doubles themselves (equal_nan for the intact bulge fields).
        np.testing.assert_array_equal(getattr(back, name), getattr(cells, name), strict=True)
    assert back.cell_id == cells.cell_id and back.group == cells.group
    assert dict(back.extra) == dict(cells.extra) and back.comments == cells.comments
    second = write_cells(back, tmp_path / "b.csv")
    assert second.read_bytes() == first.read_bytes()


# --------------------------------------------------------------------------- immutability
def test_cell_data_is_immutable(tmp_path):
    cells = read_cells(write(tmp_path, text(HEADER, B1, I1)))
    for name in ("R_c", "k_c_err", "h_b", "is_bulged"):
        arr = getattr(cells, name)
        assert not arr.flags.writeable
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        cells.R_c = np.zeros(2)
    with pytest.raises(TypeError):
        cells.extra["new"] = ("a", "b")
    assert isinstance(cells.cell_id, tuple) and isinstance(cells.comments, tuple)


def test_constructor_copies_its_inputs():
    R_c = np.array([5e-7, 6e-7])
    cells = CellData(cell_id=["a", "b"], group=["intact", "intact"], R_c=R_c,
                     R_c_err=[1e-8, 1e-8], k_c=[0.01, 0.02], k_c_err=[1e-3, 1e-3])
    R_c[0] = -1.0
    assert cells.R_c[0] == 5e-7


@pytest.mark.parametrize(
    ("changes", "problem"),
    [
        ({"R_c": [5e-7, -1.0]}, r"R_c must be finite and > 0 .*cell_id 'b'"),
        ({"k_c_err": [np.nan, 1e-3]}, r"k_c_err must be finite and > 0 .*cell_id 'a'"),
        ({"h_b": [1e-7, np.nan]}, r"h_b must be NaN on intact cells .*cell_id 'a'"),
        ({"group": ["intact", "bulge"]}, r"group must be one of 'bulged', 'intact', got 'bulge'"),
        ({"cell_id": ["a", "a"]}, r"duplicate cell_id 'a'"),
        ({"cell_id": ["a", "#b"]}, r"starts with '#'"),
        ({"R_c": [5e-7]}, r"R_c has shape \(1,\), expected \(2,\)"),
        ({"comments": ["no hash"]}, r"comment lines must be str starting with '#'"),
        ({"extra": {"Rc_nm": ["1", "2"]}}, r"other than the standard columns"),
    ],
)
def test_constructor_validates_like_the_loader(changes, problem):
    args = dict(cell_id=["a", "b"], group=["intact", "intact"], R_c=[5e-7, 6e-7],
                R_c_err=[1e-8, 1e-8], k_c=[0.01, 0.02], k_c_err=[1e-3, 1e-3])
    args.update(changes)
    with pytest.raises(DataError, match=problem):
        CellData(**args)


def test_bulged_cell_needs_its_bulge_fields():
    with pytest.raises(DataError, match=r"R_b must be finite and > 0 .*cell_id 'a'"):
        CellData(cell_id=["a"], group=["bulged"], R_c=[5e-7], R_c_err=[1e-8], k_c=[0.01],
                 k_c_err=[1e-3])


def test_public_column_lists():
    # The cell-data format of the README, typed out independently.
    assert REQUIRED_COLUMNS == ("cell_id", "group", "Rc_nm", "Rc_err_nm", "kc_N_per_m",
                                "kc_err_N_per_m")
    assert BULGE_COLUMNS == ("Rb_nm", "Rb_err_nm", "kb_N_per_m", "kb_err_N_per_m", "hb_nm")
