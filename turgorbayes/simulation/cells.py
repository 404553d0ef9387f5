"""Synthetic cell data drawn from the forward model, with known truths.

Generator (defaults = the paper's table and experiment; every choice is an argument)
------------------------------------------------------------------------------------
* Wall: ``gamma = 1.22``, ``E0t = 0.026 N/m``, ``R0 = 464.2 nm`` at ``P0 = 5 kPa``;
  intact cells at ``P_phys = 29 kPa`` (:data:`turgorbayes.physics.parameters.PUBLISHED`).
* Bulged cells: true pressures log-uniform over 1-25 kPa (the paper's P0 = 5 kPa sits
  mid-range; ``design_kwargs={"P_range": ...}`` or ``simulate --P-range-kPa`` for another
  experiment); bulge radii lognormal with median 500 nm and log-sd 0.2 (the paper's
  "R_b ~ 0.5 um"); indentation depths ``h_b/R_b`` uniform over 0.17-0.27, the range where
  the paper quotes k_b/(P R_b) = 0.35-0.38 (docs/physics.md, Bulge model).
* True observables from :mod:`turgorbayes.physics.forward` (R_c, k_c) and :mod:`turgorbayes.physics.bulge`
  (``k_b = r(h_b/R_b) P R_b``).

Measurement errors (:class:`ErrorModel`; the *reported* errors are exactly those used)
--------------------------------------------------------------------------------------
* ``R_c``: additive Gaussian, per-cell sd uniform in 15-25 nm (mean 20 nm). The paper's
  intact cells scatter by 0.02 um; the baseline model has no cell-to-cell variation, so the
  whole scatter is assigned to the measurement (contact-point) error.
* ``k_c``: Gaussian, per-cell sd = 9-15 % of the true value (mean 12 %), the paper's
  intact-cell scatter 0.002/0.017 N/m, again all measurement error. Reported as that
  fraction of the *observed* value (what an experimenter can compute), which the likelihood
  reads as a relative error (:func:`turgorbayes.inference.observations.stiffness_sd`).
* ``k_b``: multiplicative (lognormal), log-sd 6-14 % per cell: the slope of a soft bulge
  (~1 pN/nm) against an 11 pN/nm cantilever is noisier than the cell's.
* ``R_b``: multiplicative, log-sd 6-12 % per cell: a ~0.5 um radius from diffraction-
  limited fluorescence is good to 30-60 nm.
* ``h_b``: exact (the piezo displacement is known to ~1 nm).

Reported absolute errors are ``sd`` (R_c), ``relative sd x observed value`` (k_c),
``log-sd x observed value`` (k_b, R_b), which is what :mod:`turgorbayes.inference.likelihood` assumes.

Effects (docs/effects.md) plug in through objects with optional methods
``pressures(design, rng) -> design`` (the intact cells' own true pressures),
``cell_parameters(params, design, rng) -> params`` (per-cell wall parameters),
``observations(obs, design, rng) -> obs`` (corrupt measurements) and
``radius_and_stiffness(P, params, surrogate) -> (R_c, k_c)`` (a different wall model), the
attribute ``error_correlation`` (the correlation of every cell's R_c and k_c errors), plus
``describe() -> dict`` for the sidecar; see :func:`simulate_cells`.
"""

from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from turgorbayes import __version__
from turgorbayes import surrogate as surrogate_module
from turgorbayes.cells.table import CellData
from turgorbayes.physics import bulge, forward, parameters
from turgorbayes.physics.parameters import PUBLISHED

__all__ = [
    "PAPER_TRUTH",
    "TRUTHS",
    "Design",
    "ErrorModel",
    "Truth",
    "draw_design",
    "simulate_cells",
]


@dataclass(frozen=True)
class Truth:
    """Global parameters of a simulation, SI units."""

    gamma: float = PUBLISHED["gamma"]
    E0t: float = PUBLISHED["E0t"]
    R0: float = PUBLISHED["R0"]
    P_phys: float = PUBLISHED["P_phys"]
    P0: float = parameters.P0

    def as_dict(self):
        return asdict(self)


#: The paper's published values (:data:`turgorbayes.physics.parameters.PUBLISHED`).
PAPER_TRUTH = Truth()
#: Range of the bulged cells' true pressures [Pa] (log-uniform), the paper's experiment.
DEFAULT_P_RANGE = (1e3, 25e3)
#: Populations of bulged-cell pressures :func:`draw_design` can draw.
P_DISTRIBUTIONS = ("loguniform", "lognormal")
#: The parameter sets of the recovery tests and studies (docs/validation.md): the paper's table, a
#: wall without stress stiffening (gamma = 1 exactly), one that stiffens less (gamma = 0.8) and one
#: that stiffens more (gamma = 1.5; intact cells then 537 nm and 0.018 N/m, near the paper's).
TRUTHS = {
    "paper": PAPER_TRUTH,
    "gamma_one": Truth(gamma=1.0, E0t=0.030, R0=470e-9, P_phys=25e3),
    "gamma_0.8": Truth(gamma=0.8, E0t=0.035, R0=455e-9, P_phys=35e3),
    "gamma_1.5": Truth(gamma=1.5, E0t=0.022, R0=465e-9, P_phys=29e3),
}


@dataclass(frozen=True)
class ErrorModel:
    """Measurement-error sizes (ranges of per-cell values drawn uniformly; module docstring).

    ``reported`` says how the file's error columns of the stiffnesses and the bulge radius are
    written: ``"observed"`` (the default) as the relative error times the *observed* value,
    what an experimenter can compute; ``"true"`` as the sd of the noise itself, i.e. the
    relative error times the *true* value, so that a cell's error bar is independent of its
    noise (docs/validation.md, "Calibration as experiments grow").
    """

    R_c_sd: tuple = (15e-9, 25e-9)
    k_c_rel_sd: tuple = (0.09, 0.15)
    k_b_log_sd: tuple = (0.06, 0.14)
    R_b_log_sd: tuple = (0.06, 0.12)
    reported: str = "observed"

    def __post_init__(self):
        if self.reported not in ("observed", "true"):
            raise ValueError(f"reported must be 'observed' or 'true', got {self.reported!r}")


@dataclass
class Design:
    """Per-cell settings of a simulation (everything but the noise).

    Attributes
    ----------
    is_bulged : ndarray of bool
    P : ndarray [Pa]
        True pressure of every cell (P_phys for intact cells).
    R_b : ndarray [m]
        True bulge radius (NaN on intact cells).
    h_over_Rb : ndarray
        Indentation depth over true bulge radius (NaN on intact cells).
    R_c_sd, k_c_rel_sd, k_b_log_sd, R_b_log_sd : ndarray
        Per-cell error sizes.
    """

    is_bulged: np.ndarray
    P: np.ndarray
    R_b: np.ndarray
    h_over_Rb: np.ndarray
    R_c_sd: np.ndarray
    k_c_rel_sd: np.ndarray
    k_b_log_sd: np.ndarray
    R_b_log_sd: np.ndarray
    extra: dict = field(default_factory=dict)


def _check_counts(n_bulged, n_intact):
    """Bulged cells may be none (an osmotic series of intact cells); intact cells may not."""
    if int(n_bulged) != n_bulged or n_bulged < 0:
        raise ValueError(f"n_bulged must be an integer >= 0, got {n_bulged!r}")
    if int(n_intact) != n_intact or n_intact < 1:
        raise ValueError(f"n_intact must be a positive integer, got {n_intact!r}")


def draw_design(rng, n_bulged=72, n_intact=42, truth=PAPER_TRUTH, errors=ErrorModel(),
                P_range=DEFAULT_P_RANGE, R_b_median=500e-9, R_b_log_sd=0.2,
                h_over_Rb_range=(0.17, 0.27), P_distribution="loguniform"):
    """Draw pressures, bulge geometry and error sizes (bulged cells first, then intact).

    Parameters
    ----------
    rng : numpy.random.Generator
    n_bulged, n_intact : int
    truth : Truth
    errors : ErrorModel
    P_range : (float, float) [Pa]
        Bulged-cell pressures are log-uniform over this range (a population with hard edges,
        the paper's experiment) or, with ``P_distribution="lognormal"``, lognormal with the
        range's geometric mean as median and a quarter of its log-width as log-sd (95 % of
        the cells inside it; a smooth population).
    R_b_median : float [m]
    R_b_log_sd : float
    h_over_Rb_range : (float, float)
    P_distribution : {"loguniform", "lognormal"}

    Returns
    -------
    Design
    """
    _check_counts(n_bulged, n_intact)
    if not 0 < P_range[0] < P_range[1]:
        raise ValueError(f"P_range must be 0 < low < high Pa, got {P_range}")
    if P_distribution not in P_DISTRIBUTIONS:
        raise ValueError(f"P_distribution must be one of {P_DISTRIBUTIONS}, got "
                         f"{P_distribution!r}")
    n = n_bulged + n_intact
    is_bulged = np.arange(n) < n_bulged
    P = np.full(n, float(truth.P_phys))
    lo, hi = np.log(P_range)
    if P_distribution == "loguniform":
        P[:n_bulged] = np.exp(rng.uniform(lo, hi, n_bulged))
    else:
        P[:n_bulged] = np.exp((lo + hi) / 2 + (hi - lo) / 4 * rng.standard_normal(n_bulged))
    R_b = np.full(n, np.nan)
    R_b[:n_bulged] = R_b_median * np.exp(R_b_log_sd * rng.standard_normal(n_bulged))
    x = np.full(n, np.nan)
    x[:n_bulged] = rng.uniform(*h_over_Rb_range, n_bulged)
    sizes = {name: rng.uniform(*getattr(errors, name), n) for name in
             ("R_c_sd", "k_c_rel_sd", "k_b_log_sd", "R_b_log_sd")}
    for name in ("k_b_log_sd", "R_b_log_sd"):
        sizes[name][~is_bulged] = np.nan
    return Design(is_bulged=is_bulged, P=P, R_b=R_b, h_over_Rb=x, **sizes)


def _true_observables(design, params, surrogate, wall_model=None):
    if wall_model is not None:
        R_c, k_c = wall_model(design.P, params, surrogate)
        bad = ~(np.isfinite(R_c) & np.isfinite(k_c))
        if bad.any():
            i = int(np.flatnonzero(bad)[0])
            raise ValueError(f"the effect's wall model is undefined for simulated cell {i} at P = "
                             f"{design.P[i]:.4g} Pa: {_wall_model_reason(R_c[i], surrogate)}; "
                             f"choose other parameters, effect sizes or pressures")
        R_c, k_c = np.asarray(R_c, float), np.asarray(k_c, float)
    else:
        R_c, k_c = forward.cell_radius_and_stiffness(design.P, params["gamma"], params["E0t"],
                                                     params["R0"], params["P0"], surrogate,
                                                     forward.fe_settings(params))
    if not (np.all(np.isfinite(R_c)) and np.all(np.isfinite(k_c))):
        codes, reasons = forward.explain_nan(design.P, params["gamma"], params["E0t"],
                                             params["R0"], params["P0"], surrogate,
                                             forward.fe_settings(params))
        bad = np.flatnonzero(codes)[0]
        raise ValueError(
            f"the forward model is undefined for simulated cell {bad} at P = "
            f"{design.P[bad]:.4g} Pa: {reasons[int(codes[bad])]}; choose other parameters"
        )
    b = design.is_bulged
    k_b = np.full(design.P.shape, np.nan)
    k_b[b] = bulge.reduced_stiffness(design.h_over_Rb[b]) * design.P[b] * design.R_b[b]
    return {"R_c": R_c, "k_c": k_c, "k_b": k_b, "R_b": design.R_b.copy(),
            "h_b": design.h_over_Rb * design.R_b}


def _wall_model_reason(R_c, surrogate):
    """Why an effect's wall model gave no (R_c, k_c) for one cell."""
    if not np.isfinite(R_c):
        return "no radius (the wall cannot bear this pressure)"
    dom = getattr(surrogate, "domain", None)
    where = (f" (x in [{dom['x'][0]:.4g}, {dom['x'][1]:.4g}], E_par/E_perp in "
             f"[{dom['ratio'][0]:.3g}, {dom['ratio'][1]:.3g}])" if dom else "")
    return (f"R_c = {1e9 * R_c:.1f} nm; {forward.REASONS[forward.OUTSIDE_SURROGATE]}{where}, or "
            f"{forward.REASONS[forward.BUCKLED]}")


def _add_noise(true, design, rng, noise, reported="observed", rho=None):
    n = design.P.size
    z = rng.standard_normal((4, n)) if noise else np.zeros((4, n))
    if rho:  # an effect's correlation of R_c's and k_c's errors (correlated_errors)
        z[1] = rho * z[0] + np.sqrt(1 - rho * rho) * z[1]
    b = design.is_bulged
    obs = {
        "R_c": true["R_c"] + design.R_c_sd * z[0],
        "R_c_err": design.R_c_sd.copy(),
        "k_c": true["k_c"] * (1 + design.k_c_rel_sd * z[1]),
        "k_c_err": design.k_c_rel_sd * true["k_c"],
        "k_b": true["k_b"] * np.exp(design.k_b_log_sd * z[2]),
        "R_b": true["R_b"] * np.exp(design.R_b_log_sd * z[3]),
        "h_b": true["h_b"].copy(),
    }
    ref = obs if reported == "observed" else true
    obs["k_b_err"] = np.where(b, design.k_b_log_sd * ref["k_b"], np.nan)
    obs["R_b_err"] = np.where(b, design.R_b_log_sd * ref["R_b"], np.nan)
    return obs


def _sessions(n_cells, n_sessions, seed):
    """Session labels ``s1 ... sN``, as equal in counts as possible, shuffled (own stream)."""
    if int(n_sessions) != n_sessions or not 1 <= n_sessions <= n_cells:
        raise ValueError(f"n_sessions must be an integer in [1, {n_cells}], got {n_sessions!r}")
    labels = np.arange(n_cells) % int(n_sessions)
    np.random.default_rng([int(seed), 20111014]).shuffle(labels)
    return [f"s{j + 1}" for j in labels]


def simulate_cells(n_bulged=72, n_intact=42, truth=PAPER_TRUTH, seed=0, errors=ErrorModel(),
                   surrogate=None, noise=True, effects=(), design_kwargs=None, n_sessions=None):
    """Simulate a cell data set from the baseline model (plus optional effects).

    Parameters
    ----------
    n_bulged, n_intact : int
        Cells per group (the paper: 72 and 42).
    truth : Truth
        Global parameters.
    seed : int
        Seed of every random draw (same seed, same data).
    errors : ErrorModel
        Measurement-error sizes.
    surrogate : Surrogate, optional
        k/(PR) table (the shipped one if None).
    noise : bool
        False returns the noise-free observables with the same reported errors.
    effects : sequence
        Objects with optional ``pressures`` / ``cell_parameters`` / ``observations`` /
        ``radius_and_stiffness`` / ``describe`` methods (module docstring), applied in order.
    design_kwargs : dict, optional
        Passed to :func:`draw_design` (``P_range``, ``R_b_median`` ...).
    n_sessions : int, optional
        Assign the cells to this many measurement sessions (``session`` column ``s1``, ``s2``
        ...: as equal in size as possible, in random order, from a random stream of its own,
        so the other draws do not change); the ``calibration`` effect needs them.

    Returns
    -------
    cells : turgorbayes.cells.table.CellData
        Bulged cells first (``b001`` ...), then intact (``i001`` ...), with comment lines
        saying the data are simulated.
    truths : dict
        JSON-ready: parameters, per-cell true pressures and bulge radii, generator settings.
    """
    rng = np.random.default_rng(seed)
    if surrogate is None:
        surrogate = surrogate_module.load()
    design = draw_design(rng, n_bulged, n_intact, truth, errors, **(design_kwargs or {}))
    for effect in effects:  # intact cells' own pressures (only an effect with them draws)
        if hasattr(effect, "pressures"):
            design = effect.pressures(design, rng)
    n = design.P.size
    params = {k: np.full(n, float(v)) for k, v in truth.as_dict().items() if k != "P_phys"}
    for effect in effects:
        if hasattr(effect, "cell_parameters"):
            params = effect.cell_parameters(params, design, rng)
    # an effect may replace the wall model (e.g. a load-bearing outer membrane); the last wins
    wall_model = None
    for effect in effects:
        wall_model = getattr(effect, "radius_and_stiffness", None) or wall_model
    true = _true_observables(design, params, surrogate, wall_model)
    rho = next((e.error_correlation for e in effects if hasattr(e, "error_correlation")), None)
    obs = _add_noise(true, design, rng, noise, errors.reported, rho)
    if n_sessions is not None:
        obs["extra"] = {"session": _sessions(n, n_sessions, seed)}
    for effect in effects:
        if hasattr(effect, "observations"):
            obs = effect.observations(obs, design, rng)
    # reported as an experimenter would: the relative error times the value read (or, with
    # ErrorModel(reported="true"), times the true value: an error bar independent of the noise)
    obs["k_c_err"] = design.k_c_rel_sd * (obs["k_c"] if errors.reported == "observed"
                                          else true["k_c"])
    ids = [f"b{i + 1:03d}" for i in range(n_bulged)] + [f"i{i + 1:03d}" for i in range(n_intact)]
    groups = ["bulged" if b else "intact" for b in design.is_bulged]
    P_range = (design_kwargs or {}).get("P_range", DEFAULT_P_RANGE)
    P_distribution = (design_kwargs or {}).get("P_distribution", "loguniform")
    comments = _comments(truth, seed, noise, effects, surrogate, errors, P_range, P_distribution)
    cells = CellData(cell_id=ids, group=groups, comments=comments, **obs)
    truths = _truths(truth, design, params, true, seed, noise, errors, effects, ids)
    truths["bulge_pressure_range_kPa"] = [P_range[0] / 1e3, P_range[1] / 1e3]
    truths["bulge_pressure_distribution"] = P_distribution
    truths["surrogate"] = {"path": Path(str(getattr(surrogate, "path", ""))).name or None,
                           "sha256": getattr(surrogate, "sha256", None)}
    return cells, truths


def _comments(truth, seed, noise, effects, surrogate=None, errors=ErrorModel(),
              P_range=None, P_distribution="loguniform"):
    sha = getattr(surrogate, "sha256", None)
    e = errors
    lines = [
        "# SIMULATED DATA (not measurements): turgorbayes simulate "
        f"{__version__}, seed {seed}{'' if noise else ', noise-free'}",
        f"# truth: gamma = {truth.gamma:g}, E0t = {truth.E0t:g} N/m, R0 = {truth.R0 * 1e9:g} nm, "
        f"P_phys = {truth.P_phys / 1e3:g} kPa, P0 = {truth.P0 / 1e3:g} kPa",
        f"# errors: R_c {e.R_c_sd[0] * 1e9:g}-{e.R_c_sd[1] * 1e9:g} nm, k_c "
        f"{e.k_c_rel_sd[0] * 100:g}-{e.k_c_rel_sd[1] * 100:g} %, k_b {e.k_b_log_sd[0] * 100:g}-"
        f"{e.k_b_log_sd[1] * 100:g} %, R_b {e.R_b_log_sd[0] * 100:g}-{e.R_b_log_sd[1] * 100:g} % "
        "(per cell, reported = used; k_c errors are relative, reported x the observed value)",
    ]
    if P_distribution == "lognormal":
        lines.append(f"# bulged-cell pressures lognormal, median {np.sqrt(np.prod(P_range)) / 1e3:.3g} "
                     f"kPa, 95 % within {P_range[0] / 1e3:g}-{P_range[1] / 1e3:g} kPa")
    elif P_range is not None and tuple(P_range) != DEFAULT_P_RANGE:
        lines.append(f"# bulged-cell pressures log-uniform over {P_range[0] / 1e3:g}-"
                     f"{P_range[1] / 1e3:g} kPa")
    if sha:
        lines.append(f"# k_c from the FE surrogate table sha256 {sha}")
    for effect in effects:
        desc = effect.describe() if hasattr(effect, "describe") else {"effect": repr(effect)}
        lines.append(f"# effect: {desc}")
    return lines


def _round12(value):
    """``value`` with every float rounded to 12 significant digits (no 464.20000000000005)."""
    if isinstance(value, dict):
        return {k: _round12(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_round12(v) for v in value]
    if isinstance(value, float) and np.isfinite(value):
        return float(f"{value:.12g}")
    return value


def _truths(truth, design, params, true, seed, noise, errors, effects, ids):
    def arr(a):
        return [None if not np.isfinite(v) else float(v) for v in np.asarray(a, float)]

    truths = {
        "simulated": True,
        "generator": f"turgorbayes {__version__} synthetic.simulate_cells",
        "seed": seed,
        "noise": bool(noise),
        "parameters": {"gamma": truth.gamma, "E0t_N_per_m": truth.E0t,
                       "R0_nm": truth.R0 * 1e9, "P_phys_kPa": truth.P_phys / 1e3,
                       "P0_kPa": truth.P0 / 1e3},
        "errors": {"R_c_sd_nm": [v * 1e9 for v in errors.R_c_sd],
                   "k_c_rel_sd": list(errors.k_c_rel_sd),
                   "k_b_log_sd": list(errors.k_b_log_sd),
                   "R_b_log_sd": list(errors.R_b_log_sd),
                   "reported": errors.reported},
        "effects": [e.describe() if hasattr(e, "describe") else repr(e) for e in effects],
        "cells": {
            "cell_id": list(ids),
            "P_kPa": arr(design.P / 1e3),
            "R_b_nm": arr(design.R_b * 1e9),
            "h_over_Rb": arr(design.h_over_Rb),
            "R_c_true_nm": arr(true["R_c"] * 1e9),
            "k_c_true_N_per_m": arr(true["k_c"]),
            "R0_nm": arr(np.broadcast_to(params["R0"], design.P.shape) * 1e9),
            "E0t_N_per_m": arr(np.broadcast_to(params["E0t"], design.P.shape)),
        },
    }
    # the JSON sidecar shows 12 significant digits; the effects' own records are kept as they are
    return {k: v if k == "effects" else _round12(v) for k, v in truths.items()}
