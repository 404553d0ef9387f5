"""Where the tau_R prior comes from: width spreads of the shared mother-machine data, side by side.

Prints, per file, the plain and robust (MAD-based) spreads of width and of log width, the same
spread within mother-machine channels (each channel's median removed: channel-to-channel focus
and illumination differences taken out), the bound and half-normal scale the package uses
(turgorbayes.inference.width_prior), and the prior's quantiles next to the AFM paper's own intact-cell
radius scatter (0.02/0.55 um = 3.6 %, measurement error included).
Run: .venv/bin/python studies/width_prior.py  (needs the width data of a clone,
tests/data/ecoli_width_mother_machine)
"""

import argparse
import csv
import gzip
import sys

import numpy as np
from scipy import stats

from turgorbayes import provenance
from turgorbayes.inference import width_prior as wp


def within_channel_mad_log(path):
    """Robust log-width spread after removing each (fov, peak) channel's median."""
    with gzip.open(path, "rt", newline="") as f:
        rows = [(r["fov"], r["peak"], float(r["width"])) for r in csv.DictReader(f) if r["width"]]
    keys = np.array([f"{a}/{b}" for a, b, _ in rows])
    log_w = np.log([w for _, _, w in rows])
    centred = np.empty_like(log_w)
    for k in np.unique(keys):
        m = keys == k
        centred[m] = log_w[m] - np.median(log_w[m])
    return wp.MAD_TO_SD * np.median(np.abs(centred - np.median(centred))), len(np.unique(keys))


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    args = provenance.add_output_options(parser).parse_args()
    folder = wp.default_width_data_dir()
    if args.smoke and folder is None:  # an installed package without its tests
        print("skipped: width data absent (tests/data/ecoli_width_mother_machine of a clone)")
        return 0
    provenance.tee_stdout(args, "width_prior.txt")
    print(provenance.header_line(), flush=True)
    if folder is None:
        print("width data absent (tests/data/ecoli_width_mother_machine of a clone): nothing to do")
        return 1
    files = sorted(folder.glob("*_complete_cells*.csv.gz"))
    summary = wp.width_spread_summary(files)
    head = ("n", "median um", "CV", "CV_MAD", "sd_log", "MADlog", "within-ch")
    print(f"{'file':52s} " + " ".join(f"{h:>9s}" for h in head))
    for path in files:
        s = summary[path.name]
        within, n_ch = within_channel_mad_log(path)
        print(
            f"{path.name:52s} {s['n_cells']:9d} {s['median_width_um']:9.4f} {s['cv']:9.4f} {s['cv_mad']:9.4f} "
            f"{s['sd_log']:9.4f} {s['mad_log']:9.4f} {within:9.4f}  ({n_ch} channels)"
        )
    recomputed = max(v["mad_log"] for v in summary.values())
    print(f"\nupper bound (largest MAD log spread): recomputed {recomputed:.4f}, module {wp.TAU_R_UPPER_BOUND:.4f}")
    print(f"half-normal scale (95 % below the bound): {wp.TAU_R_PRIOR_SCALE:.4f}")
    q = stats.halfnorm.ppf([0.05, 0.5, 0.9, 0.95, 0.99], scale=wp.TAU_R_PRIOR_SCALE)
    print("prior quantiles 5/50/90/95/99 %: " + ", ".join(f"{v:.4f}" for v in q))
    for t in (0.02, 0.036, 0.05):
        print(f"P(tau_R > {t:.3f}) = {stats.halfnorm.sf(t, scale=wp.TAU_R_PRIOR_SCALE):.3f}")
    print("AFM paper, intact cells: R_c = 0.55 +- 0.02 um -> total relative scatter 0.036 (incl. measurement)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
