"""Each walker's ``ln R_c`` and ``ln k_c`` tabulated on a uniform grid in ``ln P``.

The baseline likelihood shares one wall per walker across all cells, so the forward model is
tabulated once per walker without a root search and read by cubic interpolation
(docs/statistics.md, "Speed").
"""

import numpy as np

from turgorbayes.physics import forward, wall

__all__ = ["LogPressureGrid", "WallGrid"]


def _lagrange4_weights(pos, n_grid, slope=False):
    """Cubic Lagrange weights (and their derivatives if ``slope``) at grid positions."""
    i = np.asarray(pos).astype(np.intp)  # floor for pos >= 0; clipped anyway
    np.clip(i, 1, n_grid - 3, out=i)
    t = pos - i
    tm1, tm2, tp1 = t - 1, t - 2, t + 1
    a, b = t * tm1, tp1 * tm2
    # a * tm2 * (-1 / 6), b * tm1 * 0.5, b * t * (-0.5), a * tp1 * (1 / 6), each product
    # scaled in place (the same operations in the same order)
    w = (np.multiply(a, tm2, out=tm2), np.multiply(b, tm1, out=tm1), b * t,
         np.multiply(a, tp1, out=tp1))
    for wk, c in zip(w, (-1 / 6, 0.5, -0.5, 1 / 6), strict=True):
        wk *= c
    if not slope:
        return i, w, None
    t2 = t * t
    dw = (-(3 * t2 - 6 * t + 2) / 6, (3 * t2 - 4 * t - 1) / 2,
          -(3 * t2 - 2 * t - 2) / 2, (3 * t2 - 1) / 6)
    return i, w, dw


def _grid_position(log_P, g0, h):
    """``(log_P - g0) / h`` (in place in the difference)."""
    pos = np.subtract(log_P, g0)
    pos /= h
    return pos


def _interpolate(tables, flat, w, dw=None):
    """``sum_k w[k] * table[flat + k - 1]`` for each table (and ``sum_k dw[k] * ...`` if
    ``dw``), accumulated from 0 in stencil order as ``val = val + w[k] * v``, in place (the
    index arrays shared by the tables).

    Returns
    -------
    list
        ``[val, ...]``, one per table, or ``[val, der, ...]`` with ``dw``.
    """
    idx = [flat + (k - 1) for k in range(4)]
    out = []
    for table in tables:
        val = der = 0.0
        for k, ix in enumerate(idx):
            v = np.take(table, ix)
            if dw is not None:
                der = _add(der, dw[k] * v)
            val = _add(val, np.multiply(v, w[k], out=v))
        out += [val] if dw is None else [val, der]
    return out


def _add(total, term):
    """``total + term`` for a fresh array ``term`` of the full shape: into ``term`` while
    ``total`` is the starting ``0.0``, then into ``total``."""
    if np.ndim(total) == 0:
        term += total
        return term
    total += term
    return total


def _hermite(t, delta, y0, y1, m0, m1, slope):
    """Cubic Hermite interpolant on ``[x0, x0 + delta]`` (and its derivative in x)."""
    t2, t3 = t * t, t * t * t
    val = ((2 * t3 - 3 * t2 + 1) * y0 + (t3 - 2 * t2 + t) * delta * m0
           + (3 * t2 - 2 * t3) * y1 + (t3 - t2) * delta * m1)
    if not slope:
        return val, None
    der = ((6 * t2 - 6 * t) * (y0 - y1) / delta + (3 * t2 - 4 * t + 1) * m0
           + (3 * t2 - 2 * t) * m1)
    return val, der


class LogPressureGrid:
    """Each walker's ``ln R_c`` and ``ln k_c`` on a uniform grid in ``ln P``.

    Lookups are 4-point Lagrange (cubic) interpolation in ``ln P`` (one gather per table
    and stencil point). Building the table needs the radius at every grid pressure; it is
    found without a general root search: the pressure is explicit along
    ``s = ln(R_c/R0)`` (:func:`turgorbayes.physics.forward.pressure_on_branch`), so a second table
    at equally spaced ``s`` (only its two end radii come from Newton) gives every grid
    point's ``s`` by cubic Hermite interpolation with exact slopes, and two Newton steps
    on the explicit law polish it to machine precision. Pressures beyond the largest one
    the wall can bear give NaN.

    Parameters
    ----------
    lo, hi : float [ln Pa]
        Range of the query pressures (the grid adds guard points).
    step : float
        Spacing in ``ln P``.
    gamma, E0t, R0 : ndarray (W,)
    P0 : float [Pa]
    surrogate : Surrogate
    """

    _ROW = 1e4  # row offset in ln P for the flat searchsorted (ln P spans << 1e4)

    def __init__(self, lo, hi, step, gamma, E0t, R0, P0, surrogate):
        self.h = float(step)
        n = int(np.ceil((hi - lo) / step)) + 4
        self.g0 = lo - 1.5 * step
        grid = self.g0 + step * np.arange(n)
        g, e, r = gamma[:, None], E0t[:, None], R0[:, None]
        s = _log_radius_on_grid(grid, g, e, r, P0)
        k = forward.stiffness_at_radius(np.exp(grid), r * np.exp(s), g, e, r, P0, surrogate)
        with np.errstate(divide="ignore", invalid="ignore"):
            # flat (W * n,) tables: a 1-D np.take is the fastest gather
            self.values = ((np.log(r) + s).ravel(), np.log(k).ravel())
        self.shape = s.shape

    def __call__(self, log_P, walker_axis=False, slope=False):
        """Interpolated ``(ln R_c, ln k_c)`` (and slopes ``d/d ln P`` if ``slope``).

        ``log_P`` is ``(Q...)`` (shared by all walkers) or ``(W, Q...)`` with
        ``walker_axis``; results are ``(W, Q...)``. With ``slope`` the order is
        ``(ln R_c, d ln R_c, ln k_c, d ln k_c)``.
        """
        W, G = self.shape
        log_P = np.asarray(log_P, float)
        i, w, dw = _lagrange4_weights(_grid_position(log_P, self.g0, self.h), G, slope)
        if walker_axis:
            flat = i + (G * np.arange(W)).reshape((W,) + (1,) * (i.ndim - 1))
        else:
            flat = i[None] + (G * np.arange(W)).reshape((W,) + (1,) * i.ndim)
        out = _interpolate(self.values, flat, w, dw if slope else None)
        if slope:
            out[1::2] = [der / self.h for der in out[1::2]]
        return tuple(out)


class WallGrid:
    """``ln R_c``, ``ln k_c`` of ``W x V`` walls (walkers x wall variants) of any wall model.

    Rows are tabulated on a uniform ``ln P`` grid (the fast :class:`LogPressureGrid` for the
    baseline wall model, else the wall model at every grid point) and read by 4-point
    Lagrange interpolation. Each row's domain (the ``ln P`` interval where the model is
    finite, ends located by bisection on the model itself) is exact: a query inside it whose
    stencil reaches an undefined grid point is evaluated directly, a query outside is NaN.

    Parameters
    ----------
    lo, hi : float [ln Pa]
        Range of the query pressures.
    step : float
        Spacing in ``ln P``.
    point_model : callable
        ``(log_P (N,), rows (N,)) -> (ln R_c, ln k_c)``: the wall model of row ``rows[j]``
        at ``exp(log_P[j])``.
    shape : tuple of int
        ``(W, V)``.
    table : LogPressureGrid, optional
        The rows already tabulated (baseline wall model); else built with ``point_model``.
    n_bisect : int
        Bisection steps per domain end (the grid step / 2**n_bisect is the accuracy).
    """

    #: Halvings of a domain end's bracket per call of the wall model (16 points per call;
    #: studies/wall_grid_bisection.py compares 1).
    halvings_per_call = 4

    def __init__(self, lo, hi, step, point_model, shape, table=None, n_bisect=20):
        self.point_model = point_model
        self.W, self.V = shape
        rows = self.W * self.V
        if table is None:
            table = _Table(lo, hi, step)
            n = int(np.ceil((hi - lo) / step)) + 4
            x = table.g0 + step * np.arange(n)
            with np.errstate(all="ignore"):
                table.values = point_model(np.tile(x, rows), np.repeat(np.arange(rows), n))
            table.shape = (rows, n)
        self.h, self.g0, self.values, self.G = table.h, table.g0, table.values, table.shape[1]
        self.lo, self.hi = self._domain(n_bisect)

    def _domain(self, n_bisect):
        """Each row's finite interval ``(lo, hi)`` [ln Pa] (+-inf: defined to the grid end)."""
        rows, G = self.W * self.V, self.G
        ok = np.isfinite(self.values[0]) & np.isfinite(self.values[1])
        ok = ok.reshape(rows, G)
        any_ok = ok.any(axis=1)
        first = np.argmax(ok, axis=1)
        last = G - 1 - np.argmax(ok[:, ::-1], axis=1)
        x = self.g0 + self.h * np.arange(G)
        lo = np.where(any_ok, -np.inf, np.inf)
        hi = np.where(any_ok, np.inf, -np.inf)
        for end, out, side in ((first, lo, -1), (last, hi, 1)):
            r = np.flatnonzero(any_ok & ((end > 0) if side < 0 else (end < G - 1)))
            if r.size:
                out[r] = self._bisect(r, x[end[r]], x[end[r] + side], n_bisect)
        return lo, hi

    def _bisect(self, rows, x_in, x_out, n):
        """Last finite ``ln P`` between a finite ``x_in`` and an undefined ``x_out``.

        Splits the bracket into ``2**halvings_per_call`` parts per call of the model (``n``
        halvings in ``ceil(n / halvings_per_call)`` calls): the same point on the same dyadic
        grid as ``n`` bisection steps wherever the model is defined on one side of its edge, at
        a fraction of the calls (each call of a wall model that solves for its state has a
        fixed cost).
        """
        while n > 0:
            k = min(self.halvings_per_call, n)
            frac = np.arange(1, 2**k) / 2**k  # interior points, from x_in towards x_out
            pts = x_in[:, None] + frac * (x_out - x_in)[:, None]
            with np.errstate(all="ignore"):
                lnR, lnk = self.point_model(pts.ravel(), np.repeat(rows, frac.size))
            ok = (np.isfinite(lnR) & np.isfinite(lnk)).reshape(pts.shape)
            # the first undefined point ends the defined run that starts at x_in
            m = np.where(ok.all(axis=1), frac.size, np.argmin(ok, axis=1))
            width = x_out - x_in
            x_in, x_out = x_in + m / 2**k * width, x_in + (m + 1) / 2**k * width
            n -= k
        return x_in

    def __call__(self, log_P):
        """``(ln R_c, ln k_c)`` of shape ``(W, V, Q...)`` at ``log_P (W, Q...)``."""
        W, V, G = self.W, self.V, self.G
        log_P = np.asarray(log_P, float)
        i, w, _ = _lagrange4_weights(_grid_position(log_P, self.g0, self.h), G)
        rows = (V * np.arange(W)[:, None] + np.arange(V)).reshape((W, V) + (1,) * (i.ndim - 1))
        flat = i[:, None] + G * rows
        out = _interpolate(self.values, flat, [wk[:, None] for wk in w])
        return self._fill(np.broadcast_to(log_P[:, None], out[0].shape), rows, out)

    def _fill(self, x, rows, out):
        """Direct model where the stencil reaches an undefined point inside the domain."""
        inside = (x >= self.lo[rows]) & (x <= self.hi[rows])  # each row's ends, broadcast
        redo = (np.isnan(out[0]) | np.isnan(out[1])) & inside
        if redo.any():
            with np.errstate(all="ignore"):
                lnR, lnk = self.point_model(x[redo], np.broadcast_to(rows, x.shape)[redo])
            out[0][redo], out[1][redo] = lnR, lnk
        if not inside.all():
            outside = ~inside
            out[0][outside] = np.nan
            out[1][outside] = np.nan
        return tuple(out)


class _Table:
    """Grid geometry of a table built point by point (see :class:`WallGrid`)."""

    def __init__(self, lo, hi, step):
        self.h = float(step)
        self.g0 = lo - 1.5 * step


_S_SCAN = np.linspace(-3.0, 3.0, 121)  # coarse ln(R_c/R0) scan for the table's end radii


def _end_radii(lo, hi, g, e, r, P0):
    """``s`` bracketing ``[lo, hi]`` in ln P per walker, from one explicit coarse scan."""
    s_end, log_p_max = forward.branch_end(g, e, r, P0)
    cap = np.where(np.isfinite(s_end), s_end, np.inf)
    scan = np.minimum(_S_SCAN, cap - 1e-9 * np.maximum(np.abs(cap), 1.0))  # (W, K)
    x, _ = forward.pressure_on_branch(scan, g, e, r, P0)
    below = np.where(np.isfinite(x) & (x <= lo), scan, -np.inf).max(axis=1, keepdims=True)
    above = np.where(np.isfinite(x) & (x >= hi), scan, np.inf).min(axis=1, keepdims=True)
    # no scan point below the grid: start at the scan's left end, or, where the wall has a
    # zero-pressure radius (gamma < 1: P -> 0 at a finite s_zero, NaN left of it) that falls
    # between two scan points, just right of s_zero, where ln P lies more than 13.8 below the
    # first finite scan point (without this the walker's whole table was NaN)
    s_lo = np.where(np.isfinite(below), below, _zero_pressure_side(scan, x, g, P0 * r / e))
    # an unreachable (or off-scan) top: tabulate up to just short of the branch end
    top = np.minimum(cap, _S_SCAN[-1])
    s_hi = np.where(np.isfinite(above), above, s_lo + 0.999 * (top - s_lo))
    return s_lo, s_hi, log_p_max


def _zero_pressure_side(scan, x, g, p):
    """Left end of a walker's table when no scan point lies below the grid (:func:`_end_radii`).

    For ``gamma < 1`` the wall law's bracket vanishes at ``rho^gamma = 1 + gamma p/(1 - gamma)``
    (``docs/physics.md``, Domain of the wall law): ``P -> 0`` at
    ``s_zero = -ln(1 + gamma p/(1 - gamma))/gamma`` (``-p`` at ``gamma = 0``) and the law is
    NaN left of it. Where the scan's left end is NaN, the table starts a millionth of the way
    from ``s_zero`` to the first finite scan point; elsewhere at the scan's left end, as before.
    """
    first = np.argmax(np.isfinite(x), axis=1)[:, None]
    s_first = np.take_along_axis(scan, first, 1)
    gm = np.where(g < 1, g, 0.0)
    s_zero = -(p / (1 - gm)) * wall.log1p_ratio(gm * p / (1 - gm))
    use = (g < 1) & ~np.isfinite(x[:, :1]) & (s_zero < s_first)
    return np.where(use, s_zero + 1e-6 * (s_first - s_zero), _S_SCAN[0])


def _log_radius_on_grid(grid, g, e, r, P0, n_polish=2):
    """``s = ln(R_c/R0)`` at the pressures ``exp(grid)`` (shared) for walkers ``(W, 1)``."""
    W, n = g.shape[0], grid.size
    s_lo, s_hi, log_p_max = _end_radii(grid[0], grid[-1], g, e, r, P0)
    s_tab = s_lo + (s_hi - s_lo) * np.linspace(0.0, 1.0, n)
    x_tab, m_tab = forward.pressure_on_branch(s_tab, g, e, r, P0)
    bad = ~np.isfinite(x_tab).all(axis=1)
    x_tab[bad] = np.arange(n) * 1e-3 - 1e3  # invalid walker: keep the rows sorted
    rows = (x_tab + LogPressureGrid._ROW * np.arange(W)[:, None]).ravel()
    base = n * np.arange(W)[:, None]
    q = np.broadcast_to(grid, (W, n))
    j = np.searchsorted(rows, q + LogPressureGrid._ROW * np.arange(W)[:, None]) - 1
    j = np.clip(j - base, 0, n - 2)
    x0, x1 = np.take_along_axis(x_tab, j, 1), np.take_along_axis(x_tab, j + 1, 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        m0 = 1 / np.take_along_axis(m_tab, j, 1)
        m1 = 1 / np.take_along_axis(m_tab, j + 1, 1)
        s, _ = _hermite((q - x0) / (x1 - x0), x1 - x0, np.take_along_axis(s_tab, j, 1),
                        np.take_along_axis(s_tab, j + 1, 1), m0, m1, False)
        for _ in range(n_polish):
            x, m = forward.pressure_on_branch(s, g, e, r, P0)
            s = s + (q - x) / m
    # on the table (not beyond the scan) and below the pressure maximum
    reachable = (q < log_p_max) & (q >= x_tab[:, :1]) & (q <= x_tab[:, -1:]) & ~bad[:, None]
    return np.where(reachable, s, np.nan)
