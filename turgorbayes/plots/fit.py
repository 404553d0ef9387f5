"""Figures of a fit: the paper's Fig. 3, the joint posterior, convergence and residuals.

A fit is a :class:`turgorbayes.results.FitResult` or the DataTree of ``posterior.nc``; axes use
the units of the bench (nm, kPa, pN/nm = mN/m).
"""

import numpy as np

from turgorbayes import forward
from turgorbayes.parameters import BASELINE, QUANTITIES
from turgorbayes.parameters import PUBLISHED as _PUBLISHED
from turgorbayes.plots.bands import (
    CurveBands,
    baseline_bands,
    binned_means,
    extended_bands,
    pressure_grid,
)
from turgorbayes.plots.data import (
    cell_table,
    flat_draws,
    plot_title,
    posterior_tree,
    surrogate_of,
)
from turgorbayes.plots.style import PN_PER_NM, figure, rc, save

__all__ = ["DISPLAY", "PUBLISHED", "corner_plot", "fig3", "rank_plot", "residual_plot",
           "standardized_residuals", "trace_plot"]

#: The paper's published baseline parameters (SI), the default reference of the figures.
PUBLISHED = {n: _PUBLISHED[n] for n in BASELINE}
#: Display name and SI per display unit of the baseline parameters (ArviZ panels).
DISPLAY = {n: (QUANTITIES[n].plain, QUANTITIES[n].factor) for n in BASELINE}

_PANELS = (("R_c", 1e-9, r"cell radius $R_c$ [nm]", "R"),
           ("k_c", PN_PER_NM, r"cell stiffness $k_c$ [pN/nm]", "k"))
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
    table = surrogate_of(fit, surrogate)
    P = pressure_grid(dt)
    models = [baseline_bands(dt, P, table, n_curves, seed)]
    models += [e if isinstance(e, CurveBands) else extended_bands(e, P, n_curves, seed)
               for e in _as_list(extended)]
    cells = cell_table(dt, pressure)
    ref = None if reference is None else forward.cell_radius_and_stiffness(
        P, reference["gamma"], reference["E0t"], reference["R0"], surrogate=table)
    with rc():
        fig = figure((11.0, 5.2))
        axes = fig.subplots(1, 2)
        for i, (ax, (obs, unit, ylabel, attr)) in enumerate(zip(axes, _PANELS, strict=True)):
            for bands, style in zip(models, _BAND_STYLE, strict=False):
                _draw_bands(ax, bands, attr, unit, style)
            if ref is not None:
                ax.plot(P / 1e3, ref[i] / unit, ":", color="k", lw=1.2,
                        label="published parameters")
            _draw_cells(ax, cells, obs, unit, flat_draws(dt, "P_phys"))
            ax.set_xscale("log")
            ax.set_xlabel("turgor pressure $P$ [kPa]")
            ax.set_ylabel(ylabel)
        axes[1].set_yscale("log")
        handles, labels = axes[0].get_legend_handles_labels()
        fig.legend(handles, labels, loc="outside lower center", ncol=4, frameon=False)
        where = "bulge-derived" if pressure == "bulge" else "posterior-mean latent"
        fig.suptitle(f"{plot_title(dt)}; bulged cells at their {where} pressure", fontsize=11)
    return save(fig, path)


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
    x = np.column_stack([flat_draws(dt, n) / DISPLAY[n][1] for n in names])
    truths = None if reference is None else [reference[n] / DISPLAY[n][1] for n in names]
    with rc():
        fig = figure((8.5, 8.5))
        fig.set_layout_engine(None)
        corner.corner(x, fig=fig, labels=[QUANTITIES[n].tex for n in names], quantiles=[0.05, 0.5, 0.95],
                      show_titles=True, title_fmt=".3g", truths=truths, truth_color="tab:red",
                      smooth=1.0, labelpad=0.1, max_n_ticks=3,
                      title_kwargs={"fontsize": 9.5})
        fig.subplots_adjust(left=0.12, bottom=0.12, top=0.86, right=0.94, wspace=0.12,
                            hspace=0.12)
        fig.suptitle(plot_title(dt) + ("\nred: published values (Deng et al. 2011)"
                                   if reference is not None else ""), fontsize=10.5)
    return save(fig, path)


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
    with rc():
        pc = getattr(azp, plot)(_display_tree(dt), backend="matplotlib",
                                figure_kwargs={"figsize": figsize, "layout": "constrained"},
                                **kwargs)
        fig = pc.viz["figure"].item()
        plt.close(fig)  # arviz-plots draws through pyplot; keep no global reference
        for ax in fig.axes:
            ax.xaxis.set_major_locator(MaxNLocator(5))
        fig.suptitle(plot_title(dt), fontsize=10.5)
    return save(fig, path)


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
    cells = cell_table(dt, "posterior")
    b = cells["b"]
    P = cells["P"] / 1e3
    with rc():
        fig = figure((11.0, 4.2))
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
        fig.suptitle(plot_title(dt), fontsize=10.5)
    return save(fig, path)
