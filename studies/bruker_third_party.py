"""Third-party Bruker NanoScope readers on the vendor-export pairs (evaluation behind docs/curves.md).

Run with an interpreter that has the readers installed (they are not turgorbayes dependencies),
e.g. a scratch venv with ``pip install pyfmreader SciFiReaders pySPM``::

    /path/to/scratch/bin/python studies/bruker_third_party.py [DATA_DIR]

``DATA_DIR`` is the folder of the pairs (default: ``$TURGORBAYES_BRUKER_PAIRS``; docs/curves.md,
"Bruker files", says what it holds).

For each reader and each native file it prints whether the file was read, and for what it
returns: the largest difference from NanoScope Analysis' own ASCII export (height in um,
deflection in nm; the export's deflection is baseline-corrected, so a straight line in height
is fitted and removed before comparing, as in studies/bruker_pairs.py). Bruker's own
``nanoscope`` package (PyPI 1.2.300) wraps Windows DLLs and is not run here.
"""

import argparse
import os
import sys
import traceback
from pathlib import Path

import numpy as np

from turgorbayes import provenance

PAIRS_VARIABLE = "TURGORBAYES_BRUKER_PAIRS"
#: The folder of the pairs (set by :func:`main`).
DATA = None
NAMES = ["MDA-MB231_Dish2_Cell1.000", "MDA-MB231_Dish2_Cell1.001"]


def export(name):
    """NanoScope Analysis' export: height [um] and deflection [nm] columns."""
    return np.loadtxt(DATA / f"{name}.nanoscope_export.txt", skiprows=1, encoding="latin-1")


def compare(x_um, defl_nm, ex):
    """Largest |difference| in height (after a constant offset) and deflection (after a line)."""
    if x_um.size != ex.shape[0]:
        return f"{x_um.size} points, export has {ex.shape[0]}"
    dx = x_um - ex[:, 0]
    a = np.vstack([np.ones(x_um.size), ex[:, 0]]).T
    line, *_ = np.linalg.lstsq(a, defl_nm - ex[:, 1], rcond=None)
    dd = defl_nm - ex[:, 1] - a @ line
    return (f"height: max |diff - offset| {np.ptp(dx):.3g} um (of {np.ptp(ex[:, 0]):.3g}); "
            f"deflection: max |diff - line| {np.abs(dd).max():.3g} nm (of {np.ptp(ex[:, 1]):.3g})")


def pyfmreader(name):
    from pyfmreader import loadfile

    f = loadfile(str(DATA / name))
    seg = dict(f.getcurve(0).extend_segments)["0"].segment_formated_data
    meta = f.filemetadata
    x_um, defl_nm = seg["height"] * 1e6, seg["vDeflection"] * meta["defl_sens_nmbyV"]
    return f"k {meta['spring_const_Nbym']} N/m; " + compare(x_um, defl_nm, export(name))


def scifireaders(name):
    from SciFiReaders import BrukerAFMReader

    sets = BrukerAFMReader(str(DATA / name)).read()
    first = np.asarray(sets[0])
    return (f"{len(sets)} datasets of {first.size} points, values {first[:3]} (raw LSB counts, "
            f"labelled {sets[0].units!r}; no scaling, no approach/retract split)")


def pyspm(name):
    import pySPM

    b = pySPM.Bruker(str(DATA / name))
    return f"{len(b.layers)} image layers (reads '*Ciao image list' only; no force data)"


def main():
    global DATA
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("folder", nargs="?", default=os.environ.get(PAIRS_VARIABLE, ""),
                        help=f"folder of the pairs (default: ${PAIRS_VARIABLE})")
    args = provenance.add_output_options(parser).parse_args()
    if not args.folder or not Path(args.folder).is_dir():
        message = f"no folder of the pairs {args.folder!r}: give it as argument, or set {PAIRS_VARIABLE}"
        if args.smoke:  # the same run on the same two pairs: there is nothing smaller
            print(f"skipped: {message}")
            return
        sys.exit(message)
    DATA = Path(args.folder)
    lines = [provenance.header_line()]
    for reader in (pyfmreader, scifireaders, pyspm):
        for name in NAMES:
            try:
                result = reader(name)
            except Exception as err:  # a reader failing is a result here
                result = f"FAILED {type(err).__name__}: {err}"
                traceback.print_exc(limit=1, file=sys.stderr)
            lines.append(f"{reader.__name__:13s} {name}: {result}")
            print(lines[-1])
    provenance.study_path(args, "bruker_third_party.txt").write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
