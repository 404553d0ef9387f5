"""The cell data set: :class:`CellData`, validated and immutable, SI units inside.

The file format it is read from and written to is :mod:`turgorbayes.cells.table`; every check
here names the cell, the reader's checks name the file's line.
"""

import types
from dataclasses import dataclass, field

import numpy as np

from turgorbayes.cells.columns import BULGE_COLUMNS, COLUMNS, GROUPS, NUMERIC_COLUMNS, REQUIRED_COLUMNS
from turgorbayes.errors import DataError

__all__ = ["CellData", "cell_id_problem"]

_BULGE_FIELDS = tuple(NUMERIC_COLUMNS[c].field for c in BULGE_COLUMNS)
_CORE_FIELDS = tuple(NUMERIC_COLUMNS[c].field for c in REQUIRED_COLUMNS[2:])


def _rebuilt(kwargs):
    """A :class:`CellData` from its pickled arguments (:meth:`CellData.__reduce__`)."""
    return CellData(**kwargs)


@dataclass(frozen=True, eq=False)
class CellData:
    """A validated, immutable set of measured cells, SI units inside.

    Build it with :func:`~turgorbayes.cells.table.read_cells` or directly (the constructor
    validates the same rules as the loader, naming the cell instead of the line). Arrays are
    copied and made read-only.

    Parameters
    ----------
    cell_id : sequence of str
        Unique, non-empty names (no surrounding whitespace, not starting with ``#``).
    group : sequence of str
        ``"bulged"`` or ``"intact"`` per cell.
    R_c, R_c_err : array_like [m]
        Cell radius and its standard error, > 0 for every cell.
    k_c, k_c_err : array_like [N/m]
        Cell-body stiffness and its standard error, > 0 for every cell.
    R_b, R_b_err : array_like [m], optional
        Bulge radius and its error: > 0 on bulged cells, NaN on intact cells.
    k_b, k_b_err : array_like [N/m], optional
        Bulge stiffness and its error: > 0 on bulged cells, NaN on intact cells.
    h_b : array_like [m], optional
        Bulge indentation depth at which k_b was read: > 0 on bulged, NaN on intact cells.
        The five bulge arrays may be omitted (all NaN) when there is no bulged cell.
    extra : mapping of str to sequence of str, optional
        Further columns, carried along as text, in order.
    comments : sequence of str, optional
        Provenance lines, each starting with ``#``.
    path : str, optional
        The file the data came from.
    sha256 : str, optional
        SHA-256 hex digest of that file's bytes.

    Attributes
    ----------
    is_bulged : numpy.ndarray of bool
        ``group == "bulged"`` per cell.
    """

    cell_id: tuple
    group: tuple
    R_c: np.ndarray
    R_c_err: np.ndarray
    k_c: np.ndarray
    k_c_err: np.ndarray
    R_b: np.ndarray = None
    R_b_err: np.ndarray = None
    k_b: np.ndarray = None
    k_b_err: np.ndarray = None
    h_b: np.ndarray = None
    extra: types.MappingProxyType = field(default_factory=dict)
    comments: tuple = ()
    path: str = None
    sha256: str = None
    is_bulged: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        cell_id = _check_cell_ids(self.cell_id, self.path)
        n = len(cell_id)
        group = _check_groups(self.group, n, cell_id, self.path)
        is_bulged = _readonly(np.array([g == "bulged" for g in group], dtype=bool))
        values = {
            name: _check_numeric(getattr(self, name), name, is_bulged, cell_id, self.path)
            for name in _CORE_FIELDS + _BULGE_FIELDS
        }
        extra = _check_extra(self.extra, n, self.path)
        comments = _check_comments(self.comments, self.path)
        path = None if self.path is None else str(self.path)
        for name, value in dict(
            values, cell_id=cell_id, group=group, is_bulged=is_bulged, extra=extra,
            comments=comments, path=path,
        ).items():
            object.__setattr__(self, name, value)

    def __len__(self):
        return len(self.cell_id)

    def __reduce__(self):
        """Pickled as its constructor's arguments (the read-only ``extra`` mapping as a dict),
        so that worker processes can receive cells (:mod:`turgorbayes.parallel`)."""
        fields = {name: getattr(self, name) for name in _CORE_FIELDS + _BULGE_FIELDS}
        return _rebuilt, (dict(fields, cell_id=self.cell_id, group=self.group,
                               extra=dict(self.extra), comments=self.comments, path=self.path,
                               sha256=self.sha256),)

    def __repr__(self):
        source = f", path={self.path!r}" if self.path else ""
        return f"CellData({self.n_bulged} bulged, {self.n_intact} intact{source})"

    @property
    def n_bulged(self):
        """Number of bulged cells."""
        return int(np.count_nonzero(self.is_bulged))

    @property
    def n_intact(self):
        """Number of intact cells."""
        return len(self) - self.n_bulged

    def bulged(self):
        """The bulged cells, in file order, as a new :class:`CellData`."""
        return self.take(np.flatnonzero(self.is_bulged))

    def intact(self):
        """The intact cells, in file order, as a new :class:`CellData`."""
        return self.take(np.flatnonzero(~self.is_bulged))

    def take(self, indices):
        """The cells at ``indices`` (integers, in that order, or a boolean mask of length
        ``len(self)``) as a new :class:`CellData`.

        Comments, path and sha256 (of the source file) are kept as provenance.
        """
        idx = np.asarray(indices)
        if idx.dtype == bool:
            if idx.shape != (len(self),):
                raise ValueError(f"boolean mask has shape {idx.shape}, expected ({len(self)},)")
            idx = np.flatnonzero(idx)
        idx = idx.astype(np.intp, casting="same_kind").reshape(-1)
        arrays = {name: getattr(self, name)[idx] for name in _CORE_FIELDS + _BULGE_FIELDS}
        return CellData(
            cell_id=tuple(self.cell_id[i] for i in idx),
            group=tuple(self.group[i] for i in idx),
            extra={k: tuple(v[i] for i in idx) for k, v in self.extra.items()},
            comments=self.comments, path=self.path, sha256=self.sha256, **arrays,
        )

    def require_both_groups(self):
        """Return self if there are bulged and intact cells, else raise :class:`DataError`.

        The global fit needs bulged cells (their bulges give each cell's pressure, which
        calibrates the wall elasticity) and intact cells (whose pressure is the physiological
        turgor to be estimated). Loading a single group is allowed, e.g. to inspect it.
        """
        missing = [g for g, n in (("bulged", self.n_bulged), ("intact", self.n_intact)) if n == 0]
        if missing:
            raise DataError(
                f"no {' and no '.join(missing)} cells (found {self.n_bulged} bulged, "
                f"{self.n_intact} intact); the fit needs bulged cells to calibrate the wall "
                "elasticity and intact cells to estimate the physiological turgor",
                path=self.path,
            )
        return self


def _readonly(arr):
    arr.flags.writeable = False
    return arr


def _ids_text(cell_id, bad, limit=5):
    names = [repr(cell_id[i]) for i in np.flatnonzero(bad)[:limit]]
    more = int(np.count_nonzero(bad)) - len(names)
    return ", ".join(names) + (f" and {more} more" if more > 0 else "")


def _check_cell_ids(cell_id, path):
    if isinstance(cell_id, str):
        raise DataError(f"cell_id must be a sequence of str, got one str {cell_id!r}", path=path)
    cell_id = tuple(cell_id)
    seen = {}
    for i, cid in enumerate(cell_id):
        problem = cell_id_problem(cid)
        if problem is None and cid in seen:
            problem = f"duplicate cell_id {cid!r} (cells {seen[cid] + 1} and {i + 1})"
        if problem is not None:
            raise DataError(problem, path=path, column="cell_id", value=cid)
        seen[cid] = i
    return cell_id


def cell_id_problem(cid):
    """What is wrong with the cell name ``cid`` (a sentence), or None for a valid one: a
    non-empty str without surrounding whitespace or line breaks, not starting with ``#``."""
    if not isinstance(cid, str):
        return f"cell_id must be str, got {type(cid).__name__} {cid!r}"
    if not cid.strip():
        return "cell_id is empty; every cell needs a unique name"
    if cid != cid.strip() or "\n" in cid or "\r" in cid:
        return f"cell_id {cid!r} has surrounding whitespace or a line break"
    if cid.startswith("#"):
        return f"cell_id {cid!r} starts with '#', which would read as a comment line"
    return None


def _check_groups(group, n, cell_id, path):
    group = tuple(group)
    if len(group) != n:
        raise DataError(f"group has {len(group)} entries for {n} cells", path=path, column="group")
    for cid, g in zip(cell_id, group, strict=True):
        if g not in GROUPS:
            raise DataError(
                f"group must be one of {', '.join(map(repr, GROUPS))}, got {g!r} "
                f"(cell_id {cid!r})",
                path=path, column="group", value=g,
            )
    return group


def _check_numeric(values, name, is_bulged, cell_id, path):
    n = len(cell_id)
    is_bulge = name in _BULGE_FIELDS
    if values is None and is_bulge:
        values = np.full(n, np.nan)
    try:
        arr = np.array(values, dtype=float, copy=True)
    except (TypeError, ValueError) as err:
        raise DataError(f"{name} must be numeric: {err}", path=path, column=name) from None
    if arr.shape != (n,):
        raise DataError(f"{name} has shape {arr.shape}, expected ({n},)", path=path, column=name)
    must_be_set = is_bulged if is_bulge else np.ones(n, dtype=bool)
    bad = must_be_set & ~(np.isfinite(arr) & (arr > 0))
    if bad.any():
        raise DataError(
            f"{name} must be finite and > 0 [SI]; bad for cell_id {_ids_text(cell_id, bad)}"
            f" (values {arr[bad][:5].tolist()})",
            path=path, column=name,
        )
    stray = ~must_be_set & ~np.isnan(arr)
    if stray.any():
        raise DataError(
            f"{name} must be NaN on intact cells (a bulge field); set for cell_id "
            f"{_ids_text(cell_id, stray)}",
            path=path, column=name,
        )
    return _readonly(arr)


def _check_extra(extra, n, path):
    checked = {}
    for name, values in dict(extra).items():
        if not isinstance(name, str) or not name.strip() or name in COLUMNS:
            raise DataError(
                f"extra column name must be a non-empty str other than the standard columns, "
                f"got {name!r}",
                path=path,
            )
        values = tuple(values)
        if len(values) != n or not all(isinstance(v, str) for v in values):
            raise DataError(
                f"extra column must hold {n} str values, got {len(values)} entries",
                path=path, column=name,
            )
        checked[name] = values
    return types.MappingProxyType(checked)


def _check_comments(comments, path):
    if isinstance(comments, str):
        comments = (comments,)
    comments = tuple(comments)
    for c in comments:
        if not isinstance(c, str) or not c.startswith("#") or "\n" in c or "\r" in c:
            raise DataError(
                f"comment lines must be str starting with '#' without line breaks, got {c!r}",
                path=path,
            )
    return comments
