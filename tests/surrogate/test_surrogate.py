"""Tests of the surrogate interpolator (turgorbayes.surrogate) and the Fig. 4 plot.

Synthetic tables are built here directly as xarray Datasets from closed-form functions, so the
reference values never come from the code under test. The shipped-table tests skip until the
production table exists.
"""

import hashlib
import json
import warnings
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose, assert_array_equal

from turgorbayes.plots.surrogate import plot_reduced_stiffness
from turgorbayes.surrogate import (
    FILE_FORMAT,
    Surrogate,
    SurrogateError,
    default_path,
    force_drops,
    leave_one_out,
    load,
)


def smooth_k(x, ratio):
    """A smooth stand-in for k/(PR): power law in x that bends near x ~ 0.02, rising in ratio.

    Its logarithm is not a polynomial in (log x, log ratio), so cubic interpolation is inexact.
    """
    return (0.6 + 0.5 * np.sqrt(ratio)) / np.sqrt(x + 0.02)


def smooth_k_linear(x, ratio):
    return 0.8 * smooth_k(x, ratio) * (1 + 0.1 * ratio)


def dlog_smooth_k(x, ratio):
    """Closed-form d log(smooth_k) / d log x."""
    return -0.5 * x / (x + 0.02)


def cubic_log_k(x, ratio):
    """exp of a tensor-product cubic in (log x, log ratio): reproduced exactly by the scheme."""
    lx, lr = np.log(x), np.log(ratio)
    return np.exp(0.1 - 0.4 * lx + 0.02 * lx**2 + 0.003 * lx**3 + 0.3 * lr - 0.05 * lr**3
                  + 0.01 * lx * lr)


def synthetic_table(n_x=13, n_ratio=5, fun=smooth_k, fun_linear=smooth_k_linear):
    """A table on log-spaced x in [0.01, 0.5] and ratio in [0.3, 1]; the FE's x is x (1 + x).

    The shift mimics an FE inflation number differing from the target (R = R0 (1 + x)).
    """
    x = np.geomspace(0.01, 0.5, n_x)
    ratio = np.geomspace(0.3, 1.0, n_ratio)
    x_act = np.broadcast_to(x * (1 + x), (n_ratio, n_x)).copy()
    r2 = ratio[:, None]
    return xr.Dataset(
        {
            "k_over_PR": (("ratio", "x"), fun(x_act, r2)),
            "k_linear_over_PR": (("ratio", "x"), fun_linear(x_act, r2)),
            "x_actual": (("ratio", "x"), x_act),
        },
        coords={"ratio": ratio, "x": x},
        attrs={"file_format": FILE_FORMAT, "format_version": 1, "fe_config": '{"t_m": 6e-09}'},
    )


@pytest.fixture
def table():
    return synthetic_table()


def interior_points(rng, n=2000):
    """Random points inside the synthetic tables' common domain (x_actual range)."""
    x = np.exp(rng.uniform(np.log(0.01 * 1.01), np.log(0.5 * 1.5), n))
    r = np.exp(rng.uniform(np.log(0.3), np.log(1.0), n))
    return x, r


# --------------------------------------------------------------------------- accuracy


def test_interpolates_fe_points_at_their_actual_x(table):
    # Reference: the tabulated values themselves; an interpolating spline passes through its
    # nodes. Using the target x instead of x_actual would miss them by up to ~25%.
    s = Surrogate.from_dataset(table)
    x_act, k = table["x_actual"].values, table["k_over_PR"].values
    ratio = table["ratio"].values[:, None]
    assert_allclose(s(x_act, ratio), k, rtol=1e-7)
    assert_allclose(s.linear(x_act, ratio), table["k_linear_over_PR"].values, rtol=1e-7)


def test_cubic_accuracy_converges_at_fourth_order(rng):
    # Reference: the closed form smooth_k. A cubic spline's error falls as h^4 (the same
    # log-log slope check scikit-fem uses for its elements).
    x, r = interior_points(rng)
    sizes = [(6, 4), (11, 7), (21, 13), (41, 25)]
    errors, steps = [], []
    for n_x, n_r in sizes:
        s = Surrogate.from_dataset(synthetic_table(n_x, n_r))
        errors.append(np.max(np.abs(s(x, r) / smooth_k(x, r) - 1)))
        steps.append(np.log(50) / (n_x - 1))
    slope = np.polyfit(np.log(steps), np.log(errors), 1)[0]
    assert slope == pytest.approx(4.0, abs=0.5), (slope, errors)
    # On a production-size grid (13 x 5) this function is interpolated to < 0.1 %.
    assert errors[1] < 1e-3


def test_reproduces_tensor_cubic_in_log_coordinates_exactly(rng):
    # Reference: not-a-knot cubic splines reproduce cubic polynomials exactly, so a table of
    # exp(cubic in log x, log ratio) is interpolated to the resampling precision (~1e-9).
    s = Surrogate.from_dataset(synthetic_table(fun=cubic_log_k, fun_linear=cubic_log_k))
    x, r = interior_points(rng)
    assert_allclose(s(x, r), cubic_log_k(x, r), rtol=1e-7)


def test_log_slope_matches_closed_form(rng):
    # Reference: analytic derivative of log(smooth_k) with respect to log x.
    s = Surrogate.from_dataset(synthetic_table(41, 13))
    x, r = interior_points(rng)
    assert_allclose(s.dlog_dlogx(x, r), dlog_smooth_k(x, r), atol=2e-4)


def test_leave_one_out_is_exact_for_cubics_and_not_otherwise():
    # Reference: exactness on polynomials of the spline degree. Removing one point (or one
    # ratio) still leaves >= 4 points, which determine a cubic: LOO error ~ 0. For smooth_k
    # (not a cubic) the LOO error must be visibly larger, or LOO would test nothing.
    cubic = leave_one_out(synthetic_table(fun=cubic_log_k, fun_linear=cubic_log_k))
    other = leave_one_out(synthetic_table())
    for key in ("x", "ratio"):
        assert np.nanmax(np.abs(cubic[key])) < 1e-7
        assert np.nanmax(np.abs(other[key])) > 1e-5
    # edge points need extrapolation: they are reported as NaN, interior ones are all finite
    assert np.all(np.isnan(other["x"][:, [0, -1]]))
    assert np.all(np.isfinite(other["x"][:, 1:-1]))
    assert np.all(np.isnan(other["ratio"][[0, -1]]))


# --------------------------------------------------------------------------- behaviour


def test_outside_table_gives_nan_and_one_warning(table):
    s = Surrogate.from_dataset(table)
    x = np.array([0.005, 0.05, 2.0, 0.05, 0.05])
    r = np.array([0.5, 0.5, 0.5, 0.2, 1.5])
    with pytest.warns(RuntimeWarning, match="4 of 5 points lie outside") as record:
        out = s(x, r)
    assert len(record) == 1
    assert np.isnan(out[[0, 2, 3, 4]]).all()
    # reference value inside: closed form (interpolation error < 1e-3 on this grid)
    assert_allclose(out[1], smooth_k(0.05, 0.5), rtol=1e-3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert np.isnan(s(x, r, warn=False)[[0, 2, 3, 4]]).all()
        assert np.isnan(s.linear(np.nan, 0.5))  # NaN in, NaN out, no warning


def test_vectorized_broadcasting(table, rng):
    s = Surrogate.from_dataset(table)
    x = np.exp(rng.uniform(np.log(0.02), np.log(0.4), (3, 1)))
    r = np.array([0.3, 0.45, 0.7, 1.0])
    out = s(x, r)
    assert out.shape == (3, 4)
    # Reference: the same points evaluated one at a time (must not depend on the layout).
    loop = np.array([[s(float(xi), float(rj)) for rj in r] for xi in x[:, 0]])
    assert_allclose(out, loop, rtol=1e-14)
    assert isinstance(s(0.05, 0.5), float)
    assert_allclose(out, smooth_k(x, r), rtol=1e-3)  # closed form


def test_domain_is_intersection_of_actual_x_ranges(table):
    # Reference: the table's construction, x_actual = x (1 + x) at x = 0.01 and 0.5.
    s = Surrogate.from_dataset(table)
    assert_allclose(s.domain["x"], (0.01 * 1.01, 0.5 * 1.5), rtol=1e-12)
    assert_allclose(s.domain["ratio"], (0.3, 1.0), rtol=1e-12)


# --------------------------------------------------------------------------- files


def test_load_records_path_sha_and_metadata(table, tmp_path):
    path = tmp_path / "t.nc"
    table.to_netcdf(path, engine="h5netcdf")
    s = load(path)
    assert s.path == path
    assert s.sha256 == hashlib.sha256(path.read_bytes()).hexdigest()
    assert s.metadata["fe_config"] == {"t_m": 6e-09}  # JSON attribute decoded
    assert_allclose(s.grid["x"], np.geomspace(0.01, 0.5, 13), rtol=1e-12)


def test_load_errors(table, tmp_path):
    with pytest.raises(SurrogateError, match="surrogate file not found: .*nope.nc"):
        load(tmp_path / "nope.nc")
    text = tmp_path / "text.nc"
    text.write_text("hello")
    with pytest.raises(SurrogateError, match="is not a readable netCDF file"):
        load(text)
    plain = tmp_path / "plain.nc"
    table.assign_attrs(file_format="something else").to_netcdf(plain, engine="h5netcdf")
    with pytest.raises(SurrogateError, match="not a turgorbayes surrogate file.*something else"):
        load(plain)


def test_rejects_non_increasing_actual_x(table):
    bad = table.copy(deep=True)
    bad["x_actual"][2, 5] = bad["x_actual"][2, 4]
    with pytest.raises(SurrogateError, match="x_actual must increase along x.*ratio = \\[0.5"):
        Surrogate.from_dataset(bad)


def test_plot_shows_fe_points_and_curves(table, tmp_path):
    s = Surrogate.from_dataset(table)
    png = tmp_path / "fig4.png"
    ax = plot_reduced_stiffness(s, path=png)
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # markers are exactly the table's FE points (reference: the dataset)
    markers = [ln for ln in ax.lines if ln.get_marker() == "o"]
    assert len(markers) == 5
    for j, ln in enumerate(markers):
        assert_allclose(ln.get_xdata(), table["x_actual"].values[j], rtol=0)
        assert_allclose(ln.get_ydata(), table["k_over_PR"].values[j], rtol=0)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == [f"{r:g}" for r in table["ratio"].values]
    assert ax.get_xscale() == "log"
    assert ax.get_xlabel() == r"$P R_c/(E_\perp t)$"
    assert ax.get_ylabel() == r"$k_c/(P R_c)$"


def test_force_drops_finds_exactly_the_snapping_curves():
    # Reference: hand-made curves. Hertz-like F ~ h^1.5 rises everywhere except one curve
    # lowered by 20 % of its maximum from its 7th of 10 steps on, and one curve padded with NaN
    # (a shorter run).
    ds = synthetic_table(n_x=4, n_ratio=3)
    h = np.broadcast_to(np.linspace(0.0, 25e-9, 11), (3, 4, 11)).copy()
    F = 1e-9 * (h / 25e-9) ** 1.5
    F[1, 2, 7:] -= 0.2e-9
    h[2, 0, 9:] = F[2, 0, 9:] = np.nan
    ds["h_m"], ds["F_N"] = (("ratio", "x", "step"), h), (("ratio", "x", "step"), F)
    drops = force_drops(ds)
    assert len(drops) == 1
    d = drops[0]
    assert (d["ratio"], d["x"]) == (ds["ratio"].values[1], ds["x_actual"].values[1, 2])
    assert_allclose(d["depth"], 0.7)  # the force first falls at step 7 of 10
    # the fall at step 7 (0.2 minus the rise 0.7^1.5 - 0.6^1.5) over the new maximum 0.8
    assert_allclose(d["drop"], (0.2 - (0.7**1.5 - 0.6**1.5)) / 0.8, rtol=1e-12)


# --------------------------------------------------------------------------- shipped table

_SHIPPED = default_path()
shipped = pytest.mark.skipif(
    not _SHIPPED.is_file(),
    reason=f"the production table {_SHIPPED} has not been built yet "
    "(turgorbayes surrogate build --out turgorbayes/data/k_over_PR.nc)",
)


@shipped
def test_shipped_table_leave_one_out_below_half_percent_where_x_le_020():
    # Reference: the FE points themselves, each predicted from the others (target: < 0.5 %,
    # docs/fem.md). Leaving a node out doubles the spacing there, so this is a pessimistic
    # proxy of the interpolation error. It holds up to x = 0.20 except at the two lowest
    # ratios' x = 0.179 nodes (0.71 % at ratio 0.15, 0.68 % at 0.2; the spacing to x = 0.245
    # doubled, next to the steepest curvature in x): there a held-out FE point, x 0.179 at
    # ratio 0.151, is interpolated within 0.002 % (studies/results/surrogate_heldout.txt),
    # so those two are held to 0.75 % and every other node to 0.5 %.
    s = load()
    loo = leave_one_out(s.table)
    x = s.table.transpose("ratio", "x", ...)["x_actual"].values
    low = (s.table["ratio"].values <= 0.2)[:, None] & (np.abs(x / 0.179 - 1) < 0.01)
    inner = (x <= 0.20) & ~low
    assert low.sum() == 2
    assert np.nanmax(np.abs(loo["x"][inner])) < 5e-3, loo["x"]
    assert np.nanmax(np.abs(loo["x"][low])) < 7.5e-3, loo["x"]
    assert np.nanmax(np.abs(loo["ratio"][x <= 0.20])) < 5e-3, loo["ratio"]


@shipped
@pytest.mark.xfail(
    strict=True,
    reason="shipped tip-resolved, 24-step table (16 x 8 points): leave-one-out error up to 2.9 % "
    "at x >= 0.2 for E_par/E_perp <= 0.4 (a whole ratio left out: 0.53 % at x = 0.38). The "
    "force curves of the axially soft walls at x = 0.52 dip by about 8 % and recover before "
    "h = R/20 (ratio 0.25, 0.3), and ratio 0.4 reads k there inside such a dip (0.524 against "
    "0.575 and 0.565 for ratios 0.3 and 0.5): k(h = R/20) is not smooth in x there. The dips "
    "are snaps under the tip that come earlier on the table's mesh than on a finer one "
    "(surrogate.force_drops, surrogates/README.md). The target is < 0.5 % (docs/fem.md). Strict: passing "
    "means a better table was built, so remove this mark.",
)
def test_shipped_table_leave_one_out_below_half_percent_everywhere():
    loo = leave_one_out(load().table)
    assert np.nanmax(np.abs(loo["x"])) < 5e-3, loo["x"]
    assert np.nanmax(np.abs(loo["ratio"])) < 5e-3, loo["ratio"]


#: A copy of the held-out points' result file (tests/data/study_results/README.md says whence).
_HELDOUT = Path(__file__).parents[1] / "data" / "study_results" / "surrogate_heldout.json"


def _held_out_errors():
    """Interpolation error s(x, ratio)/k_FE - 1 of the shipped table at its 22 held-out FE points."""
    d = json.loads(_HELDOUT.read_text())
    s = load()
    # the FE points were run for this very table: regenerate them if the table is rebuilt
    assert d["table_sha256"] == s.sha256, ("held-out points belong to another table: run "
                                           "surrogate check again (tests/data/study_results)")
    pts = [p for p in d["points"] if p["status"] == "ok"]
    x, ratio, k = (np.array([p[key] for p in pts]) for key in ("x", "ratio", "k_over_PR"))
    return x, ratio, s(x, ratio, warn=False) / k - 1


@shipped
def test_held_out_points_are_interpolated_within_half_percent_outside_the_buckled_region():
    # Reference: 22 held-out FE runs (not grid nodes: 4 by hand, 6 random, 12 cell midpoints),
    # with the table's own FE settings (turgorbayes surrogate check --at X,RATIO / --n 6;
    # studies/results/surrogate_heldout.{txt,json}). Target (docs/fem.md): error < 0.5 %
    # outside the buckled region (measured max 0.33 %, at x 0.29, ratio 0.175; at the paper's
    # implied point 0.011 %). Inside the region the table returns NaN; the region comes from
    # the buckled grid points alone (surrogate.buckled_boxes), not from these runs: x > 0.34 at
    # ratio <= 0.5 and x > 0.46 at every ratio.
    x, ratio, err = _held_out_errors()
    inside = load().buckled(x, ratio)
    assert x.size == 22 and inside.sum() == 2
    assert np.all(np.isnan(err[inside])) and np.all(np.isfinite(err[~inside]))
    assert np.max(np.abs(err[~inside])) < 5e-3
    assert list(inside) == list(((x > 0.34) & (ratio <= 0.5)) | (x > 0.46))
    # the paper's implied point (x 0.0706, ratio 0.457) is one of them, within 0.05 %
    (at,) = np.flatnonzero((np.abs(x / 0.0706 - 1) < 0.01) & (np.abs(ratio - 0.457) < 1e-3))
    assert abs(err[at]) < 5e-4


def _table_with_a_buckled_point():
    """Hand-made curves, one falling at grid node (ratio index 1, x index 2)."""
    ds = synthetic_table(n_x=5, n_ratio=4)
    h = np.broadcast_to(np.linspace(0.0, 25e-9, 11), (4, 5, 11)).copy()
    F = 1e-9 * (h / 25e-9) ** 1.5
    F[1, 2, 7:] -= 0.2e-9
    ds["h_m"], ds["F_N"] = (("ratio", "x", "step"), h), (("ratio", "x", "step"), F)
    return ds


def test_buckled_boxes_surround_the_buckled_point():
    # Reference: the box is the four grid cells with that corner, in nominal grid coordinates.
    ds = _table_with_a_buckled_point()
    x, r = ds["x"].values, ds["ratio"].values
    s = Surrogate.from_dataset(ds)
    assert s.buckled_boxes == [{"x": (x[1], x[3]), "ratio": (r[0], r[2])}]
    xm, rm = np.sqrt(x[:-1] * x[1:]), 0.5 * (r[:-1] + r[1:])  # cell midpoints
    flagged = s.buckled(xm[None, :], rm[:, None])
    expected = np.zeros((3, 4), bool)
    expected[:2, 1:3] = True
    assert_array_equal(flagged, expected)
    # a table without snaps (or without force curves) flags nothing
    assert Surrogate.from_dataset(synthetic_table()).buckled_boxes == []
    # a point the FE marked buckled (its run stopped after the fall, so the stored curve
    # may be short) makes the same box without a falling curve
    ds2 = synthetic_table(n_x=5, n_ratio=4)
    ds2["buckled"] = (("ratio", "x"), np.zeros((4, 5), bool))
    ds2["buckled"][1, 2] = True
    assert Surrogate.from_dataset(ds2).buckled_boxes == s.buckled_boxes


def test_the_table_gives_no_stiffness_where_the_wall_buckles():
    # Reference: the box of the test above (x[1]-x[3], ratio[0]-ratio[2]); outside it the
    # value is the interpolation of the table without the buckled point's box.
    ds = _table_with_a_buckled_point()
    x, r = ds["x"].values, ds["ratio"].values
    s = Surrogate.from_dataset(ds)
    plain = Surrogate.from_dataset(ds.drop_vars(["h_m", "F_N"]))
    xs, rs = np.array([np.sqrt(x[1] * x[2]), np.sqrt(x[3] * x[4])]), np.array([r[1], r[1]])
    with pytest.warns(RuntimeWarning, match="1 of 2 points lie where the wall buckles under the tip"):
        k = s(xs, rs)
    assert np.isnan(k[0]) and k[1] == plain(xs[1], rs[1])
    assert np.isnan(s.dlog_dlogx(xs[0], rs[0], warn=False))
    # the linear stiffness is unique there and still given
    assert s.linear(xs[0], rs[0]) == plain.linear(xs[0], rs[0])


@shipped
def test_shipped_table_decreases_with_x():
    # Physics (docs/fem.md): k/(PR) falls monotonically as the
    # capsule inflates, in the FE points and in the interpolated curves (where the table has
    # a value: NaN in the buckled region).
    s = load()
    k = s.table.transpose("ratio", "x", ...)["k_over_PR"].values
    assert np.all(np.diff(k, axis=1) < 0)
    xx = np.geomspace(*s.domain["x"], 400)
    curves = s(xx[None, :], s.grid["ratio"][:, None], warn=False)
    steps = np.diff(curves, axis=1)
    assert np.all(steps[np.isfinite(steps)] < 0) and np.isfinite(steps).mean() > 0.9


@shipped
def test_shipped_table_softer_axial_wall_is_softer_where_x_le_020():
    # docs/fem.md, Verification (physics checks): a smaller E_par/E_perp gives a lower stiffness (compared at equal x
    # through the interpolator). The anisotropy's effect shrinks as tension takes over (from
    # 28 % between ratio 0.25 and 1 at x = 0.005 to 1.5 % at x = 0.2) and reverses beyond:
    # see the strict xfail below.
    s = load()
    xx = np.geomspace(s.domain["x"][0], 0.20, 200)
    curves = s(xx[None, :], s.grid["ratio"][:, None])
    assert np.all(np.diff(curves, axis=0) > 0)


@shipped
@pytest.mark.xfail(
    strict=True,
    reason="shipped tip-resolved, 24-step table: at x = 0.28 the FE k/PR decreases smoothly "
    "with E_par/E_perp from 0.25 to 1 (0.756 -> 0.735), and so it does on a mesh with half "
    "the element size (0.758 -> 0.735; docs/fem.md, Verification, cites its result file): "
    "the model's physics, not the mesh. At x = 0.52 it scatters by a few per cent (force "
    "dips, see the leave-one-out xfail); the monotonicity check holds only up to x = 0.20",
)
def test_shipped_table_softer_axial_wall_is_softer_everywhere():
    s = load()
    xx = np.geomspace(*s.domain["x"], 200)
    curves = s(xx[None, :], s.grid["ratio"][:, None])
    assert np.all(np.diff(curves, axis=0) > 0)


@shipped
def test_shipped_table_provenance():
    m = load().metadata
    assert m["file_format"] == FILE_FORMAT
    assert len(m["git_commit"]) == 40
    assert m["point_function"] == "turgorbayes.fem.indentation_point" or m[
        "point_function"
    ].startswith("turgorbayes.fem.")
    assert isinstance(m["fe_config"], dict) and m["fe_config"]


def test_info_lists_points_whose_run_stopped_before_the_reading_depth():
    # Reference: hand-made curves; one point's run ends at 60 % of h = R_c/20 (a lost path,
    # recorded as buckled), the others reach it.
    from turgorbayes.cli.surrogate import _stopped_points

    ds = synthetic_table(n_x=5, n_ratio=4)
    R_c = np.full((4, 5), 500e-9)
    h = np.broadcast_to(np.linspace(0.0, 25e-9, 11), (4, 5, 11)).copy()
    h[2, 3, 7:] = np.nan  # the run stopped after h = 15 nm
    ds["h_m"], ds["R_c_m"] = (("ratio", "x", "step"), h), (("ratio", "x"), R_c)
    stopped = _stopped_points(ds, 1 / 20)
    assert len(stopped) == 1
    x, ratio, reached = stopped[0]
    assert (x, ratio) == (ds["x_actual"].values[2, 3], ds["ratio"].values[2])
    assert reached == pytest.approx(15e-9 / 25e-9, rel=1e-12)
