r"""Frictionless penalty contact with rigid bodies: the AFM cone with its spherical tip, and a plane.

Node-to-surface contact: every outer-surface node ``a`` with reference area ``A_a`` (its share
of the outer surface, :func:`turgorbayes.fem.loads.node_areas`) that penetrates a rigid body by
``-g > 0`` is pushed out along the body's outward normal with the force ``A_a p(g)``, where
the contact pressure ``p`` grows like ``epsilon (-g)`` (smoothed near g = 0,
:func:`contact_pressure`), so ``epsilon`` [Pa/m] is a contact-pressure stiffness independent
of the mesh. The tangent includes the curvature of the rigid surface.

The indenter is axisymmetric about the z axis, pointing down: a sphere of radius ``rho``
(centre on the axis) continued tangentially by a cone of half-angle ``alpha``; in the
half-plane (r, zeta = z - z_centre) the tangent circle is at
``T = rho (cos alpha, -sin alpha)``, the cone generator direction is ``(sin alpha, cos alpha)``
and its outward normal ``(cos alpha, -sin alpha)``.
"""

import numpy as np

__all__ = ["contact_pressure", "indenter_contact", "plane_contact"]


def contact_pressure(g, penalty, smoothing):
    """Penalty contact pressure [Pa] at gap ``g`` and its slope ``-dp/dg`` [Pa/m].

    ``p = penalty (-g - smoothing/2)`` for ``g <= -smoothing``, ``penalty g^2 / (2 smoothing)``
    for ``-smoothing < g < 0`` and 0 for ``g >= 0``: continuously differentiable, so a node
    touching the boundary of the contact zone does not make Newton's method cycle between
    contact and separation.
    """
    g = np.asarray(g, dtype=float)
    deep = g <= -smoothing
    p = np.where(deep, -g - 0.5 * smoothing, 0.5 * g**2 / smoothing)
    slope = np.where(deep, 1.0, -g / smoothing)
    inside = g < 0
    return penalty * np.where(inside, p, 0.0), penalty * np.where(inside, slope, 0.0)


def _penalty(area, g, n, curvature, penalty, smoothing):
    """Forces ``A p(g) n`` on active nodes and the residual tangent ``-d f / d x``."""
    p, slope = contact_pressure(g, penalty, smoothing)
    f = (area * p)[:, None] * n
    K = ((area * slope)[:, None, None] * (n[:, :, None] * n[:, None, :])
         - (area * p)[:, None, None] * curvature)
    return f, K


def indenter_contact(x, area, z_tip, tip_radius, half_angle, penalty, smoothing, offset=None):
    """Contact forces of the cone-with-spherical-tip indenter on nodes.

    Parameters
    ----------
    x : ndarray (m, 3) [m]
        Current positions of candidate nodes.
    area : ndarray (m,) [m^2]
        Their reference areas.
    z_tip : float [m]
        Height of the lowest point of the indenter (on the z axis).
    tip_radius : float [m]
    half_angle : float [rad]
    penalty : float [Pa/m]
    smoothing : float [m]
        Penetration over which the contact pressure is smoothed (:func:`contact_pressure`).
    offset : ndarray (m,) [m], optional
        Augmented-Lagrangian shift per node: the penalty acts on ``gap - offset``, so a node
        carrying the pressure ``penalty * offset`` sits on the surface (Uzawa updates set
        ``offset`` from the last penetration).

    Returns
    -------
    idx : ndarray of int
        Positions (into ``x``) of the active nodes.
    f : ndarray (k, 3) [N]
        Forces on them (acting on the body).
    K : ndarray (k, 3, 3) [N/m]
        Their contribution to the residual's tangent.
    gap : ndarray (m,) [m]
        Signed gap of every candidate (negative = penetration).
    """
    rho, sa, ca = tip_radius, np.sin(half_angle), np.cos(half_angle)
    centre = np.array([0.0, 0.0, z_tip + rho])
    d = x - centre
    r = np.hypot(d[:, 0], d[:, 1])
    e_r = np.zeros_like(d)
    nz = r > 0
    e_r[nz, 0], e_r[nz, 1] = d[nz, 0] / r[nz], d[nz, 1] / r[nz]
    tau = (r - rho * ca) * sa + (d[:, 2] + rho * sa) * ca
    on_cone = tau > 0
    dist = np.linalg.norm(d, axis=1)
    gap = np.where(on_cone, (r - rho * ca) * ca - (d[:, 2] + rho * sa) * sa, dist - rho)
    g_eff = gap if offset is None else gap - offset
    idx = np.flatnonzero(g_eff < 0)
    n = np.where(on_cone[idx, None], ca * e_r[idx] - sa * np.array([0.0, 0.0, 1.0]),
                 d[idx] / np.maximum(dist[idx], 1e-300)[:, None])
    curvature = np.empty((idx.size, 3, 3))
    eye = np.eye(3)
    for k, i in enumerate(idx):
        if on_cone[i]:
            pxy = np.diag([1.0, 1.0, 0.0]) - np.outer(e_r[i], e_r[i])
            curvature[k] = ca * pxy / max(r[i], 1e-300)
        else:
            curvature[k] = (eye - np.outer(n[k], n[k])) / max(dist[i], 1e-300)
    f, K = _penalty(area[idx], g_eff[idx], n, curvature, penalty, smoothing)
    return idx, f, K, gap


def plane_contact(x, area, z_plane, penalty, smoothing, tangent_floor=1e-3):
    """Contact forces of the rigid plane ``z = z_plane`` (body above it) on nodes.

    Same conventions as :func:`indenter_contact`; the plane has no curvature. Nodes closer
    than ``smoothing`` to the plane get at least ``tangent_floor * penalty * A`` of normal
    stiffness in the tangent (not in the force): a body that only touches the plane would
    otherwise have a singular tangent (free vertical translation) before it is pressed.
    """
    gap = x[:, 2] - z_plane
    idx = np.flatnonzero(gap < smoothing)
    n = np.broadcast_to(np.array([0.0, 0.0, 1.0]), (idx.size, 3))
    f, K = _penalty(area[idx], gap[idx], n, np.zeros((idx.size, 3, 3)), penalty, smoothing)
    K[:, 2, 2] = np.maximum(K[:, 2, 2], tangent_floor * penalty * area[idx])
    return idx, f, K, gap
