"""The rod-shaped cell of the synthetic force maps: its shape and stiffness, and its height
above the substrate (docs/curves.md, Whole force maps)."""

from dataclasses import dataclass

import numpy as np

__all__ = ["RodCell", "rod_height"]


@dataclass(frozen=True)
class RodCell:
    """A rod-shaped cell lying on the substrate, and its stiffness (SI units).

    Attributes
    ----------
    R : float [m]
        Radius.
    length : float [m]
        Length of the cylindrical part (the caps add ``R`` at each end).
    angle : float [rad]
        Long axis' angle from the x axis.
    center : (float, float) [m]
        Middle of the axis (x, y).
    k_c : float [N/m]
        Secant stiffness at ``R/20`` (law :func:`~turgorbayes.simulation.curves.cell_force`) of
        the curves whose pixel is within ``crest_width R`` of the axis.
    flank_ratio : float [-]
        The other pixels on the cell have ``flank_ratio k_c`` (a stand-in for indenting a
        sloped surface: a crest rule that takes flank curves is biased).
    crest_width : float [-]
    """

    R: float = 450e-9
    length: float = 1.0e-6
    angle: float = np.deg2rad(30.0)
    center: tuple = (0.0, 0.0)
    k_c: float = 0.02
    flank_ratio: float = 0.5
    crest_width: float = 0.3


def rod_height(x, y, cell, tip_radius=0.0):
    r"""Height [m] above the substrate of a spherocylinder lying on it, as a spherical tip of
    radius ``tip_radius`` touches it.

    With ``rho`` the distance from the axis segment in the plane, the tip's apex touches at
    :math:`R - r + \sqrt{(R + r)^2 - \rho^2}` (0 where that is below the substrate or
    ``rho >= R + r``); ``r = 0`` is the bare surface :math:`R + \sqrt{R^2 - \rho^2}`.

    Parameters
    ----------
    x, y : array_like [m]
    cell : RodCell
    tip_radius : float [m]

    Returns
    -------
    ndarray [m]
    """
    dx, dy = np.asarray(x, float) - cell.center[0], np.asarray(y, float) - cell.center[1]
    s = dx * np.cos(cell.angle) + dy * np.sin(cell.angle)
    d = -dx * np.sin(cell.angle) + dy * np.cos(cell.angle)
    rho2 = np.maximum(np.abs(s) - cell.length / 2, 0.0) ** 2 + d * d
    reach = (cell.R + tip_radius) ** 2 - rho2
    h = cell.R - tip_radius + np.sqrt(np.maximum(reach, 0.0))
    return np.where(reach > 0, np.maximum(h, 0.0), 0.0)
