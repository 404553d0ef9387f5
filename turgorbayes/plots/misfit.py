"""The criticism's residual figure: the baseline and the adopted extension against pressure."""

from pathlib import Path

import numpy as np

from turgorbayes.io import is_simulated

__all__ = ["misfit_plot", "plot_misfit"]


def _residuals(arrays, obs):
    """Mean standardized residual per cell and the 5-95 % range of replicated ones."""
    y, s = arrays["y"][obs], arrays["sigma"][obs]
    mu, rep = arrays["mu"][obs], arrays["y_rep"][obs]
    z = np.nanmean((y - mu) / s, axis=0)
    zr = (rep - mu) / s
    return z, np.nanquantile(zr, 0.05, axis=0), np.nanquantile(zr, 0.95, axis=0)


def plot_misfit(result, path):
    """Residual figure: one row per model (baseline, adopted extension or best candidate).

    Columns: standardized residual of ``R_c`` and of ``k_c`` against the cell's pressure
    (bulged cells at their bulge-derived pressure, intact cells at the posterior median of
    ``P_phys``), each cell's 90 % range of replicated residuals in grey; and ``z(k_c)``
    against ``z(R_c)``. A model that fits leaves the points inside the grey ranges.
    """
    from matplotlib.figure import Figure

    rows = ["baseline"] + [m for m in [result.selected] if m]
    fig = Figure(figsize=(13, 3.6 * len(rows)))
    axes = fig.subplots(len(rows), 3, squeeze=False)
    for r, name in enumerate(rows):
        arrays = result.check_arrays[name]
        P = np.exp(np.median(arrays["log_pressure"], axis=0)) / 1e3
        bulged = arrays["group"] == "bulged"
        flagged = [c["name"] for c in result.checks[name] if c["flagged"]]
        zs = {}
        for c, (obs, label) in enumerate((("R_c", "R_c"), ("k_c", "k_c"))):
            ax = axes[r, c]
            z, lo, hi = _residuals(arrays, obs)
            zs[obs] = z
            order = np.argsort(P)
            ax.vlines(P[order], lo[order], hi[order], color="0.8", lw=2.5, zorder=1)
            ax.scatter(P[bulged], z[bulged], s=12, c="C0", label="bulged", zorder=2)
            ax.scatter(P[~bulged], z[~bulged], s=12, c="C3", label="intact", zorder=2)
            ax.axhline(0, color="k", lw=0.6)
            ax.set_xscale("log")
            ax.set_xlabel("pressure [kPa]")
            ax.set_ylabel(f"standardized residual of ${label}$")
            if c == 0:
                ax.set_title(f"{name}: {len(flagged)} check(s) flagged", loc="left", fontsize=10)
                ax.legend(fontsize=8, loc="lower right")
        ax = axes[r, 2]
        ax.scatter(zs["R_c"][bulged], zs["k_c"][bulged], s=12, c="C0")
        ax.scatter(zs["R_c"][~bulged], zs["k_c"][~bulged], s=12, c="C3")
        ax.axhline(0, color="k", lw=0.6)
        ax.axvline(0, color="k", lw=0.6)
        ax.set_xlabel("residual of $R_c$")
        ax.set_ylabel("residual of $k_c$")
        ax.set_title(", ".join(flagged) if flagged else "no check flagged", fontsize=8)
    fig.suptitle("Residuals in units of the reported errors (grey: 90% of the model's own "
                 "replications)" + ("  SIMULATED DATA" if is_simulated(result.cells) else ""),
                 fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)


def misfit_plot(criticism_result, path):
    """The criticism's residual figure (:func:`plot_misfit`).

    One row per model (the baseline, and the adopted extension if any), residuals of ``R_c``
    and ``k_c`` against pressure with each cell's 90 % replicated range; written to ``path``.

    Returns
    -------
    pathlib.Path
    """
    plot_misfit(criticism_result, path)
    return Path(path)
