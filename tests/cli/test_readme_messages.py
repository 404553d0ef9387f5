"""The error messages the README and the user's guide show are the ones the command line prints.

Reference: the pages' own text; each message is regenerated from a file built to provoke it.
"""

import re
from pathlib import Path

import pytest

from turgorbayes.cells.table import read_cells
from turgorbayes.errors import DataError

ROOT = Path(__file__).resolve().parents[2]
#: The pages that quote error messages (the README's are repeated in the guide, or only there).
PAGES = (ROOT / "README.md", ROOT / "docs" / "guide.md")
HEADER = ("cell_id,group,Rc_nm,Rc_err_nm,kc_N_per_m,kc_err_N_per_m,Rb_nm,Rb_err_nm,kb_N_per_m,"
          "kb_err_N_per_m,hb_nm")
BULGED = "bulged,480,11,0.012,0.002,500,20,0.0011,0.0001,100"


def _readme_message(starts):
    """The quoted code block that starts with ``starts`` (all its lines); every page that
    quotes one quotes the same."""
    blocks = {b for page in PAGES
              for b in re.findall(r"```\n(error: .*?)\n```", page.read_text(encoding="utf-8"), re.S)
              if b.startswith(starts)}
    (block,) = blocks
    return block


def _printed(rows, tmp_path, monkeypatch):
    """What ``turgorbayes validate cells.csv`` prints for a file of ``rows`` (cli.main's format)."""
    monkeypatch.chdir(tmp_path)
    Path("cells.csv").write_text("\n".join([HEADER, *rows]) + "\n", encoding="utf-8")
    with pytest.raises(DataError) as err:
        read_cells("cells.csv")
    return f"error: {err.value}"


def test_negative_radius_message(tmp_path, monkeypatch):
    # line 14 = header (1) + 12 good rows (2-13) + the bad row
    rows = [f"b{i:03d},{BULGED}" for i in range(12)] + ["bad," + BULGED.replace(",500,", ",-3.0,")]
    assert _printed(rows, tmp_path, monkeypatch) == _readme_message("error: cells.csv, line 14")


def test_unit_slip_message(tmp_path, monkeypatch):
    # line 7: a radius and its error typed in um
    rows = [f"b{i:03d},{BULGED}" for i in range(2, 7)]
    rows += ["b001,bulged,0.4812,0.011,0.012,0.002,500,20,0.0011,0.0001,100",
             "i001,intact,550,11,0.018,0.002,,,,,"]
    assert _printed(rows, tmp_path, monkeypatch) == _readme_message("error: cells.csv, line 7")
