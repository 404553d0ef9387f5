"""Reduce the lab's two JPK vesicle force curves (ha_001, pbs_001) with both contact methods.

These curves have no licence that lets the repository ship them, so they are a benchmark, not
a test (the reading path is tested on vendored afmformats files in
tests/curves/test_instrument_files.py). Point ``$TURGORBAYES_AFM_CURVES`` at the folder holding
``ha_001.jpk-force`` and ``pbs_001.jpk-force``. Prints, per curve: the spring constant, the
contact height and k_b at h_b = 2 um by the power-law fit and by the threshold method, and how
far the two contacts are apart (docs/curves.md, "Real curves").

    python studies/vesicle_curves.py [--output-dir DIR | --update] [--smoke]
"""

import argparse
import os
import sys
from pathlib import Path

from turgorbayes import provenance
from turgorbayes.curves import ReductionSettings, reduce_curve
from turgorbayes.curves.load import read_approach

#: The folder of the vesicle curves (.jpk-force), from the environment (docs/curves.md).
FOLDER = Path(os.environ.get("TURGORBAYES_AFM_CURVES", ""))
DEPTH = 2e-6  # [m] secant depth of the bulge stiffness


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args = provenance.add_output_options(parser).parse_args()
    paths = sorted(FOLDER.glob("*.jpk-force")) if str(FOLDER) != "." else []
    if args.smoke and not paths:  # the curves are not shipped: nothing to run
        print(f"skipped: no .jpk-force curves in {FOLDER} (TURGORBAYES_AFM_CURVES unset or empty)")
        return
    provenance.tee_stdout(args, "vesicle_curves.txt")
    print(provenance.header_line(), flush=True)
    if not paths:
        sys.exit(f"no .jpk-force curves in {FOLDER} (set TURGORBAYES_AFM_CURVES)")
    print(f"{'curve':10s} {'k_cant N/m':>10s} {'contact um':>11s} {'threshold':>10s} "
          f"{'apart nm':>9s} {'k_b mN/m':>9s} {'threshold':>10s}")
    for path in paths:
        approach = read_approach(path)
        fit = reduce_curve(path, "bulge", DEPTH)
        simple = reduce_curve(path, "bulge", DEPTH, ReductionSettings(method="threshold"))
        if not (fit.accepted and simple.accepted):
            print(f"{path.stem:10s} rejected: {fit.detail} / {simple.detail}")
            continue
        print(f"{path.stem:10s} {approach.spring_constant:10.4f} {fit.contact_height * 1e6:11.3f} "
              f"{simple.contact_height * 1e6:10.3f} "
              f"{abs(fit.contact_height - simple.contact_height) * 1e9:9.1f} "
              f"{fit.k * 1e3:9.3f} {simple.k * 1e3:10.3f}")


if __name__ == "__main__":
    main()
