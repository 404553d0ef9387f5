"""Real instrument files through the raw-curves front end (read_approach -> reduce_curve).

The files are afmformats' own test data, vendored with its MIT licence in tests/data/afmformats/
(README.md there: source commit, original paths, what each file is). None is an indentation of a
bacterium: a JPK CellHesion curve and force map of undocumented soft samples and an Asylum
Research MFP-3D curve (sample undocumented; afmformats credits its Igor data to the authors of a
microgel study), so these tests check the reading and the reduction path, not turgor. They run
in every clone (no skips): the data are in the repository.

Every expected number is read from the file's own header independently of afmformats: the JPK
``.properties`` text inside the zip archive with zipfile, the Igor binary wave's note with igor2.
"""

import functools
import re
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from igor2 import binarywave

from turgorbayes.curves import ReductionSettings, reduce_curve
from turgorbayes.curves.load import read_approach

DATA = Path(__file__).resolve().parents[1] / "data" / "afmformats"
FILES = {
    "jpk-force": DATA / "fmt-jpk-fd_spot3-0192.jpk-force",
    "jpk-force-map": DATA / "fmt-jpk-fd_map-data-reference-points.jpk-force-map",
    "ibw": DATA / "fmt-igor-fd_U3_3_p10004.ibw",
}

# afmformats 0.18.7 (formats/fmt_igor.py) labels every point of an .ibw curve segment 0;
# read_approach cuts the approach at the Igor note's "Indexes" (turgorbayes/curves/load.py).
ALL = sorted(FILES)


@dataclass(frozen=True)
class Header:
    """What the file's own header says (SI units)."""

    spring_constant: float  # [N/m]
    n_approach: int  # points in the approach (extend) segment
    setpoint: float  # [N] force rise above the baseline at which the approach stops


def _properties(archive, member):
    """A Java ``.properties`` member of a JPK zip archive as a dict (keys and values as text)."""
    out = {}
    for line in archive.read(member).decode("latin-1").splitlines():
        if line and not line.startswith("#"):
            key, _, value = line.partition("=")
            out[key.strip()] = value.strip()
    return out


def _jpk_header(path):
    """JPK: the first curve's header (a force map's lowest ``index/N/``, read_approach's curve)."""
    with zipfile.ZipFile(path) as archive:
        names = archive.namelist()
        indices = sorted(int(m.group(1)) for n in names if (m := re.fullmatch(r"index/(\d+)/header\.properties", n)))
        prefix = f"index/{indices[0]}/" if indices else ""
        curve = _properties(archive, prefix + "header.properties")
        segment = _properties(archive, prefix + "segments/0/segment-header.properties")
        lcd = segment.get("channel.vDeflection.lcd-info.*")
        if lcd is None:  # single curve: the conversions are in the segment header
            conversions, key = segment, "channel.vDeflection.conversion-set.conversion."
        else:  # force map: the segment points to shared-data's lcd-info entry
            conversions = _properties(archive, "shared-data/header.properties")
            key = f"lcd-info.{lcd}.conversion-set.conversion."
    k = float(conversions[key + "force.scaling.multiplier"])  # [N/m]
    sensitivity = float(conversions[key + "distance.scaling.multiplier"])  # [m/V]
    # the setpoint is stored in volts of vDeflection, relative to the baseline
    volts = next(float(v) for name, v in curve.items()
                 if name.endswith(("force-settings.relative-setpoint", "force-settings.segment.0.setpoint")))
    return Header(k, int(segment["force-segment-header.num-points"]), volts * sensitivity * k)


def _ibw_header(path):
    """Asylum Research: the wave note's ``SpringConstant``, ``Indexes``/``Direction`` (the
    approach is the segment of direction 1, points 0..Indexes[i]) and ``TriggerPoint`` [N]."""
    note = binarywave.load(path)["wave"]["note"].decode("latin-1")
    fields = dict(line.split(":", 1) for line in note.split("\r") if ":" in line)
    fields = {key.strip(): value.strip() for key, value in fields.items()}
    indexes = [int(v) for v in fields["Indexes"].split(",") if v.strip()]
    direction = [v.strip() for v in fields["Direction"].split(",") if v.strip()]
    assert fields["TriggerChannel"] == "Force"  # else TriggerPoint is not a force
    return Header(float(fields["SpringConstant"]), indexes[direction.index("1")] + 1,
                  float(fields["TriggerPoint"]))


@functools.cache
def header(name):
    path = FILES[name]
    return _ibw_header(path) if path.suffix == ".ibw" else _jpk_header(path)


@functools.cache
def approach(name):
    return read_approach(FILES[name])


@functools.cache
def reductions(name):
    """Power-law fit and threshold contact on the bulge target (deepest point; the radius is
    not used by the reduction)."""
    fit = reduce_curve(FILES[name], "bulge", 2e-6)
    simple = reduce_curve(FILES[name], "bulge", 2e-6, ReductionSettings(method="threshold"))
    assert fit.ok and simple.ok, (fit.detail, simple.detail)
    return fit, simple


@pytest.mark.parametrize("name", ALL)
def test_spring_constant_is_the_headers(name):
    # Reference: the header's force multiplier of vDeflection (JPK) / SpringConstant (Igor note);
    # measured 0.04349, 0.01095, 0.31451 N/m. Both are float text, so they agree to rounding.
    assert approach(name).spring_constant == pytest.approx(header(name).spring_constant, rel=1e-12)
    fit, _ = reductions(name)
    assert fit.spring_constant == pytest.approx(header(name).spring_constant, rel=1e-12)


@pytest.mark.parametrize("name", ALL)
def test_approach_has_the_headers_point_count(name):
    # Reference: force-segment-header.num-points of segment 0 (JPK: 2000 and 10000 points) / the
    # note's Indexes (Igor: points 0..5057 approach, 5058..10096 retract). Equality also means no
    # point was dropped as non-finite and none of the retract was taken.
    assert approach(name).z.size == header(name).n_approach


@pytest.mark.parametrize("name", ALL)
def test_force_rise_equals_the_headers_setpoint(name):
    # Reference: the header's setpoint, the force rise at which the instrument ended the approach
    # (JPK: volts x sensitivity x k = 4.00e-9 N in both; Igor TriggerPoint 1.8e-7 N). Checks
    # the whole calibration chain. Tolerance 3 %: the baseline here (median of the first 100
    # points) differs from the instrument's by its drift over the approach, and the trigger stops
    # within a sample (< 1 % of the setpoint at these speeds); measured -0.8 %, -0.2 %, +0.4 %.
    # A wrong unit, spring constant or sensitivity is off by a factor.
    a = approach(name)
    rise = a.force.max() - np.median(a.force[:100])
    assert rise == pytest.approx(header(name).setpoint, rel=0.03)


@pytest.mark.parametrize("name", ALL)
def test_contact_methods_agree_and_force_is_flat_then_rising(name):
    # No reference contact exists in these files; the check is two independent methods and the
    # shape of the curve around the contact they find.
    a, (fit, simple) = approach(name), reductions(name)
    z_fit, z_simple = a.height0 - fit.contact_height, a.height0 - simple.contact_height
    z0 = min(z_fit, z_simple)
    depth = a.z[-1] - z0  # travel from the earlier contact to the end of the approach
    rise = a.force.max() - np.median(a.force[:100])
    # Tolerance: the threshold (3 baseline sd) lags a power-law onset F = A t^n by
    # t = depth (3 sd / rise)^(1/n); n <= 4 is the fit's upper bound (contact.py), so the
    # methods may differ by up to depth (3 sd / rise)^(1/4). Measured: curve 0.9 nm (bound 80 nm,
    # depth 0.24 um), map 1.36 um (bound 2.1 um, depth 7.3 um; a gradual soft onset), .ibw 22 nm
    # once cut to its approach (bound 155 nm; uncut: 204 nm, bound 180 nm, fails).
    assert abs(z_fit - z_simple) < depth * (3 * fit.baseline_noise / rise) ** 0.25
    # flat before: the half-depth just before the contact is at the level of a window further
    # out, within 5 % of the rise (a missed earlier contact or an unremoved slope would show;
    # measured 0.5 %, 0.4 %, and 1.5 % for the cut .ibw)
    def mean(lo, hi):
        return a.force[(a.z > lo) & (a.z < hi)].mean()

    early, late = mean(z0 - 2 * depth, z0 - 1.5 * depth), mean(z0 - depth / 2, z0)
    assert abs(late - early) < 0.05 * rise
    # rising after: over the last quarter of the indentation F = A t^n averages at least
    # 0.75^n >= 0.32 of the rise (n <= 4); measured 0.85, 0.73, and 0.87 for the cut .ibw
    assert mean(z0 + 0.75 * depth, a.z[-1] + 1) - late > 0.3 * rise
