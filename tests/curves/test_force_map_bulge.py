"""A bulge on a whole force map: k_b, h_b and R_b from the dome above the cell's fitted cylinder
(turgorbayes/curves/bulgedome.py, bulgemap.py; docs/curves.md, Bulges on force maps).

Truth (turgorbayes/simulation/bulge_map.py): a spherocylinder of R = 450 nm, cylindrical length
1.8 um, axis at 30 deg, and a sphere of R_b = 400 nm whose centre sits on the crest 0.5 um from
the cell's middle (apex 400 nm above the cell), on a 16 x 16 grid over 3.4 um (212.5 nm pitch),
written by afmformats and reduced through the manifest (one cell row and one bulge row on the
same map, both curve_index 'map'). Bulge curves: the liquid-membrane law of the single synthetic
bulge curves (bulge_force) at P = 10 kPa within 0.4 R_b of the apex, P/2 on the rest of the dome
(an apex rule taking flank curves would miss k_b by -50 %), indented to h_b = 0.22 R_b. Noise:
the thermal limit of the 0.011 N/m cantilever (6.7 pN), as in test_recovery.py.
"""

import csv
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.curves import read_manifest, reduce_manifest, write_curves_table
from turgorbayes.curves.bulgemap import reduce_bulge_map
from turgorbayes.simulation.bulge_map import MapBulge, bulge_apex, bulge_surface
from turgorbayes.simulation.forcemap import RodCell, rod_height, write_force_map

CELL = RodCell(R=450e-9, length=1.8e-6, angle=np.deg2rad(30.0), k_c=0.02, flank_ratio=0.5)
BULGE = MapBulge(R_b=400e-9, P=10e3, along=0.5e-6)
HEADER = "file,cell_id,target,Rc_nm,Rc_err_nm,Rb_nm,Rb_err_nm,curve_index\n"


@pytest.fixture(scope="module")
def bulged(tmp_path_factory):
    """The written map, its truth and its reduction (line 2: the cell, line 3: the bulge)."""
    folder = tmp_path_factory.mktemp("bulge")
    truth = write_force_map(folder / "map.h5", CELL, n=16, extent=3.4e-6, seed=5, bulge=BULGE)
    (folder / "m.csv").write_text(HEADER + "map.h5,c1,cell,,,,,map\nmap.h5,c1,bulge,,,,,map\n")
    result = reduce_manifest(read_manifest(folder / "m.csv"))
    write_curves_table(folder / "curves.csv", result)
    return folder, truth, result


def test_simulated_bulge_is_a_sphere_on_the_crest():
    x, y, top = bulge_apex(CELL, BULGE)
    assert_allclose(top, 2 * CELL.R + BULGE.R_b, rtol=1e-12)  # centre on the crest, 2 R up
    rho = np.array([0.0, 0.6, 0.99]) * BULGE.R_b
    px, py = x + rho, np.full(3, y)
    surface, on = bulge_surface(px, py, CELL, BULGE, rod_height(px, py, CELL))
    assert on.all()
    assert_allclose(surface, 2 * CELL.R + np.sqrt(BULGE.R_b**2 - rho**2), rtol=1e-9)


def test_bulge_radius_and_apex_recovered(bulged):
    """Bound: 4 reported sd of the sphere fit, and 25 nm (6 %): the contact heights of the soft
    bulge curves miss by up to ~8 nm (the fit's residual scatter carries them), and 6 % is the
    smallest error the simulated manifests give an imaged R_b (turgorbayes.simulation.cells.ErrorModel,
    R_b_log_sd 6-12 %)."""
    _, _, result = bulged
    fm = result.maps[3]
    assert fm.ok, fm.detail
    d = fm.dome
    assert abs(d.R_b - BULGE.R_b) < min(4 * d.R_b_err, 25e-9), (d.R_b, d.R_b_err)
    x, y, top = bulge_apex(CELL, BULGE)
    assert math.hypot(d.apex_x - x, d.apex_y - y) < 30e-9  # a seventh of the pitch
    assert abs(d.dome_height - BULGE.R_b) < 25e-9
    assert_allclose([fm.R_b, fm.R_b_err], [d.R_b, math.hypot(d.R_b_err, 0.01 * d.R_b)], rtol=1e-12)


def test_bulge_stiffness_and_depth_recovered(bulged):
    """Bound: 3 reported sd and 10 %: single bulge curves of these laws at 6.7 pN, reduced
    alone, scatter by 4.8 % sd (studies/results/force_map_bulge_recovery.txt), and the map
    combines 1-3 apex curves: about 2 single-curve sd."""
    _, _, result = bulged
    fm = result.maps[3]
    assert abs(fm.k / BULGE.k_b - 1) < 0.10 and abs(fm.k - BULGE.k_b) < 3 * fm.k_err, \
        (fm.k / BULGE.k_b - 1, fm.k_err / fm.k)
    assert abs(fm.depth / BULGE.h_b - 1) < 0.03, fm.depth / BULGE.h_b - 1
    cells = result.cells
    assert cells.group == ("bulged",)
    assert_allclose([cells.k_b[0], cells.h_b[0], cells.R_b[0], cells.R_b_err[0]],
                    [fm.k, fm.depth, fm.R_b, fm.R_b_err], rtol=1e-12)


def test_apex_curves_are_the_ones_nearest_the_true_apex(bulged):
    _, truth, result = bulged
    fm = result.maps[3]
    chosen = fm.dome.apex_index
    x, y, _ = bulge_apex(CELL, BULGE)
    distance = np.hypot(truth.x - x, truth.y - y)
    nearest = np.argsort(distance)[:chosen.size]
    assert set(chosen.tolist()) == set(nearest.tolist()), (chosen, nearest)
    assert np.all(truth.k[chosen] == BULGE.k_b)  # the apex law, no flank curve (P/2)
    assert np.all(truth.bulge[chosen])


def test_cell_row_on_the_bulged_map_leaves_the_dome_out(bulged):
    """The cell's R_c and k_c as on a map without a bulge (test_force_maps.py's bounds: 1.5 nm,
    2 %); no crest curve on the dome."""
    _, truth, result = bulged
    fm = result.maps[2]
    assert fm.ok, fm.detail
    assert abs(fm.section.R - CELL.R) < 1.5e-9, fm.section.R
    assert abs(fm.k / CELL.k_c - 1) < 0.02, fm.k / CELL.k_c - 1
    assert not np.any(truth.bulge[fm.crest_index]) and not np.any(truth.bulge[fm.section.arc])
    assert "a dome of" in fm.detail


def test_tables_report_the_chosen_curves_and_the_rule(bulged):
    folder, _, result = bulged
    fm = result.maps[3]
    indices = " ".join(str(i) for i in fm.dome.apex_index)
    with open(folder / "curves.csv") as fh:
        rows = list(csv.DictReader(fh))
    assert rows[1]["target"] == "bulge" and rows[1]["status"] == "ok"
    assert f"apex curves {indices.replace(' ', ', ')}:" in rows[1]["detail"]
    assert "R_b fit" in rows[1]["detail"]
    with open(folder / "force_maps.csv") as fh:
        summary = list(csv.DictReader(fh))
    assert [s["target"] for s in summary] == ["cell", "bulge"] and None not in summary[1]
    assert summary[1]["apex_curves"] == indices
    assert_allclose([float(summary[1][c]) for c in ("Rb_fit_nm", "dome_height_nm", "k_N_per_m")],
                    [fm.dome.R_b * 1e9, fm.dome.dome_height * 1e9, fm.k], rtol=1e-5)
    with open(folder / summary[1]["pixel_table"]) as fh:
        pixels = list(csv.DictReader(fh))
    assert [int(r["curve_index"]) for r in pixels if r["apex"] == "1"] == sorted(fm.dome.apex_index)
    assert sum(r["dome"] == "1" for r in pixels) == fm.dome.dome.sum()


def test_map_figure_marks_the_apex_curves(bulged, tmp_path):
    from turgorbayes.plots.forcemap import map_figure

    _, _, result = bulged
    fm = result.maps[3]
    fig = map_figure(fm, "map.h5", "c1", tmp_path / "bulge.png")
    lines = {line.get_gid(): line for ax in fig.axes for line in ax.get_lines() if line.get_gid()}
    assert_allclose(lines["apex_pixels"].get_xdata(), fm.pixels.x[fm.dome.apex_index] * 1e6)
    assert lines["dome_pixels"].get_xdata().size == fm.dome.dome.sum()
    assert "k_b" in fig.get_suptitle()


def test_bulge_row_on_a_map_without_a_bulge_is_rejected(tmp_path):
    """The cell of test_force_maps.py, no bulge: no dome, no made-up k_b; the cell is left out."""
    cell = RodCell(R=450e-9, length=1.0e-6, angle=np.deg2rad(30.0), k_c=0.02)
    write_force_map(tmp_path / "plain.h5", cell, n=12, extent=2.6e-6, seed=4)
    (tmp_path / "m.csv").write_text(HEADER + "plain.h5,c1,cell,,,,,map\nplain.h5,c1,bulge,,,,,map\n")
    result = reduce_manifest(read_manifest(tmp_path / "m.csv"))
    res = result.results[1]
    assert res.status == "no_bulge" and math.isnan(res.k), res
    assert "no bulge: no 6 connected pixels over the cell rise more than" in res.detail
    assert result.results[0].ok  # the cell row is unaffected
    assert result.cells is None and "every bulge curve rejected (no_bulge)" in result.left_out["c1"]
    fm = reduce_bulge_map(tmp_path / "plain.h5")
    assert fm.dome is None and fm.section is not None
