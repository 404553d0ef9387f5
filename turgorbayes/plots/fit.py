"""Figures of a fit: the paper's Fig. 3, the joint posterior, convergence and residuals.

A fit is a :class:`turgorbayes.workflows.fit.FitResult` or the DataTree of ``posterior.nc``; axes use
the units of the bench (nm, kPa, pN/nm = mN/m).
"""

import numpy as np

from turgorbayes.formatting import format_pm
from turgorbayes.physics import forward
from turgorbayes.physics.parameters import BASELINE, QUANTITIES
from turgorbayes.physics.parameters import PUBLISHED as _PUBLISHED
from turgorbayes.plots.style import (
    PN_PER_NM,
    figure,
    format_p,
    log_axis,
    rc,
    save,
)
from turgorbayes.workflows.bands import CurveBands, baseline_bands, binned_means, extended_bands, pressure_grid
from turgorbayes.workflows.fit_data import cell_table, flat_draws, plot_title, posterior_tree, surrogate_of

__all__ = ["DISPLAY", "PUBLISHED", "corner_plot", "fig3", "rank_plot", "rank_pvalues",
           "residual_plot", "standardized_residuals", "trace_plot"]

#: The paper's published baseline parameters (SI), the default reference of the figures.
PUBLISHED = {n: _PUBLISHED[n] for n in BASELINE}
#: Display label (TeX symbol with unit, as on the corner plot's axes) and SI per display unit
#: of the baseline parameters: the variable names of the ArviZ trace and rank panels.
DISPLAY = {n: (QUANTITIES[n].tex, QUANTITIES[n].factor) for n in BASELINE}

_PANELS = (("R_c", 1e-9, r"cell radius $R_c$ [nm]", "R"),
           ("k_c", PN_PER_NM, r"cell stiffness $k_c$ [pN/nm]", "k"))
#: Per model: colour, median line style and width, fill opacity of the 95 % and 68 % bands.
#: The baseline is a wide solid line under the narrower dashed extension, so both show.
_BAND_STYLE = (dict(color="tab:red", ls="-", lw=2.6, alpha=(0.20, 0.40), zorder=3),
               dict(color="tab:green", ls="--", lw=1.7, alpha=(0.16, 0.34), zorder=4),
               dict(color="tab:purple", ls="-.", lw=1.7, alpha=(0.16, 0.34), zorder=4))
_BULGED = dict(color="tab:blue", ecolor="tab:blue")
_INTACT = dict(color="0.15", ecolor="0.35")


def _draw_bands(ax, bands, attr, unit, style):
    """68 % and 95 % bands (fills, the 95 % edges as thin lines) and the median of one model.

    Returns
    -------
    tuple, str
        Legend handle (the artists overlaid) and its label.
    """
    q = getattr(bands, attr) / unit
    P = bands.P / 1e3
    a95, a68 = style["alpha"]
    z = style["zorder"]
    f95 = ax.fill_between(P, q[0], q[4], color=style["color"], alpha=a95, lw=0, zorder=1.1,
                          label=f"{bands.label}: 95 %")
    f68 = ax.fill_between(P, q[1], q[3], color=style["color"], alpha=a68, lw=0, zorder=1.2,
                          label=f"{bands.label}: 68 %")
    for edge in (q[0], q[4]):
        ax.plot(P, edge, color=style["color"], ls=style["ls"], lw=0.8, alpha=0.8, zorder=z)
    (line,) = ax.plot(P, q[2], color=style["color"], ls=style["ls"], lw=style["lw"], zorder=z,
                      label=f"{bands.label}: median")
    return (f95, f68, line), f"{bands.label}: median, 68 % and 95 % bands"


def _draw_bulged(ax, cells, obs, unit):
    """Bulged cells with both error bars, and their error-weighted means in 10 bins (nothing
    without bulged cells: an osmotic series of intact cells)."""
    b = cells["b"]
    if not b.any():
        return
    y, err = (np.asarray(a, float) for a in cells[obs])
    P = cells["P"][b] / 1e3
    xerr = np.clip([P - cells["P_range"][0][b] / 1e3, cells["P_range"][1][b] / 1e3 - P], 0, None)
    ax.errorbar(P, y[b] / unit, xerr=xerr, yerr=err[b] / unit, fmt="o", ms=3, alpha=0.35,
                lw=0.7, zorder=2, label="bulged cells (±1 sd of pressure and of the reading)",
                **_BULGED)
    binned = binned_means(cells["P"][b], y[b], err[b], cells["sd_logP"][b])
    ax.errorbar(binned[:, 0] / 1e3, binned[:, 1] / unit, yerr=binned[:, 2] / unit, fmt="x",
                ms=9, mew=2.2, lw=1.5, zorder=5, label="bulged, weighted mean in 10 bins",
                **_BULGED)


def _draw_intact(ax, cells, obs, unit, P_phys, levels=None):
    """Intact cells at the posterior median of ``P_phys``, its 68 % interval as x error bar;
    with ``levels`` (an osmotic series: ``[(mask of cells, turgor draws)]``) each medium
    level's cells at its own turgor."""
    b = cells["b"]
    y, err = (np.asarray(a, float) for a in cells[obs])
    groups = [(~b, P_phys)] if levels is None else levels
    what = (r"all at posterior $P_\mathrm{phys}$" if levels is None
            else "each medium at its posterior turgor")
    for j, (mask, P) in enumerate(groups):
        lo, mid, hi = np.quantile(P, [0.16, 0.5, 0.84]) / 1e3
        n = int(mask.sum())
        xerr = np.tile([[mid - lo], [hi - mid]], (1, n))
        ax.errorbar(np.full(n, mid), y[mask] / unit, xerr=xerr, yerr=err[mask] / unit, fmt="s",
                    mfc="none", ms=4, alpha=0.3, lw=0.7, zorder=2,
                    label=None if j else (r"intact cells: no pressure reading, " + what
                                          + " (median, 68 %)"), **_INTACT)
        w = 1 / err[mask] ** 2
        mean, se = np.sum(w * y[mask]) / np.sum(w), np.sum(w) ** -0.5
        ax.errorbar([mid], [mean / unit], xerr=[[mid - lo], [hi - mid]], yerr=[se / unit],
                    fmt="s", ms=9, mfc="white", mew=2, lw=1.8, capsize=3, zorder=6,
                    label=None if j else "intact, weighted mean", **_INTACT)


def _intact_levels(dt, b):
    """An osmotic series' intact cells by medium level, ``[(mask, turgor draws)]`` from the
    posterior's ``P_cell``; None for any other fit (every intact cell at ``P_phys``)."""
    if "osmotic" not in dt.attrs:
        return None
    draws = np.asarray(dt["posterior"]["P_cell"].values).reshape(-1, b.size)
    means = np.where(b, np.nan, draws.mean(axis=0))
    out = []
    for m in np.unique(means[~b]):
        mask = ~b & (means == m)
        out.append((mask, draws[:, np.flatnonzero(mask)[0]]))
    return out


def _as_list(extended):
    """One model (CurveBands or Posterior) or a sequence of them, as a list."""
    if isinstance(extended, CurveBands) or hasattr(extended, "model"):
        return [extended]
    return list(extended or ())


def _fig3_legend(fig, ax, band_handles):
    """One legend below both panels: models (bands overlaid on the median), reference, cells."""
    handles, labels = list(zip(*band_handles, strict=True)) if band_handles else ((), ())
    handles, labels = list(handles), list(labels)
    for h, label in zip(*ax.get_legend_handles_labels(), strict=True):
        if label.startswith(("published", "bulged", "intact")):
            handles.append(h)
            labels.append(label)
    fig.legend(handles, labels, loc="outside lower center", ncol=2, frameon=False)


def fig3(fit, extended=(), surrogate=None, reference=PUBLISHED, pressure="bulge", n_curves=300,
         seed=0, path=None):
    """The paper's Fig. 3: ``R_c`` and ``k_c`` against pressure with posterior bands.

    Bulged cells are drawn at their bulge-derived pressure (``pressure="bulge"``, as the paper
    did; horizontal error bar ``P exp(-/+ s)``, ``s`` the lognormal sd of the bulge estimate)
    or at the posterior mean of their latent pressure (``"posterior"``; error bar the 16-84 %
    posterior quantiles), with vertical error bars the reported errors of ``R_c`` and ``k_c``,
    and with their error-weighted means in 10 log-spaced bins (:func:`binned_means`, crosses).
    Pressures come from the fit's tree (:func:`~turgorbayes.workflows.fit_data.cell_table`); nothing
    is recomputed.

    Intact cells have no pressure reading: in every model they sit at the one shared
    physiological pressure ``P_phys``. They are drawn as open squares at its posterior median,
    with its 68 % posterior interval as horizontal error bar, plus their error-weighted mean
    (large square). They are not jittered: any horizontal spread would suggest per-cell
    pressure information the data do not have, and the ``P_phys`` interval is wider than a
    readable jitter would be.

    Each model is a median curve with 68 % and 95 % bands (the 95 % edges as thin lines); the
    baseline is a wide solid red line under the extensions' narrower dashed ones, so both stay
    visible where they coincide. The published parameters are a thin dotted line. The pressure
    axis is labelled at 1, 2, 5, 10, 20 ... kPa.

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
        fig = figure((11.0, 5.8))
        axes = fig.subplots(1, 2)
        for i, (ax, (obs, unit, ylabel, attr)) in enumerate(zip(axes, _PANELS, strict=True)):
            band_handles = [_draw_bands(ax, bands, attr, unit, style)
                            for bands, style in zip(models, _BAND_STYLE, strict=False)]
            if ref is not None:
                ax.plot(P / 1e3, ref[i] / unit, ":", color="k", lw=1.2, zorder=7,
                        label="published parameters (Deng et al. 2011)")
            _draw_bulged(ax, cells, obs, unit)
            _draw_intact(ax, cells, obs, unit, flat_draws(dt, "P_phys"),
                         _intact_levels(dt, cells["b"]))
            log_axis(ax)
            ax.set_xlabel("turgor pressure $P$ [kPa]")
            ax.set_ylabel(ylabel)
        log_axis(axes[1], "y")
        _fig3_legend(fig, axes[0], band_handles)
        where = "bulge-derived" if pressure == "bulge" else "posterior-mean latent"
        said = (f"; bulged cells at their {where} pressure" if cells["b"].any()
                else "; intact cells only")
        fig.suptitle(f"{plot_title(dt)}{said}", fontsize=11)
    return save(fig, path)


def _title(name, draws):
    """Corner title: the axis label, then ``mean ± sd`` as the report and command line print it."""
    return f"{QUANTITIES[name].tex}\n{format_pm(np.mean(draws), np.std(draws, ddof=1))}"


def corner_plot(fit, reference=PUBLISHED, path=None):
    """Corner plot of ``gamma, E0t, R0, P_phys`` in display units, published values in red.

    Titles give the posterior mean ± sd (two significant digits of the sd, the mean to the
    same decimal), as ``summary.json``, the report and the command line do; the dashed lines
    of the histograms are the 5 %, 50 % and 95 % quantiles (the report's 90 % interval).

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
        corner.corner(x, fig=fig, labels=[QUANTITIES[n].tex for n in names],
                      quantiles=[0.05, 0.5, 0.95], show_titles=False, truths=truths,
                      truth_color="tab:red", smooth=1.0, labelpad=0.1, max_n_ticks=3)
        for i, name in enumerate(names):
            fig.axes[i * (len(names) + 1)].set_title(_title(name, x[:, i]), fontsize=10.5)
        fig.subplots_adjust(left=0.12, bottom=0.12, top=0.84, right=0.94, wspace=0.12,
                            hspace=0.22)
        notes = ["titles: posterior mean ± sd; dashed: 5 %, 50 %, 95 % quantiles"]
        if reference is not None:
            notes.append("red: published values (Deng et al. 2011)")
        fig.suptitle(plot_title(dt) + "\n" + "\n".join(notes), fontsize=10.5)
    return save(fig, path)


def _display_tree(dt):
    """A DataTree of the baseline parameters (code names) in display units (:data:`DISPLAY`)."""
    import xarray as xr

    post = dt["posterior"]
    data = {n: post[n] / DISPLAY[n][1] for n in DISPLAY}
    return xr.DataTree.from_dict({"posterior": xr.Dataset(data)})


def _arviz_figure(plot, dt, figsize, **kwargs):
    """An ``arviz_plots`` figure of :func:`_display_tree` labelled by :data:`DISPLAY`.

    Made without keeping a pyplot reference.
    """
    import arviz_plots as azp
    import matplotlib.pyplot as plt
    from arviz_base.labels import MapLabeller
    from matplotlib.ticker import MaxNLocator

    labeller = MapLabeller(var_name_map={n: DISPLAY[n][0] for n in DISPLAY})
    pc = getattr(azp, plot)(_display_tree(dt), backend="matplotlib", labeller=labeller,
                            figure_kwargs={"figsize": figsize, "layout": "constrained"},
                            **kwargs)
    fig = pc.viz["figure"].item()
    plt.close(fig)  # arviz-plots draws through pyplot; keep no global reference
    for ax in fig.axes:
        ax.xaxis.set_major_locator(MaxNLocator(5))
    return fig


def trace_plot(fit, path=None):
    """ArviZ trace plot (``arviz_plots.plot_trace_dist``): one line per independent ensemble.

    Parameters are labelled as on the corner plot (symbol and display unit, :data:`DISPLAY`).

    Parameters
    ----------
    fit : FitResult or DataTree
    path : path-like, optional

    Returns
    -------
    matplotlib.figure.Figure
        Left: the posterior density per ensemble; right: the draws in order.
    """
    dt = posterior_tree(fit)
    with rc():
        fig = _arviz_figure("plot_trace_dist", dt, (10, 7.5))
        fig.suptitle(f"{plot_title(dt)}: one line per independent ensemble", fontsize=10.5)
    return save(fig, path)


def rank_pvalues(fit):
    """p-value of ArviZ's multi-chain rank uniformity test per baseline parameter.

    ``arviz_stats`` ``mchain_uniformity_test`` on the fractional ranks over all ensembles
    (Tesso et al. 2026): small when the ensembles do not sample the same distribution. It
    accounts for autocorrelation, unlike the envelope of :func:`rank_plot`.

    Returns
    -------
    dict
        Parameter name (``gamma`` ...) -> p-value.
    """
    import arviz_stats  # noqa: F401 (registers the .azstats accessor)

    post = _display_tree(posterior_tree(fit))["posterior"].to_dataset()
    ranks = post.azstats.compute_ranks(dim=["chain", "draw"], relative=True)
    p, _, _ = ranks.azstats.mchain_uniformity_test(dim=["chain", "draw"])
    return {n: float(p[n]) for n in DISPLAY}


def rank_plot(fit, path=None, envelope_prob=0.99):
    """ArviZ rank plot: fractional-rank Delta-ECDF per ensemble inside a uniformity envelope.

    ``arviz_plots.plot_rank(method="envelope")``: each ensemble's ECDF of its draws' ranks
    (over all ensembles) minus the uniform CDF, with the ``envelope_prob`` simultaneous
    envelope of ensembles that sample the same posterior (draws thinned to be nearly
    independent). Each panel also states the multi-chain test's p-value
    (:func:`rank_pvalues`), which accounts for autocorrelation; below ``1 - envelope_prob``
    the ensembles disagree.

    Parameters
    ----------
    fit : FitResult or DataTree
    path : path-like, optional
    envelope_prob : float
        Probability content of the envelope; ``1 - envelope_prob`` is the test's level.

    Returns
    -------
    matplotlib.figure.Figure
    """
    dt = posterior_tree(fit)
    p = rank_pvalues(dt)
    alpha = 1 - envelope_prob
    with rc():
        fig = _arviz_figure("plot_rank", dt, (11, 3.9), method="envelope",
                            envelope_prob=envelope_prob, visuals={"remove_axis": False})
        by_title = {ax.get_title(): ax for ax in fig.axes}
        for name in DISPLAY:
            ax = by_title[DISPLAY[name][0]]
            ax.axhline(0, color="0.5", lw=0.6)
            verdict = "ensembles agree" if p[name] >= alpha else "ENSEMBLES DISAGREE"
            ax.text(0.03, 0.97, f"{verdict}\n{format_p(p[name])}", transform=ax.transAxes,
                    va="top", fontsize=9, bbox=dict(fc="white", ec="none", alpha=0.8))
        fig.axes[0].set_ylabel("ECDF of ranks − uniform CDF")
        fig.suptitle(f"{plot_title(dt)}: one line per ensemble\ngrey: {envelope_prob:.0%} "
                     f"envelope of uniform ranks; p: multi-chain rank test (flag if "
                     f"p < {alpha:g})", fontsize=10.5)
    return save(fig, path)


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
            log_axis(ax)
            ax.set_xlabel("pressure $P$ [kPa] (posterior mean)")
            ax.set_title(f"${label}$: {np.mean(np.abs(z) > 1.645):.0%} outside the 90 % band",
                         fontsize=11)
        axes[0].set_ylabel("standardized residual")
        axes[1].legend(loc="upper right", fontsize=8.5)
        fig.suptitle(plot_title(dt), fontsize=10.5)
    return save(fig, path)
