"""Read the approach segment of a force curve with afmformats, with calibration overrides.

Bruker NanoScope files (suffix :data:`BRUKER_SUFFIX`), which afmformats does not read, go to
:mod:`turgorbayes.curves.nanoscope` (single 16-bit force curves, checked against NanoScope
Analysis' export); the kinds it does not read stop with a :class:`~turgorbayes.errors.DataError`
naming the file and the reason (docs/curves.md, "Bruker files").
"""

import contextlib
import logging
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from turgorbayes.curves.qc import CurveRejected
from turgorbayes.errors import DataError

__all__ = ["BRUKER_SUFFIX", "Approach", "approach_columns", "calibration_value", "count_curves",
           "curve_index_problem", "force_calibration", "load_curves", "read_approach"]

#: Suffixes of Bruker Nanoscope files: ``.spm``, ``.pfc`` and numbered ``.000``-``.999``
#: (afmformats has no format with any of them; :mod:`turgorbayes.curves.nanoscope` reads them).
BRUKER_SUFFIX = re.compile(r"\.(spm|pfc|\d{3})", re.IGNORECASE)


@dataclass(frozen=True)
class Approach:
    """The approach segment of one force curve, SI units.

    Attributes
    ----------
    z : ndarray [m]
        Piezo travel toward the sample, ``height[0] - height`` (increasing).
    force : ndarray [N]
        Force from the cantilever deflection, as recorded (baseline not removed).
    height0 : float [m]
        Height at the first point (``height = height0 - z``).
    spring_constant : float [N/m]
        Cantilever spring constant used for ``force`` (after any override).
    height_column : str
        ``"height (measured)"`` (sensor) if the file has it, else ``"height (piezo)"``.
    path : pathlib.Path
    sensitivity : float [m/V] or None
        Deflection sensitivity (InvOLS) used for ``force`` (after any override; None if
        neither the file nor the caller gives one).
    curve_index : int
        Index of the curve in its file.
    """

    z: np.ndarray
    force: np.ndarray
    height0: float
    spring_constant: float
    height_column: str
    path: Path
    sensitivity: float = None
    curve_index: int = 0


def read_approach(path, spring_constant=None, sensitivity=None, curve_index=0):
    """Load one curve's approach segment from an AFM file (any afmformats format).

    Overrides rescale the recorded force, which the instrument computed as
    ``k_file * s_file * V``: ``F = F_file (k / k_file) (s / s_file)``.

    Parameters
    ----------
    path : str or pathlib.Path
    spring_constant : float [N/m], optional
        Overrides the file's spring constant.
    sensitivity : float [m/V], optional
        Overrides the file's deflection sensitivity.
    curve_index : int
        0-based index of the curve in a multi-curve file (a ``.jpk-force-map``), in the order
        afmformats lists them; 0 for a single-curve file.

    Returns
    -------
    Approach

    Raises
    ------
    CurveRejected
        ``unreadable_file`` or ``calibration_missing``.
    turgorbayes.errors.DataError
        ``curve_index`` is not an integer >= 0, or the file has no curve of that index, or it
        is a Bruker NanoScope file (suffix :data:`BRUKER_SUFFIX`) of a kind
        :func:`turgorbayes.curves.nanoscope.read_nanoscope` does not read, or malformed.
    """
    path = Path(path)
    curve = _curve(path, curve_index)
    force, height, column = approach_columns(curve, path)
    k_file = calibration_value(curve, "spring constant")
    s_file = calibration_value(curve, "sensitivity")
    scale, k = force_calibration(k_file, s_file, spring_constant, sensitivity)
    order = np.argsort(height[0] - height, kind="stable")
    z = (height[0] - height)[order]
    return Approach(z=z, force=force[order] * scale, height0=float(height[0]),
                    spring_constant=k, height_column=column, path=path,
                    sensitivity=sensitivity if sensitivity is not None else s_file,
                    curve_index=curve_index)


def count_curves(path):
    """Number of curves afmformats reads in ``path`` (a force map's data are read lazily).

    Raises
    ------
    CurveRejected
        ``unreadable_file``.
    turgorbayes.errors.DataError
        A Bruker NanoScope file that is not read (as in :func:`read_approach`).
    """
    return len(load_curves(Path(path)))


def _nanoscope_curves(path):
    """A Bruker NanoScope file's curve as afmformats data (the last suffix decides, not the content).

    Raises
    ------
    turgorbayes.errors.DataError
        From :func:`turgorbayes.curves.nanoscope.load_nanoscope`: a kind it does not read, or a
        malformed file (the run stops: every such file of a session would fail the same way).
    """
    from afmformats import AFMForceDistance

    from turgorbayes.curves.nanoscope import load_nanoscope

    return [AFMForceDistance(data=d["data"], metadata=d["metadata"]) for d in load_nanoscope(path)]


#: afmformats' loader logger: it logs the traceback of every file it fails to load.
_AFMFORMATS_LOGGER = "afmformats.formats"


@contextlib.contextmanager
def _quiet(name):
    """No records from the logger ``name`` inside the block."""
    log = logging.getLogger(name)
    drop = lambda record: False  # noqa: E731
    log.addFilter(drop)
    try:
        yield
    finally:
        log.removeFilter(drop)


def load_curves(path):
    """Every force-distance curve of a file (a force map has many): Bruker NanoScope files by
    :mod:`turgorbayes.curves.nanoscope`, every other format by afmformats.

    Raises
    ------
    turgorbayes.curves.qc.CurveRejected
        ``unreadable_file``: afmformats cannot read it, or it holds no curve.
    turgorbayes.errors.DataError
        A NanoScope file the reader refuses (force volume, PeakForce, 4-byte data, ...).
    """
    if BRUKER_SUFFIX.fullmatch(path.suffix):
        return _nanoscope_curves(path)
    import afmformats
    from afmformats import errors, meta

    # afmformats' own errors derive from BaseException, not Exception
    failures = (Exception, errors.AFMFileFormatError, errors.MissingMetaDataError,
                meta.MetaDataMissingError)
    try:
        with _quiet(_AFMFORMATS_LOGGER):  # it logs a failed load's traceback; we say why once
            curves = afmformats.load_data(path)
    except UnicodeDecodeError as err:
        raise CurveRejected("unreadable_file", f"{path.name} is not text of the {path.suffix} "
                            f"format (byte {err.start} is not {err.encoding}): a binary file, "
                            "or another format under this suffix?") from None
    except failures as err:
        raise CurveRejected("unreadable_file", f"{type(err).__name__}: {err}") from None
    if not curves:
        raise CurveRejected("unreadable_file", "no force-distance curve in the file")
    return curves


def _curve(path, index):
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)) or index < 0:
        raise DataError(f"curve_index must be an integer >= 0, got {index!r}", path=path,
                        column="curve_index", value=str(index))
    curves = load_curves(path)
    if index >= len(curves):
        raise DataError(curve_index_problem(index, len(curves)), path=path, column="curve_index",
                        value=str(index))
    return curves[index]


def curve_index_problem(index, n_curves, name="the file"):
    """The words of an out-of-range ``curve_index`` error (also used by the manifest)."""
    return (f"curve_index {index} is out of range: {name} has {n_curves} "
            f"curve{'s' if n_curves != 1 else ''} (indices 0 to {n_curves - 1})")


def approach_columns(curve, path):
    """Finite approach force [N] and height [m] of one afmformats curve, and the height column used.

    The measured height if the file has it, else the piezo height; an Asylum Research ``.ibw``
    curve is cut at its approach's end. Raises ``CurveRejected("unreadable_file")`` if fewer
    than 10 finite points remain.
    """
    column = "height (measured)" if "height (measured)" in curve.columns else "height (piezo)"
    try:
        force = np.asarray(curve.appr["force"], float)
        height = np.asarray(curve.appr[column], float)
    except (KeyError, ValueError) as err:
        raise CurveRejected("unreadable_file", f"no approach force/height: {err}") from None
    if path.suffix.lower() == ".ibw":
        end = _ibw_approach_end(path)
        force, height = force[:end], height[:end]
    finite = np.isfinite(force) & np.isfinite(height)
    if finite.sum() < 10:
        raise CurveRejected("unreadable_file", f"approach has {finite.sum()} finite points")
    return force[finite], height[finite], column


def _ibw_approach_end(path):
    """Points in an Asylum Research curve's approach, from its wave note (None: all of them).

    afmformats (0.18.7) puts every point of an .ibw curve in segment 0, approach and retract
    alike. The note's ``Indexes`` (e.g. ``0,5057,10096``) ends each segment and ``Direction``
    (``NaN,1,-1``) gives its direction: the approach is the segment of direction 1.
    """
    from igor2 import binarywave

    note = binarywave.load(path)["wave"]["note"].decode("latin-1")
    fields = {key.strip(): value for key, _, value in
              (line.partition(":") for line in note.split("\r"))}
    try:
        indexes = [int(v) for v in fields["Indexes"].split(",") if v.strip()]
        direction = [v.strip() for v in fields["Direction"].split(",") if v.strip()]
        return indexes[direction.index("1")] + 1
    except (KeyError, ValueError, IndexError):
        return None


def calibration_value(curve, key):
    """A calibration value of a curve's metadata (``"spring constant"``, ``"sensitivity"``), or None.

    None if the file lacks it or it is not a finite positive number.
    """
    from afmformats.meta import MetaDataMissingError  # a BaseException, not an Exception

    try:
        value = float(curve.metadata[key])
    except (MetaDataMissingError, TypeError, ValueError):
        return None
    return value if np.isfinite(value) and value > 0 else None


def force_calibration(k_file, s_file, k_new, s_new):
    """Force scale factor and the spring constant in use.

    Parameters
    ----------
    k_file, s_file : float or None
        The file's spring constant [N/m] and sensitivity [m/V] (:func:`calibration_value`).
    k_new, s_new : float or None
        The manifest's overrides (None: keep the file's).

    Returns
    -------
    (float, float)
        The factor the file's forces are multiplied by, and the spring constant in use.
    """
    if k_file is None and k_new is None:
        raise CurveRejected("calibration_missing", "no spring constant in the file or manifest")
    scale = 1.0
    if s_new is not None:
        if s_file is None:
            raise CurveRejected("calibration_missing", "a sensitivity override needs the file's "
                                "sensitivity to rescale its forces, and the file has none")
        scale *= s_new / s_file
    if k_new is not None and k_file is not None:
        scale *= k_new / k_file
    return scale, k_new if k_new is not None else k_file
