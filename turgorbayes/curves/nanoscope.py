"""Bruker NanoScope force curves, read natively (single curves, 16-bit), as an afmformats recipe.

A NanoScope file (``.000``-``.999``, ``.spm``, ``.pfc``) is an ASCII header of ``\\Key: value``
lines in ``\\*Section`` blocks, ending at ``\\*File list end``, followed by the binary data.
A single force curve (``\\Operating mode: Force``) has one ``\\*Ciao force image list`` block
per channel (deflection, ``Height Sensor``, ...), each with its ``\\Data offset``,
``\\Data length`` and ``\\Bytes/pixel``. The channel holds two slots of
``Data length / Bytes per pixel / 2`` little-endian integers: the extend (approach), stored
from the turnaround backwards, then the retract, stored forwards. ``\\Samps/line: A B`` gives
the points used: ``B`` of the extend (fewer than the slot when a trigger ended the approach
early; the rest is padding) and ``A`` of the retract.

Scalings (verified against NanoScope Analysis' own ASCII export: docs/curves.md, "Bruker
files"; ``studies/bruker_pairs.py``):

- a channel's value in volts is ``integer x hard scale``, the ``(... V/LSB)`` of its
  ``\\@4:Z scale`` line; in metres it is that times the soft scale the line names in brackets,
  ``\\@Sens. DeflSens`` for a deflection, ``\\@Sens. ZsensSens`` for the height sensor (nm/V);
- the nominal Z ramp: ``\\@4:Ramp size`` (volts) x ``\\@Sens. Zsens`` (nm/V) over ``A``
  steps; the extend's ``B`` points are its last ``B`` positions;
- ``\\Spring Constant`` (N/m) of the deflection channel's block; ``\\Deflection Sensitivity
  Correction`` is recorded but not applied (the vendor's export does not apply it to the
  deflection either).

Heights follow afmformats' convention (they fall as the tip approaches the sample):
``height (piezo)`` is minus the ramp position, ``height (measured)`` the height sensor,
oriented the same way. Refused with a :class:`~turgorbayes.errors.DataError` that says why:
force volumes, PeakForce Capture and images (``\\Operating mode`` other than ``Force``),
4-byte data (its scale is not verified against a vendor export), files without a deflection
channel, and malformed headers or data.

:func:`load_nanoscope` has afmformats' loader signature and :data:`recipe_nanoscope` its
recipe layout, so the reader can be offered upstream (one recipe per suffix:
:func:`recipe_for`).
"""

import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from turgorbayes.errors import DataError

__all__ = ["Channel", "NanoscopeCurve", "detect_nanoscope", "load_nanoscope", "parse_header",
           "read_nanoscope", "recipe_for", "recipe_nanoscope"]

HEADER_END = b"\\*File list end"
FORCE_FILE_START = b"\\*Force file list"
CHANNEL_SECTION = "Ciao force image list"
_SCALED = re.compile(r"^V\s*(?:\[(?P<soft>[^\]]*)\])?\s*\((?P<hard>[-+0-9.eE]+)\s*(?P<unit>[^)/]*)/LSB\)"
                     r"\s*(?P<value>[-+0-9.eE]+)?")
_SOFT = re.compile(r"^V\s+(?P<value>[-+0-9.eE]+)\s*(?P<unit>\S*)")
_LENGTH_PER_VOLT = {"nm/V": 1e-9, "um/V": 1e-6, "~m/V": 1e-6, "\xb5m/V": 1e-6}


@dataclass(frozen=True)
class Channel:
    """One channel of a NanoScope force curve, in SI units.

    Attributes
    ----------
    name : str
        The channel's data type in brackets (``DeflectionError``, ``ZSensor``, ...).
    approach, retract : ndarray [m]
        The extend in time order, and the retract in time order.
    hard_scale : float [V/LSB]
    soft_scale : float [m/V]
    """

    name: str
    approach: np.ndarray
    retract: np.ndarray
    hard_scale: float
    soft_scale: float


@dataclass(frozen=True)
class NanoscopeCurve:
    """A single NanoScope force curve with the header values that scale it.

    Attributes
    ----------
    path : pathlib.Path
    deflection : Channel
        Cantilever deflection [m] (sensitivity applied, offset as recorded).
    ramp_approach, ramp_retract : ndarray [m]
        Nominal Z ramp position (increases toward the sample), as NanoScope Analysis exports it.
    ramp_size : float [m]
        ``\\@4:Ramp size`` x ``\\@Sens. Zsens``.
    height_sensor : Channel or None
        The ``Height Sensor`` channel [m] (increases toward the sample), if recorded.
    spring_constant : float [N/m]
    deflection_sensitivity : float [m/V]
        ``\\@Sens. DeflSens``.
    sensitivity_correction : float or None
        ``\\Deflection Sensitivity Correction`` (not applied).
    version : str
        ``\\Version`` of the header (e.g. ``0x09010300``).
    header : list of (str, dict)
        Every section's name and its ``key: value`` strings (first occurrence of a key).
    """

    path: Path
    deflection: Channel
    ramp_approach: np.ndarray
    ramp_retract: np.ndarray
    ramp_size: float
    height_sensor: Channel
    spring_constant: float
    deflection_sensitivity: float
    sensitivity_correction: float
    version: str
    header: list = field(repr=False)


def parse_header(raw, path):
    """The ASCII header's sections, in file order.

    Parameters
    ----------
    raw : bytes
        The file's content (at least up to ``\\*File list end``).
    path : str or pathlib.Path
        For error messages.

    Returns
    -------
    list of (str, dict)
        Section name (without ``\\*``) and its ``key: value`` strings; a key repeated within a
        section keeps its first value.

    Raises
    ------
    turgorbayes.errors.DataError
        No ``\\*File list end`` in the file.
    """
    end = raw.find(HEADER_END)
    if end < 0:
        raise DataError("not a readable Bruker NanoScope file: no '\\*File list end' line "
                        f"ends its header (file of {len(raw)} bytes)", path=path)
    sections = []
    for line in raw[:end].decode("latin-1").replace("\r", "\n").split("\n"):
        if line.startswith("\\*"):
            sections.append((line[2:].strip(), {}))
        elif line.startswith("\\") and sections:
            key, _, value = line[1:].rstrip(":").partition(": ")  # '@4:Z scale: V ...'
            sections[-1][1].setdefault(key.strip(), value.strip())
    return sections


def _find(header, key, section=None):
    """First value of ``key`` (in sections named ``section`` if given), or None."""
    for name, entries in header:
        if (section is None or name == section) and key in entries:
            return entries[key]
    return None


def _require(header, key, path, section=None):
    value = _find(header, key, section)
    if value is None:
        where = f" in '\\*{section}'" if section else ""
        raise DataError(f"Bruker NanoScope header has no '\\{key}'{where}", path=path)
    return value


def _number(text, key, path):
    try:
        value = float(text)
    except ValueError:
        raise DataError(f"Bruker NanoScope header: '\\{key}' is not a number", path=path,
                        column=key, value=text) from None
    if not np.isfinite(value):
        raise DataError(f"Bruker NanoScope header: '\\{key}' is not finite", path=path,
                        column=key, value=text)
    return value


def _scaled(text, key, path):
    """``(soft scale name, hard scale [V/LSB], value [V])`` of a ``V [Sens. X] (h V/LSB) v V`` line."""
    match = _SCALED.match(text)
    if match is None or match["unit"].strip() != "V":
        raise DataError(f"Bruker NanoScope header: '\\{key}' is not of the form "
                        "'V [Sens. name] (scale V/LSB) value V'", path=path, column=key, value=text)
    value = match["value"]
    return (match["soft"], _number(match["hard"], key, path),
            None if value is None else _number(value, key, path))


def _soft_scale(header, name, path):
    """A ``\\@Sens. name: V s nm/V`` soft scale, in m/V."""
    key = f"@{name}"
    text = _require(header, key, path)
    match = _SOFT.match(text)
    if match is None or match["unit"] not in _LENGTH_PER_VOLT:
        raise DataError(f"Bruker NanoScope header: '\\{key}' is not a length per volt "
                        f"(nm/V or um/V)", path=path, column=key, value=text)
    scale = _number(match["value"], key, path) * _LENGTH_PER_VOLT[match["unit"]]
    if scale <= 0:
        raise DataError(f"Bruker NanoScope header: '\\{key}' must be > 0", path=path, column=key,
                        value=text)
    return scale


def _check_single_curve(header, path):
    mode = _require(header, "Operating mode", path)
    if mode != "Force":
        raise DataError(f"a Bruker NanoScope file in operating mode '{mode}', which turgorbayes "
                        "does not read: only single force curves ('\\Operating mode: Force') are "
                        "verified against NanoScope Analysis (docs/curves.md, 'Bruker files'); "
                        "export the curve as ASCII instead", path=path, column="Operating mode",
                        value=mode)


def _point_counts(entries, path):
    """``(retract points A, extend points B)`` of a channel's ``\\Samps/line: A B``."""
    text = entries.get("Samps/line", "")
    parts = text.split()
    if len(parts) != 2 or not all(p.isdigit() and int(p) > 1 for p in parts):
        raise DataError("Bruker NanoScope channel: '\\Samps/line' must be two point counts "
                        "(retract, extend) > 1", path=path, column="Samps/line", value=text)
    return int(parts[0]), int(parts[1])


def _slot(entries, raw, path):
    """``(data offset [bytes], points per segment slot)`` of a channel, checked against the file."""
    values = {}
    for key in ("Data offset", "Data length", "Bytes/pixel"):
        text = entries.get(key, "")
        if not text.isdigit():
            raise DataError(f"Bruker NanoScope channel: '\\{key}' must be an integer >= 0",
                            path=path, column=key, value=text)
        values[key] = int(text)
    offset, length, size = values["Data offset"], values["Data length"], values["Bytes/pixel"]
    if size != 2:
        raise DataError(f"Bruker NanoScope force data of {size} bytes per point, which "
                        "turgorbayes does not read: only 2-byte data are verified against "
                        "NanoScope Analysis (docs/curves.md, 'Bruker files')", path=path,
                        column="Bytes/pixel", value=str(size))
    if offset + length > len(raw):
        raise DataError(f"Bruker NanoScope channel data end at byte {offset + length}, past the "
                        f"end of the file ({len(raw)} bytes): truncated file", path=path,
                        column="Data length", value=str(length))
    return offset, length // (2 * size)


def _channel(entries, raw, header, path):
    """A ``\\*Ciao force image list`` block's data, scaled to metres."""
    n_retract, n_approach = _point_counts(entries, path)
    offset, slot = _slot(entries, raw, path)
    if max(n_retract, n_approach) > slot:
        raise DataError(f"Bruker NanoScope channel: '\\Samps/line' asks for {n_retract} and "
                        f"{n_approach} points, the data hold {slot} per segment", path=path,
                        column="Samps/line", value=entries["Samps/line"])
    soft_name, hard, _ = _scaled(entries.get("@4:Z scale", ""), "@4:Z scale", path)
    if soft_name is None:
        raise DataError("Bruker NanoScope channel: '\\@4:Z scale' names no soft scale "
                        "('[Sens. ...]'), so its values have no length unit", path=path,
                        column="@4:Z scale", value=entries.get("@4:Z scale", ""))
    scale = hard * _soft_scale(header, soft_name, path)
    data = np.frombuffer(raw, "<i2", count=2 * slot, offset=offset).astype(float) * scale
    name = re.search(r"\[([^\]]*)\]", entries.get("@4:Image Data", ""))
    return Channel(name=name[1] if name else "", approach=data[:n_approach][::-1].copy(),
                   retract=data[slot:slot + n_retract].copy(), hard_scale=hard,
                   soft_scale=scale / hard)


def _ramp(entries, header, path, n_retract, n_approach):
    """Ramp size [m] and nominal ramp position [m] of the extend and retract points.

    The position increases toward the sample in ``A = n_retract`` steps of ``size / A``; the
    extend's ``B`` points are the last ``B`` positions, the retract runs back from the end.
    """
    soft_name, _, size_V = _scaled(_require(header, "@4:Ramp size", path, CHANNEL_SECTION),
                                   "@4:Ramp size", path)
    if soft_name is None or size_V is None or size_V <= 0:
        raise DataError("Bruker NanoScope header: '\\@4:Ramp size' needs a soft scale and a "
                        "size > 0 V", path=path, column="@4:Ramp size",
                        value=entries.get("@4:Ramp size", ""))
    size = size_V * _soft_scale(header, soft_name, path)
    step = size / n_retract
    approach = (n_retract - n_approach + np.arange(n_approach)) * step
    retract = (n_retract - 1 - np.arange(n_retract)) * step
    return size, approach, retract


def _channels(header, raw, path):
    """The deflection block's entries and every channel, by bracketed data type."""
    blocks = [entries for name, entries in header if name == CHANNEL_SECTION]
    channels = [_channel(entries, raw, header, path) for entries in blocks]
    for entries, channel in zip(blocks, channels, strict=True):
        if "Deflection" in channel.name:
            return entries, channel, channels
    names = ", ".join(c.name or "?" for c in channels) or "none"
    raise DataError(f"Bruker NanoScope file has no deflection channel (channels: {names})",
                    path=path)


def _spring_constant(entries, path):
    text = entries.get("Spring Constant", entries.get("Spring constant"))
    if text is None:
        return None
    value = _number(text, "Spring Constant", path)
    return value if value > 0 else None


def _correction(header, path):
    text = _find(header, "Deflection Sensitivity Correction")
    return None if text is None else _number(text, "Deflection Sensitivity Correction", path)


def read_nanoscope(path):
    """Read a single Bruker NanoScope force curve with its scalings.

    Parameters
    ----------
    path : str or pathlib.Path

    Returns
    -------
    NanoscopeCurve

    Raises
    ------
    turgorbayes.errors.DataError
        A file this reader does not read (force volume, PeakForce Capture, image, 4-byte data,
        no deflection channel) or a malformed one; the message names the file and the reason.
    """
    path = Path(path)
    raw = path.read_bytes()
    if not raw.startswith(FORCE_FILE_START):
        raise DataError("not a Bruker NanoScope force file: it does not start with "
                        "'\\*Force file list'", path=path, value=raw[:20].decode("latin-1"))
    header = parse_header(raw, path)
    _check_single_curve(header, path)
    entries, deflection, channels = _channels(header, raw, path)
    n_retract, n_approach = _point_counts(entries, path)
    ramp_size, ramp_approach, ramp_retract = _ramp(entries, header, path, n_retract, n_approach)
    sensor = next((c for c in channels if c.name == "ZSensor"), None)
    if sensor is not None and (sensor.approach.size, sensor.retract.size) != (n_approach, n_retract):
        sensor = None  # a sensor of another length cannot be paired point by point
    return NanoscopeCurve(path=path, deflection=deflection, ramp_approach=ramp_approach,
                          ramp_retract=ramp_retract, ramp_size=ramp_size, height_sensor=sensor,
                          spring_constant=_spring_constant(entries, path),
                          deflection_sensitivity=_soft_scale(header, "Sens. DeflSens", path),
                          sensitivity_correction=_correction(header, path),
                          version=_find(header, "Version") or "", header=header)


def _sensor_height(curve):
    """Height sensor as a height (falls as the tip approaches), oriented by the ramp."""
    sensor = curve.height_sensor
    both = np.concatenate([sensor.approach, sensor.retract])
    ramp = np.concatenate([curve.ramp_approach, curve.ramp_retract])
    sign = -1.0 if np.cov(both, ramp)[0, 1] >= 0 else 1.0
    return sign * both


def _metadata(curve, k, s):
    meta = {"path": curve.path, "enum": 0, "imaging mode": "force-distance",
            "software": "NanoScope", "software version": curve.version,
            "point count": curve.ramp_approach.size + curve.ramp_retract.size,
            "z range": curve.ramp_size}
    if k is not None:
        meta["spring constant"] = k
    meta["sensitivity"] = s
    instrument = _find(curve.header, "Description")
    if instrument:
        meta["instrument"] = instrument
    return meta


def _curve_dict(curve, meta_override):
    """afmformats' ``{"data", "metadata"}`` of a curve (calibration overrides applied to force)."""
    k = meta_override.get("spring constant", curve.spring_constant)
    s = meta_override.get("sensitivity", curve.deflection_sensitivity)
    deflection = np.concatenate([curve.deflection.approach, curve.deflection.retract])
    n_approach = curve.ramp_approach.size
    data = {"height (piezo)": -np.concatenate([curve.ramp_approach, curve.ramp_retract]),
            "segment": np.repeat(np.array([0, 1], dtype=np.uint8),
                                 [n_approach, curve.ramp_retract.size])}
    if k is not None:
        data["force"] = deflection * (s / curve.deflection_sensitivity) * k
    if curve.height_sensor is not None:
        data["height (measured)"] = _sensor_height(curve)
    meta = _metadata(curve, k, s)
    meta.update({key: value for key, value in meta_override.items()
                 if key not in ("spring constant", "sensitivity")})
    return {"data": data, "metadata": meta}


def load_nanoscope(path, callback=None, meta_override=None):
    """afmformats loader: a single NanoScope force curve as afmformats' data and metadata.

    Parameters
    ----------
    path : str or pathlib.Path
    callback : callable, optional
        Called with 1.0 when done (afmformats' progress convention).
    meta_override : dict, optional
        afmformats metadata to override; ``spring constant`` [N/m] and ``sensitivity`` [m/V]
        rescale the force (computed from the raw deflection).

    Returns
    -------
    list of dict
        One ``{"data": {"force" [N], "height (piezo)" [m], "height (measured)" [m] if the
        file has a height sensor, "segment"}, "metadata": {...}}``. Without a spring constant
        in the file or ``meta_override`` there is no ``force`` column.
    """
    curve = read_nanoscope(path)
    result = [_curve_dict(curve, dict(meta_override or {}))]
    if callback is not None:
        callback(1.0)
    return result


def detect_nanoscope(path):
    """True if ``path`` starts like a NanoScope force file (``\\*Force file list``)."""
    with Path(path).open("rb") as handle:
        return handle.read(len(FORCE_FILE_START)) == FORCE_FILE_START


#: afmformats recipe (``afmformats.formats.register_format``); NanoScope numbers its files
#: ``.000``-``.999``, so upstream registers one copy per suffix (:func:`recipe_for`).
recipe_nanoscope = {
    "descr": "NanoScope single force curve (16-bit)",
    "detect": detect_nanoscope,
    "loader": load_nanoscope,
    "suffix": ".spm",
    "modalities": ["force-distance"],
    "maker": "Bruker",
}


def recipe_for(suffix):
    """:data:`recipe_nanoscope` for another suffix (e.g. ``".000"``)."""
    return {**recipe_nanoscope, "suffix": suffix}
