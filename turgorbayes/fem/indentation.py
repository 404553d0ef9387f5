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

About 600 lines, kept together on purpose: the depth schedule (fixed and adaptive), the
cutting of failed steps and the reading of k from the force curve are one procedure whose
parts share the model state; docs/fem.md describes it.
"""

import functools
import math
import time
from dataclasses import asdict, dataclass, field

import numpy as np
from threadpoolctl import threadpool_limits

from turgorbayes.fem.config import CapsuleConfig
from turgorbayes.fem.contact import indenter_contact, plane_contact
from turgorbayes.fem.errors import FEConfigError, FEConvergenceError
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


# --- analytic inflation of the law ----------------------------------------------------------

def _coupling(ratio, cfg):
    """Factor of the hoop strain from the axial stress (sigma_z = sigma_theta / 2), thin wall."""
    return 1.0 - 0.5 * cfg.nu * math.sqrt(1.0 / ratio)


def axial_stretch(P, ratio, cfg=None):
    r"""Axial stretch of the long cylinder inflated by P, from the wall law (thin wall, nu = 0).

    .. math:: \ln\lambda_z = \frac{\sigma_z}{E_\parallel}
              = \frac{P\,(R - t/2)}{2\,\rho\,E_\perp t},\qquad \rho = E_\parallel/E_\perp,

    i.e. exp(x / (2 rho)) in terms of the inflation number: 1.9 at x = 0.445, rho = 0.35 and 2.8
    at x = 0.52, rho = 0.25 (the Poisson coupling, small for the wall, is left out: this sizes
    mesh elements, see :attr:`CapsuleConfig.axial_stretch_mesh`).

    Parameters
    ----------
    P : float [Pa]
    ratio : float [-]
        ``E_par / E_perp``.
    cfg : CapsuleConfig, optional
    """
    cfg = _check_config(cfg)
    R = inflated_radius(P, ratio, cfg)
    return math.exp(P * (R - 0.5 * cfg.thickness) / (2.0 * ratio * cfg.E_perp * cfg.thickness))


def inflated_radius(P, ratio, cfg=None):
    r"""Mid-surface radius of the long cylinder inflated by P, from the wall law (thin wall).

    .. math::

        \ln\frac{R}{R_0} = c_\nu \frac{P\,(R - t/2)}{E_\perp t},
        \qquad c_\nu = 1 - \frac{\nu}{2}\sqrt{E_\perp/E_\parallel},

    the hoop stress being :math:`P R_\mathrm{in}/t` (exact equilibrium) and the axial stress half
    of it. For :math:`\nu = 0` and small P: :math:`R = R_0 (1 + P R_0/(E_\perp t))`.

    Parameters
    ----------
    P : float [Pa]
    ratio : float [-]
        ``E_par / E_perp``.
    cfg : CapsuleConfig, optional
    """
    cfg = _check_config(cfg)
    _check_ratio(ratio)
    c = _coupling(ratio, cfg)
    a = c * P / (cfg.E_perp * cfg.thickness)
    R = cfg.R0
    for _ in range(200):
        R_new = cfg.R0 * math.exp(a * (R - 0.5 * cfg.thickness))
        if not math.isfinite(R_new) or R_new > 100 * cfg.R0:
            raise FEConfigError(f"pressure {P!r} Pa is beyond the inflation limit of the wall law "
                                f"(P R / (E_perp t) must stay below about 1)")
        if abs(R_new - R) < 1e-14 * R:
            return R_new
        R = R_new
    raise FEConfigError(f"pressure {P!r} Pa: the inflated radius did not converge (too close to "
                        "the inflation limit P R / (E_perp t) ~ 1)")


def pressure_for_inflation_number(x, ratio, cfg=None):
    r"""Pressure [Pa] that gives the inflation number :math:`x = P R_c/(E_\perp t)`.

    Uses the law's analytic inflation (:func:`inflated_radius`); the FE's own ``R_c`` agrees
    to a fraction of a percent (test ``tests/fem/test_inflation.py``), and the FE result
    reports its exact ``x``.

    Parameters
    ----------
    x : float [-]
        Inflation number, 0 < x < 0.9.
    ratio : float [-]
        ``E_par / E_perp`` (enters only through nu).
    cfg : CapsuleConfig, optional
    """
    cfg = _check_config(cfg)
    _check_ratio(ratio)
    if not (isinstance(x, int | float) and 0.0 < x < 0.9):
        raise FEConfigError(f"inflation number x must be in (0, 0.9), got {x!r}")
    c = _coupling(ratio, cfg)
    R = cfg.R0
    for _ in range(200):
        R = cfg.R0 * math.exp(c * x * (1.0 - 0.5 * cfg.thickness / R))
    return x * cfg.E_perp * cfg.thickness / R


def _check_config(cfg):
    if cfg is None:
        return CapsuleConfig()
    if not isinstance(cfg, CapsuleConfig):
        raise FEConfigError(f"cfg must be a CapsuleConfig, got {type(cfg).__name__}")
    return cfg


def _check_ratio(ratio):
    if not (isinstance(ratio, int | float) and math.isfinite(ratio) and 0.01 <= ratio <= 100):
        raise FEConfigError(f"ratio E_par/E_perp must be a number in [0.01, 100], got {ratio!r}")


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


def _newton(problem, u, D, fixed, cfg, stage, step, load, **kw):
    try:
        return problem.newton(u, D, fixed, rtol=cfg.newton_rtol, max_iter=cfg.newton_max_iter,
                              **kw)
    except NewtonFailure as err:
        raise FEConvergenceError(stage, step, load, err.residual, err.detail) from None


def _membrane_inflation(X, P, ratio, cfg):
    """Displacement predicted by membrane theory with the wall law (Newton's starting point).

    Cylinder: hoop stretch from :func:`inflated_radius`, axial log-strain
    ``P R / (2 E_par t)``; caps: the axial shift of the cylinder's end plus a radial
    expansion with log-strain ``P R / (2 E_perp t)``.
    """
    half = 0.5 * cfg.length
    lam_hoop = inflated_radius(P, ratio, cfg) / cfg.R0
    lam_axial = math.exp(P * cfg.R0 / (2.0 * ratio * cfg.E_perp * cfg.thickness))
    lam_cap = math.exp(P * cfg.R0 / (2.0 * cfg.E_perp * cfg.thickness))
    u = np.zeros_like(X)
    cyl = X[:, 0] <= half
    u[cyl, 0] = (lam_axial - 1.0) * X[cyl, 0]
    u[cyl, 1:] = (lam_hoop - 1.0) * X[cyl, 1:]
    cap = ~cyl
    rel = X[cap] - [half, 0.0, 0.0]
    u[cap] = (lam_cap - 1.0) * rel
    u[cap, 0] += (lam_axial - 1.0) * half
    return u


def inflate(model, P, ratio, D, cfg):
    """Load-step the pressure to P from the membrane prediction; return u and iterations.

    A pressure step whose Newton iterations fail is cut in half (down to 1/64 of the
    nominal step) before :class:`FEConvergenceError` is raised.
    """
    x_est = P * cfg.R0 / (cfg.E_perp * cfg.thickness)
    n = cfg.n_inflate_steps or max(1, math.ceil(x_est / 0.2))
    targets = list(P * np.arange(1, n + 1) / n)
    u, iters, P_done, step = np.zeros((model.mesh.n_nodes, 3)), 0, 0.0, 0
    X = model.mesh.X
    while targets:
        Pi = targets[0]
        guess = u + _membrane_inflation(X, Pi, ratio, cfg) - _membrane_inflation(X, P_done, ratio, cfg)
        try:
            u_new, info = model.problem.newton(guess, D, model.fixed["inflate"], P=Pi,
                                               rtol=cfg.newton_rtol, max_iter=cfg.newton_max_iter,
                                               stall_window=cfg.newton_stall_window)
        except NewtonFailure as err:
            if Pi - P_done < P / (64 * n):
                raise FEConvergenceError("inflation", step, Pi, err.residual, err.detail) from None
            targets.insert(0, 0.5 * (Pi + P_done))
            continue
        targets.pop(0)
        u, P_done, step = u_new, Pi, step + 1
        iters += info["iterations"]
    return u, iters


def _depth_schedule(cfg, h_end):
    """Two small steps up to linear_depth, then nominal steps of h_end / n_indent_steps."""
    h_lin = min(cfg.linear_depth, 0.25 * h_end)
    first = [0.5 * h_lin, h_lin]
    n = cfg.n_indent_steps
    rest = [h for h in np.linspace(0.0, h_end, n + 1)[1:] if h > h_lin * 1.0001]
    return first + rest


#: A depth step that converged within this many Newton iterations lets the next one grow 1.5x.
_EASY_ITERATIONS = 8


def _next_depth(targets, h_done, dh_max):
    """The next depth to solve for: the next scheduled one, or an intermediate depth.

    After a failed step the increment is capped at ``dh_max`` (half the failed increment) and
    only grows back by 1.5x per easily converged step, so a hard stretch of the indentation
    (contact spreading over a new ring of tip elements) is not retried at the full scheduled
    step after every success, which cost one failed Newton solve per scheduled step.
    """
    return min(targets[0], h_done + dh_max)


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


#: Adaptive depth steps (``CapsuleConfig.step_tolerance > 0``): the largest step, as a
#: fraction of h_end, and the factor above the tolerance at which a step is redone smaller.
_MAX_STEP_FRACTION = 0.25
_REJECT_FACTOR = 4.0


def _correction(u_new, guess, u_old):
    """Newton's correction of the predictor relative to the step's increment (max norms)."""
    increment = np.max(np.abs(u_new - u_old))
    return float(np.max(np.abs(u_new - guess)) / increment) if increment > 0 else 0.0


def _adapted_step(dh, e, tol):
    """Next depth step from this one's relative correction e: keeps e near tol."""
    factor = 2.0 if e <= 0 else 0.9 * math.sqrt(tol / e)
    return dh * min(2.0, max(0.5, factor))


def _next_adaptive_depth(h_end, h_done, dh_adapt, dh_max):
    """Next depth of adaptive steps: ``h_done + dh_adapt``, within a cut ``dh_max`` and h_end,
    stretched to h_end rather than leaving a last step shorter than dh_adapt/4 (unless a failed
    step was cut shorter than that stretch: then cutting would otherwise never end)."""
    h = min(h_end, h_done + dh_max, h_done + dh_adapt)
    if h_end - h < 0.25 * dh_adapt and h_end - h_done <= dh_max:
        h = h_end
    return h


def _indent(model, u0, P, D, cfg, R_c, progress, adaptive):
    """Push the indenter to h_end in steps; return depths, forces, deflections, iterations
    and the remaining penetration. A failure raises :class:`FEConvergenceError` with the
    curve reached so far as ``err.curve`` (depths, forces) and ``err.iterations``.

    Fixed schedule (``adaptive`` False): the depths of :func:`_depth_schedule`,
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
    targets = _depth_schedule(cfg, h_end)
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
    dh_max = np.inf  # largest depth increment allowed since the last cut (see _next_depth)
    dh_adapt = dh_nominal = h_end / cfg.n_indent_steps
    while targets:
        if adaptive and len(targets) == 1:  # past the two small steps: targets == [h_end]
            h = _next_adaptive_depth(h_end, h_done, dh_adapt, dh_max)
        else:
            h = _next_depth(targets, h_done, dh_max)

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
            e = _correction(u_new, guess, u)
            if e > _REJECT_FACTOR * cfg.step_tolerance and h - h_done > 1.01 * dh_nominal:
                dh_adapt = max(0.5 * (h - h_done), dh_nominal)  # redo this step shorter
                iters += info["iterations"]
                continue
            dh_adapt = min(max(_adapted_step(h - h_done, e, cfg.step_tolerance), dh_nominal),
                           _MAX_STEP_FRACTION * h_end)
        offset = offset_new
        if h == targets[0]:
            targets.pop(0)
        dh_max = 1.5 * dh_max if info["iterations"] <= _EASY_ITERATIONS else dh_max
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


def _linear_slope(h, w, F, depths):
    """Slope at 0 of the fit F = k w + c w^2 through the steps at the scheduled ``depths``.

    The depths are the schedule's two small steps (:func:`_depth_schedule`), which every run
    reaches exactly. Steps cut shorter after a failed Newton solve come before them and are
    not used: k from ``F(w)`` depends on the depths it is read at (the contact patch under the
    tip grows with depth), so reading it at the first two *recorded* steps, as the shipped
    table's builds did, made it up to 13 % lower wherever the first step had been cut.

    Parameters
    ----------
    h, w, F : ndarray [m], [m], [N]
        Depth, mid-surface deflection under the tip and force at each converged step.
    depths : sequence of float [m]
    """
    idx = [int(np.argmin(np.abs(h - d))) for d in depths]
    if not np.allclose(h[idx], depths, rtol=1e-9, atol=0.0):
        raise RuntimeError(f"the scheduled depths {list(depths)} m are not among the steps")
    A = np.stack([w[idx], w[idx] ** 2], axis=1)
    return float(np.linalg.lstsq(A, F[idx], rcond=None)[0][0])


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
    cfg = _check_config(cfg)
    _check_ratio(ratio)
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
    cfg = _check_config(cfg)
    _check_ratio(ratio)
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
        k_linear_over_PR=_linear_slope(h, w, F, _depth_schedule(cfg, h_end)[:2]) / PR,
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
        h_lin = _depth_schedule(cfg, cfg.h_over_R * R_c)[1]
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

