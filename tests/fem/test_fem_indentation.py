"""The capsule indentation driver on a coarse mesh: interface, errors, physics sanity.

Coarse mesh (mesh_scale = 4) for CI time; full-accuracy numbers are in studies/.
"""

import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from turgorbayes.errors import TurgorBayesError
from turgorbayes.fem import (
    CapsuleConfig,
    FEConfigError,
    FEConvergenceError,
    indentation_point,
    pressure_for_inflation_number,
)
from turgorbayes.fem.solver import available_solvers

COARSE = CapsuleConfig(mesh_scale=4.0)


#: Tests of the module-scoped ``points`` fixture (~85 s of FE runs) carry this
#: ``xdist_group``, so that under ``pytest -n 2 --dist loadgroup`` one process computes it
#: (spread over both, each process ran the same FE points).
POINTS_GROUP = pytest.mark.xdist_group("fem_points")


@pytest.fixture(scope="module")
def points():
    """k/(P R_c) of the coarse model at a few (x, ratio), computed once for all tests."""
    out = {}
    for x, ratio in ((0.02, 1.0), (0.1, 1.0), (0.4, 1.0), (0.1, 0.4)):
        out[x, ratio] = indentation_point(pressure_for_inflation_number(x, ratio, COARSE), ratio, COARSE)
    return out


@pytest.mark.slow
@POINTS_GROUP
def test_result_follows_its_definitions(points):
    r = points[0.1, 1.0]
    # x is the FE's own P R_c / (E t); the analytic inversion aims at it within the
    # caps' effect (< 0.5% at x = 0.1, see test_fem_inflation)
    assert_allclose(r.x, r.pressure_Pa * r.R_c_m / (COARSE.E_perp * COARSE.thickness), rtol=1e-12)
    assert_allclose(r.x, 0.1, rtol=0.005)
    # the stiffness is read at h = R_c / 20 and is F/(h P R_c) there
    assert_allclose(r.h_m[-1], COARSE.h_over_R * r.R_c_m, rtol=1e-12)
    assert_allclose(r.k_over_PR, r.F_N[-1] / (r.h_m[-1] * r.pressure_Pa * r.R_c_m), rtol=1e-12)
    assert r.h_m[0] == 0.0 and r.F_N[0] == 0.0
    assert np.all(np.diff(r.h_m) > 0) and np.all(np.diff(r.F_N) > 0)  # pushing harder, deeper
    # penalty contact: the penetration biases h by about that much; the coarse CI mesh has
    # the largest nodal contact pressure (production: 0.3%, see studies/fem_convergence.py)
    assert r.max_penetration_m < 1e-2 * r.h_m[-1]
    d = json.loads(json.dumps(r.to_dict()))
    assert d["config"]["mesh_scale"] == 4.0 and len(d["F_N"]) == len(r.F_N)
    assert len(d["w_m"]) == len(r.F_N) and np.all(np.diff(r.w_m) > 0)
    # the linear stiffness: F = k w + c w^2 through the steps at linear_depth/2 and linear_depth,
    # solved here by Cramer's rule on the recorded curve
    i, j = (int(np.flatnonzero(np.isclose(r.h_m, d, rtol=1e-9, atol=0.0))[0]) for d in (0.5e-9, 1e-9))
    (w1, w2), (F1, F2) = r.w_m[[i, j]], r.F_N[[i, j]]
    k_lin = (F1 * w2**2 - F2 * w1**2) / (w1 * w2**2 - w2 * w1**2)
    assert_allclose(r.k_linear_over_PR, k_lin / (r.pressure_Pa * r.R_c_m), rtol=1e-9)


@pytest.mark.slow  # the FE points of the fixture (~80 s) are the slow tier's
@POINTS_GROUP
def test_reduced_stiffness_falls_as_the_capsule_inflates(points):
    # Deng et al. 2011 Fig. 4: k/(P R) decreases monotonically with P R/(E t)
    k = [points[x, 1.0].k_over_PR for x in (0.02, 0.1, 0.4)]
    assert k[0] > k[1] > k[2]


@pytest.mark.slow
@POINTS_GROUP
def test_softer_axial_direction_gives_lower_stiffness(points):
    # Deng et al. 2011 Fig. 4: smaller E_par/E_perp, lower curve
    assert points[0.1, 0.4].k_over_PR < points[0.1, 1.0].k_over_PR
    assert points[0.1, 0.4].k_linear_over_PR < points[0.1, 1.0].k_linear_over_PR


@pytest.mark.slow
@POINTS_GROUP
def test_adaptive_depth_steps_reach_the_same_equilibrium_in_fewer_steps(points):
    # Reference: the fixed-schedule point of the fixture. The wall is hyperelastic and the
    # contact frictionless, so away from snaps the equilibrium at h_end does not depend on the
    # path; what may differ is the augmented-Lagrangian penetration left at h_end (tolerance
    # 1e-3 of h_end, so 2e-3 in k). Adaptive steps must also be fewer than a fixed schedule
    # starting with the same first step (24 steps + the 2 small ones).
    cfg = CapsuleConfig(mesh_scale=4.0, n_indent_steps=24, step_tolerance=0.1)
    fixed = points[0.1, 1.0]
    r = indentation_point(fixed.pressure_Pa, 1.0, cfg)
    assert_allclose(r.k_over_PR, fixed.k_over_PR, rtol=2e-3)
    assert_allclose(r.h_m[-1], fixed.h_m[-1], rtol=1e-12)
    assert len(r.h_m) - 1 < 26
    assert np.all(np.diff(r.h_m) > 0) and np.all(np.diff(r.F_N) > 0)


@pytest.mark.slow
@pytest.mark.skipif("pardiso_sym" not in available_solvers(), reason="pypardiso not installed")
@POINTS_GROUP
def test_symmetric_solver_reaches_the_lu_equilibrium_at_high_pressure(points):
    # Reference: the same point solved with exact (LU) Newton steps. The residual is exact
    # either way, so the equilibria agree to the Newton tolerance (1e-6); at x = 0.4 the
    # symmetric part alone stalls in the inflation, so this also checks the switch to LU.
    lu = points[0.4, 1.0]
    cfg = CapsuleConfig(mesh_scale=4.0, solver="pardiso_sym")
    r = indentation_point(lu.pressure_Pa, 1.0, cfg)
    assert_allclose(r.R_c_m, lu.R_c_m, rtol=1e-6)
    assert_allclose(r.k_over_PR, lu.k_over_PR, rtol=1e-4)


def test_next_adaptive_depth():
    # hand-computed: the adapted step, stretched over a last sliver (< dh/4), but never beyond
    # a cut after a failed step (else a failing last step would be retried forever)
    from turgorbayes.fem.depth_steps import next_adaptive_depth

    assert next_adaptive_depth(10.0, 0.0, 2.0, np.inf) == 2.0
    assert next_adaptive_depth(10.0, 7.6, 2.0, np.inf) == 10.0  # 0.4 left < 2/4
    assert next_adaptive_depth(10.0, 7.0, 2.0, np.inf) == 9.0  # 1.0 left >= 2/4
    assert next_adaptive_depth(10.0, 9.0, 2.0, 0.5) == 9.5  # the cut holds
    assert next_adaptive_depth(10.0, 9.7, 2.0, 0.5) == 10.0


def test_adaptive_step_factor():
    # hand-computed: factor 0.9 sqrt(tol/e), clipped to [0.5, 2]
    from turgorbayes.fem.depth_steps import adapted_step

    assert_allclose(adapted_step(1.0, 0.1, 0.1), 0.9)
    assert_allclose(adapted_step(1.0, 0.4, 0.1), 0.5)  # 0.9 sqrt(1/4) = 0.45, clipped
    assert_allclose(adapted_step(2.0, 0.1 * 0.81 / 4, 0.1), 4.0)  # 0.9 sqrt(4/0.81) = 2
    assert_allclose(adapted_step(1.0, 0.0, 0.1), 2.0)
    assert_allclose(adapted_step(1.0, 0.1 / 1.21, 0.1), 0.99)  # 0.9 * 1.1


@pytest.mark.slow
def test_force_scales_with_modulus_and_pressure_together():
    # linearity in (E, P) (supplement, "Scaling laws"): F(h; lam E, lam P) = lam F(h; E, P),
    # so k/(P R) and x do not change when E and P are both doubled
    # (an exact property of the discrete model too, so the coarsest mesh will do)
    base = CapsuleConfig(mesh_scale=8.0)
    doubled = CapsuleConfig(mesh_scale=8.0, E_perp=2 * base.E_perp, penalty=2 * base.penalty,
                            support_penalty=2 * base.support_penalty)
    P = pressure_for_inflation_number(0.05, 1.0, base)
    a = indentation_point(P, 1.0, base)
    b = indentation_point(2 * P, 1.0, doubled)
    assert_allclose(b.x, a.x, rtol=1e-6)
    assert_allclose(b.k_over_PR, a.k_over_PR, rtol=1e-4)


def test_newton_failure_raises_with_stage_and_step():
    cfg = CapsuleConfig(mesh_scale=4.0, newton_max_iter=2, newton_rtol=1e-14)
    with pytest.raises(FEConvergenceError, match=r"Newton failed in inflation step 0") as info:
        indentation_point(1e4, 1.0, cfg)
    assert isinstance(info.value, TurgorBayesError) and info.value.stage == "inflation"
    assert math.isfinite(info.value.residual)


def test_bad_arguments_are_rejected():
    with pytest.raises(FEConfigError, match="pressure P must be a finite number > 0 Pa, got -5"):
        indentation_point(-5, 1.0, COARSE)
    with pytest.raises(FEConfigError, match="cfg must be a CapsuleConfig, got dict"):
        indentation_point(1e4, 1.0, {})
    with pytest.raises(FEConfigError, match="beyond the inflation limit"):
        indentation_point(1e6, 1.0, COARSE)
    with pytest.raises(FEConfigError, match="step_tolerance must be a finite number >= 0, got -0.1"):
        CapsuleConfig(step_tolerance=-0.1)


def test_cut_depth_step_stays_cut_and_grows_back_by_half():
    # After a cut to dh_max the next depth is h_done + dh_max, not the scheduled target (which
    # would fail again), and never beyond the target: hand-computed cases.
    from turgorbayes.fem.depth_steps import next_depth

    assert next_depth([10.0, 20.0], 0.0, np.inf) == 10.0
    assert next_depth([10.0, 20.0], 2.0, 3.0) == 5.0
    assert next_depth([10.0, 20.0], 8.0, 3.0) == 10.0


def test_linear_stiffness_is_read_at_the_scheduled_depths_after_cut_steps():
    # A run whose first step was cut records extra steps at 1/8 and 1/4 of linear_depth before
    # the scheduled 1/2 and 1. Synthetic curve: F = k w + c w^2 exactly at the scheduled steps
    # and a different law at the cut ones, so the fit recovers k (hand value 0.02 N/m) only
    # if it reads the scheduled steps; the old rule (first two recorded steps) gives 0.01.
    from turgorbayes.fem.depth_steps import depth_schedule, linear_slope

    cfg = CapsuleConfig()
    depths = depth_schedule(cfg, 25e-9)[:2]
    assert depths == [0.5e-9, 1e-9]
    h = np.array([0.0, 0.125e-9, 0.25e-9, 0.5e-9, 1e-9, 2e-9])
    w = 0.8 * h
    k, c = 0.02, 3e6
    F = k * w + c * w**2
    F[1:3] = 0.01 * w[1:3]  # cut steps: another law
    assert_allclose(linear_slope(h, w, F, depths), k, rtol=1e-9)
    with pytest.raises(RuntimeError, match="not among the steps"):
        linear_slope(h[[0, 1, 2, 4, 5]], w[[0, 1, 2, 4, 5]], F[[0, 1, 2, 4, 5]], depths)


class _StallingProblem:
    """Stand-in for ShellProblem whose Newton solves always stall (to test the fallback)."""

    calls = 0

    def newton(self, *args, **kwargs):
        from turgorbayes.fem.solver import NewtonFailure

        self.calls += 1
        raise NewtonFailure(1e-4, "stalled")


class _Model:
    fixed = {"plane": None}
    problem = _StallingProblem()


def test_stalled_uzawa_update_keeps_last_converged_state():
    # A stalled augmentation must neither raise (that rejected a converged depth step and
    # cut it, over and over, at a ratio-0.25 point at x = 0.52) nor keep the trial offsets.
    from turgorbayes.fem.indentation import _augment

    u, offset = np.ones((4, 3)), np.zeros(3)
    info = {"iterations": 5, "contact": [{"gap": np.array([-1e-9, 0.0, 1e-9])}]}
    cfg = CapsuleConfig(penetration_tol=1e-3)
    u2, info2, off2 = _augment(_Model(), u, info, offset, lambda off: (), None, 1e3, cfg, h_end=25e-9)
    assert _Model.problem.calls == 1  # penetration 1 nm > 1e-3 x 25 nm, so one update was tried
    assert u2 is u and info2 is info
    assert_allclose(off2, 0.0)


def test_axial_stretch_mesh_refines_the_crest_by_the_inflated_axial_stretch():
    # Reference: membrane theory of the long cylinder, nu = 0: the axial stress is half the
    # hoop stress, so ln(lambda_z) = x / (2 ratio) with x = P R / (E_perp t) = ln(R / R0) the
    # hoop log strain (the law's inflation, docs/physics.md, Wall law); the crest's reference
    # element then must be h_min / lambda_z long axially and h_min circumferentially.
    from turgorbayes.fem import indentation

    cfg = CapsuleConfig(mesh_scale=4.0, axial_stretch_mesh=True)
    x, ratio = 0.445, 0.35
    P = pressure_for_inflation_number(x, ratio, cfg)
    lam = indentation.axial_stretch(P, ratio, cfg)
    hoop = math.log(indentation.inflated_radius(P, ratio, cfg) / cfg.R0)
    assert_allclose(math.log(lam), hoop / (2 * ratio), rtol=2e-2)  # R_in vs R: t/R ~ 1 %
    assert_allclose(lam, math.exp(x / (2 * ratio)), rtol=2e-2)
    mesh = indentation.capsule_model(cfg, P, ratio).mesh
    X = mesh.X
    crest = (np.abs(X[:, 1]) < 1e-12) & (X[:, 2] > 0) & (np.abs(X[:, 0]) < 60e-9)
    axial = np.unique(np.round(X[crest, 0], 13))  # node x positions along the crest line
    default = indentation.capsule_model(CapsuleConfig(mesh_scale=4.0), P, ratio).mesh.X
    d_axial = np.unique(np.round(default[(np.abs(default[:, 1]) < 1e-12) & (default[:, 2] > 0)
                                         & (np.abs(default[:, 0]) < 60e-9), 0], 13))
    # the first graded element is h_start (e^g - 1)/g long (sizes grow by g per unit length),
    # so the refined and the default crest element differ by the factor lambda_z, up to the
    # rounding of the element count along the ~17-element meridian (graded_breaks: <= 6 %)
    assert_allclose(d_axial[1] / axial[1], lam, rtol=0.06)
    assert not np.isclose(d_axial[1] / axial[1], 1.0, rtol=0.2)
    assert mesh.n_nodes > default.shape[0]
    with pytest.raises(FEConfigError, match="axial_stretch_mesh must be True or False"):
        CapsuleConfig(axial_stretch_mesh="yes")


# --- schedule choice, fallback and the buckled outcome (docs/fem.md, "Cost per point",
# "The buckled corner"); the FE indentation is replaced by scripted curves, so the tests check
# the driver's decisions, not the mechanics

_CHEAP = dict(mesh_scale=8.0, n_indent_steps=24, step_tolerance=0.1)


def _scripted_indent(monkeypatch, adaptive_fails=False, fixed_curve=None, fixed_fails_after=None):
    """Replace ``_indent``: record the calls; fail or return given curves."""
    from turgorbayes.fem import indentation

    calls = []

    def fake(model, u0, P, D, cfg, R_c, progress, adaptive):
        calls.append(adaptive)
        h_end = cfg.h_over_R * R_c
        if adaptive and adaptive_fails:
            err = FEConvergenceError("indentation", 7, 0.6 * h_end, 1e-3, "scripted")
            err.iterations = 11
            raise err
        h = np.concatenate([[0.0, 0.5e-9, 1e-9], np.linspace(0, h_end, 25)[1:]])
        F = 0.02 * h if fixed_curve is None else fixed_curve(h)
        w = 0.5 * h
        if fixed_fails_after is not None and not adaptive:
            n = fixed_fails_after
            err = FEConvergenceError("indentation", n, h[n], 1e-3, "scripted")
            err.curve, err.iterations = (h[:n], F[:n], w[:n]), 40
            raise err
        return h, F, w, 30, 1e-12

    monkeypatch.setattr(indentation, "_indent", fake)
    return calls


def test_adaptive_steps_only_below_the_threshold(monkeypatch):
    P = pressure_for_inflation_number(0.1, 1.0, CapsuleConfig(**_CHEAP))
    calls = _scripted_indent(monkeypatch)
    below = indentation_point(P, 1.0, CapsuleConfig(**_CHEAP, adaptive_below_x=0.4))
    above = indentation_point(P, 1.0, CapsuleConfig(**_CHEAP, adaptive_below_x=0.05))
    assert calls == [True, False]
    assert (below.schedule, above.schedule) == ("adaptive", "fixed")
    assert not below.buckled and not above.buckled


def test_a_failed_adaptive_run_is_redone_with_the_fixed_schedule(monkeypatch):
    P = pressure_for_inflation_number(0.1, 1.0, CapsuleConfig(**_CHEAP))
    calls = _scripted_indent(monkeypatch, adaptive_fails=True)
    r = indentation_point(P, 1.0, CapsuleConfig(**_CHEAP))
    assert calls == [True, False]
    assert r.schedule.startswith("fixed after adaptive failed: Newton failed in indentation step 7")
    # the fixed run's curve: F = 0.02 h, so k = 0.02 / (P R_c)
    assert_allclose(r.k_over_PR, 0.02 / (r.pressure_Pa * r.R_c_m), rtol=1e-12)
    # the failed run's iterations are counted with the inflation's and the fixed run's 30
    assert r.newton_iterations > 30 + 11


def test_a_run_that_fails_after_the_force_fell_is_a_buckled_point(monkeypatch):
    P = pressure_for_inflation_number(0.1, 1.0, CapsuleConfig(**_CHEAP))

    def falls(h):  # rises, then falls by 5 % from 60 % of the depth on
        return 0.02 * np.minimum(h, 0.6 * h[-1]) * np.where(h > 0.6 * h[-1], 0.95, 1.0)
    _scripted_indent(monkeypatch, adaptive_fails=True, fixed_curve=falls, fixed_fails_after=20)
    r = indentation_point(P, 1.0, CapsuleConfig(**_CHEAP))
    assert r.buckled and r.h_m.size == 20 and r.h_m[-1] < r.R_c_m / 20
    # k is the secant at the deepest depth reached, not at R/20
    assert_allclose(r.k_over_PR, r.F_N[-1] / (r.h_m[-1] * r.pressure_Pa * r.R_c_m), rtol=1e-12)
    assert math.isnan(r.max_penetration_m)


def test_a_run_that_loses_the_path_without_a_fall_is_buckled_too(monkeypatch):
    # Newton failing with ever shorter steps past the linear steps: a singular tangent
    P = pressure_for_inflation_number(0.1, 1.0, CapsuleConfig(**_CHEAP))
    _scripted_indent(monkeypatch, adaptive_fails=True, fixed_fails_after=20)
    r = indentation_point(P, 1.0, CapsuleConfig(**_CHEAP))
    assert r.buckled and r.h_m.size == 20 and np.all(np.diff(r.F_N) > 0)


def test_a_run_that_fails_within_the_linear_steps_still_raises(monkeypatch):
    # no curve beyond the two small steps (h = 0, 0.5, 1 nm): nothing to record
    P = pressure_for_inflation_number(0.1, 1.0, CapsuleConfig(**_CHEAP))
    _scripted_indent(monkeypatch, adaptive_fails=True, fixed_fails_after=3)
    with pytest.raises(FEConvergenceError, match="scripted"):
        indentation_point(P, 1.0, CapsuleConfig(**_CHEAP))


def test_force_falls():
    from turgorbayes.fem import force_falls

    assert not force_falls([0.0, 1.0, 2.0, 2.0, 3.0])
    assert force_falls([0.0, 1.0, 2.0, 1.999, 3.0])
