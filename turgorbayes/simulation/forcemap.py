"""A synthetic force map of a rod-shaped cell on a tilted substrate, with its truth (docs/curves.md,
Whole force maps).

The cell is a spherocylinder (a cylinder of radius ``R`` and length ``length`` with
hemispherical caps) lying on the substrate; each grid pixel gets a curve of
:func:`turgorbayes.simulation.curves.synthetic_curve` whose contact point is at the surface's
height there. The map is written as one afmformats ``.h5`` file with afmformats' grid
metadata (``position x/y``, ``grid index/shape/size/center x/y``), which afmformats reads back
like a JPK map's.
"""

import functools
from dataclasses import dataclass, replace

import numpy as np

from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, cell_force, synthetic_curve
from turgorbayes.simulation.rod import RodCell, rod_height

#: The default cell of :func:`write_force_map`.
DEFAULT_CELL = RodCell()

__all__ = ["RodCell", "SyntheticMap", "rod_height", "write_force_map"]


@dataclass(frozen=True)
class SyntheticMap:
    """The truth of a written map (per-pixel arrays in the file's curve order).

    Attributes
    ----------
    x, y : ndarray [m]
        Pixel positions.
    contact_height : ndarray [m]
        True contact height (NaN on pixels written without a contact).
    elevation : ndarray [m]
        Height of the (tip-dilated) cell surface above the substrate.
    k : ndarray [N/m]
        True secant at ``R/20`` (NaN off the cell).
    no_contact : ndarray of int
        Curve indices written without a contact (flat force).
    shallow : ndarray of int
        Curve indices indented to half the reading depth only.
    bulge : ndarray of bool or None
        Pixels on the bulge (``k`` is their secant at ``h_b``); None: a map without one.
    """

    x: np.ndarray
    y: np.ndarray
    contact_height: np.ndarray
    elevation: np.ndarray
    k: np.ndarray
    no_contact: np.ndarray
    shallow: np.ndarray
    bulge: np.ndarray = None


def _grid(n, extent):
    """Pixel centres [m] of an ``n x n`` grid of side ``extent`` centred on 0, and indices."""
    pitch = extent / n
    centres = (np.arange(n) - (n - 1) / 2) * pitch
    iy, ix = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    return centres[ix.ravel()], centres[iy.ravel()], ix.ravel(), iy.ravel(), pitch


def _grid_metadata(x, y, ix, iy, n, extent):
    return {"position x": float(x), "position y": float(y), "grid index x": int(ix),
            "grid index y": int(iy), "grid shape x": n, "grid shape y": n,
            "grid size x": float(extent), "grid size y": float(extent),
            "grid center x": 0.0, "grid center y": 0.0}


def _pixel_law(cell, on_cell, crest, substrate_k):
    """(force law, depth [m], true k or NaN) of one pixel."""
    h_ref = cell.R / 20
    if not on_cell:
        return (lambda h: substrate_k * np.maximum(h, 0.0)), 1e-9, np.nan
    k = cell.k_c if crest else cell.flank_ratio * cell.k_c
    return functools.partial(cell_force, k_c=k, h_ref=h_ref, a=0.1), 2 * h_ref, k


def write_force_map(path, cell=DEFAULT_CELL, n=16, extent=2.6e-6, tilt=(0.02, -0.01),
                    acquisition=DEFAULT_ACQUISITION, seed=0, tip_radius=0.0, no_contact=(),
                    shallow=(), substrate_k=1.0, bulge=None):
    """Write a synthetic force map of ``cell`` as an afmformats ``.h5`` file.

    Parameters
    ----------
    path : path-like
        Ends in ``.h5``.
    cell : RodCell
    n : int
        Pixels per side.
    extent : float [m]
        Side of the square grid (pitch ``extent / n``).
    tilt : (float, float) [-]
        Substrate slope in x and y (substrate height ``tilt_x x + tilt_y y``).
    acquisition : turgorbayes.simulation.curves.Acquisition
        Cantilever and noise (``height_top`` is set per pixel).
    seed : int
    tip_radius : float [m]
        Spherical tip radius dilating the surface (:func:`rod_height`).
    no_contact : sequence of int
        Pixels (in grid order ``ix + n iy``) written with a flat force (no contact).
    shallow : sequence of int
        Pixels indented to ``R/40`` only (``too_shallow`` for ``R/20``).
    substrate_k : float [N/m]
        Stiffness of the (hard) substrate's linear law, indented to 1 nm.
    bulge : turgorbayes.simulation.bulge_map.MapBulge, optional
        A membrane bulge on the cell (not dilated by the tip).

    Returns
    -------
    SyntheticMap
        Arrays in the file's curve order (the order afmformats lists them in).
    """
    import afmformats
    import h5py

    x, y, ix, iy, _ = _grid(n, extent)
    elevation = rod_height(x, y, cell, tip_radius)
    on_bulge = np.zeros(x.size, bool)
    if bulge is not None:
        from turgorbayes.simulation.bulge_map import bulge_pixel_law, bulge_surface

        elevation, on_bulge = bulge_surface(x, y, cell, bulge, elevation)
    s_d = _axis_distance(x, y, cell)
    seeds = np.random.SeedSequence(seed).generate_state(x.size)
    rng = np.random.default_rng(seed)
    truth = {"h": np.full(x.size, np.nan), "k": np.full(x.size, np.nan)}
    with h5py.File(path, "w") as h5:
        for p in range(x.size):
            law, depth, k = _pixel_law(cell, elevation[p] > 0, abs(s_d[p]) <= cell.crest_width * cell.R,
                                       substrate_k)
            if on_bulge[p]:
                law, depth, k = bulge_pixel_law(cell, bulge, x[p], y[p])
            if p in shallow:
                depth = cell.R / 40
            if p in no_contact:
                law, k = (lambda h: 0.0 * h), np.nan
            # the contact at a random travel (off the 0.5 nm sampling grid), at the surface's height
            free = acquisition.free_length + rng.uniform(0.0, 20e-9)
            top = tilt[0] * x[p] + tilt[1] * y[p] + elevation[p] + free + 5e-6
            acq = replace(acquisition, height_top=top, free_length=free)
            curve = synthetic_curve(law, depth, acq, seed=int(seeds[p]), contact_jitter=0.0)
            meta = dict(curve.metadata, path=str(path), enum=p,
                        **_grid_metadata(x[p], y[p], ix[p], iy[p], n, extent))
            afmformats.AFMForceDistance(curve.data, meta).export_data(h5, fmt="h5")
            truth["h"][p] = np.nan if p in no_contact else curve.contact_height
            truth["k"][p] = k
    order = np.argsort([str(p) for p in range(x.size)])  # afmformats lists groups "0", "1", "10", ...
    return SyntheticMap(x=x[order], y=y[order], contact_height=truth["h"][order],
                        elevation=elevation[order], k=truth["k"][order],
                        no_contact=np.flatnonzero(np.isin(order, list(no_contact))),
                        shallow=np.flatnonzero(np.isin(order, list(shallow))),
                        bulge=None if bulge is None else on_bulge[order])


def _axis_distance(x, y, cell):
    """Signed distance [m] of pixels from the cell's axis line."""
    dx, dy = x - cell.center[0], y - cell.center[1]
    return -dx * np.sin(cell.angle) + dy * np.cos(cell.angle)
