r"""FE settings as extra axes of the k/(PR) surrogate: the wall thickness and the tip radius.

The main table is a dense FE sweep over ``(x, E_par/E_perp)`` at one FE setting (a 6 nm wall
indented by a cone with a 7.5 nm tip). Coarser FE sweeps at other settings give *correction
factors* relative to a table at the reference setting on their own mesh; the corrected
surrogate is the main table times the corrections (:class:`CorrectedSurrogate`, scheme in its
docstring; ``docs/fem.md``, "Wall thickness" and "Indenter tip radius").

:func:`load` is the package's one way to get a table for any FE setting;
:func:`correction_factor` evaluates one axis's correction at per-point values (a fitted tip
radius per walker, :mod:`turgorbayes.effects.tip_radius`).
"""

import functools
import hashlib
import json
import warnings
from dataclasses import dataclass
from importlib.resources import files
from pathlib import Path

import numpy as np

from turgorbayes.surrogate import table as table_module
from turgorbayes.surrogate.table import Surrogate, SurrogateError, warn_buckled

__all__ = [
    "AXES",
    "THICKNESS",
    "TIP_RADIUS",
    "Axis",
    "AxisCorrection",
    "CorrectedSurrogate",
    "axis_value",
    "correction_dataset",
    "correction_factor",
    "load",
    "shipped_correction",
]

#: The FE settings that define the mesh; a correction divides tables that agree on all of them.
MESH_KEYS = ("mesh_scale", "h_min", "h_bottom", "h_max", "growth", "n_thick", "half_model")


@dataclass(frozen=True)
class Axis:
    """One FE setting tabulated by correction factors.

    Attributes
    ----------
    name : str
        The :class:`turgorbayes.fem.CapsuleConfig` attribute (``thickness``, ``tip_radius``).
    label : str
        Words for messages.
    files : dict
        Value [m] -> shipped correction table (package data).
    reference_file : str
        The table at the reference value on the correction tables' mesh (package data).
    local : bool
        False: ``ln C`` is the Lagrange polynomial through all tabulated values (cubic for
        four). True: piecewise linear in ``ln v`` between the two tabulated values around
        ``v``, so that a table's buckled region (no value) reaches only the neighbouring
        intervals (the tip radius: the 3 nm sweep buckles under the tip from x = 0.2).
    """

    name: str
    label: str
    files: dict
    reference_file: str
    local: bool = False

    def values_nm(self):
        """The shipped values, reference included, in nm (sorted)."""
        return sorted({v * 1e9 for v in self.files} | {REFERENCE_VALUES[self.name] * 1e9})


#: The main table's FE settings (``turgorbayes.fem.CapsuleConfig``'s defaults) [m].
REFERENCE_VALUES = {"thickness": 6e-9, "tip_radius": 7.5e-9}
THICKNESS = Axis("thickness", "wall thickness",
                 {3e-9: "k_over_PR_t3nm.nc", 4.5e-9: "k_over_PR_t4.5nm.nc",
                  9e-9: "k_over_PR_t9nm.nc"}, "k_over_PR_t6nm_mesh3.nc")
TIP_RADIUS = Axis("tip_radius", "indenter tip radius",
                  {3e-9: "k_over_PR_tip3nm.nc", 15e-9: "k_over_PR_tip15nm.nc",
                   30e-9: "k_over_PR_tip30nm.nc"}, "k_over_PR_tip7.5nm.nc", local=True)
#: Every correction axis by name, in the order they are applied.
AXES = {a.name: a for a in (THICKNESS, TIP_RADIUS)}


def axis_value(s, name):
    """The value [m] of FE setting ``name`` behind the table ``s`` (its provenance)."""
    if isinstance(s, CorrectedSurrogate) and name in s.settings:
        return s.settings[name][1]
    cfg = s.metadata.get("fe_config", {})
    value = cfg.get(name) if isinstance(cfg, dict) else None
    if value is None:
        raise SurrogateError(f"{s.path}: the table's provenance has no fe_config {name}")
    return float(value)


def _mesh_settings(fe_config):
    cfg = json.loads(fe_config) if isinstance(fe_config, str) else (fe_config or {})
    return {k: cfg.get(k) for k in MESH_KEYS}


def correction_dataset(base, ds):
    """The FE table ``ds`` with ``k_over_PR``, ``k_linear_over_PR`` divided by ``base``.

    Parameters
    ----------
    base : turgorbayes.surrogate.Surrogate
        Table at the reference setting on the same mesh as ``ds``.
    ds : xarray.Dataset
        An FE table at another setting (same file layout).

    Returns
    -------
    xarray.Dataset
        Same layout; the two stiffness variables hold the correction factors ``C`` (on the
        reference's own FE points the ratio of FE values, else of ``ds`` to the reference's
        interpolation); ``buckled`` marks ``ds``'s buckled points and those where the
        reference buckles.

    Raises
    ------
    SurrogateError
        If an FE point of ``ds`` lies outside ``base`` (the correction would need
        extrapolation), or the two were computed on different meshes.
    """
    mesh_ref = _mesh_settings(base.metadata.get("fe_config"))
    mesh_ds = _mesh_settings(ds.attrs.get("fe_config"))
    if mesh_ref != mesh_ds:
        diff = {k: (mesh_ref[k], mesh_ds[k]) for k in MESH_KEYS if mesh_ref[k] != mesh_ds[k]}
        raise SurrogateError(
            f"the correction table and its reference table were computed on different "
            f"meshes ({', '.join(f'{k}: {a} vs {b}' for k, (a, b) in diff.items())}); a "
            "correction factor must divide like meshes")
    ds = ds.transpose("ratio", "x", ...).copy()
    x = ds["x_actual"].values
    ratio = np.broadcast_to(ds["ratio"].values[:, None], x.shape)
    fe = base.table.transpose("ratio", "x", ...)
    shared = _shared_nodes(fe, ds)
    ds["buckled"] = (("ratio", "x"), _reference_buckled(base, ds, shared))
    for name, fn in (("k_over_PR", functools.partial(base, mask_buckled=False)),
                     ("k_linear_over_PR", base.linear)):
        # on the reference's own FE points its FE values, elsewhere its interpolation
        with np.errstate(invalid="ignore"):
            ref = fn(x, ratio, warn=False)
        for (j, i), m in shared.items():
            ref[j, i] = fe[name].values[m]
        if not np.all(np.isfinite(ref)):
            j, i = np.argwhere(~np.isfinite(ref))[0]
            raise SurrogateError(
                f"correction table point x = {x[j, i]:.5g}, ratio = {ratio[j, i]:g} lies outside "
                f"the reference table (x in {base.domain['x']}, ratio in {base.domain['ratio']})")
        ds[name] = ds[name] / ref
    return ds


def _shared_nodes(ref, ds):
    """``(j, i) -> (j_ref, i_ref)`` for the points of ``ds`` that are FE points of the
    reference table ``ref`` (both dims ratio, x): the same nominal grid values and the same FE
    inflation number to 1e-6 (a sweep that changes only the indentation, as the tip radius
    does)."""
    where = {(r, x): (jr, ir) for jr, r in enumerate(ref["ratio"].values)
             for ir, x in enumerate(ref["x"].values)}
    x_ref, x_ds = ref["x_actual"].values, ds["x_actual"].values
    out = {}
    for j, r in enumerate(ds["ratio"].values):
        for i, x in enumerate(ds["x"].values):
            m = where.get((r, x))
            if m is not None and abs(x_ds[j, i] / x_ref[m] - 1) <= 1e-6:
                out[(j, i)] = m
    return out


def _reference_buckled(base, ds, shared):
    """Points of ``ds`` to mark buckled: its own, and where the reference buckles (its buckled
    FE points where the two share points, elsewhere its buckled boxes), so that a correction
    has no value where the FE values it divides have none."""
    flags = np.zeros((ds.sizes["ratio"], ds.sizes["x"]), bool)
    if "buckled" in ds:
        flags |= np.asarray(ds["buckled"].values, bool)
    ref_points = set(table_module.buckled_points(base.table))
    boxes = base.buckled(ds["x_actual"].values, ds["ratio"].values[:, None])
    for j in range(flags.shape[0]):
        for i in range(flags.shape[1]):
            m = shared.get((j, i))
            flags[j, i] |= (m in ref_points) if m is not None else bool(boxes[j, i])
    return flags


def _in_domain(domain, x, ratio):
    """Where ``(x, ratio)`` lies in ``domain`` (``{"x": (lo, hi), "ratio": (lo, hi)}``; a
    relative slack of 1e-12 keeps the tables' own corners inside)."""
    (lo, hi), (rlo, rhi) = domain["x"], domain["ratio"]
    return (x >= lo * (1 - 1e-12)) & (x <= hi * (1 + 1e-12)) & (ratio >= rlo * (1 - 1e-12)) \
        & (ratio <= rhi * (1 + 1e-12))


def _lagrange_weights(nodes, value):
    """Weights ``l_j(value)`` of the Lagrange polynomial through ``nodes``: shape
    ``(len(nodes),) + value.shape``."""
    value = np.asarray(value, float)
    w = np.ones((len(nodes),) + value.shape)
    for j, nj in enumerate(nodes):
        for m, nm in enumerate(nodes):
            if m != j:
                w[j] = w[j] * (value - nm) / (nj - nm)
    return w


class AxisCorrection:
    r"""One axis's FE correction factors ``C_j(x, rho)`` at the tabulated values ``v_j``.

    ``ln C(x, rho; v) = sum_j w_j(v) ln C_j(x, rho)``, the reference included with
    ``ln C = 0``; the weights ``w_j`` (:meth:`weights`) are those of the Lagrange polynomial in
    ``ln v`` through the tabulated values (cubic for four), or of piecewise-linear
    interpolation in ``ln v`` for a local axis (:attr:`Axis.local`).

    Parameters
    ----------
    axis : Axis
    reference : float [m]
        The main table's value of the setting.
    corrections : dict
        Value [m] -> :class:`~turgorbayes.surrogate.Surrogate` of the correction factor
        (from :func:`correction_dataset`).
    """

    def __init__(self, axis, reference, corrections):
        self.axis, self.reference = axis, float(reference)
        self.corrections = {float(v): c for v, c in corrections.items()}
        self.nodes = sorted(set(self.corrections) | {self.reference})
        self._log_nodes = np.log(self.nodes)
        self.domain = {ax: (max(c.domain[ax][0] for c in self.corrections.values()),
                            min(c.domain[ax][1] for c in self.corrections.values()))
                       for ax in ("x", "ratio")}

    def check(self, value):
        """``value`` [m] as a float array, refused (SurrogateError) outside the tabulated range."""
        v = np.asarray(value, float)
        lo, hi = self.nodes[0], self.nodes[-1]
        bad = ~((v >= lo * (1 - 1e-9)) & (v <= hi * (1 + 1e-9)))
        if np.any(bad):
            raise SurrogateError(
                f"{self.axis.label} {float(v[bad].flat[0]) * 1e9:g} nm is outside the tabulated "
                f"range [{lo * 1e9:g}, {hi * 1e9:g}] nm (never extrapolated)")
        return np.clip(v, lo, hi)  # rounding of e.g. 9 * 1e-9 only

    def weights(self, value):
        """Weight of each tabulated value at ``value`` [m]: ``(len(nodes),) + value.shape``."""
        u = np.log(self.check(value))
        if not self.axis.local:
            return _lagrange_weights(self._log_nodes, u)
        k = np.clip(np.searchsorted(self._log_nodes, u, side="right") - 1, 0, len(self.nodes) - 2)
        a = (u - self._log_nodes[k]) / (self._log_nodes[k + 1] - self._log_nodes[k])
        w = np.zeros((len(self.nodes),) + u.shape)
        for j in range(len(self.nodes)):
            w[j] = np.where(k == j, 1 - a, 0.0) + np.where(k + 1 == j, a, 0.0)
        return w

    def _terms(self, value):
        w = self.weights(value)
        return [(w[j], self.corrections[v]) for j, v in enumerate(self.nodes)
                if v != self.reference and np.any(np.abs(w[j]) > 1e-14)]

    def log_factor(self, x, ratio, value, attr="__call__"):
        """``ln C(x, ratio; value)`` (``attr`` ``"linear"``: of the linear stiffness;
        ``"dlog_dlogx"``: its slope in ``ln x``), broadcasting ``value`` with ``x``. NaN where
        a table with a non-zero weight has no value."""
        out = np.zeros(np.broadcast(x, ratio, value).shape)
        for w, c in self._terms(value):
            f = getattr(c, attr)(x, ratio, warn=False)
            with np.errstate(invalid="ignore", divide="ignore"):
                term = w * (f if attr == "dlog_dlogx" else np.log(f))
            out = out + np.where(w != 0, term, 0.0)
        return out

    def inside(self, x, ratio):
        """Where ``(x, ratio)`` lies in every correction table's domain."""
        return _in_domain(self.domain, x, ratio)

    def sha256(self):
        """Identity of the correction tables (file hashes and the reference's)."""
        digest = hashlib.sha256(f"{self.axis.name}|{self.reference!r}".encode())
        for v in sorted(self.corrections):
            digest.update(f"|{v!r}:{self.corrections[v].sha256}".encode())
        return digest.hexdigest()


class CorrectedSurrogate:
    r"""``k_c/(P R_c)`` at other FE settings: the main table times FE correction factors.

    Same call interface as :class:`turgorbayes.surrogate.Surrogate` (``s(x, ratio)``,
    ``s.linear``, ``s.dlog_dlogx``, ``domain``, ``metadata``, ``path``, ``sha256``), so it can be
    passed wherever a surrogate is (:mod:`turgorbayes.physics.forward`, the likelihoods, ``fit``).

    Parameters
    ----------
    base : turgorbayes.surrogate.Surrogate
        Main table at the reference settings.
    settings : dict
        Axis name -> ``(AxisCorrection, value [m])``.

    Notes
    -----
    For each axis (a setting ``v`` with reference ``v_ref``), coarse FE sweeps at values ``v_j``
    give at each of their FE points the correction

    .. math::

        C_j(x, \rho) = \frac{(k/PR)_{FE}(x, \rho;\, v_j)}{S_{ref}(x, \rho)}, \qquad
        C(x, \rho; v_{ref}) = 1,

    with ``S_ref`` the table at the reference value *on the correction tables' own mesh*
    (shipped beside them), evaluated at the point's own ``x``: ``C`` is a ratio of like meshes,
    so most of the coarse mesh's error cancels and ``C`` carries over to a main table built on
    a finer mesh (a mismatch of mesh settings is refused). ``C`` is close to 1 and smooth, so the
    coarse grid interpolates it far more accurately than it would ``k/PR`` itself (the same
    bicubic log-log scheme as the main table). Across the setting, ``ln C`` is a Lagrange
    polynomial in ``ln v`` through the tabulated values (cubic for four; the thickness) or
    piecewise linear in ``ln v`` (:attr:`Axis.local`; the tip radius), and the axes multiply:

    .. math::

        \frac{k_c}{P R_c}(x, \rho; t, r_{tip}) = S(x, \rho)\,
            C_t(x, \rho; t)\, C_{tip}(x, \rho; r_{tip}).

    The product assumes the two settings act independently (``docs/fem.md``, "Indenter tip
    radius", measures it). Outside the tabulated range a setting is refused (never
    extrapolated); in ``(x, rho)`` the domain is the intersection of the tables' domains, NaN
    and a warning outside, as for the main table.
    """

    def __init__(self, base, settings):
        self.base = base
        self.settings = {}
        for name, (corr, value) in settings.items():
            self.settings[name] = (corr, float(corr.check(value)))
        self._active = [(c, v) for c, v in self.settings.values() if v != c.reference]
        self.path = base.path
        self.metadata = dict(base.metadata)
        digest = hashlib.sha256(base.sha256.encode())
        for name, (corr, v) in self.settings.items():
            self.metadata[f"{name}_m"] = v
            self.metadata[f"{name}_tables"] = {f"{tj * 1e9:g} nm": str(c.path)
                                              for tj, c in corr.corrections.items()}
            digest.update(f"|{name}={v * 1e9:.9g} nm|{corr.sha256()}".encode())
        self.sha256 = digest.hexdigest()
        self.grid = dict(base.grid, **{name: np.array(c.nodes)
                                       for name, (c, _) in self.settings.items()})
        domains = [base.domain] + [c.domain for c, _ in self._active]
        self.domain = {axis: (max(d[axis][0] for d in domains), min(d[axis][1] for d in domains))
                       for axis in ("x", "ratio")}
        tables = [base] + [t for c, v in self._active for _, t in c._terms(v)]
        #: The buckled regions of every table combined (the value is NaN in each of them).
        self.buckled_boxes = [b for tb in tables for b in tb.buckled_boxes]
        self._tables = tables

    def buckled(self, x, ratio):
        """True where any of the combined tables has its buckled region
        (:meth:`turgorbayes.surrogate.Surrogate.buckled`)."""
        out = np.zeros(np.broadcast(x, ratio).shape, dtype=bool)
        for tb in self._tables:
            out = out | tb.buckled(x, ratio)
        return out if out.ndim else bool(out)

    def _evaluate(self, attr, x, ratio, warn):
        x, ratio = np.broadcast_arrays(np.asarray(x, float), np.asarray(ratio, float))
        inside = _in_domain(self.domain, x, ratio)
        n_out = np.count_nonzero(~inside & ~(np.isnan(x) | np.isnan(ratio)))
        if warn and n_out:
            warnings.warn(f"{n_out} of {x.size} points lie outside the corrected surrogate (x in "
                          f"{self.domain['x']}, ratio in {self.domain['ratio']}); returning NaN "
                          "there", RuntimeWarning, stacklevel=3)
        xs, rs = np.where(inside, x, np.nan), np.where(inside, ratio, np.nan)
        log_c = sum((c.log_factor(xs, rs, v, attr) for c, v in self._active), np.zeros(x.shape))
        with np.errstate(invalid="ignore"):
            value = getattr(self.base, attr)(xs, rs, warn=False)
            value = value + log_c if attr == "dlog_dlogx" else value * np.exp(log_c)
        value = np.asarray(value, float)
        if warn and attr != "linear" and self.buckled_boxes:
            n_in = np.count_nonzero(inside & self.buckled(x, ratio))
            if n_in:
                warn_buckled(n_in, x.size, self.buckled_boxes, stacklevel=4)
        return value if value.ndim else float(value)

    def __call__(self, x, ratio, warn=True):
        """Reduced stiffness at ``h = R/20`` at these FE settings (see the class docs)."""
        return self._evaluate("__call__", x, ratio, warn)

    def linear(self, x, ratio, warn=True):
        """Small-indentation reduced stiffness at these FE settings."""
        return self._evaluate("linear", x, ratio, warn)

    def dlog_dlogx(self, x, ratio, warn=True):
        """``d ln(k/PR)/d ln x`` (main table's slope plus the corrections')."""
        return self._evaluate("dlog_dlogx", x, ratio, warn)

    def __repr__(self):
        axes = ", ".join(f"{n} {v * 1e9:g} nm" for n, (_, v) in self.settings.items())
        return (f"CorrectedSurrogate({axes}, base {self.base.path}, x in {self.domain['x']}, "
                f"ratio in {self.domain['ratio']})")


def _data_path(name):
    return Path(str(files("turgorbayes") / "data" / name))


@functools.lru_cache(maxsize=8)
def _shipped_reference(axis_name):
    return table_module.load(_data_path(AXES[axis_name].reference_file))


def _correction(axis, reference, paths):
    corrections = {}
    for v, path in paths.items():
        ds = table_module.open_table(path)
        # identity of the correction: the file and the reference it is divided by
        sha = hashlib.sha256(Path(path).read_bytes() + reference.sha256.encode()).hexdigest()
        corrections[float(v)] = Surrogate.from_dataset(correction_dataset(reference, ds),
                                                       path=Path(path), sha256=sha)
    return AxisCorrection(axis, axis_value(reference, axis.name), corrections)


@functools.lru_cache(maxsize=8)
def _shipped_correction_cached(axis_name):
    axis = AXES[axis_name]
    return _correction(axis, _shipped_reference(axis_name),
                       {v: _data_path(f) for v, f in axis.files.items()})


def shipped_correction(axis_name, base=None):
    """The shipped :class:`AxisCorrection` of axis ``axis_name`` (read once per process).

    Parameters
    ----------
    axis_name : str
        A key of :data:`AXES`.
    base : Surrogate, optional
        The main table it will multiply: refused unless at the correction's reference value.
    """
    if axis_name not in AXES:
        raise SurrogateError(f"unknown surrogate axis {axis_name!r}; known: {', '.join(AXES)}")
    corr = _shipped_correction_cached(axis_name)
    if base is not None:
        base = base.base if isinstance(base, CorrectedSurrogate) else base
        own = axis_value(base, axis_name)
        if not np.isclose(own, corr.reference, rtol=1e-9, atol=0):
            raise SurrogateError(
                f"{AXES[axis_name].label}: the table {base.path} was computed at "
                f"{own * 1e9:g} nm, the shipped corrections are relative to "
                f"{corr.reference * 1e9:g} nm")
    return corr


def correction_factor(s, x, ratio, **values):
    """``k/PR`` of the FE settings ``values`` over that of the table ``s``, point by point.

    Parameters
    ----------
    s : Surrogate or CorrectedSurrogate
    x, ratio : array_like
    **values : array_like [m]
        Per-point settings by axis name (``tip_radius=``, ``thickness=``), broadcasting with
        ``x``; each replaces the table's own value of that setting.

    Returns
    -------
    ndarray
        The factor; NaN where ``(x, ratio)`` lies outside a correction table used.
    """
    x, ratio = np.asarray(x, float), np.asarray(ratio, float)
    out = np.zeros(np.broadcast(x, ratio, *values.values()).shape)
    inside = np.ones(out.shape, bool)
    for name, value in values.items():
        own = s.settings.get(name) if isinstance(s, CorrectedSurrogate) else None
        corr = own[0] if own else shipped_correction(name, s)
        now = own[1] if own else corr.reference
        out = out + corr.log_factor(x, ratio, value) - corr.log_factor(x, ratio, now)
        inside &= corr.inside(x, ratio)
    return np.where(inside, np.exp(out), np.nan)


def load(path=None, *, tip_radius_nm=None, thickness_nm=None):
    """The k/(PR) table for any FE setting: the main table times the FE corrections.

    Parameters
    ----------
    path : str or path-like, optional
        The main table (a file written by ``turgorbayes surrogate build``); None: the shipped
        one.
    tip_radius_nm : float, optional
        Radius of the indenter's spherical tip [nm], within the tabulated 3-30 nm. None: the
        table's own (7.5 nm for the shipped table).
    thickness_nm : float, optional
        Wall thickness [nm], within the tabulated 3-9 nm. None: the table's own (6 nm).

    Returns
    -------
    Surrogate or CorrectedSurrogate
        The main table itself when every setting is its own.

    Raises
    ------
    SurrogateError
        A file is missing or not a surrogate table, a setting lies outside its tabulated range,
        or the main table's own setting is not the shipped corrections' reference.
    """
    base = table_module.load(path)
    settings = {}
    for name, nm in (("thickness", thickness_nm), ("tip_radius", tip_radius_nm)):
        if nm is None or np.isclose(nm * 1e-9, axis_value(base, name), rtol=1e-9, atol=0):
            continue
        settings[name] = (shipped_correction(name, base), nm * 1e-9)
    return CorrectedSurrogate(base, settings) if settings else base
