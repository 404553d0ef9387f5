"""The grid of a surrogate build: target inflation numbers times anisotropies, and its parser."""

import re
from dataclasses import dataclass

import numpy as np

from turgorbayes.errors import TurgorBayesError

__all__ = ["DEFAULT_GRID_SPEC", "GridSpec", "GridSpecError", "parse_grid"]

#: The grid of the shipped table (docs/fem.md, "The surrogate table"): 19 target inflation
#: numbers, 0.001-0.0033 by hand and 16 log-spaced from 0.0056 to 0.63, times 9 anisotropies
#: 0.15-1 (what the wall law reaches within its priors, and the outer-membrane envelope for
#: gamma <= 1.5; steeper envelopes fall below 0.15 in a few % of states: docs/fem.md). The
#: top target is above the covered range because the table's domain is the FE's *actual* x,
#: which falls short of the target at large x (and the interpolator never extrapolates): the
#: shipped domain is x in [0.001, 0.587].
DEFAULT_GRID_SPEC = ("x=0.001,0.0019,0.0033,0.0056:0.63:16log,"
                     "ratio=0.15,0.2,0.25,0.3,0.4,0.5,0.65,0.8,1.0")

_AXES = ("x", "ratio")


class GridSpecError(TurgorBayesError, ValueError):
    """A ``--grid`` specification cannot be parsed or holds invalid values."""



@dataclass(frozen=True)
class GridSpec:
    """Grid of the sweep: target inflation numbers ``x`` and anisotropies ``ratio``.

    Attributes
    ----------
    x : tuple of float
        Target ``P R_c/(E_perp t)``, strictly increasing, > 0.
    ratio : tuple of float
        ``E_par/E_perp``, strictly increasing, > 0.
    spec : str
        The text it was parsed from (recorded in the file).
    """

    x: tuple
    ratio: tuple
    spec: str

    def points(self):
        """All ``(x, ratio)`` pairs, ratio-major (the order of the table's rows)."""
        return [(x, r) for r in self.ratio for x in self.x]


def parse_grid(spec=DEFAULT_GRID_SPEC):
    """Parse a grid specification.

    Syntax: ``AXIS=ITEMS[,AXIS=ITEMS]`` for the axes ``x`` and ``ratio`` (both required; ``;``
    may also separate axes). ``ITEMS`` is a comma-separated list whose items are numbers or
    ranges ``START:STOP:Nlog`` (N log-spaced values, ends included) or ``START:STOP:N[lin]``
    (N evenly spaced). Items are merged, sorted and de-duplicated. Example:
    ``x=0.01:0.5:13log,ratio=0.3,0.4,0.5,0.7,1.0``.

    Parameters
    ----------
    spec : str

    Returns
    -------
    GridSpec

    Raises
    ------
    GridSpecError
        With the offending part of the text and what is allowed.
    """
    if not isinstance(spec, str) or not spec.strip():
        raise GridSpecError(f"grid spec must be a non-empty string, got {spec!r}")
    axes = {}
    for part in re.split(r"[;,]\s*(?=[A-Za-z_]\w*\s*=)", spec.strip()):
        name, sep, items = part.partition("=")
        name = name.strip()
        if not sep or name not in _AXES:
            raise GridSpecError(
                f"grid spec {spec!r}: bad axis {part!r}; expected 'x=...' or 'ratio=...'"
            )
        if name in axes:
            raise GridSpecError(f"grid spec {spec!r}: axis {name!r} given twice")
        axes[name] = _parse_axis(name, items, spec)
    missing = [a for a in _AXES if a not in axes]
    if missing:
        raise GridSpecError(f"grid spec {spec!r}: missing axis {missing} (both x and ratio needed)")
    return GridSpec(x=axes["x"], ratio=axes["ratio"], spec=spec.strip())


def _parse_axis(name, items, spec):
    values = []
    for item in items.split(","):
        item = item.strip()
        values.extend(_parse_range(item, spec) if ":" in item else [_parse_number(item, spec)])
    arr = np.unique(np.asarray(values, dtype=float))
    if arr.size > 1:  # merge values that differ only by rounding (e.g. a list item on a range)
        arr = arr[np.r_[True, np.diff(arr) > 1e-9 * np.abs(arr[1:])]]
    if not np.all(np.isfinite(arr) & (arr > 0)):
        raise GridSpecError(f"grid spec {spec!r}: {name} values must be finite and > 0, got {arr}")
    if arr.size < 4:
        raise GridSpecError(
            f"grid spec {spec!r}: {name} needs >= 4 distinct values for a cubic table, "
            f"got {arr.size}"
        )
    return tuple(float(v) for v in arr)


def _parse_number(text, spec):
    try:
        return float(text)
    except ValueError:
        raise GridSpecError(
            f"grid spec {spec!r}: {text!r} is not a number or a range START:STOP:N[log|lin]"
        ) from None


def _parse_range(text, spec):
    m = re.fullmatch(r"([^:]+):([^:]+):(\d+)(log|lin)?", text)
    if not m:
        raise GridSpecError(
            f"grid spec {spec!r}: bad range {text!r}; expected START:STOP:N, START:STOP:Nlin "
            "or START:STOP:Nlog"
        )
    start, stop = _parse_number(m[1], spec), _parse_number(m[2], spec)
    n = int(m[3])
    if n < 2 or not 0 < start < stop:
        raise GridSpecError(
            f"grid spec {spec!r}: range {text!r} needs 0 < START < STOP and N >= 2"
        )
    return np.geomspace(start, stop, n) if m[4] == "log" else np.linspace(start, stop, n)
