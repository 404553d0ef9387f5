r"""Wall thickness as a third axis of the k/(PR) surrogate: a finite-element correction factor.

Bending (``E t^3/12``) brings ``t/R`` in beside ``x`` and ``E_par/E_perp``: at fixed ``E t`` the
FE stiffness changes by several percent between t = 3 and 9 nm. :func:`load_at_thickness`
multiplies the main table by a correction interpolated from coarser FE sweeps at other
thicknesses (scheme: :class:`ThicknessSurrogate`; ``docs/fem.md``, "Wall thickness").
"""

import hashlib
import json
import warnings
from importlib.resources import files
from pathlib import Path

import numpy as np

from turgorbayes import surrogate as surrogate_module
from turgorbayes.surrogate import Surrogate, SurrogateError
from turgorbayes.surrogate.table import warn_buckled

__all__ = [
    "REFERENCE_FILE",
    "THICKNESS_FILES",
    "ThicknessSurrogate",
    "correction_dataset",
    "load_at_thickness",
    "reference_thickness",
]

#: Shipped correction tables (package data): thickness [m] -> file name.
THICKNESS_FILES = {3e-9: "k_over_PR_t3nm.nc", 4.5e-9: "k_over_PR_t4.5nm.nc",
                   9e-9: "k_over_PR_t9nm.nc"}
#: The reference-thickness (6 nm) table on the same mesh as :data:`THICKNESS_FILES`.
REFERENCE_FILE = "k_over_PR_t6nm_mesh3.nc"
#: The FE settings that define the mesh; a correction divides tables that agree on all of them.
MESH_KEYS = ("mesh_scale", "h_min", "h_bottom", "h_max", "growth", "n_thick", "half_model")


def _mesh_settings(fe_config):
    cfg = json.loads(fe_config) if isinstance(fe_config, str) else (fe_config or {})
    return {k: cfg.get(k) for k in MESH_KEYS}


def reference_thickness(s):
    """Wall thickness [m] of the FE runs behind the surrogate ``s`` (from its provenance)."""
    cfg = s.metadata.get("fe_config", {})
    t = cfg.get("thickness") if isinstance(cfg, dict) else None
    if t is None:
        raise SurrogateError(f"{s.path}: the table's provenance has no fe_config thickness")
    return float(t)


def correction_dataset(base, ds):
    """The thickness table ``ds`` with ``k_over_PR``, ``k_linear_over_PR`` divided by ``base``.

    Parameters
    ----------
    base : turgorbayes.surrogate.Surrogate
        Table at the reference thickness on the same mesh as ``ds``.
    ds : xarray.Dataset
        An FE table at another thickness (same file layout).

    Returns
    -------
    xarray.Dataset
        Same layout; the two stiffness variables hold the correction factors ``C``.

    Raises
    ------
    SurrogateError
        If an FE point of ``ds`` lies outside ``base`` (the correction would need
        extrapolation of the main table), or the two were computed on different meshes.
    """
    mesh_ref = _mesh_settings(base.metadata.get("fe_config"))
    mesh_ds = _mesh_settings(ds.attrs.get("fe_config"))
    if mesh_ref != mesh_ds:
        diff = {k: (mesh_ref[k], mesh_ds[k]) for k in MESH_KEYS if mesh_ref[k] != mesh_ds[k]}
        raise SurrogateError(
            f"the thickness table and its reference-thickness table were computed on different "
            f"meshes ({', '.join(f'{k}: {a} vs {b}' for k, (a, b) in diff.items())}); a "
            "correction factor must divide like meshes")
    ds = ds.transpose("ratio", "x", ...).copy()
    x = ds["x_actual"].values
    ratio = np.broadcast_to(ds["ratio"].values[:, None], x.shape)
    for name, fn in (("k_over_PR", base), ("k_linear_over_PR", base.linear)):
        ref = fn(x, ratio, warn=False)
        if not np.all(np.isfinite(ref)):
            j, i = np.argwhere(~np.isfinite(ref))[0]
            raise SurrogateError(
                f"thickness table point x = {x[j, i]:.5g}, ratio = {ratio[j, i]:g} lies outside "
                f"the main table (x in {base.domain['x']}, ratio in {base.domain['ratio']})")
        ds[name] = ds[name] / ref
    return ds


def _lagrange_weights(nodes, value):
    """Weights ``l_j(value)`` of the Lagrange polynomial through ``nodes``."""
    w = np.ones(len(nodes))
    for j, nj in enumerate(nodes):
        for m, nm in enumerate(nodes):
            if m != j:
                w[j] *= (value - nm) / (nj - nm)
    return w


class ThicknessSurrogate:
    r"""``k_c/(P R_c)`` at one wall thickness: main table times the FE thickness correction.

    Same call interface as :class:`turgorbayes.surrogate.Surrogate` (``s(x, ratio)``,
    ``s.linear``, ``s.dlog_dlogx``, ``domain``, ``metadata``, ``path``, ``sha256``), so it can be
    passed wherever a surrogate is (:mod:`turgorbayes.forward`, the likelihoods, ``fit``).

    Parameters
    ----------
    base : turgorbayes.surrogate.Surrogate
        Main table at the reference thickness.
    corrections : dict
        Thickness [m] -> :class:`~turgorbayes.surrogate.Surrogate` of the correction factor
        (from :func:`correction_dataset`).
    thickness : float [m]
        Wall thickness to evaluate at, within the tabulated range.

    Notes
    -----
    The main table (:func:`turgorbayes.surrogate.load`) is the dense FE sweep at the
    reference thickness ``t_ref`` (6 nm, the paper's FE). Coarser FE sweeps at other thicknesses
    ``t_j`` (built by the same CLI with ``--set thickness=...``) give at each of their FE points the
    correction

    .. math::

        C_j(x, \rho) = \frac{(k/PR)_{FE}(x, \rho;\, t_j)}{S(x, \rho)}, \qquad C(x, \rho; t_{ref}) = 1,

    with ``S`` the table at the reference thickness *on the thickness tables' own mesh*
    (shipped as :data:`REFERENCE_FILE`), evaluated at the point's own ``x``: ``C`` is a ratio of
    like meshes, so most of the coarse mesh's error cancels and ``C`` carries over to a main table
    built on a finer mesh (a mismatch of mesh settings between the two is refused). ``C`` is close to 1 and
    smooth, so the coarse grid interpolates it far more accurately than it would ``k/PR`` itself
    (the same bicubic log-log scheme as the main table, :class:`turgorbayes.surrogate.Surrogate`).
    Across thickness, ``ln C`` is a cubic Lagrange polynomial in ``ln t`` through the tabulated
    thicknesses (the reference included with ``ln C = 0``), so

    .. math::

        \frac{k_c}{P R_c}(x, \rho; t) = S(x, \rho)\,
            \exp\Big(\sum_j \ell_j(\ln t)\, \ln C_j(x, \rho)\Big).

    Outside ``[min t_j, max t_j]`` the thickness is refused (never extrapolated); in ``(x, rho)`` the
    domain is the intersection of the tables' domains, NaN and a warning outside, as for the main
    table.
    """

    def __init__(self, base, corrections, thickness):
        t_ref = reference_thickness(base)
        t = float(thickness)
        nodes = sorted(set(corrections) | {t_ref})
        if not nodes[0] * (1 - 1e-9) <= t <= nodes[-1] * (1 + 1e-9):
            raise SurrogateError(
                f"wall thickness {t * 1e9:g} nm is outside the tabulated range "
                f"[{nodes[0] * 1e9:g}, {nodes[-1] * 1e9:g}] nm (never extrapolated)")
        t = min(max(t, nodes[0]), nodes[-1])  # rounding of e.g. 9 * 1e-9 only
        w = _lagrange_weights(np.log(nodes), np.log(t))
        self.base, self.thickness = base, t
        self._terms = [(wj, corrections[tj]) for wj, tj in zip(w, nodes, strict=True)
                       if tj != t_ref and abs(wj) > 1e-14]
        self.path = base.path
        self.metadata = dict(base.metadata, thickness_m=t, thickness_tables={
            f"{tj * 1e9:g} nm": str(c.path) for tj, c in corrections.items()})
        digest = hashlib.sha256(f"{base.sha256}|t={t * 1e9:.9g} nm".encode())
        for tj in sorted(corrections):
            digest.update(f"|{tj!r}:{corrections[tj].sha256}".encode())
        self.sha256 = digest.hexdigest()
        self.grid = dict(base.grid, thickness=np.array(nodes))
        tables = [base] + [c for _, c in self._terms]
        self.domain = {axis: (max(tb.domain[axis][0] for tb in tables),
                              min(tb.domain[axis][1] for tb in tables))
                       for axis in ("x", "ratio")}
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

    def _inside(self, x, ratio):
        (lo, hi), (rlo, rhi) = self.domain["x"], self.domain["ratio"]
        return (x >= lo * (1 - 1e-12)) & (x <= hi * (1 + 1e-12)) & (ratio >= rlo * (1 - 1e-12)) \
            & (ratio <= rhi * (1 + 1e-12))

    def _log_correction(self, x, ratio, attr):
        out = np.zeros(np.broadcast(x, ratio).shape)
        for w, c in self._terms:
            out = out + w * np.log(getattr(c, attr)(x, ratio, warn=False))
        return out

    def _evaluate(self, attr, x, ratio, warn):
        x, ratio = np.broadcast_arrays(np.asarray(x, float), np.asarray(ratio, float))
        inside = self._inside(x, ratio)
        n_out = np.count_nonzero(~inside & ~(np.isnan(x) | np.isnan(ratio)))
        if warn and n_out:
            warnings.warn(f"{n_out} of {x.size} points lie outside the thickness-corrected "
                          f"surrogate (x in {self.domain['x']}, ratio in "
                          f"{self.domain['ratio']}); returning NaN there", RuntimeWarning,
                          stacklevel=3)
        xs, rs = np.where(inside, x, np.nan), np.where(inside, ratio, np.nan)
        if attr == "dlog_dlogx":
            value = self.base.dlog_dlogx(xs, rs, warn=False)
            for w, c in self._terms:
                value = value + w * c.dlog_dlogx(xs, rs, warn=False)
        else:  # "__call__" or "linear": the base table's value times the correction
            with np.errstate(invalid="ignore"):
                value = (getattr(self.base, attr)(xs, rs, warn=False)
                         * np.exp(self._log_correction(xs, rs, attr)))
        value = np.asarray(value, float)
        if warn and attr != "linear" and self.buckled_boxes:
            n_in = np.count_nonzero(inside & self.buckled(x, ratio))
            if n_in:
                warn_buckled(n_in, x.size, self.buckled_boxes, stacklevel=4)
        return value if value.ndim else float(value)

    def __call__(self, x, ratio, warn=True):
        """Reduced stiffness at ``h = R/20`` for this wall thickness (see the module docs)."""
        return self._evaluate("__call__", x, ratio, warn)

    def linear(self, x, ratio, warn=True):
        """Small-indentation reduced stiffness for this wall thickness."""
        return self._evaluate("linear", x, ratio, warn)

    def dlog_dlogx(self, x, ratio, warn=True):
        """``d ln(k/PR)/d ln x`` (main table's slope plus the correction's)."""
        return self._evaluate("dlog_dlogx", x, ratio, warn)

    def __repr__(self):
        return (f"ThicknessSurrogate(t = {self.thickness * 1e9:g} nm, base {self.base.path}, "
                f"x in {self.domain['x']}, ratio in {self.domain['ratio']})")


def load_at_thickness(thickness, base=None, paths=None, reference=None):
    """The shipped (or given) surrogate evaluated at wall thickness ``thickness`` [m].

    Parameters
    ----------
    thickness : float [m]
        Within the tabulated thicknesses (3-9 nm for the shipped tables). The reference
        thickness returns the main table itself.
    base : Surrogate, optional
        Main table (the shipped one if None).
    paths : dict, optional
        Thickness [m] -> correction table file (the shipped :data:`THICKNESS_FILES` if None).
    reference : Surrogate, optional
        Reference-thickness table on the correction tables' mesh: the shipped
        :data:`REFERENCE_FILE` with the shipped tables, else ``base``.

    Returns
    -------
    Surrogate or ThicknessSurrogate
    """
    base = surrogate_module.load() if base is None else base
    if np.isclose(float(thickness), reference_thickness(base), rtol=1e-9, atol=0):
        return base
    root = files("turgorbayes") / "data"
    if reference is None:
        shipped_ref = Path(str(root / REFERENCE_FILE))
        reference = surrogate_module.load(shipped_ref) if paths is None else base
    if not np.isclose(reference_thickness(reference), reference_thickness(base), rtol=1e-9):
        raise SurrogateError(
            f"the reference table {reference.path} is at {reference_thickness(reference) * 1e9:g} "
            f"nm, the main table at {reference_thickness(base) * 1e9:g} nm")
    if paths is None:
        paths = {t: Path(str(root / name)) for t, name in THICKNESS_FILES.items()}
    corrections = {}
    for t, path in paths.items():
        ds = surrogate_module.open_table(path)
        # identity of the correction: the file and the reference it is divided by
        sha = hashlib.sha256(Path(path).read_bytes() + reference.sha256.encode()).hexdigest()
        corr = Surrogate.from_dataset(correction_dataset(reference, ds), path=Path(path),
                                      sha256=sha)
        corrections[float(t)] = corr
    out = ThicknessSurrogate(base, corrections, thickness)
    out.metadata["thickness_reference"] = str(reference.path)
    return out
