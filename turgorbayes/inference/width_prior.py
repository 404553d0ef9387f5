r"""Prior on the cell-to-cell radius spread ``tau_R`` from real *E. coli* width measurements.

The ``radius_spread`` effect lets each cell have its own reference radius,
:math:`\ln R_{0,i} \sim N(\ln R_0, \tau_R^2)`. Its prior comes from mother-machine time-lapse
data (one row per complete cell cycle, napari-MM3 segmentation; Thiermann et al., eLife 2023;
source github.com/junlabucsd/mother-machine-data, BSD-3-Clause), summarized here once. The
package does not need the data at run time (:data:`WIDTH_SPREAD_MEASURED` keeps the numbers and
their provenance); the repository's tests carry the three files with their licence
(``tests/data/ecoli_width_mother_machine``) and recompute the numbers.

How the prior is set
--------------------
1. Per file, the spread of log width across cells, robustly: :math:`1.4826\,\mathrm{MAD}(\ln w)`
   (:func:`width_spread_summary`). A log spread because ``tau_R`` is one (width ``2R`` and radius
   have the same log spread); robust because segmentation failures give outliers that are not
   cell-to-cell variation. Plain CVs are reported alongside.
2. Each measured spread is an *upper bound* on the true one: segmentation noise adds to it
   (the better U-Net segmentation of the same experiment gives 4.9 % against Otsu's 6.9 %).
3. The bound used, :data:`TAU_R_UPPER_BOUND`, is the *largest* robust spread over the three files
   (0.069): the AFM cells (imp4213, vancomycin, on glass) are another strain in another condition,
   so the prior should not be tighter than the loosest measured population.
4. ``tau_R ~ HalfNormal(scale)`` with 95 % of its mass below the bound:
   ``scale = TAU_R_UPPER_BOUND / 1.959964`` = 0.0352 (:data:`TAU_R_PRIOR_SCALE`). The half-normal
   keeps prior mass near zero (the baseline, ``tau_R = 0``, is the boundary and is not penalized
   away), has prior median 0.024 and mean 0.028, and gives 5 % to spreads above any measured one.

For scale: with each mother-machine channel's median removed (channel-to-channel focus and
lineage differences taken out) the robust spread is 0.037-0.042 (``studies/width_prior.py``),
and the AFM paper's intact cells scatter by 0.02/0.55 = 3.6 % in R_c, measurement error included.
"""

import csv
import gzip
import hashlib
from pathlib import Path

import numpy as np
from scipy import stats

from turgorbayes.inference.priors import HalfNormal

__all__ = [
    "MAD_TO_SD",
    "TAU_R_PRIOR",
    "TAU_R_PRIOR_MASS_BELOW_BOUND",
    "TAU_R_PRIOR_SCALE",
    "TAU_R_UPPER_BOUND",
    "WIDTH_SPREAD_MEASURED",
    "default_width_data_dir",
    "tau_R_prior_scale",
    "width_spread_summary",
]

#: ``1/Phi^{-1}(3/4)``: MAD times this estimates the standard deviation of a normal sample.
MAD_TO_SD = 1.482602218505602

#: The numbers :func:`width_spread_summary` gave on the width data, computed 2026-11-22 from
#: the files in ``tests/data/ecoli_width_mother_machine`` (copied unchanged from
#: github.com/junlabucsd/mother-machine-data: ``Si_2019_Curr_Biology/20171225_fs104/mm3_{otsu,unet}``,
#: MG1655 DnaN-Ypet in MOPS glycerol + 11 amino acids, and
#: ``Taheri_2015_Curr_Biology/Otsu_Method_2023``, NCM3722 in glycerol). ``sha256`` is of the .gz file.
WIDTH_SPREAD_MEASURED = {
    "20171225_fs104_otsu_complete_cells.csv.gz": {
        "sha256": "11ce8bb48716f13cd0faf29ae46b18b754452cfbf1c3cbedeb6cbb0aadca7a17",
        "n_cells": 12473,
        "median_width_um": 0.6724,
        "cv": 0.06812,
        "cv_mad": 0.06791,
        "sd_log": 0.06791,
        "mad_log": 0.06859,
    },
    "20171225_fs104_unet_complete_cells.csv.gz": {
        "sha256": "46511120505df175b6691499d1c25ab1c4d5360b43a53bd04c6d88c24597379b",
        "n_cells": 13148,
        "median_width_um": 0.541,
        "cv": 0.05337,
        "cv_mad": 0.04933,
        "sd_log": 0.05443,
        "mad_log": 0.04903,
    },
    "Taheri_NCM3722_glycerol_complete_cells_otsu.csv.gz": {
        "sha256": "5fefe3a9d159bf42ae3a7e1e84d37d1426fbccb236d0d290b08755058a4ffdde",
        "n_cells": 19523,
        "median_width_um": 0.4912,
        "cv": 0.07468,
        "cv_mad": 0.06882,
        "sd_log": 0.07275,
        "mad_log": 0.069,
    },
}

#: Prior probability that ``tau_R`` lies below :data:`TAU_R_UPPER_BOUND`.
TAU_R_PRIOR_MASS_BELOW_BOUND = 0.95


def tau_R_prior_scale(upper_bound, mass_below=TAU_R_PRIOR_MASS_BELOW_BOUND):
    r"""Half-normal scale that puts ``mass_below`` of the prior below ``upper_bound``.

    .. math:: \sigma = u / \Phi^{-1}\!\left(\tfrac{1 + m}{2}\right)

    Parameters
    ----------
    upper_bound : float [-]
        Upper bound ``u`` on the log-radius spread.
    mass_below : float [-]
        Prior mass ``m`` below the bound, in (0, 1).

    Returns
    -------
    float [-]
    """
    if not 0 < mass_below < 1:
        raise ValueError(f"mass_below must lie in (0, 1), got {mass_below!r}")
    if not (np.isfinite(upper_bound) and upper_bound > 0):
        raise ValueError(f"upper_bound must be finite and > 0, got {upper_bound!r}")
    return float(upper_bound / stats.norm.ppf((1 + mass_below) / 2))


#: Upper bound on the true log-radius spread: the largest robust spread among the files.
TAU_R_UPPER_BOUND = max(v["mad_log"] for v in WIDTH_SPREAD_MEASURED.values())
#: Scale of the half-normal prior on ``tau_R``.
TAU_R_PRIOR_SCALE = tau_R_prior_scale(TAU_R_UPPER_BOUND)
#: The prior itself (a :class:`turgorbayes.inference.priors.HalfNormal`, sampled as ``ln tau_R``).
TAU_R_PRIOR = HalfNormal(sd=TAU_R_PRIOR_SCALE)


def default_width_data_dir():
    """The width-data folder: the repository's ``tests/data/ecoli_width_mother_machine``, or
    None (an installed package without its tests).

    Returns
    -------
    pathlib.Path or None
    """
    path = Path(__file__).resolve().parents[2] / "tests" / "data" / "ecoli_width_mother_machine"
    return path if path.is_dir() else None


def _read_widths(path):
    """Widths [um] of one napari-MM3 ``*_complete_cells.csv(.gz)`` file; rows without one dropped."""
    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", newline="") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames is None or "width" not in reader.fieldnames:
            raise ValueError(f"{path}: no 'width' column (columns: {reader.fieldnames})")
        raw = [row["width"] for row in reader]
    widths = np.array([float(v) if v not in ("", "nan", "NaN") else np.nan for v in raw])
    widths = widths[np.isfinite(widths) & (widths > 0)]
    if widths.size < 2:
        raise ValueError(f"{path}: fewer than 2 positive widths ({widths.size})")
    return widths


def _spread(widths):
    log_w = np.log(widths)
    median = np.median(widths)
    return {
        "n_cells": int(widths.size),
        "median_width_um": float(median),
        "cv": float(np.std(widths, ddof=1) / np.mean(widths)),
        "cv_mad": float(MAD_TO_SD * np.median(np.abs(widths - median)) / median),
        "sd_log": float(np.std(log_w, ddof=1)),
        "mad_log": float(MAD_TO_SD * np.median(np.abs(log_w - np.median(log_w)))),
    }


def width_spread_summary(paths):
    r"""Cell-to-cell spread of width in mother-machine files, plain and robust.

    For the widths :math:`w` of one file:
    ``cv`` = sd/mean, ``cv_mad`` = :math:`1.4826\,\mathrm{MAD}(w)/\mathrm{median}(w)`,
    ``sd_log`` = sd of :math:`\ln w`, ``mad_log`` = :math:`1.4826\,\mathrm{MAD}(\ln w)`
    (the robust log spread the prior uses). Rows with an empty, non-finite or non-positive
    width are dropped.

    Parameters
    ----------
    paths : iterable of str or Path
        napari-MM3 ``*_complete_cells.csv`` files (optionally gzipped) with a ``width`` column [um].

    Returns
    -------
    dict
        ``{file name: {"sha256", "n_cells", "median_width_um", "cv", "cv_mad", "sd_log",
        "mad_log"}}``, the layout of :data:`WIDTH_SPREAD_MEASURED`.
    """
    out = {}
    for path in map(Path, paths):
        if not path.is_file():
            raise FileNotFoundError(f"width data file not found: {path}")
        entry = {"sha256": hashlib.sha256(path.read_bytes()).hexdigest()}
        entry.update(_spread(_read_widths(path)))
        out[path.name] = entry
    if not out:
        raise ValueError("width_spread_summary needs at least one file, got none")
    return out
