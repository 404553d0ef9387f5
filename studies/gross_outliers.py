"""Criticism of data with gross outliers against the same data without them.

Two readings of the bundled example are corrupted as a user's table can corrupt them (the
default: one cell's k_b x5, i.e. a bulge pressure 5x too high, and another cell's R_c x1.4,
a width taken from a dividing pair); ``turgorbayes.workflows.criticize.criticize`` runs on the clean and on
the contaminated table, one after the other in this process, and the script prints, side by
side, the wall time (and its ratio), the selected effect, the flagged cells and the baseline's
and the adopted model's gamma and P_phys. Target (docs/effects.md, outliers): the outliers
model selected, both cells named, at most 3x the clean run's time.

Usage::

    python studies/gross_outliers.py [--seed 0] [--kb-factor 5] [--rc-factor 1.4] \
        [--out studies/results/gross_outliers.txt]
"""

import argparse
import dataclasses
import time
from pathlib import Path

import numpy as np

from turgorbayes import __version__, provenance, surrogate
from turgorbayes.cells import table as io
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

#: The corrupted cells of the example (a bulged and an intact one).
KB_CELL, RC_CELL = "b004", "i009"
#: A smoke run's criticism: the outliers candidate alone, few draws, short chains.
SMOKE_SETTINGS = CriticismSettings(n_draws=200, n_rep=50, ess_min=20, n_ensembles=2, tol=5,
                                   check_every=20, max_steps=200, flag_draws=20, max_refits=0,
                                   effects=("outliers",))


def contaminate(cells, kb_factor, rc_factor):
    """The cells with ``KB_CELL``'s k_b times ``kb_factor`` and ``RC_CELL``'s R_c times
    ``rc_factor`` (reported errors unchanged)."""
    ids = list(cells.cell_id)
    k_b, R_c = cells.k_b.copy(), cells.R_c.copy()
    k_b[ids.index(KB_CELL)] *= kb_factor
    R_c[ids.index(RC_CELL)] *= rc_factor
    return dataclasses.replace(cells, k_b=k_b, R_c=R_c)


def run(cells, table, seed, settings=None):
    t0 = time.perf_counter()
    res = criticize(cells, table, seed=seed, settings=settings)
    dt = time.perf_counter() - t0
    d = criticism_dict(res)
    ext = d["parameters"]["extended"] or d["parameters"]["baseline"]
    return {"time_s": dt, "selected": d["selected_effect"], "flagged": d["flagged_cells"],
            "gamma": (d["parameters"]["baseline"]["gamma"], ext["gamma"]),
            "P_phys": (d["parameters"]["baseline"]["P_phys_kPa"], ext["P_phys_kPa"]),
            "candidates": [(c["effect"], c["delta_elpd"], c["delta_se"],
                            c["convergence"]["converged"]) for c in d["candidates"]]}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--kb-factor", type=float, default=5.0)
    ap.add_argument("--rc-factor", type=float, default=1.4)
    ap.add_argument("--out", type=Path, default=None)
    a = provenance.add_output_options(ap).parse_args()
    settings = SMOKE_SETTINGS if a.smoke else None
    provenance.tee_stdout(a, "gross_outliers.txt")
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    table = surrogate.load()
    clean = io.read_cells(io.example_path())
    dirty = contaminate(clean, a.kb_factor, a.rc_factor)
    rows = {"clean": run(clean, table, a.seed, settings),
            "contaminated": run(dirty, table, a.seed, settings)}
    lines = [f"turgorbayes {__version__}; bundled example, seed {a.seed}; contaminated: "
             f"{KB_CELL} k_b x{a.kb_factor:g}, {RC_CELL} R_c x{a.rc_factor:g}", ""]
    for name, r in rows.items():
        lines.append(f"## {name}: {r['time_s']:.0f} s, selected {r['selected']}")
        for c in r["candidates"]:
            lines.append(f"  {c[0]:<32} delta elpd {c[1]:8.1f} +- {c[2]:5.1f}  converged {c[3]}")
        for key in ("gamma", "P_phys"):
            (b, e) = r[key]
            lines.append(f"  {key}: baseline {b['q50']:.4g} [{b['q05']:.4g}, {b['q95']:.4g}], "
                         f"adopted {e['q50']:.4g} [{e['q05']:.4g}, {e['q95']:.4g}]")
        lines += [f"  flagged: {f['cell_id']} {f['quantity']} {f['score']:.3f}"
                  for f in r["flagged"]] or ["  flagged: none"]
        lines.append("")
    ratio = rows["contaminated"]["time_s"] / rows["clean"]["time_s"]
    named = {(f["cell_id"], f["quantity"]) for f in rows["contaminated"]["flagged"]}
    lines.append(f"time ratio contaminated/clean: {ratio:.2f} (target <= 3)")
    lines.append(f"both cells named: {(KB_CELL, 'k_b/R_b') in named and (RC_CELL, 'R_c') in named}")
    text = "\n".join(lines)
    print(text)
    if a.out:
        a.out.write_text(provenance.header_line(record) + "\n" + text + "\n")
    return np.isfinite(ratio)


if __name__ == "__main__":
    main()
