"""What the figures read from a fit: its DataTree, draws, cells and surrogate table.

Everything comes from the finished DataTree (:attr:`turgorbayes.workflows.fit.FitResult.tree` or
``posterior.nc``); nothing here recomputes the bulge pressures or the likelihood.
"""

import numpy as np

__all__ = ["bulged_pressures", "cell_table", "flat_draws", "plot_title", "posterior_tree",
           "surrogate_of"]


def posterior_tree(fit):
    """The DataTree of a fit: ``fit`` itself, or the one a :class:`FitResult` carries.

    Parameters
    ----------
    fit : turgorbayes.workflows.fit.FitResult or xarray.DataTree
    """
    import xarray as xr

    from turgorbayes.workflows.fit import FitResult, fit_tree

    if isinstance(fit, FitResult):
        return fit_tree(fit)
    if not isinstance(fit, xr.DataTree) or "posterior" not in fit.children:
        raise TypeError(f"expected a FitResult or the DataTree of posterior.nc, got "
                        f"{type(fit).__name__}")
    return fit


def flat_draws(dt, name):
    """All draws of posterior variable ``name``, chains concatenated (SI)."""
    return np.asarray(dt["posterior"][name].values, float).reshape(-1)


def plot_title(dt):
    """Model, convergence and a SIMULATED DATA tag, for a figure's title."""
    tag = "SIMULATED DATA - " if int(dt.attrs.get("simulated_data", 0)) else ""
    ok = "converged" if int(dt.attrs.get("converged", 1)) else "NOT CONVERGED"
    return f"{tag}model {dt.attrs.get('model', '?')} ({ok})"


def surrogate_of(fit, surrogate):
    """``surrogate``, else the fit's own table, else the shipped one checked by sha256."""
    if surrogate is not None:
        return surrogate
    import xarray as xr

    from turgorbayes import surrogate as surrogate_module

    if not isinstance(fit, xr.DataTree):  # a FitResult carries its table
        return fit.surrogate
    table = surrogate_module.load()
    want = fit.attrs.get("surrogate_sha256")
    if want and table.sha256 != want:
        raise ValueError(f"the fit used the surrogate table with sha256 {want}, the shipped "
                         f"one is {table.sha256}; pass the fit's table as surrogate=")
    return table


def bulged_pressures(dt):
    """Bulge-derived pressure of every cell [Pa] (NaN for intact cells)."""
    c = dt["constant_data"]
    return np.where(np.asarray(c["is_bulged"].values, bool), c["P_bulge"].values, np.nan)


def cell_table(dt, pressure):
    """Per cell: bulged mask, pressure (``"bulge"`` or ``"posterior"`` mean), observations.

    Parameters
    ----------
    dt : xarray.DataTree
    pressure : {"bulge", "posterior"}
        ``"bulge"``: the bulge-derived pressure, its 68 % range ``P exp(-/+ s)`` from the
        lognormal sd ``s`` of the bulge estimate (``sd_log_P_bulge``); ``"posterior"``: the
        posterior mean of the cell's latent pressure, its range the 16-84 % quantiles.

    Returns
    -------
    dict
        ``b``, ``P`` [Pa], ``P_range`` (lower, upper) [Pa], ``sd_logP``, and ``R_c``, ``k_c``
        as (value, error) pairs (SI). Nothing is recomputed: all from the fit's tree.
    """
    c, o = dt["constant_data"], dt["observed_data"]
    b = np.asarray(c["is_bulged"].values, bool)
    sd_logP = np.asarray(c["sd_log_P_bulge"].values, float)
    if pressure == "bulge":
        P = np.asarray(c["P_bulge"].values, float)
        P_range = (P * np.exp(-sd_logP), P * np.exp(sd_logP))
    elif pressure == "posterior":
        draws = np.asarray(dt["posterior"]["P_cell"].values).reshape(-1, b.size)
        P = draws.mean(axis=0)
        P_range = tuple(np.quantile(draws, [0.16, 0.84], axis=0))
    else:
        raise ValueError(f"pressure must be 'bulge' or 'posterior', got {pressure!r}")
    return {"b": b, "P": P, "P_range": P_range, "sd_logP": sd_logP,
            "R_c": (o["R_c"].values, c["R_c_err"].values),
            "k_c": (o["k_c"].values, c["k_c_err"].values)}
