"""Settings of the capsule indentation model: :class:`CapsuleConfig` (defaults = the paper),
and the checks of a point's settings and anisotropy."""

import math
from dataclasses import asdict, dataclass

from turgorbayes.fem.errors import FEConfigError

__all__ = ["SUPPORTS", "TABLE_SETTINGS", "CapsuleConfig", "check_ratio", "checked_config",
           "table_config"]

#: Allowed values of :attr:`CapsuleConfig.support`.
SUPPORTS = ("plane", "line")
_SOLVERS = ("auto", "pardiso", "pardiso_sym", "splu")


@dataclass(frozen=True)
class CapsuleConfig:
    """Every setting of one finite-element indentation point; ``dataclasses.asdict`` is provenance.

    Geometry and material (defaults: Deng, Sun & Shaevitz 2011, supplement "Finite element
    simulations"):

    Attributes
    ----------
    length : float [m]
        Length of the cylindrical part; hemispherical caps are added (2 um).
    R0 : float [m]
        Unpressurized mid-surface radius (500 nm).
    thickness : float [m]
        Wall thickness t (6 nm).
    E_perp : float [Pa]
        Circumferential modulus, the tangent d(sigma_true)/d(ln lambda) (20 MPa). The axial
        modulus is ``ratio * E_perp`` (argument of the indentation), the modulus through the
        wall is ``E_perp``.
    nu : float [-]
        Poisson parameter (0 in the paper); see :mod:`turgorbayes.fem.material`.
    law : str
        ``"log"``: true stress linear in natural strain (the wall model, default);
        ``"svk"``: St Venant-Kirchhoff, for comparison only (its tangent modulus is not
        ``E_perp`` once strained, so its x is not the inference's).
    cone_half_angle : float [rad]
        Half-angle of the conical indenter (pi/12).
    tip_radius : float [m]
        Radius of the indenter's spherical tip (7.5 nm).
    h_over_R : float [-]
        Indentation depth where the stiffness is read, over R_c (1/20).

    Mesh (27-node hexahedra; sizes are arc lengths on the mid-surface):

    Attributes
    ----------
    mesh_scale : float [-]
        Multiplies all element sizes below (1.0 = production, 0.5 = half the element size).
    h_min : float [m]
        Element size at the indenter.
    h_bottom : float [m]
        Element size along the bottom line (the substrate contact).
    h_max : float [m]
        Largest element size.
    growth : float [-]
        Increase of the element size per unit distance from the refined spots.
    n_thick : int
        Elements through the wall.
    axial_stretch_mesh : bool
        False (default): the crest's elements are ``h_min`` long in the unloaded capsule.
        True: their axial length is divided by the inflated wall's axial stretch
        exp(x / (2 E_par/E_perp)) (:func:`turgorbayes.fem.inflation.axial_stretch`), so that
        after inflation they are ``h_min`` long under the tip. Axially soft walls at large x
        stretch 1.9-2.8-fold; there the default mesh under-resolves the tip and the force
        curve snaps early (x = 0.445, ratio 0.35: with the crest's axial size halved the curve
        is smooth and k/PR 0.6378, +0.36 % from a mesh with every size halved, against a snap
        and 0.6140 on the default mesh; studies/results/fem_axial_refinement.txt). Not
        used for the shipped table (at x = 0.52 the wall buckles under the tip on every mesh).

    Loading and solution:

    Attributes
    ----------
    half_model : bool
        Model the half capsule (x >= 0, whole circumference) instead of the quadrant; only to
        check the quadrant's symmetry conditions (twice the DOFs). Lateral motion and spin
        are then held by u_y = 0 on the bottom line only.
    support : str
        ``"plane"``: the capsule rests on a rigid, frictionless plane touching its bottom
        line (unilateral penalty contact; the realistic cell-on-glass case, adhesion to the
        poly-L-lysine ignored). ``"line"``: the bottom generator of the cylinder's outer
        surface is held against vertical motion (bilateral). See the module docs of
        :mod:`turgorbayes.fem.indentation` for the effect on k.
    penalty : float [Pa/m]
        Contact-pressure stiffness of the indenter (penetration = contact pressure / penalty).
    support_penalty : float [Pa/m]
        Same for the substrate plane.
    contact_smoothing : float [m]
        Penetration over which the penalty pressure is smoothed (C1 at first contact).
    penetration_tol : float [-]
        Largest penetration into the indenter, as a fraction of the final depth, left after
        the augmented-Lagrangian (Uzawa) updates of each depth step.
    max_augmentations : int
        Cap on those updates per step (the remaining penetration is reported).
    n_inflate_steps : int
        Pressure increments of the inflation (0: automatic, ``max(1, ceil(x / 0.2))``, each
        started from the membrane-theory prediction).
    n_indent_steps : int
        Nominal number of depth increments after the small-depth steps (cut adaptively).
        With ``step_tolerance > 0``: the first step is h_end / n_indent_steps.
    step_tolerance : float [-]
        0 (default): the fixed schedule of ``n_indent_steps`` steps. > 0: adaptive depth
        steps that keep Newton's correction of the secant predictor near this fraction of
        each step's displacement increment, between h_end / n_indent_steps and h_end / 4 (a
        longer step whose correction exceeds 4x the tolerance is redone shorter).
    adaptive_below_x : float [-]
        Adaptive steps are used only where the inflated capsule's inflation number
        ``P R_c/(E_perp t)`` is below this (inf, the default: wherever ``step_tolerance > 0``);
        above it the fixed schedule. Where they are used and the indentation fails, it is
        redone from the inflated state with the fixed schedule, and the result's
        ``schedule`` says so. The shipped table: 0.4, where adaptive steps reproduce the fixed
        schedule within 0.1 % (docs/fem.md, "Cost per point").
    linear_depth : float [m]
        Depth of the second of the two small first steps that give the linear stiffness.
    newton_rtol : float [-]
        Converged when the residual norm is below this times the internal-force norm.
    newton_max_iter : int
    newton_stall_window : int
        Inflation and indentation steps give up (and are cut) when the residual has not fallen tenfold in
        this many Newton iterations (0: only ``newton_max_iter`` stops them).
    max_newton_step : float [m]
        Cap on a node's displacement change in one Newton iteration.
    solver : str
        ``"auto"`` (``"pardiso"`` if pypardiso is installed, else ``"splu"``), ``"pardiso"``
        (LU of the tangent), ``"pardiso_sym"`` (LDL^T of the tangent's symmetric part where it
        is nearly symmetric; reports the inertia), ``"splu"``; see
        :class:`turgorbayes.fem.solver.LinearSolver`.
    threads : int
        BLAS/MKL threads during the run (1: a sweep runs one point per core; more threads on a
        busy machine made the small batched products 100x slower through spin-waiting).
    """

    length: float = 2e-6
    R0: float = 500e-9
    thickness: float = 6e-9
    E_perp: float = 20e6
    nu: float = 0.0
    law: str = "log"
    cone_half_angle: float = math.pi / 12
    tip_radius: float = 7.5e-9
    h_over_R: float = 1.0 / 20.0
    mesh_scale: float = 1.0
    h_min: float = 3e-9
    h_bottom: float = 12e-9
    h_max: float = 80e-9
    growth: float = 0.25
    n_thick: int = 1
    axial_stretch_mesh: bool = False
    half_model: bool = False
    support: str = "plane"
    penalty: float = 1e17
    support_penalty: float = 1e17
    contact_smoothing: float = 5e-11
    penetration_tol: float = 1e-3
    max_augmentations: int = 6
    n_inflate_steps: int = 0
    n_indent_steps: int = 6
    step_tolerance: float = 0.0
    adaptive_below_x: float = math.inf
    linear_depth: float = 1e-9
    newton_rtol: float = 1e-6
    newton_max_iter: int = 30
    newton_stall_window: int = 8
    max_newton_step: float = 2e-9
    solver: str = "auto"
    threads: int = 1

    def __post_init__(self):
        positive = ("length", "R0", "thickness", "E_perp", "tip_radius", "h_over_R", "mesh_scale",
                    "h_min", "h_bottom", "h_max", "growth", "penalty", "support_penalty",
                    "contact_smoothing", "penetration_tol", "linear_depth", "newton_rtol",
                    "max_newton_step")
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
                raise FEConfigError(f"CapsuleConfig.{name} must be a finite number > 0, got {value!r}")
        if not (isinstance(self.step_tolerance, int | float) and math.isfinite(self.step_tolerance)
                and self.step_tolerance >= 0):
            raise FEConfigError("CapsuleConfig.step_tolerance must be a finite number >= 0, "
                                f"got {self.step_tolerance!r}")
        if not (isinstance(self.adaptive_below_x, int | float) and self.adaptive_below_x > 0):
            raise FEConfigError("CapsuleConfig.adaptive_below_x must be a number > 0 (inf: "
                                f"everywhere), got {self.adaptive_below_x!r}")
        if not -1.0 < self.nu < 0.5:
            raise FEConfigError(f"CapsuleConfig.nu must be in (-1, 0.5), got {self.nu!r}")
        if not 0.0 < self.cone_half_angle < math.pi / 2:
            raise FEConfigError(
                f"CapsuleConfig.cone_half_angle must be in (0, pi/2) rad, got {self.cone_half_angle!r}")
        if self.thickness >= 0.5 * self.R0:
            raise FEConfigError(f"CapsuleConfig.thickness must be < R0/2 = {0.5 * self.R0:.3g} m, "
                                f"got {self.thickness!r}")
        for name, low in (("n_thick", 1), ("n_inflate_steps", 0), ("n_indent_steps", 1),
                          ("newton_max_iter", 2), ("newton_stall_window", 0), ("threads", 1),
                          ("max_augmentations", 0)):
            value = getattr(self, name)
            if not isinstance(value, int) or value < low:
                raise FEConfigError(f"CapsuleConfig.{name} must be an integer >= {low}, got {value!r}")
        if self.support not in SUPPORTS:
            raise FEConfigError(f"CapsuleConfig.support must be one of {SUPPORTS}, got {self.support!r}")
        if self.law not in ("log", "svk"):
            raise FEConfigError(f"CapsuleConfig.law must be 'log' or 'svk', got {self.law!r}")
        if self.solver not in _SOLVERS:
            raise FEConfigError(f"CapsuleConfig.solver must be one of {_SOLVERS}, got {self.solver!r}")
        for name in ("half_model", "axial_stretch_mesh"):
            if not isinstance(getattr(self, name), bool):
                raise FEConfigError(f"CapsuleConfig.{name} must be True or False, "
                                    f"got {getattr(self, name)!r}")

    def as_dict(self):
        """Plain dict of all settings (JSON-able), for provenance."""
        return asdict(self)


#: The settings of the k/(PR) table that differ from :class:`CapsuleConfig`'s defaults
#: (docs/fem.md, "The surrogate table"): element sizes 3x the production mesh's, except 3 nm
#: under the tip, 12 nm along the substrate and 120 nm far away (the mesh is within 0.2 % of
#: the same with every size halved at x = 0.005, 0.0706 and 0.52, where the 2026-11-23 table's
#: mesh, 36 and 240 nm there, was 1.1-1.45 % off at x <= 0.005); 24 nominal depth steps, and
#: adaptive depth steps below x = 0.4 with the fixed 24-step schedule above it and wherever the
#: adaptive run fails.
TABLE_SETTINGS = {"mesh_scale": 3.0, "h_min": 1e-9, "h_bottom": 4e-9, "h_max": 4e-8,
                  "n_indent_steps": 24, "step_tolerance": 0.1, "adaptive_below_x": 0.4}


def table_config(**overrides):
    """:class:`CapsuleConfig` with the shipped table's settings (:data:`TABLE_SETTINGS`),
    any of them or any other setting replaced by ``overrides``."""
    return CapsuleConfig(**{**TABLE_SETTINGS, **overrides})


def checked_config(cfg):
    """``cfg``, or the default :class:`CapsuleConfig` for None.

    Raises
    ------
    FEConfigError
        ``cfg`` is not a :class:`CapsuleConfig`.
    """
    if cfg is None:
        return CapsuleConfig()
    if not isinstance(cfg, CapsuleConfig):
        raise FEConfigError(f"cfg must be a CapsuleConfig, got {type(cfg).__name__}")
    return cfg


def check_ratio(ratio):
    """Refuse an anisotropy ``ratio`` = ``E_par / E_perp`` [-] outside [0.01, 100].

    Raises
    ------
    FEConfigError
    """
    if not (isinstance(ratio, int | float) and math.isfinite(ratio) and 0.01 <= ratio <= 100):
        raise FEConfigError(f"ratio E_par/E_perp must be a number in [0.01, 100], got {ratio!r}")
