r"""A membrane bulge on a synthetic force map's cell (docs/curves.md, Bulges on force maps).

The bulge is a sphere of radius ``R_b`` whose centre sits on the cell's surface (less ``sink``)
at a point given along and across the cell's axis; the map's surface is the higher of the cell
and the sphere. Its curves follow the liquid-membrane law the single synthetic bulge curves use
(:func:`turgorbayes.simulation.curves.bulge_force`, pressure ``P``): the pixels within
``apex_width R_b`` of the apex (in the plane) with ``P``, the rest of the dome with
``flank_ratio P`` (a stand-in for indenting the sloped side: an apex rule that takes flank
curves is biased), all indented to ``h_b = h_over_Rb R_b``.
"""

import functools
from dataclasses import dataclass

import numpy as np

from turgorbayes.simulation.curves import bulge_force
from turgorbayes.simulation.rod import rod_height

__all__ = ["MapBulge", "bulge_apex", "bulge_pixel_law", "bulge_surface"]


@dataclass(frozen=True)
class MapBulge:
    """A bulge on a :class:`~turgorbayes.simulation.rod.RodCell` (SI units).

    Attributes
    ----------
    R_b : float [m]
        Sphere radius.
    P : float [Pa]
        Pressure of the apex curves' law.
    along, across : float [m]
        Position of the sphere's centre along and across the cell's axis, from the cell's centre.
    sink : float [m]
        Depth of the sphere's centre below the cell's surface there (0: a hemisphere above it).
    h_over_Rb : float [-]
        Indentation of every bulge curve, ``h_b / R_b`` (the paper's 0.17-0.27).
    apex_width : float [-]
        Pixels within ``apex_width R_b`` of the apex get the law of pressure ``P``.
    flank_ratio : float [-]
        The other pixels of the dome get ``flank_ratio P``.
    """

    R_b: float = 400e-9
    P: float = 10e3
    along: float = 0.0
    across: float = 0.0
    sink: float = 0.0
    h_over_Rb: float = 0.22
    apex_width: float = 0.4
    flank_ratio: float = 0.5

    @property
    def h_b(self):
        """Indentation depth of the bulge curves [m]."""
        return self.h_over_Rb * self.R_b

    @property
    def k_b(self):
        """True secant ``F(h_b)/h_b`` of the apex curves [N/m]."""
        return float(bulge_force(self.h_b, self.P, self.R_b)) / self.h_b


def bulge_apex(cell, bulge):
    """Apex of the bulge: position x, y [m] and height above the substrate [m].

    Parameters
    ----------
    cell : turgorbayes.simulation.rod.RodCell
    bulge : MapBulge

    Returns
    -------
    (float, float, float)
    """
    c, s = np.cos(cell.angle), np.sin(cell.angle)
    x = cell.center[0] + bulge.along * c - bulge.across * s
    y = cell.center[1] + bulge.along * s + bulge.across * c
    base = float(rod_height(x, y, cell)) - bulge.sink
    return float(x), float(y), base + bulge.R_b


def bulge_surface(x, y, cell, bulge, elevation):
    """The map's surface with the bulge: the higher of the cell's and the sphere's.

    Parameters
    ----------
    x, y : ndarray [m]
    cell : RodCell
    bulge : MapBulge
    elevation : ndarray [m]
        The cell's surface above the substrate.

    Returns
    -------
    elevation : ndarray [m]
    on_bulge : ndarray of bool
        Pixels whose surface is the sphere's.
    """
    xb, yb, top = bulge_apex(cell, bulge)
    rho2 = (np.asarray(x) - xb) ** 2 + (np.asarray(y) - yb) ** 2
    inside = rho2 < bulge.R_b**2
    dome = np.where(inside, top - bulge.R_b + np.sqrt(np.where(inside, bulge.R_b**2 - rho2, 0.0)),
                    0.0)
    on_bulge = inside & (dome > elevation)
    return np.where(on_bulge, dome, elevation), on_bulge


def bulge_pixel_law(cell, bulge, x, y):
    """(force law, depth [m], true secant at ``h_b`` [N/m]) of a pixel on the bulge.

    Parameters
    ----------
    cell : RodCell
    bulge : MapBulge
    x, y : float [m]
        The pixel's position.
    """
    xb, yb, _ = bulge_apex(cell, bulge)
    apex = np.hypot(x - xb, y - yb) <= bulge.apex_width * bulge.R_b
    P = bulge.P if apex else bulge.flank_ratio * bulge.P
    law = functools.partial(bulge_force, P=P, R_b=bulge.R_b)
    return law, bulge.h_b, float(law(np.array(bulge.h_b))) / bulge.h_b
