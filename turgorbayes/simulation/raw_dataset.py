"""Raw force curves of a simulated data set: the curve files, their manifest and the truths.

Each cell of :func:`turgorbayes.simulation.cells.simulate_cells` gets ``curves_per_cell`` cell-body
curves (law :func:`~turgorbayes.simulation.curves.cell_force` at its true ``k_c``, read depth
``R_c/20`` of its true radius, to twice that depth or to 150 pN) and, if bulged, as many bulge curves (law
:func:`~turgorbayes.simulation.curves.bulge_force` at its true pressure and bulge radius, to its
true ``h_b``). The manifest carries the *measured* radii of the simulated cells. The cells of
``map_groups`` are measured instead by one whole force map each
(:mod:`turgorbayes.simulation.forcemap`), whose radius ``curves`` fits.
"""

import csv
import functools
import json
from dataclasses import replace
from pathlib import Path

import numpy as np

from turgorbayes import __version__
from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, bulge_force, cell_force, synthetic_curve, write_curve

__all__ = ["MANIFEST_NAME", "baseline_draw", "write_raw_dataset"]

MANIFEST_NAME = "manifest.csv"
#: Cell-body curves go deeper than 2 h_ref on soft cells until this force [N] (at most 6 h_ref).
MIN_SETPOINT = 150e-12
#: Pixels per side and side [m] of a cell's whole force map (``map_groups``).
MAP_GRID = (16, 3.0e-6)
_HEADER = ("file", "cell_id", "target", "Rc_nm", "Rc_err_nm", "Rb_nm", "Rb_err_nm", "session")


def _curve_law(truths, i, target, cell_exponent):
    """(force law, max depth [m], true secant [N/m], read depth [m]) of cell ``i``."""
    c = truths["cells"]
    if target == "cell":
        R_c, k_c = c["R_c_true_nm"][i] * 1e-9, c["k_c_true_N_per_m"][i]
        h_ref = R_c / 20
        law = functools.partial(cell_force, k_c=k_c, h_ref=h_ref, a=cell_exponent)
        # to 2 h_ref, deeper on soft cells until the force reaches MIN_SETPOINT (<= 6 h_ref)
        depth = np.clip((MIN_SETPOINT / k_c) ** (1 / (1 + cell_exponent)) * h_ref
                        ** (cell_exponent / (1 + cell_exponent)), 2 * h_ref, 6 * h_ref)
        return law, float(depth), k_c, h_ref
    P, R_b = c["P_kPa"][i] * 1e3, c["R_b_nm"][i] * 1e-9
    h_b = c["h_over_Rb"][i] * R_b
    law = functools.partial(bulge_force, P=P, R_b=R_b)
    return law, h_b, float(law(np.array(h_b))) / h_b, h_b


def baseline_draw(acquisition, rng):
    """A curve's own baseline: offset, tilt and drift vary from curve to curve."""
    return replace(acquisition, offset=rng.uniform(-0.5e-9, 0.5e-9),
                   tilt=rng.uniform(-1e-4, 1e-4), drift=rng.uniform(-20e-12, 20e-12))


def _nm(value):
    return "" if value is None or not np.isfinite(value) else repr(float(value) * 1e9)


def _write_map(directory, cells, truths, i, seed, acquisition, grid):
    """A whole force map of cell ``i`` (its true radius, its true ``k_c`` on the crest, a random
    axis angle): the manifest row (``R_c`` left to the map's fit) and the truth."""
    from turgorbayes.simulation.forcemap import RodCell, write_force_map

    c, cell_id = truths["cells"], cells.cell_id[i]
    rod = RodCell(R=c["R_c_true_nm"][i] * 1e-9, k_c=c["k_c_true_N_per_m"][i],
                  angle=float(np.random.default_rng(seed).uniform(-np.pi / 2, np.pi / 2)))
    name = f"curves/{cell_id}_map.h5"
    write_force_map(directory / name, rod, n=grid[0], extent=grid[1], acquisition=acquisition,
                    seed=seed)
    return ([name, cell_id, "cell", "", "", "", "", "simulated", "map"],
            {"file": name, "k_N_per_m": rod.k_c, "R_c_nm": rod.R * 1e9})


def write_raw_dataset(directory, cells, truths, acquisition=DEFAULT_ACQUISITION, curves_per_cell=3,
                      seed=0, cell_exponent=0.1, map_groups=(), map_grid=MAP_GRID):
    """Write the raw curves of a simulated data set, ``manifest.csv`` and ``truth.json``.

    Parameters
    ----------
    directory : str or pathlib.Path
        Created if needed; curves go to ``directory/curves/``.
    cells : turgorbayes.cells.table.CellData
        Simulated measurements (their radii go into the manifest).
    truths : dict
        The truths of :func:`turgorbayes.simulation.cells.simulate_cells`.
    acquisition : Acquisition
        Cantilever, sampling and noise (each curve draws its own baseline offset, tilt and drift).
    curves_per_cell : int
        Curves per cell and target.
    seed : int
        Seed of the curves' noise, baselines and contact points.
    cell_exponent : float [-]
        Stiffening exponent ``a`` of the cell-body law.
    map_groups : sequence of str
        Groups (``"intact"``, ``"bulged"``) whose cell bodies are measured by one whole force
        map each (:func:`turgorbayes.simulation.forcemap.write_force_map`; the manifest leaves
        ``Rc_nm`` empty, so ``curves`` fits the radius from the map's contact points and reads
        ``k_c`` on its crest) instead of ``curves_per_cell`` curves.
    map_grid : (int, float)
        Pixels per side and side [m] of those maps.

    Returns
    -------
    pathlib.Path
        The manifest.
    """
    directory = Path(directory)
    (directory / "curves").mkdir(parents=True, exist_ok=True)
    seeds = iter(np.random.SeedSequence(seed).generate_state(2 * len(cells) * curves_per_cell))
    rows, curve_truths = [], []
    for i, cell_id in enumerate(cells.cell_id):
        for target in ("cell", "bulge") if cells.is_bulged[i] else ("cell",):
            if target == "cell" and cells.group[i] in map_groups:
                row, truth = _write_map(directory, cells, truths, i, int(next(seeds)), acquisition,
                                        map_grid)
                rows.append(row)
                curve_truths.append(truth)
                continue
            law, depth, k_true, h_read = _curve_law(truths, i, target, cell_exponent)
            for j in range(curves_per_cell):
                s = int(next(seeds))
                acq = baseline_draw(acquisition, np.random.default_rng(s))
                curve = synthetic_curve(law, depth, acq, seed=s)
                name = f"curves/{cell_id}_{target}_{j + 1}.tab"
                write_curve(curve, directory / name)
                bulge = target == "bulge"
                rows.append([name, cell_id, target, _nm(cells.R_c[i]), _nm(cells.R_c_err[i]),
                             _nm(cells.R_b[i]) if bulge else "", _nm(cells.R_b_err[i]) if bulge else "",
                             "simulated"] + ([""] if map_groups else []))
                curve_truths.append({"file": name, "k_N_per_m": k_true, "depth_nm": h_read * 1e9,
                                     "contact_height_nm": curve.contact_height * 1e9})
    manifest = directory / MANIFEST_NAME
    with open(manifest, "w", newline="", encoding="utf-8") as fh:
        fh.write(f"# SIMULATED force curves (not measurements): turgorbayes {__version__}, "
                 f"seed {seed}, truths in truth.json\n")
        writer = csv.writer(fh, lineterminator="\n")
        writer.writerow(_HEADER + (("curve_index",) if map_groups else ()))
        writer.writerows(rows)
    out = dict(truths, curves=curve_truths, acquisition=acquisition.as_dict(),
               curves_per_cell=curves_per_cell, curve_seed=seed, cell_exponent=cell_exponent)
    (directory / "truth.json").write_text(json.dumps(out, indent=1) + "\n")
    return manifest
