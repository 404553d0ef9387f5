"""Writing simulated data: the cell-data file and, beside it, the JSON file of its truths.

``turgorbayes simulate --out DATA.csv`` writes ``DATA.csv`` (:func:`turgorbayes.cells.table.write_cells`)
and ``DATA.json`` (the true parameters and the planted effects), which the tests and studies
compare a fit against.
"""

import json
from pathlib import Path

__all__ = ["sidecar_path", "write_simulated"]


def sidecar_path(csv_path):
    """The JSON file beside ``DATA.csv`` that holds the truths: ``DATA.json``."""
    return Path(csv_path).with_suffix(".json")


def write_simulated(cells, truths, out):
    """Write simulated ``cells`` to the cell-data file ``out`` (its folder made) and their
    ``truths`` (a JSON-able dict) to its :func:`sidecar_path`.

    Returns
    -------
    pathlib.Path
        ``out``.
    """
    from turgorbayes.cells.table import write_cells

    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    write_cells(cells, out)
    sidecar_path(out).write_text(json.dumps(truths, indent=1) + "\n")
    return out
