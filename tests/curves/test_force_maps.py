"""Whole force maps: R_c from the height map's cross-section, k_c from the crest curves
(turgorbayes/curves/forcemap.py, crosssection.py; docs/curves.md, Whole force maps).

The synthetic map (turgorbayes/simulation/forcemap.py) is written by afmformats as one ``.h5``
file with afmformats' grid metadata and read back through the manifest, like a JPK map. Truth:
a spherocylinder of R = 450 nm, cylindrical length 1.0 um, long axis at 30 deg, on a substrate
tilted by 0.02 (x) and -0.01 (y), on a 16 x 16 grid over 2.6 um (162.5 nm pitch). Every pixel's
contact is at the surface's height (closed form, ``rod_height``); the curves within 0.3 R of the
axis have k_c = 0.02 N/m at R/20, the cell's other pixels 0.01 N/m (so a crest rule that took
flank curves would miss by up to -50 %), the substrate is a 1 N/m linear law. Noise: the
thermal limit of the 0.011 N/m cantilever (6.7 pN), as in test_recovery.py.

Tolerances (derived, not fitted to the output):

- R_c: the arc's top is ``2 R`` above the substrate, so R is off by half the elevation error.
  Contact points on cell curves miss by < 2 nm (test_recovery.py's bound); the substrate's
  hard-contact kink is sampled every 0.5 nm. Elevation error < 2.5 nm -> R within 1.25 nm; plus
  5 fit sd (0.05 nm each): 1.5 nm.
- k_c: the 2 % of the single-cell recovery tests (test_recovery.py).
- axis angle: the fit's sd is 0.03 deg (contact noise 0.5 nm over a 1 um middle); 0.3 deg
  allows 10 sd for contact-point bias. The principal axis of the pixels alone is quantized by the
  pitch (up to ~ pitch/length = 5 deg).
"""

import csv
import math
import zipfile
from pathlib import Path

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.curves import read_manifest, reduce_manifest, write_curves_table
from turgorbayes.curves.crosssection import arc_height, axis_coordinates, fit_arc
from turgorbayes.curves.forcemap import reduce_map as reduce_map_file
from turgorbayes.errors import DataError
from turgorbayes.simulation.forcemap import RodCell, rod_height, write_force_map

DATA = Path(__file__).resolve().parents[1] / "data" / "afmformats"
JPK_MAP = DATA / "fmt-jpk-fd_map-data-reference-points.jpk-force-map"
CELL = RodCell(R=450e-9, length=1.0e-6, angle=np.deg2rad(30.0), k_c=0.02, flank_ratio=0.5)
N, EXTENT = 16, 2.6e-6
NO_CONTACT = 3  # grid pixel (ix 3, iy 0): bare substrate
SHALLOW = 7 + 16 * 7  # grid pixel (7, 7) at (-81, -81) nm: 30 nm from the axis, on the crest
HEADER = "file,cell_id,target,Rc_nm,Rc_err_nm,curve_index\n"


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """The written map, its truth and its reduction through the manifest."""
    folder = tmp_path_factory.mktemp("map")
    truth = write_force_map(folder / "map.h5", CELL, n=N, extent=EXTENT, tilt=(0.02, -0.01),
                            seed=11, no_contact=(NO_CONTACT,), shallow=(SHALLOW,))
    (folder / "m.csv").write_text(HEADER + "map.h5,c1,cell,,,map\n")
    result = reduce_manifest(read_manifest(folder / "m.csv"))
    write_curves_table(folder / "curves.csv", result)
    return folder, truth, result, result.maps[2]


def _true_axis_coordinates(x, y):
    """(along, across) the true axis [m]: the RodCell's geometry, rotated here by hand."""
    dx, dy = np.asarray(x) - CELL.center[0], np.asarray(y) - CELL.center[1]
    c, s = np.cos(CELL.angle), np.sin(CELL.angle)
    return dx * c + dy * s, -dx * s + dy * c


def test_arc_model_is_a_circle_on_the_substrate():
    R = 450e-9
    # top 2R at d = 0; R + R/2 at d = R sqrt(3)/2 (a circle of radius R centred R above); 0 off it
    assert_allclose(arc_height([0.0, R * np.sqrt(3) / 2, -R * np.sqrt(3) / 2], R),
                    [2 * R, 1.5 * R, 1.5 * R], rtol=1e-12)
    assert_allclose(arc_height([1.01 * R, -2 * R], R), [0.0, 0.0])


def test_arc_fit_is_exact_on_noise_free_pixels():
    """Pixels on the closed-form surface (rod_height) of a 500 nm cylinder at -40 deg: the fit
    returns the planted radius and angle from starting values 10 % and 4 deg off."""
    cell = RodCell(R=500e-9, length=4e-6, angle=np.deg2rad(-40.0))
    g = np.linspace(-0.6e-6, 0.6e-6, 13)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    _, d = axis_coordinates(x, y, cell.center, cell.angle)
    on = np.abs(d) < 0.8 * cell.R
    (R, angle, offset), cov, sd = fit_arc(x[on], y[on], rod_height(x[on], y[on], cell), (0.0, 0.0),
                                          np.deg2rad(-36.0), 550e-9)
    assert_allclose([R, np.rad2deg(angle)], [500e-9, -40.0], rtol=1e-7)
    assert abs(offset) < 1e-13 and sd < 1e-13


def test_tip_dilation_biases_the_radius_a_little_upward():
    """A 20 nm spherical tip (rod_height's closed form) leaves the top at 2 R and makes the
    curvature radius R + r: a fit held on the substrate lies between the two, R < R_fit < R + r;
    docs/curves.md quotes 0.075 r, so below r/10."""
    cell, r = RodCell(R=450e-9, length=4e-6, angle=0.3), 20e-9
    g = np.linspace(-0.8e-6, 0.8e-6, 41)
    x, y = (a.ravel() for a in np.meshgrid(g, g))
    _, d = axis_coordinates(x, y, cell.center, cell.angle)
    on = np.abs(d) < 0.8 * cell.R
    (R, _, _), _, sd = fit_arc(x[on], y[on], rod_height(x[on], y[on], cell, r), (0.0, 0.0), 0.3,
                               cell.R)
    assert 0 < R - cell.R < 0.1 * r, (R - cell.R) / r
    assert 0.1 * r < sd < 0.2 * r  # the misfit shows in the residuals (docs: 0.15 r)


def test_height_map_is_the_surface(synthetic):
    """Every contact height within 2 nm of the true surface (test_recovery.py's contact bound):
    the power law on the cell; the kink on the hard substrate is a sample of the 0.5 nm grid
    next to the true contact, within two samples (1 nm) with the noise."""
    _, truth, _, fm = synthetic
    miss = fm.pixels.height - truth.contact_height
    found = np.isfinite(truth.contact_height)
    assert np.all(np.abs(miss[found]) < 2e-9), np.nanmax(np.abs(miss)) * 1e9
    substrate = found & (truth.elevation == 0)
    assert np.all(np.abs(miss[substrate]) < 1e-9)


def test_radius_recovered_from_the_cross_section(synthetic):
    _, _, _, fm = synthetic
    assert fm.ok, fm.detail
    assert abs(fm.section.R - CELL.R) < 1.5e-9, (fm.section.R - CELL.R, fm.section.R_err)
    assert 0 < fm.section.R_err < 1e-9
    assert fm.R_c == fm.section.R  # the manifest left Rc_nm empty: the fit reads the crest


def test_axis_angle_and_position_recovered(synthetic):
    _, _, _, fm = synthetic
    s = fm.section
    assert abs(np.rad2deg(s.angle) - 30.0) < 0.3, np.rad2deg(s.angle)
    _, across = _true_axis_coordinates(*s.center)
    assert abs(across) < 5e-9  # the fitted axis passes through the true one (0.5 nm noise)


def test_crest_curves_are_on_the_crest_of_the_cylinder(synthetic):
    _, truth, _, fm = synthetic
    along, across = _true_axis_coordinates(truth.x, truth.y)
    crest = fm.crest_index
    assert crest.size >= 6
    # within 0.25 R of the true axis (+ the axis' fit error) and in the cylindrical part
    assert np.all(np.abs(across[crest]) <= 0.25 * CELL.R + 5e-9)
    assert np.all(np.abs(along[crest]) <= CELL.length / 2)
    assert np.all(truth.k[crest] == CELL.k_c)  # no flank curve (k_c/2) among them
    # every true crest pixel well inside the middle is taken (none missed by the rule)
    inner = (np.abs(across) <= 0.2 * CELL.R) & (np.abs(along) <= CELL.length / 2 - 0.2e-6)
    assert set(np.flatnonzero(inner)) <= set(crest.tolist())


def test_crest_stiffness_recovered_within_2_percent(synthetic):
    _, truth, result, fm = synthetic
    assert abs(fm.k / CELL.k_c - 1) < 0.02, (fm.k / CELL.k_c - 1, fm.k_err / fm.k)
    assert abs(fm.k - CELL.k_c) < 3 * fm.k_err  # the error is honest to a factor
    # every crest curve read at the fitted R_c/20
    assert_allclose([c.depth for c in fm.crest if c.ok], fm.section.R / 20, rtol=1e-12)
    # the cell-data row: fitted R_c and its error, the map's k_c
    cells = result.cells
    assert cells.cell_id == ("c1",)
    # R_c's error: the fit's (0.05 nm) and the 1 % height calibration in quadrature
    R_err = math.hypot(fm.section.R_err, 0.01 * fm.section.R)
    assert_allclose([cells.R_c[0], cells.R_c_err[0], cells.k_c[0], cells.k_c_err[0]],
                    [fm.section.R, R_err, fm.k, fm.k_err], rtol=1e-12)


def test_rejected_curves_keep_their_reason(synthetic):
    folder, truth, result, fm = synthetic
    (bad,) = truth.no_contact
    assert math.isnan(fm.pixels.height[bad]) and fm.pixels.status[bad] == "no_contact"
    assert np.isfinite(np.delete(fm.pixels.height, bad)).all()
    (shallow,) = truth.shallow
    crest = dict(zip(fm.crest_index.tolist(), fm.crest, strict=True))
    assert crest[shallow].status == "too_shallow"  # indented to R/40, read at R/20
    assert "(1 too_shallow)" in result.results[0].detail
    with open(folder / "force_maps" / "0002_map.csv") as fh:
        rows = {int(r["curve_index"]): r for r in csv.DictReader(fh)}
    assert len(rows) == N * N  # every curve listed, none dropped
    assert rows[bad]["status"] == "no_contact" and rows[bad]["contact_height_nm"] == ""
    assert rows[shallow]["crest"] == "1" and rows[shallow]["crest_status"] == "too_shallow"
    assert sum(r["crest"] == "1" for r in rows.values()) == fm.crest_index.size


def test_tables_report_the_map(synthetic):
    folder, truth, _, fm = synthetic
    with open(folder / "curves.csv") as fh:
        (row,) = csv.DictReader(fh)
    assert row["curve_index"] == "map" and row["status"] == "ok" and row["n_points"] == str(N * N)
    assert_allclose([float(row["k_N_per_m"]), float(row["depth_nm"])], [fm.k, fm.R_c / 20 * 1e9],
                    rtol=1e-5)
    with open(folder / "force_maps.csv") as fh:
        (summary,) = csv.DictReader(fh)
    assert None not in summary  # as many fields as columns
    assert_allclose([float(summary["Rc_fit_nm"]), float(summary["axis_angle_deg"])],
                    [fm.section.R * 1e9, np.rad2deg(fm.section.angle)], rtol=1e-5)
    assert summary["n_contact"] == str(N * N - 1)
    assert_allclose([float(summary["substrate_slope_x"]), float(summary["substrate_slope_y"])],
                    [0.02, -0.01], atol=1e-3)  # the planted tilt


def test_map_figure_draws_the_fit(synthetic, tmp_path):
    from turgorbayes.plots.forcemap import map_figure

    _, _, _, fm = synthetic
    fig = map_figure(fm, "map.h5", "c1", tmp_path / "map.png")
    assert (tmp_path / "map.png").stat().st_size > 10_000
    lines = {line.get_gid(): line for ax in fig.axes for line in ax.get_lines() if line.get_gid()}
    # the drawn arc peaks at 2 R; the crest squares sit on the accepted crest curves
    assert_allclose(lines["arc_fit"].get_ydata().max(), 2 * fm.section.R * 1e9, rtol=1e-4)
    ok = fm.crest_index[[c.ok for c in fm.crest]]
    assert_allclose(lines["crest_pixels"].get_xdata(), fm.pixels.x[ok] * 1e6)
    assert lines["crest_rejected"].get_xdata().size == 1


def test_manifest_radius_wins_and_the_fit_is_reported(synthetic):
    folder, _, _, fitted = synthetic
    (folder / "given.csv").write_text(HEADER + "map.h5,c1,cell,470,10,map\n")
    result = reduce_manifest(read_manifest(folder / "given.csv"))
    fm = result.maps[2]
    assert_allclose([fm.R_c, fm.R_c_err], [470e-9, 10e-9], rtol=1e-12)
    assert_allclose(fm.section.R, fitted.section.R, rtol=1e-12)  # still fitted and reported
    assert_allclose([c.depth for c in fm.crest if c.ok], 470e-9 / 20, rtol=1e-12)
    assert "R_c fit 450.0" in result.results[0].detail and "manifest's R_c 470 nm used" in \
        result.results[0].detail
    assert_allclose([result.cells.R_c[0], result.cells.R_c_err[0]], [470e-9, 10e-9], rtol=1e-12)


def test_vendored_jpk_map_is_too_small_for_a_cross_section(tmp_path):
    """The real JPK map holds 3 curves of its 25 x 25 grid (tests/data/afmformats/README.md)."""
    with zipfile.ZipFile(JPK_MAP) as archive:  # independent count: its index/N/ folders
        n = sum(name.endswith("header.properties") and name.startswith("index/")
                and name.count("/") == 2 for name in archive.namelist())
    assert n == 3
    m = tmp_path / "m.csv"
    m.write_text(HEADER + f"{JPK_MAP},j1,cell,,,map\n")
    result = reduce_manifest(read_manifest(m))
    res = result.results[0]
    assert res.status == "map_too_small"
    assert f"'{JPK_MAP.name}' has 3 curves, a cross-section of the cell needs >= 18" in res.detail
    assert result.cells is None and "j1" in result.left_out


def test_file_without_grid_positions_names_the_manifest_row(tmp_path, write_cell_curve):
    """An afmformats .h5 of 20 curves without grid metadata is not a map."""
    import afmformats
    import h5py

    curve = write_cell_curve(tmp_path / "one.tab", 0.02, 450e-9, 1)
    with h5py.File(tmp_path / "many.h5", "w") as h5:
        for i in range(20):
            afmformats.AFMForceDistance(curve.data, dict(curve.metadata, enum=i,
                                        path=str(tmp_path / "many.h5"))).export_data(h5, fmt="h5")
    m = tmp_path / "m.csv"
    m.write_text(HEADER + "many.h5,c1,cell,,,map\n")
    with pytest.raises(DataError, match=r"m\.csv, line 2, column file: 'many.h5' cannot be reduced "
                       r"as a whole force map .*no grid position"):
        reduce_manifest(read_manifest(m))


MAP_HEADER = "file,cell_id,target,Rc_nm,Rc_err_nm,Rb_nm,Rb_err_nm,curve_index\n"


@pytest.mark.parametrize(("rows", "where", "what"), [
    (["map.h5,c1,cell,,,,,map", "map.h5,c1,bulge,,,,10,map"], "line 3, column Rb_err_nm",
     "Rb_err_nm without Rb_nm"),
    (["map.h5,c1,cell,450,10,,,", "map.h5,c1,bulge,450,10,,,map", "map.h5,c1,bulge,450,10,,,map"],
     "line 3, column Rb_nm", "must not be empty: cell 'c1' has 2 bulge rows"),
    (["map.h5,c1,cell,450,10,,,", "map.h5,c1,bulge,450,10,,,0"], "line 3, column Rb_nm",
     "must not be empty"),
    (["map.h5,c1,cell,,10,,,map"], "line 2, column Rc_err_nm", "Rc_err_nm without Rc_nm"),
    (["map.h5,c1,cell,,,,,map", "map.h5,c1,cell,,,,,map"], "line 2, column Rc_nm",
     "must not be empty: cell 'c1' has 2 cell-body rows, 2 of them whole force maps"),
    (["map.h5,c1,cell,,,,,map", "map.h5,c1,bulge,450,10,300,10,0"], "line 3, column Rc_nm",
     "Rc_nm must be empty on all its rows, got 450"),
    (["map.h5,c1,cell,450,10,,,maps"], "line 2, column curve_index", "or 'map' (the whole force map)"),
    (["map.h5,c1,cell,,,,,"], "line 2, column Rc_nm", "must not be empty"),
    (["map.h5,c1,cell,450,10,,,", "map.h5,c1,bulge,,,300,10,"], "line 3, column Rc_nm",
     "must not be empty: cell 'c1' has 1 cell-body row, 0 of them whole force maps"),
])
def test_manifest_errors_name_line_and_column(tmp_path, rows, where, what):
    (tmp_path / "map.h5").write_bytes(b"")  # the manifest checks only that the file exists
    m = tmp_path / "m.csv"
    m.write_text(MAP_HEADER + "\n".join(rows) + "\n")
    with pytest.raises(DataError) as info:
        read_manifest(m)
    assert f"{m}, {where}: " in str(info.value) and what in str(info.value), str(info.value)


def test_command_line_writes_the_map_outputs(synthetic, capsys):
    from turgorbayes.cells.table import read_cells
    from turgorbayes.cli import main

    folder, _, _, _ = synthetic
    out = folder / "cli"
    with pytest.raises(SystemExit) as exit_info:
        main(["curves", str(folder / "m.csv"), "--out", str(out / "cells.csv"), "--no-progress"])
    text = capsys.readouterr().out
    assert exit_info.value.code == 0, text
    # the 1 % height calibration keeps R_c's error within what the cell-data checks accept
    assert "unusual" not in text
    cells = read_cells(out / "cells.csv")
    assert abs(cells.R_c[0] - CELL.R) < 1.5e-9 and abs(cells.k_c[0] / CELL.k_c - 1) < 0.02
    for name in ("force_maps.csv", "force_maps/0002_map.csv", "curve_figures/0002_map.png"):
        assert (out / name).is_file(), name
    assert 'curve_figures/0002_map.png' in (out / "curves.html").read_text()


def test_map_without_a_cell_is_rejected_not_fitted(tmp_path):
    """A bare tilted substrate (the RodCell far off the 10 x 10 grid): no pixel rises above the
    substrate's scatter, so there is no cross-section to fit; the figure shows the heights."""
    from turgorbayes.plots.forcemap import map_figure

    away = RodCell(center=(50e-6, 50e-6))
    truth = write_force_map(tmp_path / "flat.h5", away, n=10, extent=2e-6, seed=3)
    assert np.all(truth.elevation == 0)
    fm = reduce_map_file(tmp_path / "flat.h5")
    assert fm.status == "map_too_small" and "no cell" in fm.detail, fm.detail
    assert fm.section is None and np.isfinite(fm.pixels.height).all()
    fig = map_figure(fm, "flat.h5", "c0")
    assert "REJECTED: map_too_small" in fig.get_suptitle()
    assert fig.axes[0].get_images()[0].get_array().count() == 100  # every pixel drawn
