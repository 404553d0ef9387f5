r"""Indentation of a pressurized orthotropic capsule by a cone with a spherical tip.

One quarter of the capsule (symmetry planes x = 0, mid-length, and y = 0, through the axis and
the indenter) is inflated by a follower pressure P in a few Newton load steps, then pushed
down at its crest by the rigid indenter (frictionless penalty contact) in depth steps, while
it rests on the substrate (:attr:`CapsuleConfig.support`). The wall law is
:mod:`turgorbayes.fem.material` (true stress linear in natural strain, the wall model of
docs/physics.md, Wall law). Definitions used in the results:

* ``R_c``: mid-surface radius of the inflated cylinder at mid-length (FE value; the outer
  radius the AFM touches is larger by t/2, 0.6%).
* ``x = P R_c / (E_perp t)``, the inflation number.
* ``h``: travel of the indenter tip from first contact, relative to the substrate (what the
  AFM measures); ``F``: total force on the indenter (4 x the quarter model's).
* ``k/(P R_c) = F(h_end) / (h_end P R_c)`` with ``h_end = h_over_R * R_c`` (the paper's secant
  stiffness at h = R/20).
* support (:attr:`CapsuleConfig.support`): ``"plane"`` (default) lets the capsule rest on a
  rigid frictionless plane touching its bottom line, the cell on glass without adhesion; the
  contact region along the bottom is found by the solver, so the bottom can lift off where
  the capsule bends. ``"line"`` holds the bottom generator against vertical motion
  (bilateral, like an adhered line). On the production mesh at the physiological point
  (x = 0.0706, ratio 0.457): k/(P R_c) = 1.066 (plane) vs 1.085 (line), +2%; the linear
  stiffness 0.977 vs 1.084, +11% (with the plane the bottom lifts off away from the load).
  A St Venant-Kirchhoff wall (``law="svk"``) would give 1.100 (+3.3%) there.
* linear stiffness: the shell's small-load stiffness, ``dF/dw`` at w -> 0 with ``w`` the
  deflection of the wall's mid-surface under the tip (fit ``F = k w + c w^2`` through the
  steps at ``linear_depth/2`` and ``linear_depth``, whatever steps were cut before them). It
  excludes the local squeezing of the wall between tip and cavity, which makes F(h) start like
  a Hertz contact, ``h^{3/2}``, so that ``dF/dh`` itself vanishes at h = 0 and its small-depth
  value depends on the mesh.

The stepping loop, which shares the model state, is here; the inflation to P is
:mod:`turgorbayes.fem.inflation`, the depth steps' arithmetic (schedule, cuts, adaptive size,
the linear stiffness read at the schedule's small steps) :mod:`turgorbayes.fem.depth_steps`;
docs/fem.md describes the procedure.
"""

import functools
import math
import time
from dataclasses import asdict, dataclass, field

import numpy as np
from threadpoolctl import threadpool_limits

from turgorbayes.fem.config import CapsuleConfig, check_ratio, checked_config
from turgorbayes.fem.contact import indenter_contact, plane_contact
from turgorbayes.fem.depth_steps import (
    EASY_ITERATIONS,
    MAX_STEP_FRACTION,
    REJECT_FACTOR,
    adapted_step,
    depth_schedule,
    linear_slope,
    next_adaptive_depth,
    next_depth,
    step_correction,
)
from turgorbayes.fem.errors import FEConfigError, FEConvergenceError
from turgorbayes.fem.inflation import (
    axial_stretch,
    inflate,
    inflated_radius,
    pressure_for_inflation_number,
)
from turgorbayes.fem.material import orthotropic_stiffness
from turgorbayes.fem.mesh import capsule_quadrant_mesh
from turgorbayes.fem.solver import NewtonFailure, ShellProblem
from turgorbayes.progress import progress as show_progress

__all__ = [
    "IndentationResult",
    "capsule_model",
    "fe_inflated_radius",
    "force_falls",
    "indentation_point",
    "inflate",
    "inflated_radius",
    "pressure_for_inflation_number",
]


@dataclass
class IndentationResult:
    """Outcome of one indentation simulation (SI units).

    Attributes
    ----------
    x : float [-]
        Inflation number ``P R_c / (E_perp t)`` with the FE's own ``R_c``.
    pressure_Pa : float [Pa]
    ratio : float [-]
        ``E_par / E_perp``.
    R_c_m : float [m]
        Inflated mid-surface radius at mid-length.
    k_over_PR : float [-]
        ``F(h_end) / (h_end P R_c)``, ``h_end = h_over_R R_c``; for a buckled point whose
        run stopped early, the secant ``F(h)/h`` at the deepest depth reached (``h_m[-1]``),
        which is not a stiffness at ``h_end`` (the table gives no value there).
    k_linear_over_PR : float [-]
        Small-indentation slope ``dF/dh`` at h -> 0 over ``P R_c``.
    h_m, F_N : ndarray [m], [N]
        Indentation depth and force at every converged step (starting at 0, 0).
    w_m : ndarray [m]
        Deflection of the wall's mid-surface under the tip at the same steps (the linear
        stiffness is read from F against it).
    newton_iterations : int
        Total Newton iterations (inflation and indentation).
    wall_time_s : float [s]
    converged : bool
        Always True for a returned result (failures raise :class:`FEConvergenceError`;
        a buckled run that stopped early is returned, see ``buckled``).
    mesh_dofs : int
        Degrees of freedom of the quarter model.
    max_penetration_m : float [m]
        Largest penetration of a node into the indenter at ``h_end`` (penalty error).
    config : dict
        The :class:`CapsuleConfig` used (provenance).
    schedule : str
        Depth steps used: ``"fixed"``, ``"adaptive"``, or ``"fixed after adaptive failed:
        <error>"`` (:attr:`CapsuleConfig.adaptive_below_x`).
    buckled : bool
        The force fell while the depth grew (:func:`force_falls`), or the fixed schedule lost
        the loading path before ``h_end`` (the run then ends there, ``h_m[-1] < h_over_R
        R_c``): the wall buckled under the tip and k at ``h_end`` has no unique value in this
        model (docs/fem.md, "The buckled corner").
    """

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
    max_penetration_m: float = float("nan")
    config: dict = field(default_factory=dict)
    w_m: np.ndarray = field(default_factory=lambda: np.zeros(0))
    schedule: str = "fixed"
    buckled: bool = False

    def to_dict(self):
        """JSON-able dict of all fields (arrays as lists)."""
        out = asdict(self)
        out["h_m"] = [float(v) for v in self.h_m]
        out["F_N"] = [float(v) for v in self.F_N]
        out["w_m"] = [float(v) for v in self.w_m]
        return out


# --- the model --------------------------------------------------------------------------------

class _Capsule:
    """Mesh, problem and node sets of the capsule quadrant (built once per process and mesh)."""

    def __init__(self, cfg, axial_factor=1.0):
        s = cfg.mesh_scale
        self.mesh = capsule_quadrant_mesh(cfg.R0, cfg.length, cfg.thickness, s * cfg.h_min,
                                          s * cfg.h_max, cfg.growth, s * cfg.h_bottom, cfg.n_thick,
                                          half=cfg.half_model,
                                          h_min_axial=s * cfg.h_min / axial_factor)
        self.problem = ShellProblem(self.mesh, cfg.solver)
        self.multiplicity = 2.0 if cfg.half_model else 4.0
        X, tol = self.mesh.X, 1e-6 * cfg.thickness
        sym = np.zeros((self.mesh.n_nodes, 3), dtype=bool)
        sym[np.abs(X[:, 0]) < tol, 0] = True
        on_y0 = np.abs(X[:, 1]) < tol
        # half model: u_y held only on the bottom line (no lateral drift, no spin)
        sym[on_y0 & (X[:, 2] < 0) if cfg.half_model else on_y0, 1] = True
        inflate = sym.copy()
        inflate[np.abs(X[:, 2]) < tol, 2] = True  # z = 0 is a symmetry plane of pure inflation
        line = sym.copy()
        outer = np.zeros(self.mesh.n_nodes, dtype=bool)
        outer[self.mesh.outer_nodes] = True
        bottom = outer & (np.abs(X[:, 1]) < tol) & (X[:, 2] < 0) & (X[:, 0] <= 0.5 * cfg.length + tol)
        line[bottom, 2] = True
        self.fixed = {"inflate": inflate.ravel(), "plane": sym.ravel(), "line": line.ravel()}
        self.apex = int(np.argmin(np.linalg.norm(X - [0.0, 0.0, cfg.R0 + 0.5 * cfg.thickness], axis=1)))
        self.apex_mid = int(np.argmin(np.linalg.norm(X - [0.0, 0.0, cfg.R0], axis=1)))
        self.side = int(np.argmin(np.linalg.norm(X - [0.0, cfg.R0, 0.0], axis=1)))


@functools.lru_cache(maxsize=2)
def _capsule(mesh_key, axial_factor=1.0):
    return _Capsule(CapsuleConfig(**dict(mesh_key)), axial_factor)


_MESH_FIELDS = ("length", "R0", "thickness", "mesh_scale", "h_min", "h_bottom", "h_max", "growth",
                "n_thick", "half_model", "solver")


def capsule_model(cfg, P=None, ratio=None):
    """The capsule for ``cfg``; with ``axial_stretch_mesh`` its crest is refined for (P, ratio)."""
    factor = 1.0
    if cfg.axial_stretch_mesh and P is not None:
        factor = round(max(1.0, axial_stretch(P, ratio, cfg)), 3)
    return _capsule(tuple((k, getattr(cfg, k)) for k in _MESH_FIELDS), factor)


def _augment(model, u, info, offset, bodies, D, P, cfg, h_end):
    """Uzawa updates of the contact offsets until the penetration is below tolerance.

    Each update re-solves equilibrium from the converged state. An update whose Newton
    solve stalls (the active contact set flipping at the edge of the patch) ends the updates:
    the last converged state is kept and its remaining penetration is what the result
    reports (``max_penetration_m``), as when ``max_augmentations`` runs out.
    """
    fixed = model.fixed[cfg.support]
    for _ in range(cfg.max_augmentations):
        gap = info["contact"][0]["gap"]
        if -gap.min() <= cfg.penetration_tol * h_end:
            break
        trial = np.maximum(0.0, offset - gap)
        try:
            u_new, more = model.problem.newton(u, D, fixed, P=P, bodies=bodies(trial),
                                               rtol=cfg.newton_rtol, max_iter=cfg.newton_max_iter,
                                               max_step=cfg.max_newton_step,
                                               stall_window=cfg.newton_stall_window)
        except NewtonFailure:
            break
        u, offset = u_new, trial
        info = {**more, "iterations": info["iterations"] + more["iterations"]}
    return u, info, offset


def _indent(model, u0, P, D, cfg, R_c, progress, adaptive):
    """Push the indenter to h_end in steps; return depths, forces, deflections, iterations
    and the remaining penetration. A failure raises :class:`FEConvergenceError` with the
    curve reached so far as ``err.curve`` (depths, forces) and ``err.iterations``.

    Fixed schedule (``adaptive`` False): the depths of :func:`depth_schedule`,
    cut after a failed Newton solve. Adaptive (``cfg.step_tolerance > 0``): after the two small steps, a first
    step of ``h_end / n_indent_steps`` (the nominal step), then each step scaled to keep the
    relative correction of the secant predictor near the tolerance, between the nominal step
    and h_end/4, and a longer-than-nominal step whose correction exceeds 4x the tolerance
    redone shorter. So steps are long where the force curve is straight and never shorter
    than the fixed schedule's where it bends (except cuts after a failed Newton solve, as in
    the fixed schedule): at a snap under the tip the correction stays large however short
    the step, and much shorter steps made Newton fail there.
    """
    X = model.mesh.X
    z_top = X[model.apex, 2] + u0[model.apex, 2]
    bodies_fixed = model.fixed[cfg.support]
    z_plane = np.min((X + u0)[model.problem.outer, 2])
    h_end = cfg.h_over_R * R_c
    targets = depth_schedule(cfg, h_end)
    if adaptive:
        targets = targets[:2] + [h_end]
    hs, Fs, ws, iters = [0.0], [0.0], [0.0], 0
    z_mid0 = X[model.apex_mid, 2] + u0[model.apex_mid, 2]
    u, h_done, last = u0, 0.0, None
    u_prev, h_prev = None, None
    offset = np.zeros(model.problem.outer.size)
    bar = _progress_bar(progress, len(targets), adaptive)
    min_step = 1e-4 * h_end
    step_index = 0
    dh_max = np.inf  # largest depth increment allowed since the last cut (see next_depth)
    dh_adapt = dh_nominal = h_end / cfg.n_indent_steps
    while targets:
        if adaptive and len(targets) == 1:  # past the two small steps: targets == [h_end]
            h = next_adaptive_depth(h_end, h_done, dh_adapt, dh_max)
        else:
            h = next_depth(targets, h_done, dh_max)

        def bodies(off, h=h):
            tip = lambda xo, area: indenter_contact(  # noqa: E731
                xo, area, z_top - h, cfg.tip_radius, cfg.cone_half_angle, cfg.penalty,
                cfg.contact_smoothing, off)
            if cfg.support == "plane":
                base = lambda xo, area: plane_contact(  # noqa: E731
                    xo, area, z_plane, cfg.support_penalty, 1e-3 * cfg.contact_smoothing)
                return (tip, base)
            return (tip,)

        guess = u
        if u_prev is not None:  # secant predictor: continue the last step's deformation
            guess = u + (h - h_done) / (h_done - h_prev) * (u - u_prev)
        try:
            u_new, info = model.problem.newton(guess, D, bodies_fixed, P=P, bodies=bodies(offset),
                                               rtol=cfg.newton_rtol, max_iter=cfg.newton_max_iter,
                                               max_step=cfg.max_newton_step,
                                               stall_window=cfg.newton_stall_window)
        except NewtonFailure as err:
            if h - h_done < 2 * min_step:
                fail = FEConvergenceError("indentation", step_index, h, err.residual,
                                          f"{err.detail}; depth step below {min_step:.3g} m")
                fail.curve, fail.iterations = (np.array(hs), np.array(Fs), np.array(ws)), iters
                raise fail from None
            dh_max = 0.5 * (h - h_done)  # cut the step, and keep it cut for the next steps
            continue
        u_new, info, offset_new = _augment(model, u_new, info, offset, bodies, D, P, cfg, h_end)
        if adaptive and u_prev is not None and len(targets) == 1:
            e = step_correction(u_new, guess, u)
            if e > REJECT_FACTOR * cfg.step_tolerance and h - h_done > 1.01 * dh_nominal:
                dh_adapt = max(0.5 * (h - h_done), dh_nominal)  # redo this step shorter
                iters += info["iterations"]
                continue
            dh_adapt = min(max(adapted_step(h - h_done, e, cfg.step_tolerance), dh_nominal),
                           MAX_STEP_FRACTION * h_end)
        offset = offset_new
        if h == targets[0]:
            targets.pop(0)
        dh_max = 1.5 * dh_max if info["iterations"] <= EASY_ITERATIONS else dh_max
        u_prev, h_prev = u, h_done
        u, h_done, last = u_new, h, info
        iters += info["iterations"]
        hs.append(h)
        Fs.append(-model.multiplicity * info["contact"][0]["force"][2])
        ws.append(z_mid0 - X[model.apex_mid, 2] - u[model.apex_mid, 2])
        step_index += 1
        if bar is not None:
            bar.update(round(100 * h / h_end) - bar.n if adaptive else 1)
    if bar is not None:
        bar.close()
    penetration = max(0.0, -float(np.min(last["contact"][0]["gap"])))
    return np.array(hs), np.array(Fs), np.array(ws), iters, penetration


def _progress_bar(progress, total, adaptive=False):
    """Over the depth steps, or over per cent of the final depth when the steps adapt."""
    if not progress:
        return None
    if adaptive:
        return show_progress(total=100, desc="indentation", unit="%", leave=False)
    return show_progress(total=total, desc="indentation", unit="step", leave=False)


def indentation_point(P, ratio, cfg=None, progress=False):
    """Simulate inflation to pressure P and indentation to h = h_over_R * R_c.

    Parameters
    ----------
    P : float [Pa]
        Turgor pressure (> 0).
    ratio : float [-]
        Anisotropy ``E_par / E_perp``, in [0.01, 100].
    cfg : CapsuleConfig, optional
        All other settings (default: the paper's model, production mesh).
    progress : bool
        Show a progress bar over the depth steps.

    Returns
    -------
    IndentationResult

    Raises
    ------
    FEConfigError
        Bad input.
    FEConvergenceError
        Newton failed (carries the stage, step, load and residual).
    """
    cfg = checked_config(cfg)
    check_ratio(ratio)
    if not (isinstance(P, int | float) and math.isfinite(P) and P > 0):
        raise FEConfigError(f"pressure P must be a finite number > 0 Pa, got {P!r}")
    inflated_radius(P, ratio, cfg)  # raises beyond the law's inflation limit
    with threadpool_limits(limits=cfg.threads):
        return _run(float(P), float(ratio), cfg, progress)


def fe_inflated_radius(P, ratio, cfg=None):
    """Inflated mid-surface radius at mid-length from the FE model (inflation only) [m].

    Parameters
    ----------
    P : float [Pa]
    ratio : float [-]
        ``E_par / E_perp``.
    cfg : CapsuleConfig, optional
    """
    cfg = checked_config(cfg)
    check_ratio(ratio)
    inflated_radius(P, ratio, cfg)
    with threadpool_limits(limits=cfg.threads):
        model = capsule_model(cfg, P, ratio)
        model.problem.law = cfg.law
        D = orthotropic_stiffness(cfg.E_perp, ratio * cfg.E_perp, cfg.E_perp, cfg.nu)
        u, _ = inflate(model, float(P), float(ratio), D, cfg)
    return _side_radius(model, u)


def _side_radius(model, u):
    X = model.mesh.X
    return float(np.hypot(*(X[model.side, 1:] + u[model.side, 1:])))


def _run(P, ratio, cfg, progress):
    start = time.perf_counter()
    model = capsule_model(cfg, P, ratio)
    model.problem.law = cfg.law
    D = orthotropic_stiffness(cfg.E_perp, ratio * cfg.E_perp, cfg.E_perp, cfg.nu)
    u, iters_inflate = inflate(model, P, ratio, D, cfg)
    R_c = _side_radius(model, u)
    PR = P * R_c
    x = PR / (cfg.E_perp * cfg.thickness)
    h, F, w, iters_indent, penetration, schedule = _indent_with_fallback(
        model, u, P, D, cfg, R_c, progress, adaptive=cfg.step_tolerance > 0 and x < cfg.adaptive_below_x)
    h_end = cfg.h_over_R * R_c
    return IndentationResult(
        x=x,
        pressure_Pa=float(P),
        ratio=float(ratio),
        R_c_m=R_c,
        k_over_PR=float(F[-1] / (h[-1] * PR)),
        buckled=bool(force_falls(F) or h[-1] < (1 - 1e-9) * h_end),
        k_linear_over_PR=linear_slope(h, w, F, depth_schedule(cfg, h_end)[:2]) / PR,
        h_m=h,
        F_N=F,
        newton_iterations=iters_inflate + iters_indent,
        wall_time_s=time.perf_counter() - start,
        converged=True,
        mesh_dofs=int(model.mesh.n_dofs),
        max_penetration_m=penetration,
        config=cfg.as_dict(),
        w_m=w,
        schedule=schedule,
    )


def _indent_with_fallback(model, u, P, D, cfg, R_c, progress, adaptive):
    """:func:`_indent`, and where an adaptive run fails, the fixed schedule from the same
    inflated state ``u``; returns its outputs and the schedule used (``"fixed"``,
    ``"adaptive"`` or ``"fixed after adaptive failed: <error>"``)."""
    if not adaptive:
        return (*_fixed_or_buckled(model, u, P, D, cfg, R_c, progress), "fixed")
    try:
        return (*_indent(model, u, P, D, cfg, R_c, progress, True), "adaptive")
    except FEConvergenceError as err:
        h, F, w, iters, penetration = _fixed_or_buckled(model, u, P, D, cfg, R_c, progress)
        return (h, F, w, iters + getattr(err, "iterations", 0), penetration,
                f"fixed after adaptive failed: {err}")


def _fixed_or_buckled(model, u, P, D, cfg, R_c, progress):
    """The fixed schedule; a run that loses the loading path past the linear steps returns
    the curve up to there instead of raising.

    Newton then fails with ever shorter depth steps: the tangent is (nearly) singular at a
    limit or bifurcation point, where the wall buckles under the tip, whether or not the
    force has visibly fallen before (docs/fem.md, "The buckled corner"). Such a point has no
    k at ``h = R/20`` on this model (its result is ``buckled``, ``h_m[-1] < h_end``), but its
    linear stiffness and the curve up to there are still the model's."""
    try:
        return _indent(model, u, P, D, cfg, R_c, progress, False)
    except FEConvergenceError as err:
        h, F, w = getattr(err, "curve", (np.zeros(0),) * 3)
        h_lin = depth_schedule(cfg, cfg.h_over_R * R_c)[1]
        if h.size < 4 or h[-1] <= h_lin:
            raise
        return h, F, w, err.iterations, float("nan")


def force_falls(F):
    """True if an indentation force curve falls anywhere while the depth grows.

    Under displacement control an elastic indentation curve rises monotonically; a fall
    means the solution jumped to another equilibrium branch (a buckle under the tip).

    Parameters
    ----------
    F : array_like [N]
        Force at increasing depths.
    """
    return bool(np.any(np.diff(np.asarray(F, dtype=float)) < 0))

