"""The data files of a criticism: ``criticism.json``, ``criticism_diagnostics.json`` and the
adopted extension's bands (:func:`write_criticism`); report.md and the figures are drawn from
them by :mod:`turgorbayes.report.criticism` (docs/outputs.md).
"""

import json
from pathlib import Path

import numpy as np

from turgorbayes import __version__
from turgorbayes.criticism.selection import DELTA_ELPD_MIN, P_GAIN_MIN
from turgorbayes.provenance import dependency_versions
from turgorbayes.workflows.bands import write_extended_bands
from turgorbayes.workflows.criticize import criticism_dict, jsonable

__all__ = ["diagnostics_dict", "write_criticism"]


def diagnostics_dict(result):
    """Per-model engine diagnostics, LOO summaries and rule quantities (JSON-ready)."""
    out = {"seed": int(result.seed), "turgorbayes_version": __version__,
           "dependencies": dependency_versions(), "data_sha256": result.cells.sha256,
           "settings": dict(vars(result.settings)),
           "selection_rule": {"delta_elpd_min": DELTA_ELPD_MIN, "p_gain_min": P_GAIN_MIN},
           "models": {}}
    # the candidates fitted (every registered one that applies when none were named)
    out["settings"]["effects"] = [c["effect"] for c in result.candidates]
    for name, post in result.posteriors.items():
        loo = result.loo[name]
        diag = {k: v for k, v in post.diagnostics.items() if k != "chain"}
        out["models"][name] = {
            "engine": post.engine, "converged": post.converged, "reasons": post.reasons,
            "diagnostics": jsonable(diag),
            "loo": {"elpd": loo["elpd"], "se": loo["se"], "p_loo": loo["p_loo"],
                    "good_k": loo["good_k"], "n_pareto_k_bad": loo["n_bad"],
                    "refitted_cells": [result.cells.cell_id[i] for i in loo["refitted"]],
                    "n_bad_not_refitted": loo["n_bad_left"],
                    "max_pareto_k": float(np.max(loo["pareto_k"]))},
        }
    out["candidates"] = jsonable(result.candidates)
    if result.stacking is not None:
        out["stacking"] = jsonable(result.stacking)
    return out


def write_criticism(result, out):
    """Write the data files of a criticism into ``out`` (created): ``criticism.json``
    (:func:`criticism_dict`), ``criticism_diagnostics.json`` (:func:`diagnostics_dict`) and,
    when an extension is adopted, ``extended_bands.json``
    (:func:`turgorbayes.workflows.bands.write_extended_bands`), the adopted extension's R_c/k_c
    bands for Fig. 3 of ``turgorbayes report``. The figures and report.md are drawn from them
    (:func:`turgorbayes.report.criticism.write_outputs`).

    Returns
    -------
    dict
        The criticism.json content.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    d = criticism_dict(result)
    (out / "criticism.json").write_text(json.dumps(d, indent=1) + "\n")
    (out / "criticism_diagnostics.json").write_text(
        json.dumps(diagnostics_dict(result), indent=1) + "\n")
    write_extended_bands(result, out / "extended_bands.json")
    return d
