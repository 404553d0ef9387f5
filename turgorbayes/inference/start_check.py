"""Why a fit cannot start: the cells whose likelihood is zero near the starting point.

When no starting walker has a finite log posterior, :func:`start_error` names the cells whose
pointwise log-likelihood is ``-inf`` at the start (the mode, its Hessian stencil and the
walkers tried) and why, from :func:`turgorbayes.physics.forward.explain_nan` at each cell's pressure
(``docs/statistics.md``, "Sampling").
"""

import numpy as np

from turgorbayes.errors import DataError
from turgorbayes.inference.mode import HESSIAN_REL_STEP
from turgorbayes.physics import forward

__all__ = ["infinite_cells", "start_error"]

_LISTED = 5


def _start_points(u_map, tried=None):
    """The mode, its axis stencil (the Hessian's steps) and the finite walkers tried."""
    u_map = np.asarray(u_map, float).reshape(-1)
    h = HESSIAN_REL_STEP * np.maximum(np.abs(u_map), 1.0)
    points = [u_map[None], u_map + np.diag(h), u_map - np.diag(h)]
    if tried is not None:
        tried = np.atleast_2d(np.asarray(tried, float))
        points.append(tried[np.all(np.isfinite(tried), axis=1)])
    return np.vstack(points)


def infinite_cells(model, points):
    """Per cell, at how many of ``points`` its log-likelihood is not finite.

    Parameters
    ----------
    model : turgorbayes.inference.models.BaselineModel
        Or any model with ``pointwise_log_likelihood``.
    points : ndarray (W, ndim)
        Sampler coordinates.

    Returns
    -------
    ndarray of int (n_cells,)
    """
    with np.errstate(all="ignore"):
        ll = np.asarray(model.pointwise_log_likelihood(np.atleast_2d(points)), float)
    return np.count_nonzero(~np.isfinite(ll), axis=0)


def _cell_pressures(model, v):
    """Each cell's pressure [Pa]: P_phys for intact cells, the bulge's own for bulged cells."""
    obs = model.obs
    P = np.full(obs.n_cells, float(v["P_phys"][0]))
    P[obs.bulged] = np.exp(obs.log_P_bulge)
    return P


def _reasons(model, u, cells):
    """``cell index -> why`` at the sampler coordinates ``u`` (ndim,)."""
    v = model.to_physical(u[None])
    P = _cell_pressures(model, v)
    with np.errstate(all="ignore"):
        codes, text = forward.explain_nan(P, v["gamma"][0], v["E0t"][0], v["R0"][0],
                                          model.P0, model.surrogate)
    out = {}
    for i in cells:
        where = "its bulge pressure" if model.obs.is_bulged[i] else "P_phys"
        why = (text[int(codes[i])] if codes[i] != forward.DEFINED else
               "the model's R_c, k_c are defined there, but not over the whole range of "
               "pressures its bulge allows")
        out[i] = f"at {where} {P[i] / 1e3:.4g} kPa: {why}"
    return out


def _parameters_text(model, u):
    v = model.to_physical(u[None])
    return ", ".join(f"{k} = {float(x[0]):.4g}" for k, x in v.items())


def start_error(model, u_map, tried=None):
    """A :class:`~turgorbayes.errors.DataError` naming the cells the model cannot produce.

    Parameters
    ----------
    model : turgorbayes.inference.models.BaselineModel
        The model whose sampler or optimizer found no finite starting point.
    u_map : ndarray (ndim,)
        The starting point (the posterior mode found from the least-squares estimate).
    tried : ndarray (W, ndim), optional
        Starting walkers that were tried.

    Returns
    -------
    DataError
        Lists up to five cells with ``-inf`` log-likelihood near the start, most often first,
        with the reason from :data:`turgorbayes.physics.forward.REASONS` at the cell's pressure.
    """
    u_map = np.asarray(u_map, float).reshape(-1)
    points = _start_points(u_map, tried)
    counts = infinite_cells(model, points)
    bad = np.flatnonzero(counts)
    bad = bad[np.argsort(-counts[bad], kind="stable")]
    cell_id = model.cells.cell_id
    head = (f"the model {getattr(model, 'name', '')!r} has no starting point with a finite "
            f"posterior (near {_parameters_text(model, u_map)})")
    if bad.size == 0:
        return DataError(f"{head}; no single cell is to blame: the prior or the starting "
                         "spread is not finite", path=model.cells.path)
    reasons = _reasons(model, u_map, bad[:_LISTED])
    lines = [f"  cell_id {cell_id[i]!r} (-inf at {counts[i]} of {len(points)} start points), "
             f"{reasons[i]}" for i in bad[:_LISTED]]
    if bad.size > _LISTED:
        lines.append(f"  ... and {bad.size - _LISTED} more")
    return DataError(
        f"{head}: {bad.size} of {len(cell_id)} cells have zero likelihood there, the model "
        "cannot produce their R_c and k_c. Check these cells' units and values (turgorbayes "
        "validate), or remove them:\n" + "\n".join(lines),
        path=model.cells.path, column="cell_id", value=cell_id[bad[0]],
    )
