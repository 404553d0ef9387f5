r"""Verification problems with independent answers, run through the same FE machinery.

* :func:`pinched_cylinder`: Lindberg, Olson & Cowper (1969) pinched cylinder with rigid end
  diaphragms, R/t = 100, L/R = 2, nu = 0.3, two opposite point loads F at mid-length; the
  thin-shell answer is :math:`w E t / F = 164.24` (:data:`PINCHED_CYLINDER_REFERENCE`).
* :func:`sphere_point_stiffness` and :func:`vella_stiffness`: linear stiffness of a
  pressurized spherical shell under a point load at the pole, against the shallow-shell
  closed form of Vella et al., J. R. Soc. Interface 9, 448 (2012).

Both use octant models with three symmetry planes, so the sphere is pinched at both poles;
the deflection is that of the loaded pole's mid-surface relative to the equatorial plane.
"""

import numpy as np
from threadpoolctl import threadpool_limits

from turgorbayes.fem.material import orthotropic_stiffness
from turgorbayes.fem.mesh import cylinder_octant_mesh, sphere_octant_mesh
from turgorbayes.fem.solver import ShellProblem

__all__ = [
    "PINCHED_CYLINDER_REFERENCE",
    "pinched_cylinder",
    "sphere_point_stiffness",
    "vella_stiffness",
]

#: w E t / F of the pinched cylinder (Lindberg, Olson & Cowper 1969: w = 1.8248e-5 for
#: R = 300, L = 600, t = 3, E = 3e6, nu = 0.3, F = 1).
PINCHED_CYLINDER_REFERENCE = 164.24


def vella_stiffness(P, R, t, E, nu=0.0):
    r"""Point-load stiffness of a pressurized spherical shell [N/m] (Vella et al. 2012).

    .. math::

        B = \frac{E t^3}{12(1-\nu^2)},\quad Y = E t,\quad
        \tau = \frac{P R^2}{4\sqrt{BY}},\quad k_0 = \frac{8\sqrt{BY}}{R},

        k = k_0\,\frac{\pi}{2}\frac{\sqrt{1-\tau^2}}{\arccos\tau}\ (\tau<1),\qquad
        k = k_0\,\frac{\pi}{2}\frac{\sqrt{\tau^2-1}}{\operatorname{arccosh}\tau}\ (\tau>1).

    Parameters
    ----------
    P : float [Pa]
    R : float [m]
    t : float [m]
    E : float [Pa]
    nu : float [-]

    Returns
    -------
    k : float [N/m]
    tau : float [-]
    """
    B = E * t**3 / (12.0 * (1.0 - nu**2))
    Y = E * t
    root = np.sqrt(B * Y)
    tau = P * R**2 / (4.0 * root)
    k0 = 8.0 * root / R
    if np.isclose(tau, 1.0, rtol=1e-9, atol=0.0):
        return k0 * np.pi / 2.0, tau
    if tau < 1.0:
        return k0 * np.pi / 2.0 * np.sqrt(1.0 - tau**2) / np.arccos(tau), tau
    return k0 * np.pi / 2.0 * np.sqrt(tau**2 - 1.0) / np.arccosh(tau), tau


def _symmetry_fixed(X, tol, axes=(0, 1, 2)):
    fixed = np.zeros(X.shape, dtype=bool)
    for ax in axes:
        fixed[np.abs(X[:, ax]) < tol, ax] = True
    return fixed


def _through_thickness_line(X, point, tol):
    """Nodes on the wall normal through ``point`` (on the z axis), innermost first."""
    idx = np.flatnonzero(np.hypot(X[:, 0] - point[0], X[:, 1] - point[1]) < tol)
    return idx[np.argsort(X[idx, 2])]


def _line_weights(n_nodes_on_line):
    """Consistent load shares of a quadratic line: Simpson weights per element, summed."""
    n_el = (n_nodes_on_line - 1) // 2
    w = np.zeros(n_nodes_on_line)
    for e in range(n_el):
        w[2 * e:2 * e + 3] += np.array([1.0, 4.0, 1.0]) / 6.0
    return w / n_el


def pinched_cylinder(h_min=5.0, h_max=25.0, growth=0.3, n_thick=1, solver="auto"):
    """w E t / F of the pinched cylinder by the FE model (octant, dimensionless units).

    The load F/4 acts on the octant at the crest of the mid-length section, spread through
    the wall thickness with the quadratic line's consistent weights; w is the mid-surface
    deflection there.

    Parameters
    ----------
    h_min, h_max : float
        Element sizes at the load and far away (units of the benchmark, R = 300).
    growth : float
    n_thick : int
    solver : str
    """
    R, L, t, E, nu, F = 300.0, 600.0, 3.0, 3e6, 0.3, 1.0
    mesh = cylinder_octant_mesh(R, L, t, h_min, h_max, growth, n_thick)
    X, tol = mesh.X, 1e-6 * t
    fixed = _symmetry_fixed(X, tol)
    end = np.abs(X[:, 0] - 0.5 * L) < tol
    fixed[end, 1] = fixed[end, 2] = True  # rigid diaphragm: no motion in its plane
    line = _through_thickness_line(X, (0.0, 0.0), tol)
    f = np.zeros((mesh.n_nodes, 3))
    f[line, 2] = -0.25 * F * _line_weights(line.size)
    with threadpool_limits(limits=1):
        problem = ShellProblem(mesh, solver)
        u, _ = problem.newton(np.zeros_like(X), orthotropic_stiffness(E, E, E, nu),
                              fixed.ravel(), f_ext=f.ravel(), rtol=1e-10)
        problem.solver.close()
    w = -u[line[line.size // 2], 2]
    return w * E * t / F


def sphere_point_stiffness(P, R=500e-9, t=6e-9, E=20e6, nu=0.0, h_min=1.5e-9, h_max=60e-9,
                           growth=0.3, n_thick=1, load_radius=None, rel_force=1e-3,
                           solver="auto"):
    """Linear point-load stiffness of the pressurized sphere by the FE model.

    The octant (x, y, z >= 0) is inflated by the follower pressure P, then a small force
    (``rel_force`` times ``k0 t``) is added at the pole, either through the wall thickness
    (``load_radius=None``, the shell's point load) or as a uniform traction on the outer
    surface within ``load_radius``; the stiffness is that force over the change of the pole's
    mid-surface deflection.

    Parameters
    ----------
    P : float [Pa]
    R, t : float [m]
        Unpressurized mid-surface radius and wall thickness.
    E : float [Pa]
    nu : float [-]
    h_min, h_max : float [m]
        Element sizes at the pole and far away.
    growth : float
    n_thick : int
    load_radius : float [m], optional
    rel_force : float
    solver : str

    Returns
    -------
    dict
        ``k`` [N/m], ``k_vella`` [N/m], ``tau`` (both with the FE's inflated radius),
        ``R_inflated`` [m], ``dofs``.
    """
    mesh = sphere_octant_mesh(R, t, h_min, h_max, growth, n_thick)
    X, tol = mesh.X, 1e-6 * t
    fixed = _symmetry_fixed(X, tol).ravel()
    D = orthotropic_stiffness(E, E, E, nu)
    line = _through_thickness_line(X, (0.0, 0.0), tol)
    pole = line[line.size // 2]
    with threadpool_limits(limits=1):
        problem = ShellProblem(mesh, solver)
        u = np.zeros_like(X)
        n_steps = 1 if P == 0 else 2
        for i in range(1, n_steps + 1):
            u, _ = problem.newton(u, D, fixed, P=P * i / n_steps, rtol=1e-10)
        R_inflated = float(X[pole, 2] + u[pole, 2])
        k0 = 8.0 * E * t**2 / np.sqrt(12.0 * (1.0 - nu**2)) / R
        F = rel_force * k0 * t
        f = _pole_load(problem, mesh, line, load_radius, F)
        u1, _ = problem.newton(u, D, fixed, P=P, f_ext=f.ravel(), rtol=1e-10)
        problem.solver.close()
    w = -(u1[pole, 2] - u[pole, 2])
    k_vella, tau = vella_stiffness(P, R_inflated, t, E, nu)
    return {"k": F / w, "k_vella": k_vella, "tau": tau, "R_inflated": R_inflated,
            "dofs": mesh.n_dofs}


def _pole_load(problem, mesh, line, load_radius, F):
    """Nodal forces (quarter of F, along -z) of the pole load on the octant."""
    f = np.zeros((mesh.n_nodes, 3))
    if load_radius is None:
        f[line, 2] = -0.25 * F * _line_weights(line.size)
        return f
    outer, area = problem.outer, problem.outer_area
    r = np.hypot(mesh.X[outer, 0], mesh.X[outer, 1])
    inside = r < load_radius
    if not np.any(inside):
        raise ValueError(f"no outer node within load_radius = {load_radius!r} m of the pole")
    share = area[inside] / area[inside].sum()
    f[outer[inside], 2] = -0.25 * F * share
    return f
