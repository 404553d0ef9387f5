"""The analysis notebook runs top to bottom headless, as the README says (papermill with
``-p QUICK True``: the quick settings of its parameter cell), and shows what it promises.

References: the bundled example's own CSV (72 bulged + 42 intact cells, read independently
here), the paper's published table (section 8 of the notebook), and the files the notebook
must write. Outputs are stripped in git: the stored notebook has none.
"""

from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
papermill = pytest.importorskip("papermill")
pytest.importorskip("ipykernel")

from turgorbayes import surrogate  # noqa: E402

NOTEBOOK = Path(__file__).resolve().parents[2] / "notebooks" / "posterior_analysis.ipynb"


def _text(cell):
    parts = []
    for o in cell.get("outputs", []):
        parts.append(o.get("text", ""))
        parts.append(o.get("data", {}).get("text/markdown", ""))
        parts.append(o.get("data", {}).get("text/plain", ""))
    return "".join(parts)


def test_notebook_is_stored_without_outputs():
    nb = nbformat.read(NOTEBOOK, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert "parameters" in code[0].metadata.get("tags", [])
    assert all(not c.outputs and c.execution_count is None for c in code)


@pytest.mark.slow
def test_notebook_runs_top_to_bottom(tmp_path):
    if not surrogate.default_path().is_file():
        pytest.skip("shipped surrogate table not built yet")
    params = nbformat.read(NOTEBOOK, as_version=4).cells[1].source
    assert "QUICK = False" in params and 'OUT = "' in params  # the names the README's line sets
    # the README's headless line: papermill NOTEBOOK OUT.ipynb -p QUICK True (-p DATA ...)
    papermill.execute_notebook(str(NOTEBOOK), str(tmp_path / "run.ipynb"), cwd=str(tmp_path),
                               parameters={"QUICK": True, "OUT": str(tmp_path / "out")},
                               kernel_name="python3", progress_bar=False)
    nb = nbformat.read(tmp_path / "run.ipynb", as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    text = "\n".join(_text(c) for c in code)
    assert "cells     114: 72 bulged, 42 intact" in text  # the example CSV's content
    assert "| P_phys_kPa |" in text and "| 29.0 ± 3.0 |" in text  # the paper's table
    assert "Best named effect:" in text and "verdict: " in text and "quote the model average" in text
    # the candidates the text announces are the registry's, every one of them
    from turgorbayes.effects import effect_names

    assert all(f"| `{n}` |" in text for n in effect_names())
    # no raw Python warning reaches the reader (a warning is a stream output on stderr)
    stderr = [o.get("text", "") for c in code for o in c.outputs
              if o.get("output_type") == "stream" and o.get("name") == "stderr"]
    assert not any("Warning" in t for t in stderr), stderr
    n_images = sum("image/png" in o.get("data", {}) for c in code for o in c.outputs)
    # fig2b, fig4, trace, rank, corner, fig3, residuals, fig3 + extension, misfit, the series' fig3
    assert n_images == 10
    # the osmotic series without bulged cells: its four levels (0-150 mOsm added to 300) fitted
    assert "osmotic series (P_phys is the turgor at 300 mOsm" in text
    assert all(f"\n          {c}     30  " in text for c in (300, 350, 400, 450)), text[-3000:]
    for name in ("posterior.nc", "summary.json", "report.html", "criticism/criticism.json",
                 "criticism/extended_bands.json", "criticism/misfit.png"):
        assert (tmp_path / "out" / name).is_file(), name
