"""Tests of the sweep orchestration (turgorbayes.surrogate.build) and the ``surrogate`` CLI.

The FE model is replaced by a cheap, picklable point function with a closed-form answer: this
tests the orchestration (grid, files, resume, failures, executors), not the physics.
"""

import dataclasses
import hashlib
import json
import subprocess
import uuid
from pathlib import Path

import numpy as np
import pytest
import xarray as xr
from numpy.testing import assert_allclose

from turgorbayes.cli import main
from turgorbayes.cli.surrogate import check_lines
from turgorbayes.errors import TurgorBayesError
from turgorbayes.surrogate import load, provenance
from turgorbayes.surrogate.build import (
    BuildFailedError,
    GridSpecError,
    build_surrogate,
    check_surrogate,
    parse_grid,
)

GRID = "x=0.01:0.5:5log,ratio=0.3,0.5,0.7,1.0"
FAIL_POINT = (np.geomspace(0.01, 0.5, 5)[2], 0.5)


# --------------------------------------------------------------------------- the fake model


@dataclasses.dataclass(frozen=True)
class FakeConfig:
    """Settings of the fake model; control_dir holds call markers and failure switches."""

    control_dir: str = ""
    E_perp_t: float = 0.12
    R0_m: float = 500e-9


@dataclasses.dataclass
class FakeResult:
    x: float
    pressure_Pa: float
    ratio: float
    R_c_m: float
    k_over_PR: float
    k_linear_over_PR: float
    h_m: np.ndarray
    F_N: np.ndarray
    newton_iterations: int
    wall_time_s: float
    converged: bool
    mesh_dofs: int
    max_penetration_m: float = 1e-10  # optional field: stored when every point has it


def analytic_k(x, ratio):
    """Closed-form stand-in for k/(PR) (smooth, decreasing in x)."""
    return (0.6 + 0.5 * np.sqrt(ratio)) / np.sqrt(x + 0.02)


def fake_pressure(x, ratio, cfg):
    """Pressure for x if the radius stayed R0."""
    return x * cfg.E_perp_t / cfg.R0_m


def fake_point(P, ratio, cfg):
    """Linear inflation R = R0 (1 + P R0/(E t)), so the 'FE' x is x_target (1 + x_target)."""
    control = Path(cfg.control_dir)
    (control / "calls").mkdir(exist_ok=True)
    (control / "calls" / uuid.uuid4().hex).touch()
    x0 = P * cfg.R0_m / cfg.E_perp_t
    if (control / f"fail_{x0:.6f}_{ratio:.3f}").exists():
        raise TurgorBayesError("Newton diverged at step 7")
    R = cfg.R0_m * (1 + x0)
    x = P * R / cfg.E_perp_t
    n = 3 + int(20 * x0)  # curves of different length, to exercise the NaN padding
    h = np.linspace(0, R / 20, n)
    k = analytic_k(x, ratio)
    return FakeResult(x, P, ratio, R, k, 0.9 * k, h, k * P * R * h, 5 * n, 0.01, True, 1234)


def n_calls(control):
    return len(list((Path(control) / "calls").iterdir())) if (control / "calls").exists() else 0


def fail(control, x, ratio):
    marker = control / f"fail_{x:.6f}_{ratio:.3f}"
    marker.touch()
    return marker


def run_build(tmp_path, cfg, **kw):
    return build_surrogate(tmp_path / "table.nc", GRID, cfg, point_fn=fake_point,
                           pressure_fn=fake_pressure, progress=False, **kw)


@pytest.fixture
def cfg(tmp_path):
    control = tmp_path / "control"
    control.mkdir()
    return FakeConfig(control_dir=str(control))


# --------------------------------------------------------------------------- grid spec


def test_parse_grid_matches_numpy_spacing():
    g = parse_grid("x=0.01:0.5:12log,ratio=0.3,0.4,0.5,0.7,1.0")
    assert_allclose(g.x, np.geomspace(0.01, 0.5, 12), rtol=1e-11)  # reference: numpy
    assert g.ratio == (0.3, 0.4, 0.5, 0.7, 1.0)
    assert len(g.points()) == 60
    mixed = parse_grid("ratio=1.0,0.3:0.9:4lin;x=0.5,0.02:0.04:3,0.015")
    assert_allclose(mixed.ratio, [0.3, 0.5, 0.7, 0.9, 1.0], rtol=1e-12)
    assert_allclose(mixed.x, [0.015, 0.02, 0.03, 0.04, 0.5], rtol=1e-12)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("x=0.01:0.5:12log", "missing axis \\['ratio'\\]"),
        ("x=0.01:0.5:12log,y=1,2", "bad axis 'y=1,2'"),
        ("x=0.01:0.5,ratio=0.3,0.4,0.5,0.7", "bad range '0.01:0.5'"),
        ("x=0.5:0.01:12log,ratio=0.3,0.4,0.5,0.7", "needs 0 < START < STOP"),
        ("x=0.01:0.5:12log,ratio=0.3,0.4,0.5", "ratio needs >= 4 distinct values for a cubic table, got 3"),
        ("x=0.01:0.5:12log,ratio=-0.3,0.4,0.5,0.7", "must be finite and > 0"),
        ("x=a,b,c,d,ratio=0.3,0.4,0.5,0.7", "'a' is not a number"),
        ("", "non-empty string"),
    ],
)
def test_parse_grid_errors(spec, message):
    with pytest.raises(GridSpecError, match=message):
        parse_grid(spec)


# --------------------------------------------------------------------------- builds


def test_serial_build_holds_exactly_the_grid(tmp_path, cfg):
    report = run_build(tmp_path, cfg)
    ds = xr.open_dataset(report.path, engine="h5netcdf").load()
    grid = np.geomspace(0.01, 0.5, 5)
    assert_allclose(ds["x"], grid, rtol=1e-11)  # reference: numpy
    assert_allclose(ds["ratio"], [0.3, 0.5, 0.7, 1.0], rtol=0)
    # Reference: the fake's closed form, x_actual = x (1 + x), k = analytic_k(x_actual, ratio).
    x_act = grid * (1 + grid)
    assert_allclose(ds["x_actual"].transpose("ratio", "x"), np.tile(x_act, (4, 1)), rtol=1e-12)
    assert_allclose(ds["k_over_PR"], analytic_k(x_act, ds["ratio"].values[:, None]), rtol=1e-12)
    # curves: n = 3 + int(20 x) steps, NaN-padded to the longest
    n_steps = 3 + (20 * grid).astype(int)
    assert ds.sizes["step"] == n_steps.max()
    assert np.all(np.isfinite(ds["F_N"].values[0, 1, : n_steps[1]]))
    assert np.all(np.isnan(ds["F_N"].values[0, 1, n_steps[1]:]))
    assert report.n_run == 20 and report.n_skipped == 0 and n_calls(tmp_path / "control") == 20
    assert json.loads(ds.attrs["fe_config"]) == dataclasses.asdict(cfg)
    assert_allclose(ds["max_penetration_m"], 1e-10, rtol=0)


def test_provenance_records_git_commit_and_sessions(tmp_path, cfg):
    report = run_build(tmp_path, cfg, command_line="turgorbayes surrogate build --out x.nc")
    meta = load(report.path).metadata
    # Reference: git itself.
    head = subprocess.run(["git", "-C", str(Path(__file__).parent), "rev-parse", "HEAD"],
                          capture_output=True, text=True, check=True).stdout.strip()
    assert meta["git_commit"] == head
    assert meta["command_line"] == "turgorbayes surrogate build --out x.nc"
    assert meta["point_function"] == f"{__name__}.fake_point"
    assert meta["build_sessions"][0]["points_to_run"] == 20


def test_failure_is_reported_then_resume_redoes_only_it(tmp_path, cfg):
    control = tmp_path / "control"
    marker = fail(control, *FAIL_POINT)
    with pytest.raises(BuildFailedError, match="(?s)1 FE point.*x=0.0707107 ratio=0.5: "
                       "TurgorBayesError: Newton diverged at step 7") as info:
        run_build(tmp_path, cfg)
    assert len(info.value.failed) == 1
    assert not (tmp_path / "table.nc").exists()  # no table with holes
    record = json.loads(next((tmp_path / "table.nc.points").glob("ratio0.5_x0.07*.json"))
                        .read_text())
    assert record["status"] == "failed" and "Newton diverged" in record["error"]
    assert n_calls(control) == 20
    marker.unlink()
    report = run_build(tmp_path, cfg, resume=True)
    assert n_calls(control) == 21  # the 19 finished points were not redone
    assert (report.n_run, report.n_skipped) == (1, 19)
    ds = xr.open_dataset(report.path, engine="h5netcdf").load()
    x = FAIL_POINT[0] * (1 + FAIL_POINT[0])
    assert_allclose(ds["k_over_PR"].sel(ratio=0.5).values[2], analytic_k(x, 0.5), rtol=1e-12)
    sessions = load(report.path).metadata["build_sessions"]
    assert [s["points_failed"] for s in sessions] == [1, 0]


def test_fe_source_version_is_recorded_and_mixing_warned(tmp_path, cfg, monkeypatch):
    control = tmp_path / "control"
    marker = fail(control, *FAIL_POINT)
    with pytest.raises(BuildFailedError):
        run_build(tmp_path, cfg)
    record = json.loads(next((tmp_path / "table.nc.points").glob("ratio0.3_x0.01.json"))
                        .read_text())
    # Reference: hashlib over this test module (the fake's module is not in a package).
    this = Path(__file__)
    expected = hashlib.sha256(this.name.encode() + b"\0" + this.read_bytes()).hexdigest()
    assert record["fe_source_sha256"] == expected
    marker.unlink()
    # run_point looks the hash up on turgorbayes.surrogate.provenance at call time
    monkeypatch.setattr(provenance, "source_sha256", lambda module: "edited-fe-code")
    with pytest.warns(RuntimeWarning, match="2 different versions of the FE source code"):
        report = run_build(tmp_path, cfg, resume=True)
    meta = load(report.path).metadata
    assert meta["fe_source_consistent"] == "no"
    assert meta["fe_source_sha256"] == {expected: 19, "edited-fe-code": 1}


def test_existing_points_need_resume_and_same_settings(tmp_path, cfg):
    run_build(tmp_path, cfg)
    with pytest.raises(TurgorBayesError, match="already holds 20 point records; pass --resume"):
        run_build(tmp_path, cfg)
    other = dataclasses.replace(cfg, E_perp_t=0.2)
    with pytest.raises(TurgorBayesError, match="computed with other FE settings"):
        run_build(tmp_path, other, resume=True)


def _content(path):
    ds = xr.open_dataset(path, engine="h5netcdf").load()
    return ds.drop_vars(["wall_time_s"])


def test_process_pool_and_dask_give_the_serial_file_content(tmp_path, cfg):
    distributed = pytest.importorskip("distributed")
    serial = run_build(tmp_path / "serial", cfg)
    pool = run_build(tmp_path / "pool", cfg, workers=2)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                                  dashboard_address=None) as cluster:
        dask = run_build(tmp_path / "dask", cfg, scheduler=cluster.scheduler_address)
    reference = _content(serial.path)
    for other in (pool, dask):
        xr.testing.assert_identical(_content(other.path).drop_attrs(), reference.drop_attrs())
    assert n_calls(tmp_path / "control") == 60
    assert load(pool.path).metadata["build_sessions"][0]["workers"] == 2


def test_check_uses_the_fe_x_and_reports_interpolation_error(tmp_path, cfg):
    s = load(run_build(tmp_path, cfg).path)
    records = check_surrogate(s, 4, seed=3, cfg=cfg, point_fn=fake_point,
                              pressure_fn=fake_pressure, progress=False)
    assert len(records) == 4
    for rec in records:
        # Reference: the closed form at the fake FE's own x = x_target (1 + x_target).
        x = rec["x_target"] * (1 + rec["x_target"])
        assert_allclose(rec["x"], x, rtol=1e-12)
        assert_allclose(rec["err"], s(x, rec["ratio"]) / analytic_k(x, rec["ratio"]) - 1,
                        rtol=1e-9, atol=1e-15)
        assert abs(rec["err"]) < 0.02  # 5 x 4 grid: cubic interpolation error of analytic_k
    again = check_surrogate(s, 4, seed=3, cfg=cfg, point_fn=fake_point,
                            pressure_fn=fake_pressure, progress=False)
    assert [r["x_target"] for r in again] == [r["x_target"] for r in records]  # same seed


def test_check_at_given_points_runs_exactly_those(tmp_path, cfg):
    s = load(run_build(tmp_path, cfg).path)
    points = [(0.12, 0.4), (0.3, 0.85)]
    records = check_surrogate(s, points=points, cfg=cfg, point_fn=fake_point,
                              pressure_fn=fake_pressure, progress=False)
    assert sorted((r["x_target"], r["ratio"]) for r in records) == sorted(points)
    for rec in records:  # reference: the closed form at the fake FE's x = x_target (1 + x_target)
        x = rec["x_target"] * (1 + rec["x_target"])
        assert_allclose(rec["err"], s(x, rec["ratio"]) / analytic_k(x, rec["ratio"]) - 1,
                        rtol=1e-9, atol=1e-15)
    with pytest.raises(TurgorBayesError, match=r"point 2 \(x=5, ratio=0.5\) is outside"):
        check_surrogate(s, points=[(0.12, 0.4), (5.0, 0.5)], cfg=cfg, point_fn=fake_point,
                        pressure_fn=fake_pressure, progress=False)


def test_check_keeps_random_points_out_of_the_buckled_region(tmp_path, cfg):
    # Reference: a box placed by hand over the upper half of the table's x range; the table
    # has no value there (docs/fem.md, "The buckled corner"), so it cannot be checked there.
    s = load(run_build(tmp_path, cfg).path)
    (xlo, xhi), (rlo, rhi) = s.domain["x"], s.domain["ratio"]
    s.buckled_boxes = [{"x": (np.sqrt(xlo * xhi), xhi), "ratio": (rlo, rhi)}]
    records = check_surrogate(s, 6, seed=3, cfg=cfg, point_fn=fake_point,
                              pressure_fn=fake_pressure, progress=False)
    assert len(records) == 6 and all(r["x_target"] < np.sqrt(xlo * xhi) for r in records)
    assert not any(r["in_buckled_region"] for r in records)
    x_t = (np.sqrt(1 + 3.2 * xhi) - 1) / 2  # the fake FE's x = x_t (1 + x_t) = 0.8 xhi
    inside = check_surrogate(s, points=[(x_t, 0.5)], cfg=cfg, point_fn=fake_point,
                             pressure_fn=fake_pressure, progress=False)
    assert inside[0]["in_buckled_region"] and np.isnan(inside[0]["err"])
    # the printed summary takes its largest error over the points the table has a value for
    # (the record in the region has a NaN error and is listed as such)
    lines = check_lines(records + inside)
    assert sum("in the buckled region" in line for line in lines) == 1
    worst = max(abs(r["err"]) for r in records)
    assert lines[-1] == f"max |error| of k/PR at h = R/20: {worst:.3%} over 6 points"


# --------------------------------------------------------------------------- CLI


def run_cli(args, capsys):
    with pytest.raises(SystemExit) as info:
        main(args)
    out = capsys.readouterr()
    return info.value.code, out.out, out.err


def test_cli_info_prints_provenance(tmp_path, cfg, capsys):
    path = run_build(tmp_path, cfg).path
    code, out, _ = run_cli(["surrogate", "info", str(path)], capsys)
    assert code == 0
    assert hashlib.sha256(path.read_bytes()).hexdigest() in out
    assert GRID in out and "ratio     4 values 0.3, 0.5, 0.7, 1" in out
    assert len(out.splitlines()) < 40  # one screen


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["surrogate", "build", "--out", "{tmp}/a.nc", "--grid", "x=0.1:1:5"], "missing axis"),
        (["surrogate", "info", "{tmp}/missing.nc"], "surrogate file not found"),
        (["surrogate", "info", "{tmp}/text.nc"], "not a readable netCDF"),
        (["surrogate", "check", "{tmp}/plain.nc"], "not a turgorbayes surrogate file"),
        (["surrogate", "check", "{tmp}/plain.nc", "--at", "0.1"], "expected X,RATIO"),
        (["surrogate", "check", "{tmp}/plain.nc", "--at", "0.1,a"], "got '0.1,a'"),
    ],
)
def test_cli_errors_exit_2(tmp_path, capsys, args, message):
    (tmp_path / "text.nc").write_text("not netcdf")
    xr.Dataset({"a": ("n", [1.0])}).to_netcdf(tmp_path / "plain.nc", engine="h5netcdf")
    code, _, err = run_cli([a.format(tmp=tmp_path) for a in args], capsys)
    assert code == 2
    assert message in err
