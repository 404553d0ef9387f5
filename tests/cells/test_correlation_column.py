"""The optional ``rho_R_c_k_c`` column (turgorbayes.cells.correlation; docs/data_format.md,
"Correlated readings"): refused entries name the file, line, column and value; empty means
unknown; values survive write -> read.

References: file texts written by hand, their line numbers counted by eye.
"""

import numpy as np
import pytest

from turgorbayes.cells.correlation import error_correlation, with_error_correlation
from turgorbayes.cells.table import CellData, read_cells, write_cells
from turgorbayes.errors import DataError

HEADER = ("cell_id,group,Rc_nm,Rc_err_nm,kc_N_per_m,kc_err_N_per_m,"
          "Rb_nm,Rb_err_nm,kb_N_per_m,kb_err_N_per_m,hb_nm,rho_R_c_k_c")
B1 = "c1,bulged,540.7,10.8,0.017,0.002,500,10,0.0065,0.00065,100,"
I1 = "c2,intact,550,11,0.018,0.002,,,,,,"


def _file(tmp_path, b1_rho, i1_rho):
    path = tmp_path / "cells.csv"
    path.write_text("# a comment\n" + "\n".join([HEADER, B1 + b1_rho, I1 + i1_rho]) + "\n")
    return path


def test_values_and_empty_entries(tmp_path):
    cells = read_cells(_file(tmp_path, "-0.7", ""))
    rho = error_correlation(cells)
    assert rho[0] == -0.7 and np.isnan(rho[1])
    # write -> read keeps the text
    again = read_cells(write_cells(cells, tmp_path / "again.csv"))
    assert again.extra["rho_R_c_k_c"] == ("-0.7", "")
    # without the column every correlation is unknown
    plain = CellData(cell_id=cells.cell_id, group=cells.group, R_c=cells.R_c,
                     R_c_err=cells.R_c_err, k_c=cells.k_c, k_c_err=cells.k_c_err, R_b=cells.R_b,
                     R_b_err=cells.R_b_err, k_b=cells.k_b, k_b_err=cells.k_b_err, h_b=cells.h_b)
    assert np.all(np.isnan(error_correlation(plain)))
    assert np.allclose(error_correlation(with_error_correlation(plain, [0.25, -0.5])),
                       [0.25, -0.5])


@pytest.mark.parametrize("entry, problem", [
    ("1.5", r"must be strictly between -1 and 1, got 1.5"),
    ("-1", r"must be strictly between -1 and 1, got -1"),
    ("strong", r"'strong' is not a number"),
    ("nan", r"must be strictly between -1 and 1, got nan"),
])
def test_refused_entries_name_line_column_value(tmp_path, entry, problem):
    # the intact cell's row is line 4 (comment 1, header 2, c1 3)
    with pytest.raises(DataError, match=problem) as info:
        read_cells(_file(tmp_path, "0.1", entry))
    err = info.value
    assert (err.line, err.column, err.value) == (4, "rho_R_c_k_c", entry)
    assert str(err).startswith(f"{tmp_path / 'cells.csv'}, line 4, column rho_R_c_k_c: ")


def test_built_data_name_the_cell(tmp_path):
    cells = read_cells(_file(tmp_path, "", ""))
    bad = CellData(cell_id=cells.cell_id, group=cells.group, R_c=cells.R_c,
                   R_c_err=cells.R_c_err, k_c=cells.k_c, k_c_err=cells.k_c_err, R_b=cells.R_b,
                   R_b_err=cells.R_b_err, k_b=cells.k_b, k_b_err=cells.k_b_err, h_b=cells.h_b,
                   extra={"rho_R_c_k_c": ("0.2", "2")})
    with pytest.raises(DataError, match=r"column rho_R_c_k_c: must be strictly .* got 2;"
                                        r".*\(cell_id 'c2'\)"):
        error_correlation(bad)
