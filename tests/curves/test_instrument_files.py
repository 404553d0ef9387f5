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

import afmformats
import numpy as np
import pytest
from igor2 import binarywave
from numpy.testing import assert_allclose, assert_array_equal

from turgorbayes.curves import STATUSES, ReductionSettings, read_manifest, reduce_curve, reduce_manifest
from turgorbayes.curves.load import read_approach
from turgorbayes.errors import DataError

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


def _map_positions(path):
    """The curves of a JPK force map: the numbers N of its ``index/N/`` folders, ascending."""
    with zipfile.ZipFile(path) as archive:
        names = archive.namelist()
    return sorted(int(m.group(1)) for n in names if (m := re.fullmatch(r"index/(\d+)/header\.properties", n)))


def _jpk_header(path, position=0):
    """JPK: a curve's header (a force map's ``position``-th ``index/N/``; 0 is read_approach's
    default curve)."""
    indices = _map_positions(path)
    with zipfile.ZipFile(path) as archive:
        prefix = f"index/{indices[position]}/" if indices else ""
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
def header(name, position=0):
    path = FILES[name]
    return _ibw_header(path) if path.suffix == ".ibw" else _jpk_header(path, position)


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
    # t = depth (3 sd / rise)^(1/n); n <= 4 is the fit's upper bound (contact_point.py), so the
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


# ------------------------------------------------------------ curve_index: a force map's curves
MAP = FILES["jpk-force-map"]
N_MAP = 3  # tests/data/afmformats/README.md: the file holds 3 of the map's curves


@functools.cache
def map_approach(index):
    return read_approach(MAP, curve_index=index)


@pytest.mark.parametrize("index", range(N_MAP))
def test_curve_index_reads_that_curve_of_the_map(index):
    # Reference: afmformats' own list, read here directly (load_data(path)[index]); its
    # metadata 'enum' is the index-th index/N/ folder of the zip, read with zipfile (109, 129,
    # 416). The same points in any order: read_approach sorts them by piezo travel.
    ref = afmformats.load_data(MAP)[index]
    assert ref.metadata["enum"] == _map_positions(MAP)[index]
    a = map_approach(index)
    assert a.curve_index == index
    assert_array_equal(np.sort(a.force), np.sort(np.asarray(ref.appr["force"])))
    # heights come back as height0 - (height0 - height): equal to rounding (measured: exactly)
    assert_allclose(np.sort(a.height0 - a.z), np.sort(np.asarray(ref.appr["height (measured)"])),
                    rtol=0, atol=1e-15)
    others = [afmformats.load_data(MAP)[j] for j in range(N_MAP) if j != index]
    for other in others:  # and no other curve of the map
        assert not np.array_equal(np.sort(a.force), np.sort(np.asarray(other.appr["force"])))


@pytest.mark.parametrize("index", range(N_MAP))
def test_map_curve_has_its_headers_calibration_points_and_setpoint(index):
    # Reference: that curve's own index/N/ headers in the zip (and the shared lcd-info they point
    # to): k 0.010951 N/m for all three, 10000 approach points, setpoint 4.0 nN; tolerance as
    # in test_force_rise_equals_the_headers_setpoint. Measured rise -0.23, -0.26, -0.41 %.
    a, h = map_approach(index), header("jpk-force-map", index)
    assert a.spring_constant == pytest.approx(h.spring_constant, rel=1e-12)
    assert a.z.size == h.n_approach
    rise = a.force.max() - np.median(a.force[:100])
    assert rise == pytest.approx(h.setpoint, rel=0.03)


def test_map_curve_1_reduces_or_says_why():
    # Curve 1 (index/129/) has two layers: the power law and the threshold put its contact
    # 1.07 um apart (49.49 and 48.42 um of travel), so the two methods are not compared on it.
    # Each must give a stiffness from a contact inside the approach, or a status with a reason.
    a = map_approach(1)
    for method in ("powerlaw", "threshold"):
        res = reduce_curve(MAP, "bulge", 2e-6, ReductionSettings(method=method), curve_index=1)
        assert res.status in STATUSES and res.curve_index == 1
        if res.ok:
            assert np.isfinite(res.k) and res.k > 0 and res.detail == ""
            assert a.height0 - a.z[-1] < res.contact_height < a.height0
        else:
            assert res.detail


def test_curve_index_out_of_range_names_the_count(tmp_path):
    with pytest.raises(DataError, match=r"column curve_index: curve_index 3 is out of range: the file has "
                                        r"3 curves \(indices 0 to 2\)"):
        read_approach(MAP, curve_index=3)
    with pytest.raises(DataError, match=r"curve_index must be an integer >= 0, got -1"):
        reduce_curve(MAP, "bulge", 2e-6, curve_index=-1)  # no silent negative indexing
    # a manifest names its line, the file and the count (absolute paths stay absolute)
    m = tmp_path / "m.csv"
    head = "file,cell_id,target,Rc_nm,Rc_err_nm,curve_index\n"
    m.write_text(head + f"{MAP},c1,cell,540,10,2\n{MAP},c1,cell,540,10,3\n")
    with pytest.raises(DataError, match=rf"m\.csv, line 3, column curve_index: curve_index 3 is out of "
                                        rf"range: '{re.escape(str(MAP))}' has 3 curves \(indices 0 to 2\)"):
        read_manifest(m)
    m.write_text(head + f"{MAP},c1,cell,540,10,1.5\n")
    with pytest.raises(DataError, match=r"line 2, column curve_index: curve_index must be an integer "
                                        r">= 0 .*got '1\.5'"):
        read_manifest(m)


def test_manifest_radii_are_the_exact_decimal_values(tmp_path):
    # reference: Python's correctly rounded float of the decimal text in metres; 500 * 1e-9
    # (the product of two rounded numbers) is 5.000000000000001e-07, which cells.csv wrote
    # back as 500.0000000000001 nm
    m = tmp_path / "m.csv"
    m.write_text("file,cell_id,target,Rc_nm,Rc_err_nm,Rb_nm,Rb_err_nm,curve_index\n"
                 f"{MAP},c1,cell,500,10.3,,,0\n{MAP},c1,bulge,500,10.3,2e3,0.07,2\n")
    rows = read_manifest(m).rows
    assert [r.R_c for r in rows] == [float("500e-9")] * 2
    assert rows[0].R_c_err == float("10.3e-9")
    assert (rows[1].R_b, rows[1].R_b_err) == (float("2e-6"), float("0.07e-9"))


def test_manifest_curve_index_reaches_the_reduction(tmp_path):
    # Reference: reduce_curve on the same file and index, called directly
    m = tmp_path / "m.csv"
    m.write_text("file,cell_id,target,Rc_nm,Rc_err_nm,Rb_nm,Rb_err_nm,curve_index\n"
                 f"{MAP},c1,cell,540,10,,,\n{MAP},c1,bulge,540,10,2000,50,2\n")
    result = reduce_manifest(read_manifest(m))
    direct = reduce_curve(MAP, "bulge", 2e-6, curve_index=2)
    assert [r.curve_index for r in result.results] == [0, 2]
    got = result.results[1]
    assert direct.ok and (got.status, got.k, got.k_err, got.depth, got.contact_height) == (
        direct.status, direct.k, direct.k_err, direct.depth, direct.contact_height)
