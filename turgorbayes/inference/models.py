"""Statistical models of the cell data and a small registry of them.

* ``paper_wls`` (:class:`PaperWLS`): the published method (docs/statistics.md):
  bulge pressures plugged in as exact, weighted least squares of R_c and k_c with the
  reported errors as weights (``scipy.optimize.least_squares``), 68 % intervals from the
  covariance ``(J^T J)^-1`` (absolute errors, not rescaled by chi^2/dof; the reduced
  chi^2 is reported beside it).
* ``baseline`` (:class:`BaselineModel`): the Bayesian version: same forward model, each
  bulged cell's pressure latent and integrated out (:mod:`turgorbayes.inference.likelihood`),
  priors of :data:`turgorbayes.inference.priors.BASELINE_PRIORS`, posterior sampled by
  :mod:`turgorbayes.inference.sampling`.

Extending: subclass :class:`BaselineModel`, extend :attr:`parameters` and
override :meth:`BaselineModel.pointwise_log_likelihood` (and
:meth:`~BaselineModel.posterior_predictive` if the data model changes), then
``register_model("name", Class)``. Everything downstream (sampling, diagnostics,
posterior.nc, summary.json, LOO) only uses the methods of :class:`BaselineModel`.
"""

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from turgorbayes.cells.medium import require_one_medium
from turgorbayes.inference import mode
from turgorbayes.inference.context import LikelihoodContext
from turgorbayes.inference.coordinates import BASELINE_PARAMETERS, Coordinates, Parameter
from turgorbayes.inference.likelihood import DEFAULT_NODES, CellLikelihood
from turgorbayes.inference.observations import DEFAULT_LATENT, observations_from_cells, sample_latent, stiffness_sd
from turgorbayes.inference.reading_correlation import cell_correlations, correlated_normals, known_rho
from turgorbayes.physics import forward
from turgorbayes.physics.parameters import P0

__all__ = [
    "BASELINE_PARAMETERS",
    "MODELS",
    "ROBUST_LOSS",
    "ROBUST_SCALE",
    "THICKNESS_LOG_SD",
    "THICKNESS_MEDIAN",
    "BaselineModel",
    "ModelFactory",
    "Parameter",
    "PaperWLS",
    "WLSFit",
    "add_log_likelihood",
    "get_model",
    "moduli_at_pressure",
    "register_model",
    "with_population",
]

#: Wall thickness used to turn E t into moduli: lognormal with median 4.5 nm and log-sd 1/3
#: (the paper's 4.5 +- 1.5 nm, Yao et al. 2002). Lognormal rather than normal because E is
#: proportional to 1/t, whose mean does not exist for a normal t.
THICKNESS_MEDIAN = 4.5e-9
THICKNESS_LOG_SD = 1.5 / 4.5
THICKNESS_SD = 1.5e-9

#: The robust least squares a fit starts from where the published one leaves some cells
#: impossible (:meth:`BaselineModel.start_guess`): ``scipy.optimize.least_squares``' soft-L1
#: loss, quadratic up to a weighted residual of :data:`ROBUST_SCALE` reported errors and
#: linear beyond, so a few gross errors cannot pull the estimate off the other cells.
ROBUST_LOSS = "soft_l1"
ROBUST_SCALE = 3.0


def add_log_likelihood(log_prior, log_lik):
    """``log_prior + log_lik`` (summed over the cells), a NaN log-likelihood (outside the
    model's domain) read as ``-inf``: the log posterior of :meth:`BaselineModel.log_posterior`."""
    return log_prior + np.where(np.isnan(log_lik), -np.inf, log_lik)


def moduli_at_pressure(P, gamma, E0t, R0, t, P0=P0):
    """Circumferential and axial Young's moduli at pressure ``P`` for thickness ``t``.

    .. math:: E_\\perp = \\frac{E_0t\\,(P/P_0)^\\gamma}{t},\\qquad
              E_\\parallel = \\frac{E_\\parallel}{E_\\perp}(P)\\, E_\\perp

    (docs/physics.md).

    Parameters
    ----------
    P : array_like [Pa]
    gamma : array_like [-]
    E0t : array_like [N/m]
    R0 : array_like [m]
    t : array_like [m]
        Wall thickness.
    P0 : float [Pa]

    Returns
    -------
    E_perp, E_par : ndarray [Pa]
    """
    terms = forward.cell_terms(P, gamma, E0t, R0, P0, surrogate=False)
    E_perp = terms["E_perp_t"] / np.asarray(t, float)
    return E_perp, terms["ratio"] * E_perp


class BaselineModel(Coordinates):
    """Bayesian global fit with latent bulged-cell pressures (module docstring).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
        Both groups present.
    surrogate : turgorbayes.surrogate.Surrogate
    n_nodes : int
        Gauss-Hermite nodes per bulged cell.
    P0 : float [Pa]
    latent : str
        Prior of the latent pressures, one of
        :data:`turgorbayes.inference.observations.LATENT_PRIORS`.
    """

    name = "baseline"
    bayesian = True
    parameters = BASELINE_PARAMETERS
    #: The model interface every workflow reads (docs/statistics.md, "One posterior engine"):
    #: the members above and below, with these optional hooks doing nothing by default.
    #: ``conditions``: the :class:`~turgorbayes.inference.conditions.ConditionSet` of a model
    #: of several conditions, None for one.
    conditions = None
    #: ``effect_names``: the effects a model class plants when its data are simulated (the
    #: simulation-based calibration's classes, :mod:`turgorbayes.workflows.sbc`); none here.
    effect_names = ()

    def __init__(self, cells, surrogate, n_nodes=DEFAULT_NODES, P0=P0, latent=DEFAULT_LATENT):
        self.cells = require_one_medium(cells.require_both_groups(), f"the {self.name} model")
        self.surrogate = surrogate
        self.P0 = float(P0)
        self.obs = observations_from_cells(cells, latent=latent)
        self.lik = CellLikelihood(self.obs, surrogate, n_nodes=n_nodes, P0=P0)

    # ------------------------------------------------------------------ likelihood
    def pointwise_log_likelihood(self, u):
        """``(W, n_cells)`` log-likelihood per cell (latent pressures integrated out)."""
        v = self.to_physical(u)
        return self.lik.pointwise(v["gamma"], v["E0t"], v["R0"], v["P_phys"])

    def log_posterior(self, u):
        """Vectorized ``(W, ndim) -> (W,)`` log posterior (the function emcee samples)."""
        u = np.atleast_2d(np.asarray(u, float))
        lp = np.asarray(self.log_prior(u), float)
        ok = np.isfinite(lp)
        if ok.any():
            with np.errstate(all="ignore"):
                ll = self.pointwise_log_likelihood(u[ok]).sum(axis=1)
            lp[ok] = add_log_likelihood(lp[ok], ll)
        return lp

    # ------------------------------------------------------------------ optional hooks
    def start_values(self, guess):
        """Every parameter's starting value from a guess of the baseline's four (default: the
        guess itself; a model with more parameters fills them in)."""
        return dict(guess)

    def least_squares(self):
        """The weighted least-squares fit the fit starts from and reports beside the posterior
        (default: the published method on the same cells, :class:`PaperWLS`)."""
        return PaperWLS(self.cells, self.surrogate, P0=self.P0)

    def start_guess(self, estimate=None):
        """Every parameter's start (:meth:`start_values`) from the least-squares estimate.

        ``estimate`` (physical values; :meth:`least_squares`' fit if None) is used where the
        log posterior is finite. Where it is not (gross errors can pull the least squares to
        where the model cannot produce some cells), the start is the same fit with a robust
        loss (:data:`ROBUST_LOSS`) if the posterior is finite there; otherwise the
        least-squares start is returned and the caller names the cells at fault
        (:func:`turgorbayes.inference.start_check.start_error`; docs/statistics.md,
        "Sampling").
        """
        wls = self.least_squares()
        first = self.start_values(wls.fit().estimate if estimate is None else estimate)
        if self._finite_at(first):
            return first
        robust = self.start_values(wls.fit(loss=ROBUST_LOSS).estimate)
        return robust if self._finite_at(robust) else first

    def _finite_at(self, values):
        with np.errstate(all="ignore"):
            return bool(np.isfinite(self.log_posterior(self.to_u(values)[0][None])[0]))

    def population_shift_covariance(self, u_map, cov, seed, n_boot):
        """The covariance of the parameters' shift from re-estimating the plug-in latent
        population, for a model whose populations are its own (several conditions); None
        (the default): the fit computes it for the one population
        (:func:`turgorbayes.inference.population_noise.shift_covariance`)."""
        return None

    def flag_cells(self, draws, cell_ids, n_draws, screen):
        """The gross-error screen of a model that screens its parts itself (several
        conditions: each at its own parameters), or None (the default): the workflow screens
        the whole model (:func:`turgorbayes.workflows.flags.flag_cells`)."""
        return None

    def flagged_cells(self, values, cell_ids, gross=False):
        """The same for a criticism model of several conditions, at already resampled
        ``values``; None (the default): screened as one model."""
        return None

    def condition_values(self, v):
        """``[(cell indices, values)]``: each condition's cells and the physical values
        ``v`` its wall model sees, for checks that evaluate the wall outside the likelihood
        (the FE-table check); None (the default) for one condition (every cell at ``v``)."""
        return None

    def intact_levels(self):
        """Each intact cell's group within the intact cells ``(n_intact,)`` of int, for a model
        whose intact cells sit at several turgors (the medium levels of an osmotic series): the
        predictive checks centre residuals within them; None (the default): one group."""
        return None

    def context(self, v, skip=()):
        """The :class:`~turgorbayes.inference.context.LikelihoodContext` of the model for
        physical values ``v`` (dict of ``(W,)``), with the effects named in ``skip`` left out
        (the baseline: the context no effect changed)."""
        return LikelihoodContext(v, v)

    # ------------------------------------------------------------------ predictions
    def curves(self, u, P):
        """Model ``R_c(P)``, ``k_c(P)`` of the intact-cell wall: arrays ``(W, len(P))``."""
        v = self.to_physical(u)
        return self.lik.forward(np.log(np.asarray(P, float)), v["gamma"], v["E0t"], v["R0"])

    def cell_pressures(self, u):
        """``(W, n_cells)``: E[P_i | data_i, theta] for bulged cells, P_phys for intact [Pa]."""
        v = self.to_physical(u)
        out = np.empty((len(v["gamma"]), self.obs.n_cells))
        out[:, self.obs.bulged] = self.lik.latent_pressure_mean(v["gamma"], v["E0t"], v["R0"])
        out[:, self.obs.intact] = v["P_phys"][:, None]
        return out

    def posterior_predictive(self, u, rng):
        """Replicated ``R_c``, ``k_c`` ``(W, n_cells)`` for each draw ``u``.

        Bulged cells: a pressure is drawn from the bulge measurement and the population
        prior alone, ``ln P ~ N(c_i, sigma_i)`` (:func:`turgorbayes.inference.observations.latent_prior`),
        so the replicate is conditioned on the cell's bulge but not on its own R_c, k_c (what
        a model check needs). Intact cells at P_phys. Then Gaussian noise with the reported
        radius errors and the relative stiffness errors
        (:func:`turgorbayes.inference.observations.stiffness_sd`), correlated where the
        cells' ``rho_R_c_k_c`` says so.
        """
        v = self.to_physical(u)
        W = len(v["gamma"])
        log_P = np.empty((W, self.obs.n_cells))
        b = self.obs.bulged
        log_P[:, b] = sample_latent(self.obs, rng, W)
        log_P[:, self.obs.intact] = np.log(v["P_phys"])[:, None]
        R, k = self.lik.forward(log_P, v["gamma"], v["E0t"], v["R0"], walker_axis=True)
        z_R, z_k = correlated_normals(rng, R.shape, known_rho(cell_correlations(self.obs)))
        R = R + self.obs.R_c_err * z_R
        k = k + stiffness_sd(k, self.obs.k_c, self.obs.k_c_err) * z_k
        return {"R_c": R, "k_c": k}

    def derived(self, u, rng):
        """E_perp, E_par at P_phys [Pa] per draw, with a lognormal wall thickness drawn."""
        v = self.to_physical(u)
        t = THICKNESS_MEDIAN * np.exp(THICKNESS_LOG_SD * rng.standard_normal(v["gamma"].shape))
        E_perp, E_par = moduli_at_pressure(v["P_phys"], v["gamma"], v["E0t"], v["R0"], t,
                                           self.P0)
        return {"E_perp": E_perp, "E_par": E_par}

    # ------------------------------------------------------------------ starting point
    def start(self, guess=None):
        """MAP (Nelder-Mead from ``guess``) and a Laplace covariance in sampler coordinates.

        Parameters
        ----------
        guess : dict, optional
            Physical starting values; :meth:`start_guess` if None.

        Returns
        -------
        u_map : ndarray (ndim,)
        cov : ndarray (ndim, ndim)
            Inverse of the finite-difference Hessian of -log posterior (a diagonal fallback
            if it is not positive definite): :func:`turgorbayes.inference.mode.inverse_hessian`.
        """
        if guess is None:
            guess = self.start_guess()
        u0 = self.to_u({k: guess[k] for k in self.names})[0]
        u_map = mode.find_mode(self, u0, method="Nelder-Mead")
        return u_map, mode.inverse_hessian(mode.hessian(self, u_map, strict=False))


@dataclass
class WLSFit:
    """Result of :meth:`PaperWLS.fit`.

    Attributes
    ----------
    estimate : dict
        Best-fit physical values (SI).
    sd : dict
        Standard errors (SI) from the covariance, delta method for log coordinates.
    cov_u : ndarray
        Covariance in fit coordinates ``(gamma, ln E0t, R0/nm, ln P_phys)``.
    u : ndarray
        Best fit in those coordinates.
    chi2 : float
    dof : int
    success : bool
    message : str
    nfev : int
        Residual evaluations over all starts.
    """

    estimate: dict
    sd: dict
    cov_u: np.ndarray
    u: np.ndarray
    chi2: float
    dof: int
    success: bool
    message: str
    nfev: int


class PaperWLS(Coordinates):
    """The published weighted least-squares fit (module docstring).

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
    surrogate : turgorbayes.surrogate.Surrogate
    P0 : float [Pa]
    """

    name = "paper_wls"
    bayesian = False
    parameters = BASELINE_PARAMETERS
    _PENALTY = 1e3  # weighted residual where the forward model is undefined

    def __init__(self, cells, surrogate, P0=P0):
        self.cells = require_one_medium(cells.require_both_groups(), "the published method")
        self.surrogate = surrogate
        self.P0 = float(P0)
        self.obs = observations_from_cells(cells, relative_errors="reported")
        self._P_bulge = np.exp(self.obs.log_P_bulge)

    def residuals(self, u):
        """Weighted residuals ``(obs - model)/err`` of R_c then k_c, all cells."""
        v = {k: float(a[0]) for k, a in self.to_physical(u).items()}
        P = np.empty(self.obs.n_cells)
        P[self.obs.bulged] = self._P_bulge
        P[self.obs.intact] = v["P_phys"]
        R, k = forward.cell_radius_and_stiffness(P, v["gamma"], v["E0t"], v["R0"], self.P0,
                                                 self.surrogate)
        r = np.concatenate([(self.obs.R_c - R) / self.obs.R_c_err,
                            (self.obs.k_c - k) / self.obs.k_c_err])
        return np.where(np.isfinite(r), r, self._PENALTY)

    def _starts(self):
        """Data-driven starting points for a few stiffening exponents."""
        b = self.obs.bulged
        slope, icpt = np.polyfit(self.obs.log_P_bulge, self.obs.R_c[b], 1)
        R0 = icpt + slope * np.log(self.P0)
        p = max(slope / R0, 1e-3)  # d ln R/d ln P ~ p for a stiff wall
        E0t = self.P0 * R0 / p
        R_int = np.mean(self.obs.R_c[self.obs.intact])
        P_phys = np.exp((R_int - icpt) / slope) if slope > 0 else 30e3
        bounds = {p_.name: (p_.prior.lower, p_.prior.upper) for p_ in self.parameters}

        def clip(name, x):
            lo, hi = bounds[name]
            return float(np.clip(x, lo + 1e-6 * (hi - lo), hi - 1e-6 * (hi - lo)))

        for gamma in (0.5, 1.0, 1.5, 2.2):
            yield {"gamma": gamma, "E0t": clip("E0t", E0t), "R0": clip("R0", R0),
                   "P_phys": clip("P_phys", P_phys)}

    def fit(self, starts=None, loss="linear"):
        """Weighted least squares from several starts; the lowest cost wins.

        Parameters
        ----------
        starts : iterable of dict, optional
            Physical starting values (default: data-driven, a few stiffening exponents).
        loss : str
            ``"linear"``: the published chi^2; :data:`ROBUST_LOSS`: the robust fit a Bayesian
            fit may start from (scale :data:`ROBUST_SCALE`), whose covariance is the same
            ``(J^T J)^-1`` at its estimate.

        Returns
        -------
        WLSFit
        """
        lower = self.to_u({p.name: p.prior.lower for p in self.parameters})[0]
        upper = self.to_u({p.name: p.prior.upper for p in self.parameters})[0]
        # an estimate on a bound stays 1e-7 of the range inside it: a model sampled in other
        # coordinates (wall_references) maps it there and back with a rounding error
        margin = 1e-7 * (upper - lower)
        lower, upper = lower + margin, upper - margin
        best, nfev = None, 0
        for start in (starts or self._starts()):
            u0 = np.clip(self.to_u(start)[0], lower + 1e-9, upper - 1e-9)
            res = optimize.least_squares(self.residuals, u0, bounds=(lower, upper),
                                         x_scale="jac", xtol=1e-14, ftol=1e-14, gtol=1e-14,
                                         max_nfev=2000, loss=loss, f_scale=ROBUST_SCALE)
            nfev += res.nfev
            if best is None or res.cost < best.cost:
                best = res
        return self._summarize(best, nfev)

    def _edge_jacobian(self, u):
        """d(residual)/du one-sided beside an undefined region; None if there is none near u.

        At an optimum on the edge of the FE table's buckled region or domain a step to one
        side meets the penalty residual, which is a wall, not a slope (the solver's own
        Jacobian then holds ~1e8 entries): such a row takes the difference from the defined
        side (zero if neither side is defined), the others central differences.
        """
        r0 = self.residuals(u)
        J, edge = np.zeros((r0.size, u.size)), False
        for i in range(u.size):
            h = 1e-6 * max(abs(u[i]), 1.0)
            up, down = self.residuals(u + h * np.eye(u.size)[i]), self.residuals(
                u - h * np.eye(u.size)[i])
            ok_up, ok_down = up != self._PENALTY, down != self._PENALTY
            edge |= not (ok_up & ok_down).all()
            J[:, i] = np.select([ok_up & ok_down, ok_up, ok_down],
                                [(up - down) / (2 * h), (up - r0) / h, (r0 - down) / h], 0.0)
        return J if edge else None

    def _summarize(self, res, nfev):
        J = self._edge_jacobian(res.x)
        J = res.jac if J is None else J
        try:
            cov_u = np.linalg.inv(J.T @ J)
        except np.linalg.LinAlgError:
            cov_u = np.full((J.shape[1],) * 2, np.nan)
        with np.errstate(invalid="ignore"):  # a singular J^T J: nan, reported as such
            sd_u = np.sqrt(np.diag(cov_u))
        est = {k: float(a[0]) for k, a in self.to_physical(res.x).items()}
        sd = {}
        for i, p in enumerate(self.parameters):
            h = 1e-6 * max(abs(res.x[i]), 1.0)  # delta method: dx/du by central difference
            deriv = (p.prior.to_physical(res.x[i] + h) - p.prior.to_physical(res.x[i] - h)) / (
                2 * h)
            sd[p.name] = float(abs(deriv) * sd_u[i])
        chi2 = float(2 * res.cost)
        dof = int(res.fun.size - res.x.size)
        ok = bool(res.success) and bool(np.all(np.abs(res.fun) < self._PENALTY))
        return WLSFit(estimate=est, sd=sd, cov_u=cov_u, u=res.x, chi2=chi2, dof=dof,
                      success=ok, message=str(res.message), nfev=int(nfev))

    def derived(self, fit):
        """E_perp, E_par at P_phys with linear error propagation (the paper's way).

        Returns
        -------
        dict
            ``{"E_perp": (value, sd), "E_par": (value, sd)}`` in Pa; the sd combines the
            fit covariance (numerical gradient) and the 1.5 nm error of t = 4.5 nm.
        """
        def moduli_t(u):
            v = self.to_physical(u)
            return np.array(moduli_at_pressure(v["P_phys"], v["gamma"], v["E0t"], v["R0"],
                                               1.0, self.P0)).ravel()

        f0 = moduli_t(fit.u)
        grad = np.empty((2, fit.u.size))
        for i in range(fit.u.size):
            h = 1e-6 * max(abs(fit.u[i]), 1.0)
            e = np.zeros(fit.u.size)
            e[i] = h
            grad[:, i] = (moduli_t(fit.u + e) - moduli_t(fit.u - e)) / (2 * h)
        var_t = np.einsum("ij,jk,ik->i", grad, fit.cov_u, grad)
        out = {}
        for name, val, var in zip(("E_perp", "E_par"), f0, var_t, strict=True):
            E = val / THICKNESS_MEDIAN
            rel = np.sqrt(var / val**2 + (THICKNESS_SD / THICKNESS_MEDIAN) ** 2)
            out[name] = (float(E), float(E * rel))
        return out


@dataclass(frozen=True)
class ModelFactory:
    """How a workflow builds the model it fits (:func:`turgorbayes.workflows.fit.fit_cells`).

    Attributes
    ----------
    build : callable
        ``(cells, surrogate, n_nodes) -> model`` (``n_nodes`` None: the model's default).
    name : str
        The model's name in the outputs (``"baseline"``, ``"osmotic"``, ``"radius_spread"``).
    bayesian : bool
        Sampled (True) or the published least squares (False).
    own_design : bool
        The model checks its data's design itself (an osmotic series: several media, bulged
        cells optional); otherwise the fit requires both groups and one medium.
    """

    build: object
    name: str
    bayesian: bool = True
    own_design: bool = False

    def __call__(self, cells, surrogate, n_nodes=None):
        return self.build(cells, surrogate, n_nodes)

    @classmethod
    def of_class(cls, model_class, name, **kwargs):
        """The factory of a model class taking ``(cells, surrogate, n_nodes=...)``."""
        def build(cells, surrogate, n_nodes=None):
            return model_class(cells, surrogate, **({} if n_nodes is None else {"n_nodes": n_nodes}))

        return cls(build, name, bayesian=model_class.bayesian, **kwargs)


#: Model name -> class (more with :func:`register_model`).
MODELS = {"baseline": BaselineModel, "paper_wls": PaperWLS}


def register_model(name, cls):
    """Add a model class to :data:`MODELS` (name as used on the command line)."""
    if not isinstance(name, str) or not name:
        raise ValueError(f"model name must be a non-empty string, got {name!r}")
    MODELS[name] = cls
    return cls


def get_model(name):
    """The model class registered under ``name``."""
    try:
        return MODELS[name]
    except KeyError:
        raise ValueError(f"unknown model {name!r}; known models: {sorted(MODELS)}") from None


def with_population(model, pop):
    """``model`` with its latent population of bulge pressures replaced by ``pop``.

    The observations get ``pop`` and the likelihood is rebuilt on them (same surrogate, nodes
    and ``P0``). Changes ``model`` in place and returns it.
    """
    model.obs = dataclasses.replace(model.obs, population=pop)
    model.lik = CellLikelihood(model.obs, model.lik.surrogate, n_nodes=model.lik.n_nodes,
                               P0=model.lik.P0)
    return model
