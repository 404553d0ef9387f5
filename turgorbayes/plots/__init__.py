"""Every figure of turgorbayes, shared by the notebook, ``turgorbayes report`` and ``fit``.

* :func:`fig2b`: the bulge model, dimensionless force against indentation (paper Fig. 2b);
* :func:`fig3`: cell radius and stiffness against pressure, data and posterior bands of the
  baseline and of an extended model (paper Fig. 3);
* :func:`fig4`: the finite-element reduced stiffness against the inflation number (paper Fig. 4);
* :func:`corner_plot`, :func:`trace_plot`, :func:`rank_plot` (ArviZ): the joint posterior and
  the convergence of the independent ensembles;
* :func:`residual_plot`: posterior predictive residuals of every cell against its pressure;
  :func:`misfit_plot`: the criticism's residual figure (baseline against the adopted extension).

A fit is passed either as a :class:`turgorbayes.results.FitResult` or as the DataTree that
``fit`` writes (``xarray.open_datatree("posterior.nc", engine="h5netcdf")``), so that the same
figures are drawn in a session and from an old output directory. Figures are
:class:`matplotlib.figure.Figure` objects made without pyplot (no global state); each function
takes ``path`` to write a PNG (:func:`fig2b` and :func:`fig4` return their main Axes, whose
``.figure`` is the Figure). Axes use the units of the bench: nm, kPa and pN/nm (= mN/m).

Reference: Deng, Sun & Shaevitz, Phys. Rev. Lett. 107, 158101 (2011).
"""

import json
from dataclasses import dataclass

import numpy as np

from turgorbayes import forward
from turgorbayes.plots.bulge import plot_bulge_response as fig2b
from turgorbayes.plots.surrogate import plot_reduced_stiffness as fig4

__all__ = [
    "PUBLISHED",
    "QUANTILES",
    "CurveBands",
    "baseline_bands",
    "binned_means",
    "corner_plot",
    "curve_bands",
    "extended_bands",
    "fig2b",
    "fig3",
    "fig4",
    "misfit_plot",
    "posterior_tree",
    "pressure_grid",
    "rank_plot",
    "read_bands",
    "residual_plot",
    "standardized_residuals",
    "trace_plot",
    "write_bands",
    "write_extended_bands",
]

#: The paper's published parameters (SCIENCE.md section 6), SI.
PUBLISHED = {"gamma": 1.22, "E0t": 0.026, "R0": 464.2e-9, "P_phys": 29e3}
#: Quantiles of a band: 95 % (2.5-97.5), 68 % (16-84) and the median.
QUANTILES = (0.025, 0.16, 0.5, 0.84, 0.975)
#: Display name and SI per display unit of the baseline parameters.
DISPLAY = {"gamma": ("gamma", 1.0), "E0t": ("E0t [N m⁻¹]", 1.0), "R0": ("R0 [nm]", 1e-9),
           "P_phys": ("P_phys [kPa]", 1e3)}
_TEX = {"gamma": r"$\gamma$", "E0t": r"$E_0t$ [N/m]", "R0": r"$R_0$ [nm]",
        "P_phys": r"$P_\mathrm{phys}$ [kPa]"}
_FONT = {"font.size": 11, "axes.labelsize": 12, "legend.fontsize": 9.5}
_PN_PER_NM = 1e-3  # N/m per pN/nm


def _figure(figsize):
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def _rc():
    import matplotlib as mpl

    return mpl.rc_context(_FONT)


def _save(fig, path, dpi=130):
    if path is not None:
        fig.savefig(path, dpi=dpi)
    return fig


# ------------------------------------------------------------------------------ fit input
def posterior_tree(fit):
    """The DataTree of a fit: ``fit`` itself, or :func:`turgorbayes.results.to_datatree` of it.

    Parameters
    ----------
    fit : turgorbayes.results.FitResult or xarray.DataTree
    """
    if hasattr(fit, "draws") and hasattr(fit, "cells"):
        from turgorbayes.results import to_datatree

        return to_datatree(fit)
    if not hasattr(fit, "children") or "posterior" not in fit.children:
        raise TypeError(f"expected a FitResult or the DataTree of posterior.nc, got "
                        f"{type(fit).__name__}")
    return fit


def _flat(dt, name):
    return np.asarray(dt["posterior"][name].values, float).reshape(-1)


def _title(dt):
    tag = "SIMULATED DATA - " if int(dt.attrs.get("simulated_data", 0)) else ""
    ok = "converged" if int(dt.attrs.get("converged", 1)) else "NOT CONVERGED"
    return f"{tag}model {dt.attrs.get('model', '?')} ({ok})"


def _surrogate_of(fit, surrogate):
    if surrogate is not None:
        return surrogate
    if getattr(fit, "surrogate", None) is not None:
        return fit.surrogate
    from turgorbayes import surrogate as surrogate_module

    table = surrogate_module.load()
    want = fit.attrs.get("surrogate_sha256") if hasattr(fit, "attrs") else None
    if want and table.sha256 != want:
        raise ValueError(f"the fit used the surrogate table with sha256 {want}, the shipped "
                         f"one is {table.sha256}; pass the fit's table as surrogate=")
    return table


# ------------------------------------------------------------------------------ bands
@dataclass
class CurveBands:
    """Quantiles of the model curves ``R_c(P)``, ``k_c(P)`` over posterior draws.

    Attributes
    ----------
    P : ndarray (n,) [Pa]
    R : ndarray (5, n) [m]
        Quantiles :data:`QUANTILES` of ``R_c`` at each ``P``.
    k : ndarray (5, n) [N/m]
        The same for ``k_c``.
    label : str
    """

    P: np.ndarray
    R: np.ndarray
    k: np.ndarray
    label: str


def curve_bands(P, R_curves, k_curves, label):
    """Pointwise quantiles :data:`QUANTILES` of curves drawn from a posterior.

    Parameters
    ----------
    P : array_like (n,) [Pa]
    R_curves : array_like (draws, n) [m]
    k_curves : array_like (draws, n) [N/m]
    label : str

    Returns
    -------
    CurveBands
        NaN curves (pressures a draw's wall cannot reach) are left out of the quantiles.
    """
    q = np.asarray(QUANTILES)
    return CurveBands(np.asarray(P, float), np.nanquantile(R_curves, q, axis=0),
                      np.nanquantile(k_curves, q, axis=0), label)


def pressure_grid(fit, n=120):
    """Log-spaced pressures [Pa] spanning the bulge pressures and ``P_phys`` with margins."""
    dt = posterior_tree(fit)
    return _grid(_bulge_pressures(dt), _flat(dt, "P_phys"), n)


def _grid(P_bulge, P_phys, n):
    hi = max(np.nanmax(P_bulge), np.quantile(P_phys, 0.99))
    return np.geomspace(np.nanmin(P_bulge) / 1.5, hi * 1.5, n)


def _draw_indices(n_total, n, seed):
    rng = np.random.default_rng(seed)
    return rng.choice(n_total, size=min(n, n_total), replace=False)


def baseline_bands(fit, P=None, surrogate=None, n_curves=300, seed=0, label=None):
    """Bands of the baseline (or ``paper_wls``) curves from a fit's ``gamma, E0t, R0`` draws.

    Parameters
    ----------
    fit : FitResult or DataTree
    P : array_like [Pa], optional
        Default :func:`pressure_grid`.
    surrogate : turgorbayes.surrogate.Surrogate, optional
        Default the fit's own (FitResult) or the shipped table, checked by sha256.
    n_curves : int
        Posterior draws used (drawn without replacement with ``seed``).
    label : str, optional

    Returns
    -------
    CurveBands
    """
    dt = posterior_tree(fit)
    table = _surrogate_of(fit, surrogate)
    P = pressure_grid(dt) if P is None else np.asarray(P, float)
    draws = {n: _flat(dt, n) for n in ("gamma", "E0t", "R0")}
    idx = _draw_indices(draws["gamma"].size, n_curves, seed)
    R, k = forward.cell_radius_and_stiffness(P[None, :], *(draws[n][idx, None] for n in draws),
                                             surrogate=table)
    return curve_bands(P, R, k, label or str(dt.attrs.get("model", "baseline")))


def extended_bands(posterior, P, n_curves=300, seed=0, label=None):
    """Bands of an extended model's curves (median intact-cell wall) from criticism draws.

    Parameters
    ----------
    posterior : turgorbayes.criticism.Posterior
        Weighted draws of one model (``CriticismResult.posteriors[name]``).
    P : array_like [Pa]
    n_curves : int
        Draws resampled by weight with ``seed``.
    label : str, optional
        Default the model's name and "(intact-cell wall)".

    Returns
    -------
    CurveBands
    """
    P = np.asarray(P, float)
    idx = posterior.resample(n_curves, np.random.default_rng(seed))
    R, k = posterior.model.curves(posterior.u[idx], P)
    return curve_bands(P, R, k, label or f"{posterior.model.name} (intact-cell wall)")


def write_extended_bands(criticism_result, path, n_curves=300, seed=0):
    """Write the adopted extension's bands (``extended_bands.json``) of a criticism, if any.

    The pressure grid spans the cells' bulge pressures and the extension's ``P_phys`` like
    :func:`pressure_grid`; ``turgorbayes report`` draws these bands in Fig. 3.

    Parameters
    ----------
    criticism_result : turgorbayes.criticism.CriticismResult
    path : path-like
    n_curves, seed : int

    Returns
    -------
    CurveBands or None
        None (and no file) when no extension was adopted.
    """
    if not criticism_result.selected:
        return None
    post = criticism_result.posteriors[criticism_result.selected]
    P_phys = post.model.to_physical(post.u)["P_phys"]
    P = _grid(np.exp(post.model.obs.log_P_bulge), P_phys, 120)
    bands = extended_bands(post, P, n_curves, seed)
    write_bands(bands, path)
    return bands


def write_bands(bands, path):
    """Write :class:`CurveBands` as JSON (SI), for :func:`read_bands` and ``turgorbayes report``."""
    d = {"label": bands.label, "quantiles": list(QUANTILES), "P_Pa": bands.P.tolist(),
         "R_c_m": np.asarray(bands.R).tolist(), "k_c_N_per_m": np.asarray(bands.k).tolist()}
    with open(path, "w", encoding="utf-8") as fh:
        json.dump(d, fh)


def read_bands(path):
    """Read :class:`CurveBands` written by :func:`write_bands`."""
    with open(path, encoding="utf-8") as fh:
        d = json.load(fh)
    if tuple(d["quantiles"]) != QUANTILES:
        raise ValueError(f"{path}: bands at quantiles {d['quantiles']}, expected {QUANTILES}")
    return CurveBands(np.asarray(d["P_Pa"]), np.asarray(d["R_c_m"], float),
                      np.asarray(d["k_c_N_per_m"], float), d["label"])


# ------------------------------------------------------------------------------ Fig. 3
def binned_means(P, y, y_err, log_P_err=None, n_bins=10):
    r"""Error-weighted means of ``y`` in ``n_bins`` log-spaced pressure bins (paper Fig. 3).

    In bin :math:`b`, with weights :math:`w_i = 1/\sigma_{y,i}^2` and
    :math:`v_i = 1/\sigma_{\ln P,i}^2`:

    .. math::

        \bar y_b = \frac{\sum w_i y_i}{\sum w_i},\quad
        \sigma_{\bar y_b} = \Big(\sum w_i\Big)^{-1/2},\quad
        \bar P_b = \exp\frac{\sum v_i \ln P_i}{\sum v_i}.

    Parameters
    ----------
    P : array_like [Pa]
        Pressure of each cell.
    y : array_like
        Observable (any unit).
    y_err : array_like
        Its standard errors (same unit, > 0).
    log_P_err : array_like, optional
        Standard errors of ``ln P`` (equal weights if None).
    n_bins : int
        Bins between the smallest and largest ``P`` (both included).

    Returns
    -------
    ndarray (n_filled, 4)
        Rows ``(P_b [Pa], y_b, se_b, n_b)`` of the non-empty bins, in order of pressure.
    """
    P, y, y_err = (np.asarray(a, float) for a in (P, y, y_err))
    v = np.ones_like(P) if log_P_err is None else 1.0 / np.asarray(log_P_err, float) ** 2
    edges = np.geomspace(P.min(), P.max(), n_bins + 1)
    which = np.clip(np.searchsorted(edges, P, side="right") - 1, 0, n_bins - 1)
    rows = []
    for b in range(n_bins):
        m = which == b
        if m.any():
            w = 1.0 / y_err[m] ** 2
            rows.append((np.exp(np.average(np.log(P[m]), weights=v[m])),
                         np.average(y[m], weights=w), w.sum() ** -0.5, m.sum()))
    return np.array(rows)


def _bulge_pressures(dt):
    c = dt["constant_data"]
    return np.where(np.asarray(c["is_bulged"].values, bool), c["P_bulge"].values, np.nan)


def _cell_table(dt, pressure):
    c, o = dt["constant_data"], dt["observed_data"]
    b = np.asarray(c["is_bulged"].values, bool)
    if pressure == "bulge":
        P = np.asarray(c["P_bulge"].values, float)
    elif pressure == "posterior":
        P = np.asarray(dt["posterior"]["P_cell"].values).reshape(-1, b.size).mean(axis=0)
    else:
        raise ValueError(f"pressure must be 'bulge' or 'posterior', got {pressure!r}")
    return {"b": b, "P": P, "sd_logP": np.asarray(c["sd_log_P_bulge"].values, float),
            "R_c": (o["R_c"].values, c["R_c_err"].values),
            "k_c": (o["k_c"].values, c["k_c_err"].values)}


_PANELS = (("R_c", 1e-9, r"cell radius $R_c$ [nm]", "R"),
           ("k_c", _PN_PER_NM, r"cell stiffness $k_c$ [pN/nm]", "k"))
_BAND_STYLE = (dict(color="tab:red", ls="-"), dict(color="tab:green", ls="--"),
               dict(color="tab:purple", ls="-."))


def _draw_bands(ax, bands, attr, unit, style):
    q = getattr(bands, attr) / unit
    P = bands.P / 1e3
    ax.fill_between(P, q[0], q[4], color=style["color"], alpha=0.13, lw=0,
                    label=f"{bands.label}: 95 %")
    ax.fill_between(P, q[1], q[3], color=style["color"], alpha=0.28, lw=0,
                    label=f"{bands.label}: 68 %")
    ax.plot(P, q[2], color=style["color"], ls=style["ls"], lw=1.8,
            label=f"{bands.label}: median")


def _draw_cells(ax, cells, obs, unit, P_phys):
    b = cells["b"]
    y, err = (np.asarray(a, float) for a in cells[obs])
    ax.errorbar(cells["P"][b] / 1e3, y[b] / unit, yerr=err[b] / unit, fmt="o", ms=3,
                color="tab:blue", alpha=0.25, lw=0.6, label="bulged cells")
    binned = binned_means(cells["P"][b], y[b], err[b], cells["sd_logP"][b])
    ax.errorbar(binned[:, 0] / 1e3, binned[:, 1] / unit, yerr=binned[:, 2] / unit, fmt="x",
                color="tab:blue", ms=9, mew=2.2, lw=1.5, label="bulged, 10 bins")
    P_i = np.full((~b).sum(), np.median(P_phys)) / 1e3
    ax.plot(P_i, y[~b] / unit, "s", mfc="none", color="k", ms=6, alpha=0.5,
            label=r"intact cells (at median $P_\mathrm{phys}$)")


def _as_list(extended):
    """One model (CurveBands or Posterior) or a sequence of them, as a list."""
    if isinstance(extended, CurveBands) or hasattr(extended, "model"):
        return [extended]
    return list(extended or ())


def fig3(fit, extended=(), surrogate=None, reference=PUBLISHED, pressure="bulge", n_curves=300,
         seed=0, path=None):
    """The paper's Fig. 3: ``R_c`` and ``k_c`` against pressure with posterior bands.

    Bulged cells are drawn faintly at their bulge-derived pressure (``pressure="bulge"``, as
    the paper did) or at the posterior mean of their latent pressure (``"posterior"``), with
    their error-weighted means in 10 log-spaced bins (:func:`binned_means`, crosses); intact
    cells as open squares at the posterior median of ``P_phys``. Each model is a median curve
    with 68 % and 95 % bands; the published parameters are a thin dotted line.

    Parameters
    ----------
    fit : FitResult or DataTree
        The baseline fit.
    extended : CurveBands, criticism.Posterior or sequence of them
        Further models (e.g. ``CriticismResult.posteriors[selected]``, or
        :func:`read_bands` of a saved one).
    surrogate : turgorbayes.surrogate.Surrogate, optional
        See :func:`baseline_bands`.
    reference : dict or None
        Parameters (SI) of the dotted reference curve; None omits it.
    pressure : {"bulge", "posterior"}
    n_curves, seed : int
        Posterior draws per band and the seed that picks them.
    path : path-like, optional
        Write a PNG there.

    Returns
    -------
    matplotlib.figure.Figure
        Two axes: ``R_c`` [nm] and ``k_c`` [pN/nm] against ``P`` [kPa] (log).
    """
    dt = posterior_tree(fit)
    table = _surrogate_of(fit, surrogate)
    P = pressure_grid(dt)
    models = [baseline_bands(dt, P, table, n_curves, seed)]
    models += [e if isinstance(e, CurveBands) else extended_bands(e, P, n_curves, seed)
               for e in _as_list(extended)]
    cells = _cell_table(dt, pressure)
    ref = None if reference is None else forward.cell_radius_and_stiffness(
        P, reference["gamma"], reference["E0t"], reference["R0"], surrogate=table)
    with _rc():
        fig = _figure((11.0, 5.2))
        axes = fig.subplots(1, 2)
        for i, (ax, (obs, unit, ylabel, attr)) in enumerate(zip(axes, _PANELS, strict=True)):
            for bands, style in zip(models, _BAND_STYLE, strict=False):
                _draw_bands(ax, bands, attr, unit, style)
            if ref is not None:
                ax.plot(P / 1e3, ref[i] / unit, ":", color="k", lw=1.2,
                        label="published parameters")
            _draw_cells(ax, cells, obs, unit, _flat(dt, "P_phys"))
            ax.set_xscale("log")
            ax.set_xlabel("turgor pressure $P$ [kPa]")
            ax.set_ylabel(ylabel)
        axes[1].set_yscale("log")
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncol=4, frameon=False)
        where = "bulge-derived" if pressure == "bulge" else "posterior-mean latent"
        fig.suptitle(f"{_title(dt)}; bulged cells at their {where} pressure", fontsize=11)
    return _save(fig, path)


# ------------------------------------------------------------------------------ posterior
def corner_plot(fit, reference=PUBLISHED, path=None):
    """Corner plot of ``gamma, E0t, R0, P_phys`` (90 % quantiles), published values in red.

    Parameters
    ----------
    fit : FitResult or DataTree
    reference : dict or None
        Values (SI) drawn as lines.
    path : path-like, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    import corner

    dt = posterior_tree(fit)
    names = list(DISPLAY)
    x = np.column_stack([_flat(dt, n) / DISPLAY[n][1] for n in names])
    truths = None if reference is None else [reference[n] / DISPLAY[n][1] for n in names]
    with _rc():
        fig = _figure((8.5, 8.5))
        fig.set_layout_engine(None)
        corner.corner(x, fig=fig, labels=[_TEX[n] for n in names], quantiles=[0.05, 0.5, 0.95],
                      show_titles=True, title_fmt=".3g", truths=truths, truth_color="tab:red",
                      smooth=1.0, labelpad=0.1, max_n_ticks=3,
                      title_kwargs={"fontsize": 9.5})
        fig.subplots_adjust(left=0.12, bottom=0.12, top=0.86, right=0.94, wspace=0.12,
                            hspace=0.12)
        fig.suptitle(_title(dt) + ("\nred: published values (Deng et al. 2011)"
                                   if reference is not None else ""), fontsize=10.5)
    return _save(fig, path)


def _display_tree(dt):
    """A DataTree holding only the baseline parameters, in display units (nm, kPa)."""
    import xarray as xr

    post = dt["posterior"]
    data = {DISPLAY[n][0]: post[n] / DISPLAY[n][1] for n in DISPLAY}
    return xr.DataTree.from_dict({"posterior": xr.Dataset(data)})


def _arviz_figure(plot, fit, path, figsize, **kwargs):
    import arviz_plots as azp
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    dt = posterior_tree(fit)
    with _rc():
        pc = getattr(azp, plot)(_display_tree(dt), backend="matplotlib",
                                figure_kwargs={"figsize": figsize, "layout": "constrained"},
                                **kwargs)
        fig = pc.viz["figure"].item()
        plt.close(fig)  # arviz-plots draws through pyplot; keep no global reference
        for ax in fig.axes:
            ax.xaxis.set_major_locator(MaxNLocator(5))
        fig.suptitle(_title(dt), fontsize=10.5)
    return _save(fig, path)


def trace_plot(fit, path=None):
    """ArviZ trace plot (``arviz_plots.plot_trace_dist``): one line per independent ensemble.

    Parameters
    ----------
    fit : FitResult or DataTree
    path : path-like, optional

    Returns
    -------
    matplotlib.figure.Figure
        Left: the posterior density per ensemble; right: the draws in order.
    """
    return _arviz_figure("plot_trace_dist", fit, path, (10, 7.5))


def rank_plot(fit, path=None):
    """ArviZ rank plot (``arviz_plots.plot_rank``, fractional-rank Delta-ECDF per ensemble).

    Ensembles that sample the same posterior stay inside the envelope; the p-value of the
    multi-chain test is printed in each panel.

    Returns
    -------
    matplotlib.figure.Figure
    """
    return _arviz_figure("plot_rank", fit, path, (11, 3.6))


# ------------------------------------------------------------------------------ residuals
def standardized_residuals(y, y_rep):
    r"""Residual of each observation in units of its posterior predictive spread.

    .. math:: z_i = \frac{y_i - \mathrm{mean}_s\, y^{rep}_{s,i}}{\mathrm{sd}_s\, y^{rep}_{s,i}}

    Parameters
    ----------
    y : array_like (n,)
    y_rep : array_like (draws, n)
        Posterior predictive replicates.

    Returns
    -------
    ndarray (n,)
        About N(0, 1) per cell when the model fits (exactly so for a Gaussian predictive).
    """
    y_rep = np.asarray(y_rep, float)
    return (np.asarray(y, float) - y_rep.mean(axis=0)) / y_rep.std(axis=0, ddof=1)


def residual_plot(fit, path=None):
    """Posterior predictive residuals of ``R_c`` and ``k_c`` against each cell's pressure.

    Points: :func:`standardized_residuals` of bulged (blue) and intact (black) cells; crosses:
    their means in 10 log-spaced pressure bins with standard errors; grey: the central 90 %
    of N(0, 1), where 90 % of the points fall when the model fits. A trend of the crosses with
    pressure, or a spread wider than the grey band, is a misfit.

    Parameters
    ----------
    fit : FitResult or DataTree
    path : path-like, optional

    Returns
    -------
    matplotlib.figure.Figure
    """
    dt = posterior_tree(fit)
    cells = _cell_table(dt, "posterior")
    b = cells["b"]
    P = cells["P"] / 1e3
    with _rc():
        fig = _figure((11.0, 4.2))
        axes = fig.subplots(1, 2, sharey=True)
        for ax, (obs, label) in zip(axes, (("R_c", "R_c"), ("k_c", "k_c")), strict=True):
            rep = np.asarray(dt["posterior_predictive"][obs].values).reshape(-1, b.size)
            z = standardized_residuals(dt["observed_data"][obs].values, rep)
            ax.axhspan(-1.645, 1.645, color="0.88", lw=0, label="90 % of N(0, 1)")
            ax.axhline(0, color="k", lw=0.7)
            ax.plot(P[b], z[b], "o", ms=4, color="tab:blue", alpha=0.6, label="bulged cells")
            ax.plot(P[~b], z[~b], "s", ms=4, mfc="none", color="k", alpha=0.6,
                    label="intact cells")
            m = binned_means(P[b], z[b], np.ones(b.sum()))
            ax.errorbar(m[:, 0], m[:, 1], yerr=1 / np.sqrt(m[:, 3]), fmt="x", color="tab:red",
                        ms=8, mew=2, label="bulged, binned mean")
            ax.set_xscale("log")
            ax.set_xlabel("pressure $P$ [kPa] (posterior mean)")
            ax.set_title(f"${label}$: {np.mean(np.abs(z) > 1.645):.0%} outside the 90 % band",
                         fontsize=11)
        axes[0].set_ylabel("standardized residual")
        axes[1].legend(loc="upper right", fontsize=8.5)
        fig.suptitle(_title(dt), fontsize=10.5)
    return _save(fig, path)


def misfit_plot(criticism_result, path):
    """The criticism's residual figure (:func:`turgorbayes.report.criticism.plot_misfit`).

    One row per model (the baseline, and the adopted extension if any), residuals of ``R_c``
    and ``k_c`` against pressure with each cell's 90 % replicated range; written to ``path``.

    Returns
    -------
    pathlib.Path
    """
    from pathlib import Path

    from turgorbayes.report.criticism import plot_misfit

    plot_misfit(criticism_result, path)
    return Path(path)
