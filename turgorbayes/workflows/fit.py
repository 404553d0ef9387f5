"""Run a fit end to end and write its results (posterior.nc, summary.json).

:func:`fit_cells` takes a :class:`turgorbayes.cells.table.CellData`, fits a registered model
(:mod:`turgorbayes.inference.models`) and returns a :class:`FitResult`; :func:`write_results` writes

* ``posterior.nc``: ArviZ DataTree (netCDF4 via h5netcdf) with groups ``posterior``
  (gamma, E0t [N/m], R0 [m], P_phys [Pa], E_perp and E_par [Pa], and ``P_cell`` [Pa], the
  conditional mean of every cell's pressure), ``log_likelihood`` (``cells``: one value per
  cell, the latent pressure integrated out), ``posterior_predictive`` (R_c [m], k_c [N/m]),
  ``observed_data`` (R_c, k_c), ``constant_data`` (errors, group, bulge-derived pressures)
  and ``sample_stats`` (``lp``); SI units, cells indexed by their ``cell_id``;
* ``summary.json`` with exactly the keys of :data:`SUMMARY_KEYS`.

:func:`fit_cells` builds the DataTree once (:attr:`FitResult.tree`); figures and reports read it.

For ``paper_wls`` there is no posterior: the ``posterior`` group holds draws from the normal
approximation ``N(estimate, (J^T J)^-1)`` (attribute ``inference``), its summary uses the
estimate +- standard error (q05/q95 = estimate -+ 1.645 sd), E_perp and E_par are propagated
linearly as in the paper, and ``r_hat``, ``ess_*`` and ``loo`` are null.
"""

import json
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from turgorbayes import __version__
from turgorbayes.cells.medium import require_one_medium
from turgorbayes.cells.table import is_simulated
from turgorbayes.errors import TurgorBayesError
from turgorbayes.inference import diagnostics, engine, models, sampling, start_check, table_check
from turgorbayes.inference import population_noise as pop_noise
from turgorbayes.inference.engine import stream_rng
from turgorbayes.inference.observations import observations_from_cells
from turgorbayes.physics.parameters import QUANTITIES, SUMMARY_PARAMETERS
from turgorbayes.progress import note
from turgorbayes.provenance import dependency_versions
from turgorbayes.workflows.fit_wls import wls_fit
from turgorbayes.workflows.flags import flag_cells

__all__ = [
    "FitResult",
    "FitSettings",
    "LARGE_FIT",
    "SUMMARY_KEYS",
    "SUMMARY_PARAMETERS",
    "fit_cells",
    "file_name",
    "fit_tree",
    "flag_cells",
    "mode_search_note",
    "resolve_model",
    "summary_dict",
    "to_datatree",
    "wls_parameters",
    "write_results",
]

#: A fit of at least this many cells says what it does before each slow stage: preparing the
#: model took 4 s for 5000 cells and 45 s for 20 000 (twice: the model and the least-squares
#: start), on a shared 2-core machine; at 10 000 cells the stages after sampling took up to
#: 2 minutes each, at 100 000 preparing the model 5 minutes
#: (studies/results/fit_large.txt).
LARGE_FIT = 5000

#: Log-posterior evaluations of the mode search and its Hessian (306 on the bundled example,
#: baseline model): the estimate announced before a long search.
_MODE_EVALUATIONS = 300

#: summary.json: top-level keys and their sub-keys.
SUMMARY_KEYS = {
    "model": None,
    "data": ("path", "sha256", "n_bulged", "n_intact"),
    "surrogate": ("path", "sha256"),
    "converged": None,
    "parameters": tuple(q.key for q in QUANTITIES.values()),
    "loo": ("elpd", "se", "p_loo", "n_pareto_k_bad"),
    "timing_s": None,
    "version": None,
    "dependencies": None,
    "seed": None,
    "flagged_cells": ("cell_id", "quantity", "score", "reason"),
}
#: Fields of every entry of ``summary["parameters"]``.
PARAMETER_FIELDS = ("mean", "sd", "q05", "q50", "q95", "r_hat", "ess_bulk", "ess_tail")


@dataclass
class FitSettings(engine.Settings):
    """The settings of :func:`fit_cells`: the posterior engine's
    (:class:`turgorbayes.inference.engine.Settings`, engine ``"emcee"``) and the fit's own.

    Attributes
    ----------
    population_noise : bool
        Carry the plug-in latent population's own estimation noise into the posterior
        (:mod:`turgorbayes.inference.population_noise`, ``population_noise_bootstrap``
        bootstrap populations).
    """

    population_noise: bool = True
    population_noise_bootstrap: int = pop_noise.N_BOOTSTRAP


@dataclass
class FitResult:
    """Everything a fit produced (see the module docstring for the groups)."""

    model: str
    cells: object
    surrogate: object
    seed: int
    draws: dict  # name -> (chain, draw) SI
    log_lik: np.ndarray  # (chain, draw, cell)
    ppc: dict  # R_c, k_c -> (chain, draw, cell)
    P_cell: np.ndarray  # (chain, draw, cell)
    lp: np.ndarray  # (chain, draw)
    converged: bool
    reasons: list
    chain_diag: dict = field(default_factory=dict)
    loo: dict = None
    sampler: dict = field(default_factory=dict)
    wls: object = None
    wls_moduli: dict = None
    timing_s: float = 0.0
    settings: FitSettings = None
    table_check: dict = None  # turgorbayes.inference.table_check.check_fit
    #: Readings that look like gross errors (:func:`flag_cells`).
    flagged_cells: list = field(default_factory=list)
    #: The DataTree of :func:`to_datatree`, built once by :func:`fit_cells` (not copied by
    #: ``dataclasses.replace``, whose result gets a fresh one).
    tree: object = field(default=None, init=False, repr=False, compare=False)
    #: The data set's conditions (:class:`turgorbayes.inference.conditions.ConditionSet`),
    #: set by :func:`turgorbayes.workflows.conditions.fit_conditions`; None otherwise.
    conditions: object = field(default=None, init=False, repr=False, compare=False)
    #: The contrasts of the shared-wall model when the headline let the wall differ between
    #: conditions (:func:`turgorbayes.workflows.conditions.fit_conditions`); None otherwise.
    shared_wall_contrasts: list = field(default=None, init=False, repr=False, compare=False)
    #: How the released walls were drawn (:func:`turgorbayes.workflows.conditions.fit_conditions`):
    #: failed draws per condition and the importance sampling's effective sample size.
    wall_release: dict = field(default=None, init=False, repr=False, compare=False)
    #: Sections a workflow adds to ``summary.json`` (name -> JSON-ready dict, e.g. the osmotic
    #: series' levels, :func:`turgorbayes.workflows.osmotic.fit_osmotic`), and the posterior
    #: variables they summarize (left out of ``parameters``).
    sections: dict = field(default_factory=dict, init=False, repr=False, compare=False)
    section_variables: tuple = field(default=(), init=False, repr=False, compare=False)


def _chains(model, u_draws, rng):
    """Per-draw quantities ``(chain, draw, ...)`` from sampler coordinates."""
    C, D, k = u_draws.shape
    flat = u_draws.reshape(C * D, k)
    phys = model.to_physical(flat)
    phys.update(model.derived(flat, rng))
    # chunks of ~60,000 cell-draws keep the quadrature arrays small for large data sets
    step = max(8, 60000 // model.obs.n_cells)
    chunks = [flat[i:i + step] for i in range(0, len(flat), step)]
    ll = np.concatenate([model.pointwise_log_likelihood(c) for c in chunks])
    ppc = [model.posterior_predictive(c, rng) for c in chunks]
    P_cell = np.concatenate([model.cell_pressures(c) for c in chunks])

    def shape(a):
        return np.asarray(a).reshape((C, D) + np.shape(a)[1:])

    return ({n: shape(v) for n, v in phys.items()}, shape(ll),
            {n: shape(np.concatenate([p[n] for p in ppc])) for n in ("R_c", "k_c")},
            shape(P_cell))


def resolve_model(name):
    """Model factory for ``name``: a registered model, or baseline + effects ``"a+b"``.

    Effect models (``radius_spread``, ``bad_curves+pressure_error`` ...; see
    :mod:`turgorbayes.effects`) are :class:`turgorbayes.effects.ExtendedModel` instances.

    Returns
    -------
    turgorbayes.inference.models.ModelFactory
        ``name`` itself if it is one (e.g. of
        :func:`turgorbayes.workflows.conditions.fit_conditions`).
    """
    if isinstance(name, models.ModelFactory):
        return name
    if name in models.MODELS:
        return models.ModelFactory.of_class(models.MODELS[name], name)
    from turgorbayes import effects

    try:
        names = effects.parse_model_name(name)
    except ValueError:
        raise ValueError(f"unknown model {name!r}; known: {', '.join(sorted(models.MODELS))}, "
                         f"or effects joined by '+' ({', '.join(effects.effect_names())})") from None

    def build(cells, surrogate, n_nodes=None):
        return effects.ExtendedModel(cells, surrogate, names)

    return models.ModelFactory(build, name)


def _changes_wall(name):
    """Whether the model ``name`` (a registered model, a factory, or effects joined by '+')
    changes the wall the FE table is read at."""
    if not isinstance(name, str) or name in models.MODELS:
        return False
    from turgorbayes import effects

    return effects.changes_wall(name)


def _bayesian_fit(name, cells, surrogate, model_cls, seed, settings):
    """The posterior from :func:`turgorbayes.inference.engine.fit_posterior` (emcee from the
    model's own mode and Laplace covariance, :meth:`~turgorbayes.inference.models.BaselineModel.start`),
    with the population noise carried and the per-draw quantities of the DataTree.

    Returns
    -------
    FitResult
        Named ``name``; ``chain_diag`` holds R-hat and ESS of the sampler's own draws, the
        fields that need the DataTree (``loo`` ...) are left to :func:`fit_cells`.
    model
        The model sampled.
    CellObservations
        The cells' bulge-derived pressures (of the least-squares model).
    """
    if settings.engine != "emcee":
        raise ValueError(f"the fit samples by emcee (engine 'emcee'), got {settings.engine!r}; "
                         "importance sampling is the criticism's engine")
    _stage(settings, cells, f"preparing the fit of {len(cells)} cells: the population of "
           f"{int(np.count_nonzero(cells.is_bulged))} bulge pressures (a deconvolution)...")
    model = model_cls(cells, surrogate, n_nodes=settings.n_nodes)
    _stage(settings, cells, "preparing the fit: the least-squares start...")
    wls_model = model.least_squares()
    wls = wls_model.fit()
    guess = model.start_guess(wls.estimate)
    message = mode_search_note(model, guess, len(cells)) if settings.progress else None
    note(message, enabled=message is not None)
    u_map, cov = model.start(guess)
    try:
        post = engine.fit_posterior(model, None, seed, settings, pointwise=False,
                                    laplace=engine.given_laplace(model, u_map, cov))
    except sampling.StartError as err:  # name the cells the model cannot produce
        raise start_check.start_error(model, u_map, err.positions) from None
    run = post.run
    u, lp = post.chains(post.u), post.chains(post.lp)
    if settings.population_noise:
        _stage(settings, cells, "carrying the latent population's own noise: "
               f"{settings.population_noise_bootstrap} populations deconvolved from bootstrap "
               f"resamples of {int(np.count_nonzero(cells.is_bulged))} bulge pressures...")
    carried = _carry_population_noise(model, post.u_map, post.cov, u, seed, settings)
    if carried is not None:
        u = carried.pop("u")
    _stage(settings, cells, f"per-draw quantities of {len(cells)} cells at "
           f"{u.shape[0] * u.shape[1]} draws (log-likelihood, predictions, pressures)...")
    draws, ll, ppc, P_cell = _chains(model, u, stream_rng(seed, 1000))
    if carried is not None:  # the carried draws' log posterior, from their log-likelihood
        lp = models.add_log_likelihood(
            model.log_prior(u.reshape(-1, model.ndim)).reshape(u.shape[:2]), ll.sum(axis=-1))
    stride = u.shape[1] and (run.draws().shape[1] / u.shape[1])
    sampler_info = {
        "n_walkers": settings.n_walkers, "n_ensembles": settings.n_ensembles,
        "n_steps": run.n_steps, "tol": settings.tol,
        "burn": run.ensembles[0].burn, "thin": run.ensembles[0].thin * stride,
        "n_draws_per_chain": int(u.shape[1]),
        "tau": {n: float(t) for n, t in zip(model.names, run.tau, strict=True)},
        "ensembles_converged": [e.converged for e in run.ensembles],
        "ensembles_stuck": list(run.stuck),
        "acceptance": run.acceptance, "moves": run.moves, "n_nodes": settings.n_nodes,
        "seeds": [e.seed for e in run.ensembles],
        "ess_emcee": {n: float(settings.n_ensembles * settings.n_walkers
                               * (run.n_steps - run.ensembles[0].burn) / t)
                      for n, t in zip(model.names, run.tau, strict=True)},
    }
    if post.attempts:  # unconverged runs of the engine's ladder before this one
        sampler_info["attempts"] = post.attempts
    if carried is not None:
        sampler_info["population_noise"] = carried["record"]
    # convergence is the engine's: judged on the sampler's own draws, before any carried noise
    chain = {n: post.diagnostics["chain"][n] for n in model.names}
    result = FitResult(model=name, cells=cells, surrogate=surrogate, seed=seed, draws=draws,
                       log_lik=ll, ppc=ppc, P_cell=P_cell, lp=lp, converged=bool(post.converged),
                       reasons=list(post.reasons), chain_diag=chain, sampler=sampler_info,
                       wls=wls, wls_moduli=wls_model.derived(wls), settings=settings)
    return result, model, wls_model.obs


def _stage(settings, cells, message):
    """Say ``message`` on stderr before a slow stage of a large fit (at least
    :data:`LARGE_FIT` cells, with ``settings.progress``)."""
    note(message, enabled=settings.progress and len(cells) >= LARGE_FIT)


def mode_search_note(model, guess, n_cells):
    """What to say before the posterior-mode search, or None when it is short.

    One evaluation of the posterior is timed; when ``_MODE_EVALUATIONS`` of them would take
    over 10 s, the note gives the cells, the estimate and the time of one evaluation.

    Parameters
    ----------
    model : object
        With ``names``, ``to_u`` and a vectorized ``log_posterior``.
    guess : dict
        Physical starting values of the search.
    n_cells : int
    """
    u0 = model.to_u({k: guess[k] for k in model.names})
    t0 = time.perf_counter()
    model.log_posterior(u0)
    seconds = time.perf_counter() - t0
    if seconds * _MODE_EVALUATIONS <= 10.0:
        return None
    return (f"finding the posterior mode of {n_cells} cells (about "
            f"{seconds * _MODE_EVALUATIONS:.0f} s: ~{_MODE_EVALUATIONS} evaluations of the "
            f"posterior at {seconds:.2g} s each), then sampling...")


def _carry_population_noise(model, u_map, cov, u, seed, settings):
    """The draws ``u (chain, draw, ndim)`` convolved with the plug-in population's noise
    (:func:`turgorbayes.inference.population_noise.carry`, cut to the prior's support), with a
    record of it; None when it is switched off or the population is not estimated."""
    if not settings.population_noise:
        return None
    # a model with several latent populations (conditions) computes it; else the one's
    sigma_g = model.population_shift_covariance(u_map, cov, seed,
                                                settings.population_noise_bootstrap)
    if sigma_g is None:
        sigma_g = pop_noise.shift_covariance(model, u_map, cov, seed,
                                             settings.population_noise_bootstrap)
    if not np.any(sigma_g):
        return None
    u = pop_noise.carry(u, sigma_g, stream_rng(seed, 1003), log_prior=model.log_prior)
    ratio = np.sqrt(np.diag(sigma_g) / np.diag(cov))
    return {"u": u, "record": {
        "n_bootstrap": int(settings.population_noise_bootstrap),
        "shift_sd_over_laplace_sd": dict(zip(model.names, ratio.tolist(), strict=True))}}


def fit_cells(cells, model="baseline", seed=0, surrogate=None, settings=None):
    """Fit a model to a cell data set.

    Parameters
    ----------
    cells : turgorbayes.cells.table.CellData
        Bulged and intact cells.
    model : str
        A name in :data:`turgorbayes.inference.models.MODELS` (``baseline``, ``paper_wls`` ...).
    seed : int
        Seed of every random draw of the fit.
    surrogate : Surrogate, optional
        k/(PR) table; the shipped one if None.
    settings : FitSettings, optional

    Returns
    -------
    FitResult
    """
    from turgorbayes import surrogate as surrogate_module

    settings = FitSettings() if settings is None else settings
    model_cls = resolve_model(model)
    if not model_cls.own_design:
        require_one_medium(cells.require_both_groups(), f"model {model_cls.name}")
    surrogate = surrogate_module.load() if surrogate is None else surrogate
    model = model_cls.name
    t0 = time.perf_counter()
    if model_cls.bayesian:
        result, sampled, obs = _bayesian_fit(model, cells, surrogate, model_cls, seed, settings)
    else:
        result, sampled, obs = wls_fit(model, cells, surrogate, seed, settings, FitResult)
    if model_cls.bayesian:
        _stage(settings, cells, f"leave-one-out of {len(cells)} cells...")
    dt = to_datatree(result, obs=obs)
    if model_cls.bayesian:
        result.chain_diag.update(diagnostics.chain_diagnostics(dt, ["E_perp", "E_par"]))
        result.loo = diagnostics.loo_summary(dt)
    _stage(settings, cells, f"checking where {table_check.MAX_DRAWS} draws ask the FE table "
           f"for a stiffness it lacks ({len(cells)} cells)...")
    result.table_check = table_check.check_fit(
        result, approximate=not model_cls.own_design and _changes_wall(model))
    if model_cls.bayesian:
        from turgorbayes.effects.outliers import FLAG_DRAWS

        _stage(settings, cells, f"screening the readings of {len(cells)} cells for gross "
               f"errors at {FLAG_DRAWS} draws...")
        result.flagged_cells = flag_cells(sampled, result.draws, cells.cell_id)
    dt.attrs.update(_tree_attrs(result))
    result.tree = dt
    result.timing_s = time.perf_counter() - t0
    return result


def fit_tree(result):
    """The DataTree of a fit: :attr:`FitResult.tree`, or :func:`to_datatree` if it has none."""
    return result.tree if result.tree is not None else to_datatree(result)


def to_datatree(result, obs=None):
    """The :class:`FitResult` as an ArviZ DataTree (groups of the module docstring).

    Parameters
    ----------
    result : FitResult
    obs : turgorbayes.inference.observations.CellObservations, optional
        The cells' bulge-derived pressures; computed from ``result.cells`` if None.
    """
    cells = result.cells
    ids = list(cells.cell_id)
    obs = observations_from_cells(cells) if obs is None else obs
    log_P = np.full(len(ids), np.nan)
    sd = np.full(len(ids), np.nan)
    log_P[obs.bulged], sd[obs.bulged] = obs.log_P_bulge, obs.sd_log_P_bulge
    posterior = dict(result.draws)
    posterior["P_cell"] = result.P_cell
    dims = {"P_cell": ["cell"], "cells": ["cell"], "R_c": ["cell"], "k_c": ["cell"],
            "R_c_err": ["cell"], "k_c_err": ["cell"], "is_bulged": ["cell"],
            "P_bulge": ["cell"], "sd_log_P_bulge": ["cell"]}
    dt = engine.datatree(
        posterior, result.log_lik, result.lp, cell_ids=ids, dims=dims,
        groups={
            "posterior_predictive": dict(result.ppc),
            "observed_data": {"R_c": np.asarray(cells.R_c), "k_c": np.asarray(cells.k_c)},
            "constant_data": {"R_c_err": np.asarray(cells.R_c_err),
                              "k_c_err": np.asarray(cells.k_c_err),
                              "is_bulged": np.asarray(cells.is_bulged, dtype=np.int8),
                              "P_bulge": np.exp(log_P), "sd_log_P_bulge": sd},
        })
    dt.attrs.update(_tree_attrs(result))
    return dt


def _tree_attrs(result):
    """Attributes of the DataTree: provenance, convergence and the FE-table check."""
    cells = result.cells
    attrs = {"model": result.model, "turgorbayes_version": __version__,
             "seed": int(result.seed), "converged": int(bool(result.converged)),
             "data_sha256": cells.sha256 or "", "surrogate_sha256":
             result.surrogate.sha256 or "",
             "units": "SI (m, N/m, Pa)", "simulated_data": int(is_simulated(cells))}
    if "inference" in result.sampler:
        attrs["inference"] = result.sampler["inference"]
    if "population_noise" in result.sampler:
        attrs["population_noise_bootstrap"] = result.sampler["population_noise"]["n_bootstrap"]
    if result.table_check is not None:
        # draws in which a cell's plausible pressures reach where the FE table has no value
        attrs["fe_table_undefined_fraction"] = result.table_check["fraction_of_draws"]
        attrs["fe_table_undefined_note"] = table_check.describe(result.table_check)
    return attrs


def _stats(x):
    x = np.asarray(x, float).ravel()
    q05, q50, q95 = np.quantile(x, [0.05, 0.5, 0.95])
    return {"mean": float(np.mean(x)), "sd": float(np.std(x, ddof=1)), "q05": float(q05),
            "q50": float(q50), "q95": float(q95)}


def _none_if_nan(v):
    return None if v is None or not np.isfinite(v) else float(v)


def file_name(path):
    """The name of the file at ``path`` (None for None): shareable outputs name files this way.

    Outputs travel between machines, so they record a file's name and its sha256, never the
    absolute path of the machine that wrote them.
    """
    return None if path is None or str(path) in ("", "None") else Path(str(path)).name


def summary_dict(result):
    """The ``summary.json`` content (keys exactly :data:`SUMMARY_KEYS`)."""
    cells = result.cells
    params = {}
    for name, (key, unit) in SUMMARY_PARAMETERS.items():
        if result.model == "paper_wls":
            entry = _wls_entry(result, name, unit)
        else:
            entry = {k: v / unit for k, v in _stats(result.draws[name]).items()}
            d = result.chain_diag.get(name, {})
            entry.update({k: _none_if_nan(d.get(k)) for k in ("r_hat", "ess_bulk", "ess_tail")})
        params[key] = entry
    own = _condition_variables(result) | set(result.section_variables)
    for name in result.draws:
        if name not in SUMMARY_PARAMETERS and name not in own:
            # an effect model's own parameters (SI), same fields
            entry = _stats(result.draws[name])
            d = result.chain_diag.get(name, {})
            entry.update({k: _none_if_nan(d.get(k)) for k in ("r_hat", "ess_bulk", "ess_tail")})
            params[name] = entry
    loo = result.loo or {}
    sur = result.surrogate
    summary = {
        "model": result.model,
        "data": {"path": file_name(cells.path), "sha256": cells.sha256,
                 "n_bulged": cells.n_bulged, "n_intact": cells.n_intact},
        "surrogate": {"path": file_name(sur.path), "sha256": sur.sha256},
        "converged": bool(result.converged),
        "parameters": params,
        "loo": {k: (None if k not in loo else (int(loo[k]) if k == "n_pareto_k_bad"
                                               else float(loo[k])))
                for k in SUMMARY_KEYS["loo"]},
        "timing_s": float(result.timing_s),
        "version": __version__,
        "dependencies": dependency_versions(),
        "seed": int(result.seed),
        "flagged_cells": list(result.flagged_cells or []),
    }
    if result.conditions is not None and result.cells.extra.get("condition") is not None:
        from turgorbayes.inference import conditions

        summary["conditions"] = conditions.condition_entries(result)
        summary["contrasts"] = conditions.contrasts(result)
        if result.shared_wall_contrasts is not None:
            summary["contrasts_shared_wall"] = result.shared_wall_contrasts
        summary["wall_prior"] = dict(result.conditions.wall_prior)
        if result.wall_release is not None:
            summary["wall_release"] = result.wall_release
    summary.update(result.sections)
    return summary


def _condition_variables(result):
    """The per-condition posterior variables (summarized under ``conditions``)."""
    cs = result.conditions
    if cs is None:
        return set()
    return {cs.variable(q, c) for c in range(len(cs.names)) for q in cs.quantities(c)} | {
        cs.modulus_variable(m, c) for c in range(len(cs.names)) for m in ("E_perp", "E_par")}


def wls_parameters(result):
    """The paper_wls estimates (+- standard errors) of a fit, keyed like summary.json.

    Every :class:`FitResult` carries the weighted least-squares fit of its data (the
    Bayesian fit starts from it), so this gives the side-by-side column of the report.
    """
    return {key: _wls_entry(result, name, unit)
            for name, (key, unit) in SUMMARY_PARAMETERS.items()}


def _wls_entry(result, name, unit):
    if name in ("E_perp", "E_par"):
        value, sd = result.wls_moduli[name]
    else:
        value, sd = result.wls.estimate[name], result.wls.sd[name]
    value, sd = value / unit, sd / unit
    return {"mean": value, "sd": sd, "q05": value - 1.6448536269514722 * sd, "q50": value,
            "q95": value + 1.6448536269514722 * sd, "r_hat": None, "ess_bulk": None,
            "ess_tail": None}


def write_results(result, out_dir):
    """Write ``posterior.nc`` and ``summary.json`` into ``out_dir`` (created if needed).

    Returns
    -------
    dict
        The summary written.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    dt = fit_tree(result)
    encoding = {}
    for group in ("posterior", "log_likelihood", "posterior_predictive"):
        encoding[f"/{group}"] = {v: {"zlib": True, "complevel": 4}
                                 for v in dt[group].data_vars}
    try:
        dt.to_netcdf(out / "posterior.nc", engine="h5netcdf", encoding=encoding)
    except OSError as err:  # HDF5's own text names flags, not the cause
        raise TurgorBayesError(f"cannot write {out / 'posterior.nc'}: "
                               f"{err.strerror or 'the folder cannot be written'}") from None
    summary = summary_dict(result)
    (out / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    return summary
