"""The native Bruker NanoScope reader against NanoScope Analysis' own ASCII export of the same curves.

The pairs (``MDA-MB231_Dish2_Cell1.000`` and ``.001``, BioScope Catalyst, NanoScope 9.x, each
beside ``<name>.nanoscope_export.txt``: height [um], deflection [nm] of the extend) have no
licence that lets the repository ship them (the data's own README), so this is a benchmark;
``tests/curves/test_bruker.py`` repeats the check where ``$TURGORBAYES_BRUKER_PAIRS`` names
their folder.

Per file it records:

- height: the reader's nominal ramp (``NanoscopeCurve.ramp_approach``; the export's height is
  that ramp, not the height sensor) minus the export, largest absolute and point-by-point
  relative difference (no offset removed);
- deflection: the reader's deflection minus the export's. NanoScope Analysis subtracts a
  baseline (a straight line in height) before it exports, so the line ``b + c x`` that fits
  the difference best (least squares) is removed: the largest difference left, absolute and
  relative to the curve's deflection range, and the line. The scale ``a`` of the best fit
  ``export = a native + b + c x`` tests the hard and soft scales (``a - 1`` is 0 if they are
  right);
- the spring constant against ``\\Spring Constant`` found in the raw header by a regular
  expression (not by the reader);
- the height sensor's travel over the approach against the ramp's (what the sensor changes).

    python studies/bruker_pairs.py [DATA_DIR]

``DATA_DIR`` is the folder of the pairs (default: ``$TURGORBAYES_BRUKER_PAIRS``).

Writes ``bruker_pairs.txt`` (in ``studies/output``; ``studies/results`` with ``--update``)
and ``.json`` (with the commit, arguments,
date, machine and package version).
"""

import argparse
import datetime
import json
import os
import platform
import re
import subprocess
import sys
from pathlib import Path

import numpy as np

from turgorbayes import __version__
from turgorbayes import provenance as tb_provenance
from turgorbayes.curves.nanoscope import read_nanoscope

ROOT = Path(__file__).resolve().parents[1]
#: The variable naming the folder of the pairs when no argument does.
PAIRS_VARIABLE = "TURGORBAYES_BRUKER_PAIRS"
NAMES = ["MDA-MB231_Dish2_Cell1.000", "MDA-MB231_Dish2_Cell1.001"]
NAME = "bruker_pairs"


def provenance(argv):
    """Commit, arguments, date, machine and version of this run."""
    commit = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True,
                            cwd=ROOT, check=False).stdout.strip() or "unknown"
    return {"commit": commit, "arguments": argv,
            "date": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "machine": f"{platform.node()} {platform.machine()} {platform.processor()}".strip(),
            "python": platform.python_version(), "version": __version__}


def header_spring_constant(path):
    """``\\Spring Constant`` of the first force channel, from the raw bytes [N/m]."""
    match = re.search(rb"\\Spring Constant: ([-+0-9.eE]+)", path.read_bytes())
    return float(match[1])


def compare(path, export_path):
    """The reader's extend against the export's, in the export's units (um, nm)."""
    curve = read_nanoscope(path)
    x, d = np.loadtxt(export_path, skiprows=1, encoding="latin-1", unpack=True)
    ramp, defl = curve.ramp_approach * 1e6, curve.deflection.approach * 1e9
    a = np.vstack([np.ones(x.size), x]).T
    line, *_ = np.linalg.lstsq(a, defl - d, rcond=None)
    left = defl - d - a @ line
    scale = np.linalg.lstsq(np.vstack([defl, np.ones(x.size), x]).T, d, rcond=None)[0][0]
    sensor = curve.height_sensor.approach * 1e6
    k_header = header_spring_constant(path)
    return {"file": path.name, "points": int(ramp.size), "export_points": int(x.size),
            "height_max_abs_um": float(np.abs(ramp - x).max()),
            "height_max_rel": float(np.max(np.abs(ramp - x) / np.abs(x))),
            "deflection_max_abs_nm": float(np.abs(left).max()),
            "deflection_range_nm": float(np.ptp(d)),
            "deflection_max_rel_range": float(np.abs(left).max() / np.ptp(d)),
            "export_baseline_offset_nm": float(line[0]), "export_baseline_tilt_nm_per_um": float(line[1]),
            "deflection_scale_fit_minus_1": float(scale - 1),
            "spring_constant_read": curve.spring_constant, "spring_constant_header": k_header,
            "sensitivity_correction_not_applied": curve.sensitivity_correction,
            "sensor_over_ramp_travel": float(np.ptp(sensor) / np.ptp(ramp))}


def table(rows, meta):
    lines = [f"# {key}: {value}" for key, value in meta.items()]
    lines.append("# height: reader's ramp vs export (no offset); deflection: after removing the "
                 "export's baseline line b + c x")
    keys = list(rows[0])
    lines.append("\t".join(keys))
    lines += ["\t".join(f"{r[k]:.6g}" if isinstance(r[k], float) else str(r[k]) for k in keys)
              for r in rows]
    return "\n".join(lines) + "\n"


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", default=os.environ.get(PAIRS_VARIABLE, ""),
                        help=f"folder of the pairs (default: ${PAIRS_VARIABLE})")
    args = tb_provenance.add_output_options(parser).parse_args(argv)
    folder = args.folder
    if args.smoke and not (folder and Path(folder).is_dir()):
        print(f"skipped: no folder of the Bruker pairs ({PAIRS_VARIABLE} unset or absent)")
        return
    if not folder:
        sys.exit(f"give the folder of the pairs as argument, or set {PAIRS_VARIABLE}")
    folder = Path(folder)
    pairs = [(folder / n, folder / f"{n}.nanoscope_export.txt") for n in NAMES]
    missing = [str(p) for pair in pairs for p in pair if not p.exists()]
    if missing:
        sys.exit(f"missing: {', '.join(missing)} (give the folder of the pairs as argument, "
                 f"or set {PAIRS_VARIABLE})")
    rows = [compare(*pair) for pair in pairs]
    meta = provenance(argv)
    tb_provenance.study_path(args, f"{NAME}.txt").write_text(table(rows, meta))
    tb_provenance.study_path(args, f"{NAME}.json").write_text(
        json.dumps({"run": meta, "rows": rows}, indent=1) + "\n")
    print(table(rows, meta), end="")


if __name__ == "__main__":
    main(sys.argv[1:])
