"""Figures of a fit: ``corner.png`` (joint posterior) and ``fit.png`` (data and model).

``fit.png`` follows the paper's Fig. 3: cell radius and indentation stiffness against
pressure; bulged cells (light points, each at the posterior mean of its latent pressure;
blue crosses: inverse-variance weighted means in 10 log-spaced pressure bins), intact cells
(black open squares at the physiological pressure), the posterior median curve with 68 %
and 90 % bands, and the curve of the paper's published parameters (dashed) for comparison.
"""

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from turgorbayes import forward  # noqa: E402

__all__ = ["PUBLISHED", "plot_corner", "plot_fit"]

#: The paper's published parameters (SCIENCE.md section 6), SI.
PUBLISHED = {"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3}

_LABELS = {"gamma": r"$\gamma$", "E0t": r"$E_0t$ [N/m]", "R0": r"$R_0$ [nm]",
           "P_phys": r"$P_\mathrm{phys}$ [kPa]"}
_UNITS = {"gamma": 1.0, "E0t": 1.0, "R0": 1e-9, "P_phys": 1e3}


def _title(result):
    sim = any("simulated" in c.lower() for c in result.cells.comments)
    tag = "SIMULATED DATA - " if sim else ""
    ok = "converged" if result.converged else "NOT CONVERGED"
    return f"{tag}model {result.model} ({ok})"


def plot_corner(result, path, reference=PUBLISHED):
    """Corner plot of gamma, E0t, R0, P_phys with the published values as lines.

    Parameters
    ----------
    result : turgorbayes.results.FitResult
    path : path-like
        PNG file to write.
    reference : dict, optional
        Values (SI) drawn as lines (the paper's table by default; None for none).
    """
    import corner

    names = ["gamma", "E0t", "R0", "P_phys"]
    x = np.column_stack([np.ravel(result.draws[n]) / _UNITS[n] for n in names])
    truths = None if reference is None else [reference[n] / _UNITS[n] for n in names]
    fig = corner.corner(x, labels=[_LABELS[n] for n in names], quantiles=[0.05, 0.5, 0.95],
                        show_titles=True, title_fmt=".3g", truths=truths,
                        truth_color="tab:red", smooth=1.0)
    fig.suptitle(_title(result) + ("\nred: published values (Deng et al. 2011)"
                                   if reference is not None else ""), fontsize=10, y=0.995)
    fig.subplots_adjust(top=0.9)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _bands(result, P, n_curves=300, seed=0):
    rng = np.random.default_rng(seed)
    flat = {n: np.ravel(result.draws[n]) for n in ("gamma", "E0t", "R0")}
    idx = rng.choice(flat["gamma"].size, size=min(n_curves, flat["gamma"].size), replace=False)
    R, k = forward.cell_radius_and_stiffness(P[None, :], *(flat[n][idx, None] for n in
                                                           ("gamma", "E0t", "R0")),
                                             surrogate=result.surrogate)
    q = [5, 16, 50, 84, 95]
    return np.nanpercentile(R, q, axis=0), np.nanpercentile(k, q, axis=0)


def _binned(P, y, err, n_bins=10):
    edges = np.geomspace(P.min(), P.max() * (1 + 1e-9), n_bins + 1)
    which = np.digitize(P, edges) - 1
    out = []
    for b in range(n_bins):
        m = which == b
        if m.any():
            w = 1 / err[m] ** 2
            out.append((np.exp(np.average(np.log(P[m]), weights=w)),
                        np.average(y[m], weights=w), 1 / np.sqrt(w.sum())))
    return np.array(out)


def plot_fit(result, path, reference=PUBLISHED):
    """R_c and k_c against pressure with posterior bands (module docstring).

    Parameters
    ----------
    result : turgorbayes.results.FitResult
    path : path-like
    reference : dict, optional
        Published parameters drawn as a dashed curve (None: omit).
    """
    cells = result.cells
    b = np.asarray(cells.is_bulged)
    P_cell = np.mean(result.P_cell.reshape(-1, b.size), axis=0)
    P_phys = np.ravel(result.draws["P_phys"])
    P = np.geomspace(min(P_cell[b].min(), 1e3) / 1.5, max(np.quantile(P_phys, 0.95),
                                                            P_cell[b].max()) * 1.5, 160)
    bands = _bands(result, P, seed=result.seed)
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.4))
    ref = None if reference is None else forward.cell_radius_and_stiffness(
        P, reference["gamma"], reference["E0t"], reference["R0"], surrogate=result.surrogate)
    for i, (ax, obs, err, unit, label) in enumerate(zip(
            axes, (cells.R_c, cells.k_c), (cells.R_c_err, cells.k_c_err), (1e-9, 1.0),
            (r"cell radius $R_c$ [nm]", r"cell stiffness $k_c$ [N/m]"), strict=True)):
        band = bands[i]
        ax.fill_between(P / 1e3, band[0] / unit, band[4] / unit, color="tab:red", alpha=0.15,
                        lw=0, label="90 % band")
        ax.fill_between(P / 1e3, band[1] / unit, band[3] / unit, color="tab:red", alpha=0.3,
                        lw=0, label="68 % band")
        ax.plot(P / 1e3, band[2] / unit, color="tab:red", lw=1.5, label="posterior median")
        if ref is not None:
            ax.plot(P / 1e3, ref[i] / unit, "k--", lw=1, label="published parameters")
        ax.errorbar(P_cell[b] / 1e3, obs[b] / unit, yerr=err[b] / unit, fmt=".",
                    color="tab:blue", alpha=0.3, ms=4, lw=0.6, label="bulged cells")
        binned = _binned(P_cell[b], obs[b], err[b])
        ax.errorbar(binned[:, 0] / 1e3, binned[:, 1] / unit, yerr=binned[:, 2] / unit,
                    fmt="x", color="tab:blue", ms=8, mew=2, label="bulged, binned")
        ax.plot(np.full((~b).sum(), np.median(P_phys)) / 1e3, obs[~b] / unit, "s", mfc="none",
                color="k", ms=5, alpha=0.6, label="intact cells")
        lo, hi = np.quantile(P_phys, [0.05, 0.95]) / 1e3
        ax.axvspan(lo, hi, color="0.5", alpha=0.15, lw=0, label=r"$P_\mathrm{phys}$ 90 %")
        ax.set_xscale("log")
        ax.set_xlabel("turgor pressure P [kPa]")
        ax.set_ylabel(label)
    axes[1].set_yscale("log")
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle(_title(result) + " - bulged cells at the posterior mean of their latent "
                 "pressure", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
