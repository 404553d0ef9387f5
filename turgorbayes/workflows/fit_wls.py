"""The paper's weighted least squares as a fit (``fit --model paper_wls``): draws from the
normal approximation ``N(estimate, (J^T J)^-1)``, not a posterior (docs/statistics.md)."""

import numpy as np

from turgorbayes.errors import TurgorBayesError
from turgorbayes.inference import models
from turgorbayes.inference.engine import stream_rng
from turgorbayes.inference.observations import gaussian_logpdf
from turgorbayes.physics import forward

__all__ = ["wls_fit", "wls_pointwise"]


def wls_fit(name, cells, surrogate, seed, settings, result_type):
    """``paper_wls``: draws from the normal approximation of the weighted least-squares fit.

    ``result_type`` is :class:`turgorbayes.workflows.fit.FitResult` (passed in: this module
    sits below the one that defines it).

    Returns
    -------
    FitResult
        Named ``name``; not converged, with the optimizer's message as the reason, when the
        least squares did not converge.
    PaperWLS
        The least-squares model.
    CellObservations
        The cells' bulge-derived pressures.
    """
    wls_model = models.PaperWLS(cells, surrogate)
    wls = wls_model.fit()
    if not (np.all(np.isfinite(wls.cov_u)) and np.all(np.linalg.eigvalsh(wls.cov_u) > 0)):
        raise TurgorBayesError(
            "the least-squares fit has no covariance (J^T J is singular or not positive definite at "
            f"{', '.join(f'{k} = {v:.4g}' for k, v in wls.estimate.items())}: {wls.message}); "
            "the normal approximation of paper_wls is undefined for these data, fit the "
            "baseline model instead")
    rng = stream_rng(seed, 1000)
    C, D = settings.n_ensembles, settings.max_draws_per_chain
    u = rng.multivariate_normal(wls.u, wls.cov_u, size=(C, D))
    flat = u.reshape(C * D, -1)
    phys = wls_model.to_physical(flat)
    t = models.THICKNESS_MEDIAN * np.exp(models.THICKNESS_LOG_SD * rng.standard_normal(C * D))
    E_perp, E_par = models.moduli_at_pressure(phys["P_phys"], phys["gamma"], phys["E0t"],
                                              phys["R0"], t)
    phys.update(E_perp=E_perp, E_par=E_par)
    ll, R, k = wls_pointwise(wls_model, flat, rng)
    P = np.empty((C * D, cells.R_c.size))
    P[:, wls_model.obs.bulged] = np.exp(wls_model.obs.log_P_bulge)
    P[:, wls_model.obs.intact] = phys["P_phys"][:, None]

    def shape(a):
        return np.asarray(a).reshape((C, D) + np.shape(a)[1:])

    draws = {n: shape(v) for n, v in phys.items()}
    info = {"inference": "normal approximation N(estimate, (J^T J)^-1) of the weighted "
            "least-squares fit (not a posterior)", "chi2": wls.chi2, "dof": wls.dof,
            "nfev": wls.nfev, "message": wls.message}
    reasons = [] if wls.success else [f"least squares did not converge: {wls.message}"]
    result = result_type(model=name, cells=cells, surrogate=surrogate, seed=seed, draws=draws,
                       log_lik=shape(ll), ppc={"R_c": shape(R), "k_c": shape(k)}, P_cell=shape(P),
                       lp=shape(ll.sum(axis=1)), converged=bool(wls.success), reasons=reasons,
                       sampler=info, wls=wls, wls_moduli=wls_model.derived(wls),
                       settings=settings)
    return result, wls_model, wls_model.obs


def wls_pointwise(wls_model, flat, rng):
    """Gaussian log-likelihood per cell with plugged-in pressures, and replicates."""
    obs = wls_model.obs
    v = wls_model.to_physical(flat)
    P = np.empty((len(flat), obs.n_cells))
    P[:, obs.bulged] = np.exp(obs.log_P_bulge)
    P[:, obs.intact] = v["P_phys"][:, None]
    R, k = forward.cell_radius_and_stiffness(P, v["gamma"][:, None], v["E0t"][:, None],
                                             v["R0"][:, None], wls_model.P0,
                                             wls_model.surrogate)
    ll = gaussian_logpdf(obs.R_c, R, obs.R_c_err) + gaussian_logpdf(obs.k_c, k, obs.k_c_err)
    R_rep = R + obs.R_c_err * rng.standard_normal(R.shape)
    k_rep = k + obs.k_c_err * rng.standard_normal(k.shape)
    return ll, R_rep, k_rep
