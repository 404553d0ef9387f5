"""Bruker NanoScope force files: read natively, checked against the header's layout and the vendor.

``turgorbayes.curves.nanoscope`` reads single NanoScope force curves (16-bit). Most tests build
a NanoScope file here from the documented header layout (ASCII ``\\Key: value`` header up to
``\\*File list end``, one ``\\*Ciao force image list`` per channel, two slots of little-endian
int16 per channel: the extend stored backwards, then the retract), from integers and scales
chosen here, so they run in every clone and their expected numbers come from the construction.
One test reads the real pairs (a native file and NanoScope Analysis' own ASCII export of it)
from the folder ``$TURGORBAYES_BRUKER_PAIRS`` names, and skips where that is unset or not a
folder. What is still refused (force volume, 4-byte data, malformed files) stops with a
``DataError`` naming the file and the reason.
"""

import csv
import dataclasses
import functools
import os
from pathlib import Path

import afmformats
import numpy as np
import pytest

from turgorbayes.cli import main
from turgorbayes.curves import reduce_curve
from turgorbayes.curves.load import count_curves, read_approach
from turgorbayes.curves.nanoscope import load_nanoscope, read_nanoscope
from turgorbayes.errors import DataError
from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, cell_force, synthetic_curve, write_curve

# the first line of every NanoScope force file
NANOSCOPE_START = b"\\*Force file list\r\n\\Version: 0x09200000\r\n"
BRUKER_NAMES = ["curve.spm", "map.pfc", "cr00028.000", "DPPC00154.021", "CURVE.SPM"]
HEADER_BYTES = 8192  # where the data start in the files written here
#: The variable naming the folder of the real pairs (they have no licence to ship: docs/curves.md).
PAIRS_VARIABLE = "TURGORBAYES_BRUKER_PAIRS"


def _pairs_folder():
    """The folder of the real pairs and None, or None and the reason the test skips."""
    value = os.environ.get(PAIRS_VARIABLE, "")
    if not value:
        return None, (f"the real Bruker pairs are not in the repository: set {PAIRS_VARIABLE} "
                      "to the folder holding them (docs/curves.md, 'Bruker files')")
    if not Path(value).is_dir():
        return None, f"{PAIRS_VARIABLE}={value} is not a folder"
    return Path(value), None


PAIRS, NO_PAIRS = _pairs_folder()


@dataclasses.dataclass
class Layout:
    """What a written NanoScope file holds (scales in the header's own units)."""

    defl_appr: np.ndarray  # int16 counts of the extend, in time order
    defl_ret: np.ndarray  # int16 counts of the retract, in time order
    sensor_appr: np.ndarray = None  # int16 counts of the Height Sensor (None: no sensor channel)
    sensor_ret: np.ndarray = None
    slot: int = None  # points per segment slot (default: the longer segment)
    spring_constant: float = 0.05  # N/m
    defl_sens: float = 40.0  # nm/V, \@Sens. DeflSens
    defl_hard: float = 0.000375  # V/LSB
    zsens: float = 100.0  # nm/V, \@Sens. Zsens (ramp)
    ramp_V: float = None  # \@4:Ramp size [V] (default: 0.5 nm per ramp step)
    sensor_sens: float = 200.0  # nm/V, \@Sens. ZsensSens
    sensor_hard: float = 0.0000625  # V/LSB
    mode: str = "Force"
    bytes_per_pixel: int = 2


def _channel_block(offset, layout, image_data, z_scale):
    n_ret, n_app = layout.defl_ret.size, layout.defl_appr.size
    return [r"\*Ciao force image list", f"\\Data offset: {offset}",
            f"\\Data length: {2 * layout.slot * layout.bytes_per_pixel}",
            f"\\Bytes/pixel: {layout.bytes_per_pixel}", f"\\Samps/line: {n_ret} {n_app}",
            f"\\Spring Constant: {layout.spring_constant}", f"\\@4:Image Data: {image_data}",
            f"\\@4:Z scale: {z_scale}",
            f"\\@4:Ramp size: V [Sens. Zsens] (0.006603226 V/LSB) {layout.ramp_V} V"]


def _slots(appr, ret, slot):
    """Two slots: the extend backwards then padding (garbage), the retract then padding."""
    data = np.full(2 * slot, 12345, dtype="<i2")
    data[:appr.size] = appr[::-1]
    data[slot:slot + ret.size] = ret
    return data.tobytes()


def write_nanoscope(path, layout):
    """Write ``layout`` as a NanoScope force file (the header layout of the BioScope pairs)."""
    layout.slot = layout.slot or max(layout.defl_appr.size, layout.defl_ret.size)
    layout.ramp_V = layout.ramp_V or 0.5 * layout.defl_ret.size / layout.zsens
    lines = [r"\*Force file list", r"\Version: 0x09010300", r"\Date: 01:21:42 PM Wed May 05 2021",
             r"\*Equipment list", r"\Description: Test Scope", r"\*Scanner list",
             f"\\@Sens. Zsens: V {layout.zsens} nm/V", r"\*Ciao scan list",
             f"\\Operating mode: {layout.mode}", f"\\@Sens. DeflSens: V {layout.defl_sens} nm/V",
             f"\\@Sens. ZsensSens: V {layout.sensor_sens} nm/V", r"\*Ciao force list",
             r"\Deflection Sensitivity Correction: 1.08"]
    size = 2 * layout.slot * 2
    lines += _channel_block(HEADER_BYTES, layout, 'S [DeflectionError] "Deflection Error"',
                            f"V [Sens. DeflSens] ({layout.defl_hard} V/LSB) 2.500000 V")
    data = _slots(layout.defl_appr, layout.defl_ret, layout.slot)
    if layout.sensor_appr is not None:
        lines += _channel_block(HEADER_BYTES + size, layout, 'S [ZSensor] "Height Sensor"',
                                f"V [Sens. ZsensSens] ({layout.sensor_hard} V/LSB) 11.4 V")
        data += _slots(layout.sensor_appr, layout.sensor_ret, layout.slot)
    header = ("\r\n".join(lines) + "\r\n\\*File list end\r\n").encode("latin-1")
    path.write_bytes(header.ljust(HEADER_BYTES, b"\x00") + data)
    return path


def small_layout(**kw):
    """A 12-point extend (a trigger ended it) and a 14-point retract, with a height sensor."""
    appr = np.array([1000, 1002, 1001, 999, 1000, 1001, 1000, 1100, 1300, 1500, 1700, 2000], "<i2")
    sensor = np.arange(-3000, -799, 200, dtype="<i2")  # 12 counts, 200 apart
    return Layout(defl_appr=appr, defl_ret=np.concatenate([appr[::-1], [999, 1001]]).astype("<i2"),
                  sensor_appr=sensor, sensor_ret=np.arange(-800, -3401, -200, dtype="<i2"), **kw)


# --------------------------------------------------------------- scalings of the header
def test_scalings_recover_the_numbers_written(tmp_path):
    # by construction: count 1000 -> 1000 x 0.000375 V/LSB x 40 nm/V = 15 nm of deflection,
    # 0.75 nN at 0.05 N/m; sensor count -3000 -> -3000 x 0.0000625 V/LSB x 200 nm/V = -37.5 nm;
    # ramp 14 steps of 0.5 nm (Ramp size 0.07 V x 100 nm/V = 7 nm over Samps/line's 14)
    path = write_nanoscope(tmp_path / "c.000", small_layout())
    curve = read_nanoscope(path)
    assert curve.spring_constant == 0.05 and curve.deflection_sensitivity == pytest.approx(40e-9, rel=1e-15)
    assert curve.sensitivity_correction == 1.08 and curve.version == "0x09010300"
    assert curve.deflection.name == "DeflectionError" and curve.height_sensor.name == "ZSensor"
    assert curve.deflection.approach[0] == pytest.approx(15e-9, rel=1e-12)
    assert curve.deflection.approach[-1] == pytest.approx(30e-9, rel=1e-12)  # 2000 counts, at the turnaround
    assert curve.deflection.retract[12] == pytest.approx(999 * 0.015e-9, rel=1e-12)
    assert curve.deflection.approach.size == 12 and curve.deflection.retract.size == 14  # no padding
    assert curve.height_sensor.approach[0] == pytest.approx(-37.5e-9, rel=1e-12)
    assert curve.ramp_size == pytest.approx(7e-9, rel=1e-12)
    # the extend's 12 points are the last 12 of the 14 ramp positions: 1.0, 1.5, ... 6.5 nm
    assert np.allclose(curve.ramp_approach, np.arange(2, 14) * 0.5e-9, rtol=1e-12, atol=0)
    assert np.allclose(curve.ramp_retract, np.arange(13, -1, -1) * 0.5e-9, rtol=1e-12, atol=0)


def test_afmformats_columns_and_read_approach(tmp_path):
    path = write_nanoscope(tmp_path / "c.spm", small_layout())
    (data,) = load_nanoscope(path)
    curve = afmformats.AFMForceDistance(data["data"], data["metadata"])  # afmformats accepts it
    assert curve.metadata["spring constant"] == 0.05 and curve.metadata["z range"] == pytest.approx(7e-9)
    assert list(curve["segment"]) == [0] * 12 + [1] * 14
    # force = counts x 0.015 nm x 0.05 N/m; the approach's first point has 1000 counts
    assert curve.appr["force"][0] == pytest.approx(1000 * 0.015e-9 * 0.05, rel=1e-12)
    # heights fall as the tip approaches: sensor -(-37.5 nm) at the start, -(-10 nm) at the end
    assert curve.appr["height (measured)"][[0, -1]] == pytest.approx([37.5e-9, 10e-9], rel=1e-12)
    assert curve.appr["height (piezo)"][[0, -1]] == pytest.approx([-1.0e-9, -6.5e-9], rel=1e-12)

    a = read_approach(path)
    assert a.height_column == "height (measured)" and count_curves(path) == 1
    assert a.spring_constant == 0.05 and a.sensitivity == pytest.approx(40e-9, rel=1e-15)
    assert a.z == pytest.approx(np.arange(12) * 2.5e-9, abs=1e-20)  # 200 counts x 0.0125 nm
    # the manifest's overrides rescale the force: F (k/k_file)(s/s_file) = F x 2 x 1.5
    b = read_approach(path, spring_constant=0.1, sensitivity=60e-9)
    assert b.force == pytest.approx(3 * a.force, rel=1e-12)


def test_without_sensor_the_nominal_ramp_is_the_height(tmp_path):
    layout = dataclasses.replace(small_layout(), sensor_appr=None, sensor_ret=None)
    a = read_approach(write_nanoscope(tmp_path / "c.001", layout))
    assert a.height_column == "height (piezo)"
    assert a.z == pytest.approx(np.arange(12) * 0.5e-9, abs=1e-20)


def test_a_sensor_that_falls_toward_the_sample_is_turned_round(tmp_path):
    # some scanners count the sensor the other way: the height must still fall on approach
    layout = small_layout()
    layout.sensor_appr, layout.sensor_ret = -layout.sensor_appr, -layout.sensor_ret
    a = read_approach(write_nanoscope(tmp_path / "c.002", layout))
    assert a.z == pytest.approx(np.arange(12) * 2.5e-9, abs=1e-20)


def test_a_simulated_cell_curve_gives_the_same_stiffness_as_its_tab_file(tmp_path):
    # a cell curve of known k_c (secant at R_c/20), quantized into NanoScope counts; the same
    # counts times the same scales written as an afmformats .tab file must reduce alike
    k, R_c, k_c = 0.05, 500e-9, 0.02
    acq = dataclasses.replace(DEFAULT_ACQUISITION, spring_constant=k, sensitivity=40e-9)
    sim = synthetic_curve(functools.partial(cell_force, k_c=k_c, h_ref=R_c / 20), 2 * R_c / 20, acq, seed=3)
    travel = sim.data["height (measured)"][0] - sim.data["height (measured)"]
    defl = np.round(sim.data["force"] / k / (40e-9 * 0.000375)).astype("<i2")
    sensor = (np.round(travel / (200e-9 * 0.0000625)) - 20000).astype("<i2")  # 0.0125 nm per count
    layout = Layout(defl_appr=defl, defl_ret=defl[::-1].copy(), sensor_appr=sensor,
                    sensor_ret=sensor[::-1].copy(), spring_constant=k)
    path = write_nanoscope(tmp_path / "cell.000", layout)
    assert np.ptp(travel) / 0.0125e-9 < 40000  # the counts fit in int16 about -20000
    data = {"force": defl * 0.015e-9 * k, "height (measured)": -sensor * 0.0125e-9,
            "segment": np.zeros(defl.size, dtype=np.uint8)}
    afmformats.AFMForceDistance(data, {"path": "x", "enum": 0, "spring constant": k,
                                       "sensitivity": 40e-9}).export_data(tmp_path / "ref.tab", fmt="tab")
    got, ref = reduce_curve(path, "cell", R_c), reduce_curve(tmp_path / "ref.tab", "cell", R_c)
    assert got.ok and ref.ok, (got.detail, ref.detail)
    assert got.k == pytest.approx(ref.k, rel=1e-6)  # the .tab holds 8 significant digits
    assert abs(got.k - k_c) < 3 * got.k_err


def test_a_bruker_row_in_the_manifest_with_a_spring_constant_override(tmp_path, capsys):
    k, R_c, k_c = 0.05, 500e-9, 0.02
    acq = dataclasses.replace(DEFAULT_ACQUISITION, spring_constant=k, sensitivity=40e-9)
    sim = synthetic_curve(functools.partial(cell_force, k_c=k_c, h_ref=R_c / 20), 2 * R_c / 20, acq, seed=5)
    defl = np.round(sim.data["force"] / k / (40e-9 * 0.000375)).astype("<i2")
    travel = sim.data["height (measured)"][0] - sim.data["height (measured)"]
    sensor = (np.round(travel / (200e-9 * 0.0000625)) - 20000).astype("<i2")
    write_nanoscope(tmp_path / "cr00001.000", Layout(defl, defl[::-1].copy(), sensor, sensor[::-1].copy()))
    manifest = tmp_path / "m.csv"
    manifest.write_text("file,cell_id,target,Rc_nm,Rc_err_nm,spring_constant_N_per_m\n"
                        "cr00001.000,c1,cell,500,10,0.06\n")
    with pytest.raises(SystemExit) as exit_info:
        main(["curves", str(manifest), "--out", str(tmp_path / "cells.csv"), "--no-progress", "--no-figures"])
    assert exit_info.value.code == 0, capsys.readouterr().err
    (row,) = csv.DictReader((tmp_path / "curves.csv").open())
    assert row["status"] == "ok" and float(row["spring_constant_N_per_m"]) == 0.06


# --------------------------------------------------------------- what is still refused
def test_force_volume_is_refused_naming_the_mode(tmp_path):
    path = write_nanoscope(tmp_path / "fv.000", small_layout(mode="Force Volume"))
    with pytest.raises(DataError, match=r"fv\.000.*operating mode 'Force Volume'") as info:
        read_approach(path)
    assert info.value.path == str(path) and info.value.value == "Force Volume"


def test_four_byte_data_are_refused(tmp_path):
    path = write_nanoscope(tmp_path / "c.spm", small_layout(bytes_per_pixel=4))
    with pytest.raises(DataError, match=r"4 bytes per point") as info:
        count_curves(path)
    assert info.value.column == "Bytes/pixel" and info.value.value == "4"


def test_a_truncated_file_is_refused(tmp_path):
    path = write_nanoscope(tmp_path / "c.000", small_layout())
    path.write_bytes(path.read_bytes()[:-10])
    with pytest.raises(DataError, match=r"past the end of the file .*truncated"):
        read_approach(path)


@pytest.mark.parametrize("name", BRUKER_NAMES)
def test_a_header_without_its_end_is_refused_naming_the_file(tmp_path, name):
    path = tmp_path / name
    path.write_bytes(NANOSCOPE_START + b"\x00" * 64)
    for read in (read_approach, count_curves):  # the manifest counts a file's curves
        with pytest.raises(DataError) as info:
            read(path)
        assert str(info.value).startswith(f"{path}: not a readable Bruker NanoScope file")


def test_not_a_nanoscope_file(tmp_path):
    (tmp_path / "notes.000").write_text("exported text\n")
    with pytest.raises(DataError, match=r"notes\.000: not a Bruker NanoScope force file"):
        read_approach(tmp_path / "notes.000")


def test_the_command_line_exits_2_naming_the_file(tmp_path, capsys):
    write_nanoscope(tmp_path / "cr00028.000", small_layout(mode="Force Volume"))
    manifest = tmp_path / "m.csv"
    manifest.write_text("file,cell_id,target,Rc_nm,Rc_err_nm\ncr00028.000,c1,cell,500,10\n")
    with pytest.raises(SystemExit) as exit_info:
        main(["curves", str(manifest), "--out", str(tmp_path / "cells.csv"), "--no-progress", "--no-figures"])
    err = capsys.readouterr().err
    assert exit_info.value.code == 2
    assert (f"{tmp_path / 'cr00028.000'}, column Operating mode: a Bruker NanoScope file in operating "
            "mode 'Force Volume'") in err
    assert not (tmp_path / "cells.csv").exists()


def test_only_the_last_suffix_counts(tmp_path):
    # 'cell.000.tab' is an afmformats .tab file (only its stem looks like Bruker's numbering);
    # a two-digit suffix is no NanoScope suffix and goes to afmformats, which rejects it
    curve = synthetic_curve(functools.partial(cell_force, k_c=0.02, h_ref=25e-9), 50e-9, seed=1)
    write_curve(curve, tmp_path / "cell.000.tab")
    assert read_approach(tmp_path / "cell.000.tab").z.size == curve.data["force"].size
    (tmp_path / "cell.00").write_bytes(NANOSCOPE_START)
    result = reduce_curve(tmp_path / "cell.00", "cell", 500e-9)
    assert result.status == "unreadable_file"


# --------------------------------------------------------------- the vendor's own export
@pytest.mark.skipif(PAIRS is None, reason=NO_PAIRS or "")
@pytest.mark.parametrize("name, rows", [("MDA-MB231_Dish2_Cell1.000", 5026), ("MDA-MB231_Dish2_Cell1.001", 5124)])
def test_the_real_pairs_match_nanoscope_analysis_export(name, rows):
    # the export (NanoScope Analysis' ASCII: height um, deflection nm) is the reference; its
    # deflection has a baseline line (offset + tilt in height) subtracted, removed here by
    # least squares; 0.0777945 N/m is the header's spring constant (data README)
    curve = read_nanoscope(PAIRS / name)
    x, d = np.loadtxt(PAIRS / f"{name}.nanoscope_export.txt", skiprows=1, encoding="latin-1", unpack=True)
    assert x.size == rows and curve.ramp_approach.size == rows
    assert np.max(np.abs(curve.ramp_approach * 1e6 - x) / x) < 1e-3  # measured 3.9e-5
    a = np.vstack([np.ones(rows), x]).T
    diff = curve.deflection.approach * 1e9 - d
    left = diff - a @ np.linalg.lstsq(a, diff, rcond=None)[0]
    assert np.abs(left).max() < 1e-3 * np.ptp(d)  # measured 4.8e-7 and 4.4e-7 of the range
    assert curve.spring_constant == 0.0777945
    approach = read_approach(PAIRS / name)
    assert approach.height_column == "height (measured)" and approach.z.size == rows
