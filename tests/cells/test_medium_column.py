"""The optional ``medium_mOsm`` column (turgorbayes.cells.medium; docs/data_format.md, "Medium
osmolarity"): refused entries name the file, line, column and value; bulged rows may leave it
empty; models that put every intact cell at one turgor refuse several levels.

References: file texts written by hand, their line numbers counted by eye.
"""

import numpy as np
import pytest

from turgorbayes.cells.medium import medium_levels, medium_osmolarity, require_one_medium
from turgorbayes.cells.table import CellData, read_cells, write_cells
from turgorbayes.errors import DataError

HEADER = ("cell_id,group,Rc_nm,Rc_err_nm,kc_N_per_m,kc_err_N_per_m,"
          "Rb_nm,Rb_err_nm,kb_N_per_m,kb_err_N_per_m,hb_nm,medium_mOsm")
B1 = "c1,bulged,540.7,10.8,0.017,0.002,500,10,0.0065,0.00065,100,"
I1 = "c2,intact,550,11,0.018,0.002,,,,,,"
I2 = "c3,intact,530,11,0.012,0.002,,,,,,"


def _file(tmp_path, b1, i1, i2="350"):
    path = tmp_path / "cells.csv"
    path.write_text("# a comment\n" + "\n".join([HEADER, B1 + b1, I1 + i1, I2 + i2]) + "\n")
    return path


def test_values_levels_and_empty_bulged_entry(tmp_path):
    cells = read_cells(_file(tmp_path, "", "300"))
    c = medium_osmolarity(cells)
    assert np.isnan(c[0]) and list(c[1:]) == [300.0, 350.0]
    assert list(medium_levels(cells)) == [300.0, 350.0]  # the intact cells' levels only
    again = read_cells(write_cells(cells, tmp_path / "again.csv"))
    assert again.extra["medium_mOsm"] == ("", "300", "350")
    assert read_cells(_file(tmp_path, "0", "0", "0")).extra["medium_mOsm"] == ("0", "0", "0")


@pytest.mark.parametrize("entry, problem", [
    ("-5", r"must be >= 0 mOsm, got -5"),
    ("salty", r"'salty' is not a number"),
    ("inf", r"'inf' is not allowed"),
    ("nan", r"'nan' is not allowed"),
    ("", r"empty on an intact row"),
])
def test_refused_entries_name_line_column_value(tmp_path, entry, problem):
    # the first intact cell's row is line 4 (comment 1, header 2, c1 3)
    with pytest.raises(DataError, match=problem) as info:
        read_cells(_file(tmp_path, "300", entry))
    err = info.value
    assert (err.line, err.column, err.value) == (4, "medium_mOsm", entry)
    assert str(err).startswith(f"{tmp_path / 'cells.csv'}, line 4, column medium_mOsm: ")


def test_bulged_entry_is_checked_too(tmp_path):
    with pytest.raises(DataError, match="must be >= 0 mOsm") as info:
        read_cells(_file(tmp_path, "-1", "300"))
    assert info.value.line == 3


def test_built_data_name_the_cell(tmp_path):
    cells = read_cells(_file(tmp_path, "", "300"))
    bad = CellData(cell_id=cells.cell_id, group=cells.group, R_c=cells.R_c,
                   R_c_err=cells.R_c_err, k_c=cells.k_c, k_c_err=cells.k_c_err, R_b=cells.R_b,
                   R_b_err=cells.R_b_err, k_b=cells.k_b, k_b_err=cells.k_b_err, h_b=cells.h_b,
                   extra={"medium_mOsm": ("", "", "350")})
    with pytest.raises(DataError, match=r"empty on an intact row.*cell_id 'c2'"):
        medium_osmolarity(bad)


def test_one_turgor_models_refuse_several_levels(tmp_path, table):
    from turgorbayes.inference.models import BaselineModel, PaperWLS
    from turgorbayes.workflows.fit import fit_cells

    cells = read_cells(_file(tmp_path, "", "300"))
    with pytest.raises(DataError, match=r"2 osmolarities \(300, 350 mOsm\).*the baseline model"):
        require_one_medium(cells, "the baseline model")
    for build in (lambda: BaselineModel(cells, table), lambda: PaperWLS(cells, table),
                  lambda: fit_cells(cells, "radius_spread", surrogate=table)):
        with pytest.raises(DataError, match="osmotic model"):
            build()
    same = read_cells(_file(tmp_path, "", "300", "300"))  # one level: the baseline's data
    assert require_one_medium(same) is same


def test_validate_summarizes_each_conditions_levels(tmp_path):
    # Counts by hand: condition a has c2 at 300 and c3 at 350 (plus the bulged c1); b has c4
    # at 300 only and no bulged cell, so it alone cannot tell its wall from its turgor.
    from turgorbayes.cells.summary import validation_summary

    path = tmp_path / "cells.csv"
    header = HEADER + ",condition"
    rows = [B1 + ",a", I1 + "300,a", I2 + "350,a", I2.replace("c3", "c4") + "300,b"]
    path.write_text("\n".join([header, *rows]) + "\n")
    text = "\n".join(validation_summary(read_cells(path)))
    assert "medium [mOsm] (intact cells): 300 (2), 350 (1)" in text
    assert "    a: 300 (1), 350 (1)\n" in text + "\n"
    assert ("    b: 300 (1), 350 (0)  <- one level and no bulged cell: this condition cannot "
            "tell its wall from its turgor") in text
