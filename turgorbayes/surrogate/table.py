"""The shipped finite-element table of the reduced cell stiffness and its interpolator.

:func:`load` reads a table of ``k_c/(P R_c)`` against ``x = P R_c/(E_perp t)`` and
``E_par/E_perp`` (written by :mod:`turgorbayes.surrogate.build`; by default the one shipped in
``turgorbayes/data/``) into a :class:`Surrogate`, a smooth vectorized interpolator that never
extrapolates (``docs/fem.md``, "The surrogate table").
"""

import hashlib
import json
import warnings
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline, RectBivariateSpline

from turgorbayes.errors import TurgorBayesError

__all__ = [
    "DEFAULT_FILENAME",
    "FILE_FORMAT",
    "FORMAT_VERSION",
    "Surrogate",
    "SurrogateError",
    "buckled_boxes",
    "buckled_points",
    "default_path",
    "force_drops",
    "leave_one_out",
    "load",
    "open_table",
    "warn_buckled",
]

#: Marker stored in the ``file_format`` attribute of every surrogate file.
FILE_FORMAT = "turgorbayes k/(PR) surrogate"
#: Version of the layout described in :mod:`turgorbayes.surrogate.build`.
FORMAT_VERSION = 1
#: File name of the shipped table inside the package's ``data`` folder.
DEFAULT_FILENAME = "k_over_PR.nc"

# Resolution of the common dense grid in log x (step 2 of the scheme). 256 points over the
# factor-50 range of x make the resampling error ~1e-9, far below the FE error.
_N_DENSE = 256
# Variables every surrogate file must hold (the rest of the layout is optional for loading).
_REQUIRED_VARS = ("k_over_PR", "k_linear_over_PR", "x_actual")


class SurrogateError(TurgorBayesError, ValueError):
    """A surrogate file is missing, unreadable, or not a surrogate table."""


def default_path():
    """Path of the shipped table, ``turgorbayes/data/k_over_PR.nc``.

    Returns
    -------
    pathlib.Path
        Inside the installed package, so it is found both in a source checkout (editable
        install) and in a wheel. ``surrogates/README.md`` in the repository says how it was
        built.
    """
    return Path(str(files("turgorbayes") / "data" / DEFAULT_FILENAME))


def open_table(path):
    """Read a surrogate file into memory as an :class:`xarray.Dataset`, checking its format.

    Parameters
    ----------
    path : str or path-like
        A netCDF file written by ``turgorbayes surrogate build``.

    Returns
    -------
    xarray.Dataset
        Loaded (the file is closed on return).

    Raises
    ------
    SurrogateError
        If the file does not exist, is not netCDF, or lacks the surrogate layout.
    """
    import xarray as xr

    path = Path(path)
    if not path.is_file():
        raise SurrogateError(f"surrogate file not found: {path}")
    try:
        with xr.open_dataset(path, engine="h5netcdf") as ds:
            ds = ds.load()
    except (OSError, ValueError) as err:
        raise SurrogateError(
            f"{path} is not a readable netCDF file ({type(err).__name__}: {err})"
        ) from err
    _check_layout(ds, path)
    return ds


def _check_layout(ds, path):
    fmt = ds.attrs.get("file_format")
    if fmt != FILE_FORMAT:
        raise SurrogateError(
            f"{path} is not a turgorbayes surrogate file: attribute file_format is {fmt!r}, "
            f"expected {FILE_FORMAT!r} (write one with `turgorbayes surrogate build`)"
        )
    missing = [v for v in _REQUIRED_VARS if v not in ds]
    missing += [d for d in ("x", "ratio") if d not in ds.dims]
    if missing:
        raise SurrogateError(f"{path} lacks the surrogate variables/dimensions {missing}")


def _decode_attrs(attrs):
    meta = {}
    for key, value in attrs.items():
        if isinstance(value, str) and value[:1] in "[{":
            try:
                value = json.loads(value)
            except json.JSONDecodeError:
                pass
        elif isinstance(value, np.generic):
            value = value.item()
        meta[key] = value
    return meta


def _sha256(path):
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def load(path=None):
    """Load a surrogate table and return its interpolator.

    Parameters
    ----------
    path : str or path-like, optional
        A file written by ``turgorbayes surrogate build``; None (default) loads the shipped
        table :func:`default_path`.

    Returns
    -------
    Surrogate
        ``s(x, ratio)`` gives ``k_c/(P R_c)`` at indentation ``h = R/20``.

    Raises
    ------
    SurrogateError
        If the file is missing or not a surrogate table.
    """
    path = default_path() if path is None else Path(path)
    ds = open_table(path)
    return Surrogate.from_dataset(ds, path=path, sha256=_sha256(path))


@dataclass(frozen=True)
class _Table2D:
    """Bicubic spline of ``log value`` over ``(log x, log ratio)``, see the module docstring."""

    spline: RectBivariateSpline
    log_x_range: tuple
    log_ratio_range: tuple

    def contains(self, log_x, log_ratio):
        # Absolute slack of 1e-12 in the logs so that the table's own corners count as inside.
        (xlo, xhi), (rlo, rhi) = self.log_x_range, self.log_ratio_range
        in_x = (log_x >= xlo - 1e-12) & (log_x <= xhi + 1e-12)
        return in_x & (log_ratio >= rlo - 1e-12) & (log_ratio <= rhi + 1e-12)

    def log_value(self, log_x, log_ratio, dx=0):
        return self.spline.ev(log_x, log_ratio, dx=dx)


class Surrogate:
    """Interpolator of the finite-element reduced stiffness ``k_c/(P R_c)``.

    Build it with :func:`load`. Calling ``s(x, ratio)`` evaluates

    .. math:: \\frac{k_c}{P R_c}(x, \\rho), \\qquad x = \\frac{P R_c}{E_\\perp t},
              \\quad \\rho = \\frac{E_\\parallel}{E_\\perp},

    at the paper's indentation depth ``h = R/20`` (secant stiffness ``F(h)/h``);
    :meth:`linear` gives the small-indentation stiffness.

    Attributes
    ----------
    path : pathlib.Path or None
        The file read.
    sha256 : str or None
        SHA-256 of the file's bytes (the inference records it).
    metadata : dict
        Provenance: every FE setting, mesh convergence, package version, git commit, date,
        host, command line, wall times (JSON attributes decoded).
    grid : dict
        ``{"x": target inflation numbers, "ratio": anisotropies}`` as tabulated.
    domain : dict
        ``{"x": (lo, hi), "ratio": (lo, hi)}``, the region where values are returned (in x the
        intersection of the ratios' actual FE ranges).
    table : xarray.Dataset
        The whole file in memory (FE points, F(h) curves, timings).

    Notes
    -----
    Interpolation scheme (why: ``k/(PR)`` is close to a power law in ``x``, so its logarithm is
    nearly linear in ``log x`` and a cubic in log-log coordinates is far more accurate than one in
    linear coordinates; the tabulated ratios 0.3 ... 1.0 are close to evenly spaced in ``log rho``):

    1. per tabulated ratio, a not-a-knot cubic spline of ``log f`` against ``log x_actual``, the
       inflation number the FE itself produced (it differs slightly from the requested one);
    2. each spline is resampled onto one dense, common grid in ``log x`` (the intersection of the
       ratios' ``x_actual`` ranges, so that no curve is ever extrapolated);
    3. a bicubic interpolating spline (:class:`scipy.interpolate.RectBivariateSpline`, ``s=0``)
       over ``(log x, log rho)`` evaluates the table and its derivative.

    Outside the table the interpolator returns NaN and warns once per call. So it does in the
    *buckled* region (:meth:`Surrogate.buckled`, :attr:`buckled_boxes`): the grid cells next to
    an FE point whose wall buckled under the tip before ``h = R/20`` (its force curve fell,
    :func:`buckled_points`). There ``k`` at ``h = R/20`` depends on the loading path and on
    sub-nanometre imperfections (docs/fem.md, "The buckled corner"), so the table gives no
    value; the linear stiffness (:meth:`linear`) is unique and is returned there too.
    """

    def __init__(self, table, stiffness, linear, path=None, sha256=None):
        self.table = table
        self._k = stiffness
        self._k_lin = linear
        self.path = path
        self.sha256 = sha256
        self.metadata = _decode_attrs(table.attrs)
        self.grid = {"x": table["x"].values.copy(), "ratio": table["ratio"].values.copy()}
        self.domain = {
            "x": tuple(float(v) for v in np.exp(stiffness.log_x_range)),
            "ratio": tuple(float(v) for v in np.exp(stiffness.log_ratio_range)),
        }
        self.buckled_boxes = buckled_boxes(table)
        self.linear_excluded = []

    @classmethod
    def from_dataset(cls, ds, path=None, sha256=None, exclude=None):
        """Build from a loaded surrogate :class:`xarray.Dataset`.

        Parameters
        ----------
        ds : xarray.Dataset
            Layout of :mod:`turgorbayes.surrogate.build` (dims ``ratio``, ``x``).
        path, sha256 : optional
            Recorded as attributes.
        exclude : array_like of bool, shape (n_ratio, n_x), optional
            FE points to leave out of the fit (leave-one-out validation). A ratio with fewer
            than 4 points left is dropped entirely.
        """
        ds = ds.transpose("ratio", "x", ...)
        ratio = np.asarray(ds["ratio"].values, dtype=float)
        x_act = np.asarray(ds["x_actual"].values, dtype=float)
        k = np.asarray(ds["k_over_PR"].values, dtype=float)
        k_lin = np.asarray(ds["k_linear_over_PR"].values, dtype=float)
        _check_values(ratio, x_act, k, k_lin, path)
        keep = np.ones_like(k, dtype=bool) if exclude is None else ~np.asarray(exclude)
        rows = [j for j in range(ratio.size) if keep[j].sum() >= 4]
        if len(rows) < 4:
            raise SurrogateError(f"need >= 4 ratios with >= 4 points each, got {len(rows)}")
        stiffness = _fit_table([x_act[j][keep[j]] for j in rows], ratio[rows],
                               [k[j][keep[j]] for j in rows])
        lin = keep & (k_lin > 0)  # a linear slope <= 0 is a failed reading, not a stiffness
        linear = _fit_table([x_act[j][lin[j]] for j in rows], ratio[rows],
                            [k_lin[j][lin[j]] for j in rows])
        s = cls(ds, stiffness, linear, path=path, sha256=sha256)
        s.linear_excluded = [{"x": float(x_act[j, i]), "ratio": float(ratio[j]),
                              "k_linear_over_PR": float(k_lin[j, i])}
                             for j, i in np.argwhere(keep & ~lin)]
        return s

    def __call__(self, x, ratio, warn=True, mask_buckled=True):
        """Reduced stiffness ``k_c/(P R_c)`` at ``h = R/20``.

        Parameters
        ----------
        x : array_like
            Inflation number ``P R_c/(E_perp t)`` [dimensionless].
        ratio : array_like
            Anisotropy ``E_par/E_perp`` [dimensionless]; broadcast against ``x``.
        warn : bool, default True
            Warn once if any point lies outside :attr:`domain`; pass False inside likelihood
            loops (the NaN is still returned).
        mask_buckled : bool, default True
            False: the interpolated value also in the buckled region (only to divide FE
            tables on the same grid, :func:`turgorbayes.surrogate.axes.correction_dataset`).

        Returns
        -------
        numpy.ndarray or float
            Broadcast shape of the inputs; NaN outside the table (never extrapolated) and where
            the wall buckles under the tip (:meth:`buckled`), with a warning for each.
        """
        return self._evaluate(self._k, x, ratio, warn, mask_buckled=mask_buckled)

    def linear(self, x, ratio, warn=True):
        """Small-indentation (linear) reduced stiffness; arguments as :meth:`__call__`.

        Not used by the inference. Unique where the wall buckles at larger depth, so it is
        returned in the buckled region too (NaN only outside the table). FE points whose
        linear slope came out <= 0 (a failed reading at the first two sub-nanometre steps)
        are left out of its interpolation and listed in :attr:`linear_excluded`.
        """
        return self._evaluate(self._k_lin, x, ratio, warn)

    def dlog_dlogx(self, x, ratio, warn=True):
        """Logarithmic slope ``d log(k/PR) / d log x`` of :meth:`__call__` (same arguments)."""
        return self._evaluate(self._k, x, ratio, warn, dx=1, mask_buckled=True)

    def buckled(self, x, ratio):
        """True where ``(x, ratio)`` lies in a grid cell with a buckled FE corner.

        In such a cell the wall buckles under the tip before ``h = R/20`` in the FE model and
        ``k`` there has no unique value (it moves by up to 9 % with a 0.1-0.5 nm offset of
        the indenter and with the mesh, docs/fem.md, "The buckled corner"); :meth:`__call__`
        returns NaN there. Boxes: :attr:`buckled_boxes`.

        Parameters
        ----------
        x, ratio : array_like
            Inflation number and anisotropy (dimensionless), broadcast together.

        Returns
        -------
        numpy.ndarray of bool or bool
            False outside every box (also outside the table and for NaN input: the table's
            domain is reported by :meth:`__call__`).
        """
        x, ratio = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(ratio, dtype=float))
        out = np.zeros(x.shape, dtype=bool)
        for box in self.buckled_boxes:
            (xlo, xhi), (rlo, rhi) = box["x"], box["ratio"]
            out |= (x >= xlo) & (x <= xhi) & (ratio >= rlo) & (ratio <= rhi)
        return out if out.ndim else bool(out)

    def _evaluate(self, table, x, ratio, warn, dx=0, mask_buckled=False):
        x, ratio = np.broadcast_arrays(np.asarray(x, dtype=float), np.asarray(ratio, dtype=float))
        with np.errstate(divide="ignore", invalid="ignore"):
            lx, lr = np.log(x), np.log(ratio)
        inside = table.contains(lx, lr)
        if inside.all():
            out = table.log_value(lx.ravel(), lr.ravel(), dx=dx).reshape(x.shape)
        else:
            out = np.full(x.shape, np.nan)
            out[inside] = table.log_value(lx[inside], lr[inside], dx=dx)
            n_out = np.count_nonzero(~inside & ~(np.isnan(x) | np.isnan(ratio)))
            if warn and n_out:
                self._warn_outside(n_out, x.size)
        if mask_buckled and self.buckled_boxes:
            buckled = inside & self.buckled(x, ratio)
            if buckled.any():
                out = np.where(buckled, np.nan, out)
                if warn:
                    self._warn_buckled(np.count_nonzero(buckled), x.size)
        result = out if dx else np.exp(out)
        return result if result.ndim else float(result)

    def _warn_buckled(self, n_in, n):
        warn_buckled(n_in, n, self.buckled_boxes, stacklevel=5)

    def _warn_outside(self, n_out, n):
        (xlo, xhi), (rlo, rhi) = self.domain["x"], self.domain["ratio"]
        warnings.warn(
            f"{n_out} of {n} points lie outside the surrogate table (x in [{xlo:.4g}, "
            f"{xhi:.4g}], ratio in [{rlo:.4g}, {rhi:.4g}]); returning NaN there",
            RuntimeWarning,
            stacklevel=4,
        )

    def __repr__(self):
        return (
            f"Surrogate({self.path}, x in {self.domain['x']}, ratio in {self.domain['ratio']}, "
            f"{self.grid['ratio'].size}x{self.grid['x'].size} FE points)"
        )


def _fit_table(x_rows, ratio, value_rows):
    """Steps 1-3 of the module docstring; rows may differ in length (leave-one-out)."""
    log_x = [np.log(r) for r in x_rows]
    lo, hi = max(r[0] for r in log_x), min(r[-1] for r in log_x)
    dense = np.linspace(lo, hi, _N_DENSE)
    rows = [CubicSpline(lx, np.log(v))(dense) for lx, v in zip(log_x, value_rows, strict=True)]
    log_ratio = np.log(ratio)
    spline = RectBivariateSpline(dense, log_ratio, np.array(rows).T, kx=3, ky=3, s=0)
    return _Table2D(spline, (lo, hi), (log_ratio[0], log_ratio[-1]))


def _check_values(ratio, x_act, k, k_lin, path):
    where = path if path is not None else "surrogate table"
    if ratio.size < 4 or x_act.shape[1] < 4:
        raise SurrogateError(
            f"{where}: a bicubic table needs >= 4 ratios and >= 4 x values, got "
            f"{ratio.size} x {x_act.shape[1]}"
        )
    if np.any(np.diff(ratio) <= 0):
        raise SurrogateError(f"{where}: ratio axis must be strictly increasing, got {ratio}")
    for name, arr in (("x_actual", x_act), ("k_over_PR", k)):
        if not np.all(np.isfinite(arr) & (arr > 0)):
            raise SurrogateError(f"{where}: {name} must be finite and > 0 at every FE point")
    if not np.all(np.isfinite(k_lin)):
        raise SurrogateError(f"{where}: k_linear_over_PR must be finite at every FE point")
    bad = np.flatnonzero(np.any(np.diff(x_act, axis=1) <= 0, axis=1))
    if bad.size:
        raise SurrogateError(
            f"{where}: x_actual must increase along x for every ratio; it does not at "
            f"ratio = {ratio[bad].tolist()}"
        )


def leave_one_out(ds):
    """Leave-one-out relative interpolation errors of a surrogate table.

    Two tests, each refitting the interpolator without the held-out data:

    * ``"x"``: drop one interior FE point of one ratio's curve, predict it from the rest;
    * ``"ratio"``: drop a whole interior ratio, predict all its points from the other ratios
      (this doubles the ratio spacing, so it overestimates the error of the full table).

    Parameters
    ----------
    ds : xarray.Dataset
        A surrogate table (e.g. from :func:`open_table`).

    Returns
    -------
    dict
        ``{"x": array (n_ratio, n_x), "ratio": array (n_ratio, n_x)}`` of
        ``s_loo/k_FE - 1`` (NaN where the point is at the edge of the table and would need
        extrapolation, or where too few points would be left for a bicubic fit), for the
        stiffness at ``h = R/20``.
    """
    ds = ds.transpose("ratio", "x", ...)
    k = ds["k_over_PR"].values
    x_act, ratio = ds["x_actual"].values, ds["ratio"].values
    shape = k.shape
    err = {"x": np.full(shape, np.nan), "ratio": np.full(shape, np.nan)}
    for j in range(shape[0]):
        for i in range(1, shape[1] - 1):
            mask = np.zeros(shape, dtype=bool)
            mask[j, i] = True
            err["x"][j, i] = _held_out_error(ds, mask, x_act[j, i], ratio[j], k[j, i])
    for j in range(1, shape[0] - 1):
        mask = np.zeros(shape, dtype=bool)
        mask[j, :] = True
        err["ratio"][j] = _held_out_error(ds, mask, x_act[j], ratio[j], k[j])
    return err


def warn_buckled(n_in, n, boxes, stacklevel=2):
    """Warn that ``n_in`` of ``n`` points lie in the buckled region ``boxes``
    (:attr:`Surrogate.buckled_boxes`), where ``k`` at ``h = R/20`` is NaN."""
    region = "; ".join(f"x {b['x'][0]:.3g}-{b['x'][1]:.3g}, ratio {b['ratio'][0]:.3g}-"
                       f"{b['ratio'][1]:.3g}" for b in boxes)
    warnings.warn(
        f"{n_in} of {n} points lie where the wall buckles under the tip in the FE model "
        f"({region}): k at h = R/20 has no unique value there; returning NaN",
        RuntimeWarning,
        stacklevel=stacklevel,
    )


def buckled_points(ds):
    """Grid indices ``(j_ratio, i_x)`` of the FE points whose wall buckled under the tip.

    A point is buckled if its record says so (variable ``buckled``, written by builds since
    the FE reports it: the force fell, or Newton lost the path after it fell and the run
    stopped early) or if its force curve falls (:func:`force_drops`, for older tables).

    Parameters
    ----------
    ds : xarray.Dataset
        A surrogate table.

    Returns
    -------
    list of (int, int)
        Sorted by ``x`` index, then ratio index.
    """
    ds = ds.transpose("ratio", "x", ...)
    points = {(j, i) for j, i, _, _ in _snaps(ds)}
    if "buckled" in ds:
        points |= {(int(j), int(i)) for j, i in np.argwhere(np.asarray(ds["buckled"].values, bool))}
    return sorted(points, key=lambda p: (p[1], p[0]))


def force_drops(ds):
    """FE points whose indentation force falls while the depth grows (a snap) before h = R/20.

    An elastic indentation curve under displacement control rises monotonically; a fall
    means the solution jumped to another equilibrium branch (a buckle under the tip), and
    k = F(R/20)/(R/20) of such a point is not smooth in (x, ratio). On the shipped table these
    are the four points at x = 0.52 with ratio 0.25-0.5. The depth of the snap depends on the
    mesh: with half the element size the held-out point x = 0.445, ratio 0.35 (which snaps
    at 0.9 of the depth on the table's mesh) does not snap and its k/PR is 5.6 % higher, and
    the point x = 0.52, ratio 0.4 stalls only at 0.94 of the depth (surrogates/README.md).

    Parameters
    ----------
    ds : xarray.Dataset
        A surrogate table with its ``h_m`` and ``F_N`` curves.

    Returns
    -------
    list of dict
        One per such point, by ratio then x: ``x`` (the FE's), ``ratio``, ``depth`` (where
        the force first falls, in units of the final depth R/20) and ``drop`` (the largest
        single fall over the largest force; both dimensionless).
    """
    ds = ds.transpose("ratio", "x", ...)
    out = []
    for j, i, depth, drop in _snaps(ds):
        out.append({"x": float(ds["x_actual"].values[j, i]), "ratio": float(ds["ratio"].values[j]),
                    "depth": depth, "drop": drop})
    return out


def _snaps(ds):
    """``(j_ratio, i_x, depth, drop)`` of every snapping curve of ``ds`` (dims ratio, x)."""
    if "h_m" not in ds or "F_N" not in ds:
        return []
    h, F = ds["h_m"].values, ds["F_N"].values
    out = []
    for j in range(h.shape[0]):
        for i in range(h.shape[1]):
            ok = np.isfinite(h[j, i]) & np.isfinite(F[j, i])
            hh, dF = h[j, i][ok], np.diff(F[j, i][ok])
            if hh.size < 2 or not np.any(dF < 0):
                continue
            first = int(np.argmax(dF < 0))
            out.append((j, i, float(hh[first + 1] / hh[-1]), float(-dF.min() / np.max(F[j, i][ok]))))
    return out


def buckled_boxes(ds):
    """Grid cells of a table that touch a buckled FE point (:meth:`Surrogate.buckled`).

    Each buckled point (:func:`buckled_points`) at grid indices ``(j, i)`` makes the box ``x``
    in ``[x[i-1], x[i+1]]``, ``ratio`` in ``[ratio[j-1], ratio[j+1]]`` (the up to four grid
    cells with that corner; indices clipped to the grid, nominal ``x``); boxes with the same
    ``x`` range and overlapping ratios are merged. Conservative: on the table of 2026-11-23 the
    held-out point in the cell between ratios 0.5 and 0.6 at x = 0.44 is within 0.02 %
    although its corner at ratio 0.5 snaps (at 0.98 of the depth, by 0.4 %).

    Parameters
    ----------
    ds : xarray.Dataset
        A surrogate table (without ``h_m``/``F_N`` curves: no boxes).

    Returns
    -------
    list of dict
        ``{"x": (lo, hi), "ratio": (lo, hi)}``, dimensionless, ordered by ``x`` then ratio.
    """
    ds = ds.transpose("ratio", "x", ...)
    x, ratio = ds["x"].values, ds["ratio"].values
    boxes = []
    for j, i in buckled_points(ds):
        box = {"x": (float(x[max(i - 1, 0)]), float(x[min(i + 1, x.size - 1)])),
               "ratio": (float(ratio[max(j - 1, 0)]), float(ratio[min(j + 1, ratio.size - 1)]))}
        last = boxes[-1] if boxes else None
        if last and last["x"] == box["x"] and box["ratio"][0] <= last["ratio"][1]:
            last["ratio"] = (last["ratio"][0], max(last["ratio"][1], box["ratio"][1]))
        else:
            boxes.append(box)
    return boxes

def _held_out_error(ds, mask, x, ratio, k):
    try:
        s = Surrogate.from_dataset(ds, exclude=mask)
    except SurrogateError:  # too few points left for a bicubic fit: no estimate
        return np.nan
    return s(x, ratio, warn=False) / k - 1
