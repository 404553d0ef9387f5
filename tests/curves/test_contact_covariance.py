"""One contact point, one covariance: the R_c-k_c error correlation of a force map's cell
(turgorbayes.curves.contact_covariance; docs/curves.md, "Correlated readings").

References: the arc fit refitted after moving one pixel's height (finite differences of the
least-squares solution), the closed-form change of a secant read at a fixed depth when the
contact moves (``dk/dz0 = F'(h)/h`` for a noise-free force law, derived in the test), and the
manifest's own radius (a cell whose R_c the manifest gives gets no correlation), and a
simulated truth (raw curves and force maps of a simulated data set, through ``curves`` and the
fit).
"""

import functools
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.cells.correlation import error_correlation
from turgorbayes.curves import read_manifest, reduce_manifest
from turgorbayes.curves.contact_covariance import radius_gain
from turgorbayes.curves.contact_point import Contact
from turgorbayes.curves.crosssection import cross_section
from turgorbayes.curves.stiffness import secant_at_depth
from turgorbayes.effects import ExtendedModel
from turgorbayes.inference import models
from turgorbayes.inference.engine import fit_posterior
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, cell_force, synthetic_curve
from turgorbayes.simulation.forcemap import RodCell, rod_height, write_force_map
from turgorbayes.simulation.raw_dataset import write_raw_dataset
from turgorbayes.workflows.criticize import CriticismSettings

SETTINGS = CriticismSettings(n_draws=1000, n_rep=700, max_refits=0, retry_factor=1,
                             n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                             max_steps=4000, flag_draws=50)


def test_radius_gain_is_the_refits_sensitivity():
    # a 16 x 16 height map of a rod on a flat substrate, with 0.5 nm of height noise
    cell = RodCell(R=450e-9, length=1.0e-6, angle=np.deg2rad(30.0))
    g = (np.arange(16) - 7.5) * 2.6e-6 / 16
    y, x = (a.ravel() for a in np.meshgrid(g, g, indexing="ij"))
    iy, ix = (a.ravel() for a in np.meshgrid(np.arange(16), np.arange(16), indexing="ij"))
    h = rod_height(x, y, cell) + 0.5e-9 * np.random.default_rng(3).standard_normal(x.size)
    section = cross_section(x, y, h, ix, iy, 2.6e-6 / 16)
    gain = radius_gain(section)
    assert np.all(gain[~section.arc] == 0)
    for j in np.flatnonzero(section.arc)[::3]:
        moved = h.copy()
        moved[j] += 1e-9
        fd = (cross_section(x, y, moved, ix, iy, 2.6e-6 / 16).R - section.R) / 1e-9
        assert_allclose(gain[j], fd, rtol=0.01, atol=1e-4)
    # a pixel on the crest weighs most: raising every crest pixel raises R
    assert gain[section.crest].min() > 0


def test_secant_slope_in_the_contact_is_the_closed_form():
    # noise-free curve F = k_c h (h/h_ref)^a; contact known: read at h_ref, the secant moves
    # by dk/dz0 = F'(h_ref)/h_ref = k_c (1 + a)/h_ref per unit of contact travel (a later
    # contact reads the same force as a shallower indentation)
    k_c, R_c, a = 0.02, 500e-9, 0.1
    h_ref = R_c / 20
    law = functools.partial(cell_force, k_c=k_c, h_ref=h_ref, a=a)
    acq = replace(DEFAULT_ACQUISITION, noise_sd=0.0, offset=0.0, tilt=0.0, drift=0.0)
    curve = synthetic_curve(law, 2 * h_ref, acq, seed=1, contact_jitter=0.0)
    z = curve.data["height (piezo)"][0] - curve.data["height (piezo)"]
    contact = Contact(z0=acq.free_length, z0_err=0.1e-9, offset=0.0, exponent=np.nan,
                      method="known")
    sec = secant_at_depth(z, curve.data["force"], acq.spring_constant, contact, h_ref)
    assert_allclose(sec.k, k_c, rtol=3e-3)  # a quadratic fitted to a power law over +-30 %
    assert_allclose(sec.dk_dz0, k_c * (1 + a) / h_ref, rtol=0.01)


def test_curves_writes_the_correlation_of_a_fitted_radius(tmp_path, write_cell_curve):
    # c1's R_c and k_c come from its force map: a correlation is written (small: the 1 %
    # height calibration dominates the radius error); c2's R_c is the manifest's: unknown
    write_force_map(tmp_path / "map.h5", RodCell(k_c=0.01), n=16, extent=3.0e-6, seed=2)
    write_cell_curve(tmp_path / "c2.tab", 0.015, 500e-9, seed=4)
    (tmp_path / "m.csv").write_text("file,cell_id,target,Rc_nm,Rc_err_nm,curve_index\n"
                                    "map.h5,c1,cell,,,map\nc2.tab,c2,cell,500,15,0\n")
    result = reduce_manifest(read_manifest(tmp_path / "m.csv"))
    rho = error_correlation(result.cells)
    assert np.isnan(rho[1]) and np.isfinite(rho[0]) and abs(rho[0]) < 0.2
    assert_allclose(float(result.cells.extra["rho_R_c_k_c"][0]), result.maps[2].rho_R_k, atol=5e-5)


@pytest.mark.slow
def test_raw_maps_recover_the_turgor_with_the_column(tmp_path, table):
    # simulated truth: 24 bulged cells (single curves, radii from the manifest) and 6 intact
    # cells each measured by a whole 12 x 12 force map (the radius fitted from its contact
    # points, k_c read on its crest); curves -> cells.csv with rho_R_c_k_c on the intact cells
    # -> the fit reads them as correlated and its 90 % interval of P_phys covers the truth
    cells, truths = synthetic.simulate_cells(24, 6, seed=7, surrogate=table)
    manifest = write_raw_dataset(tmp_path, cells, truths, curves_per_cell=2, seed=7,
                                 map_groups=("intact",), map_grid=(12, 2.8e-6))
    result = reduce_manifest(read_manifest(manifest))
    out = result.cells  # a few soft bulges' curves are too noisy (docs/curves.md): left out
    assert out.n_intact == 6 and out.n_bulged >= 18, result.left_out
    rho = error_correlation(out)
    assert np.all(np.isfinite(rho[~out.is_bulged])) and np.all(np.isnan(rho[out.is_bulged]))
    model = ExtendedModel(out, table)
    assert_allclose(model.obs.rho_R_k[~out.is_bulged], rho[~out.is_bulged])
    post = fit_posterior(model, model.start_values(models.PaperWLS(out, table).fit().estimate),
                         7, SETTINGS)
    P = post.summary(np.random.default_rng(7))["P_phys_kPa"]
    assert P["q05"] <= truths["parameters"]["P_phys_kPa"] <= P["q95"], P
