"""Plan a two-condition experiment: what its turgor contrast can and cannot tell.

:func:`simulate_design` simulates ``n_experiments`` experiments of a design (bulged and intact
cells per condition) for each true wall change and turgor change, fits each the way ``turgorbayes
fit`` does, and scores the turgor contrast of both numbers ``fit`` reports: the headline (each
condition's wall may differ under the wall prior; docs/statistics.md, "A wall that may
differ") and the number conditional on a shared wall. :func:`design_summary` gives, per truth
and number, the coverage of the 90 % and 68 % intervals of the difference, how often a
direction is claimed (probability of the direction > 0.95) and the mean interval width; with a
true turgor change that rate is the power, with a wall change alone it is the rate of a false
"turgor changed".

Each experiment is fitted by the criticism's posterior engine on the fit's model (Laplace
proposal, Pareto-smoothed importance sampling, emcee where it fails;
:func:`turgorbayes.inference.engine.fit_posterior`) with the bulge population's noise carried
as ``fit`` carries it, about 1-3 s an experiment instead of a minute (checked against ``fit``:
docs/validation.md, "Comparing conditions").
"""

import numpy as np

from turgorbayes.inference import conditions, engine, models, wall_release
from turgorbayes.inference import population_noise as pop_noise
from turgorbayes.progress import progress
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation import conditions as synthetic_conditions

__all__ = ["DEFAULT_TRUTHS", "design_summary", "simulate_design", "write_design"]

#: True (E0t ratio, gamma difference, relative turgor change) of the treated condition: a
#: wall 30 % softer or stiffer at equal turgor, and a 25 % turgor drop with the wall shared.
DEFAULT_TRUTHS = ((0.7, 0.0, 0.0), (1.3, 0.0, 0.0), (1.0, 0.0, -0.25))
#: A direction is claimed when its posterior probability exceeds this.
CLAIM = 0.95


def _truth(seed, truth, wall_prior):
    """``truth``, or for ``"prior"`` a wall change drawn from ``wall_prior`` (no turgor
    change): the calibration over the prior itself."""
    if truth != "prior":
        return [tuple(float(x) for x in truth)]
    rng = np.random.default_rng(np.random.SeedSequence([seed, 51]))
    return [(float(np.exp(rng.normal(0, wall_prior["E0t"]))),
             float(rng.normal(0, wall_prior["gamma"])), 0.0) for _ in range(100)]


def experiment(seed, truth, n_bulged, n_intact, surrogate, wall_prior, P_ref=29e3,
               wall=synthetic.PAPER_TRUTH):
    """Cells of one simulated experiment (conditions ``wt`` and ``treated``) and its truth.

    A ``"prior"`` truth whose wall the FE table cannot produce (the wall buckles under the
    tip) is drawn again: the prior restricted to the model's domain, as the fit restricts it.
    """
    for ratio, dgamma, change in _truth(seed, truth, wall_prior):
        walls = {"treated": {"E0t": wall.E0t * ratio, "gamma": wall.gamma + dgamma}}
        try:
            cells = synthetic_conditions.simulate_conditions(
                {"wt": P_ref, "treated": P_ref * (1 + change)}, n_intact=n_intact,
                n_bulged=n_bulged, truth=wall, seed=seed, surrogate=surrogate, walls=walls)[0]
        except ValueError:
            if truth != "prior":
                raise
            continue
        return cells, (ratio, dgamma, change)
    raise ValueError(f"no wall of the prior produces a cell at seed {seed}")


def _posterior(cells, surrogate, wall_prior, seed):
    """Per-condition ``(P, gamma, E0t, R0)`` draws and weights of ``fit``'s model."""
    cs = conditions.condition_set(cells, wall_prior=wall_prior)
    model = conditions.ConditionsModel(cells, surrogate, cs)
    wls = models.PaperWLS(cells, surrogate).fit()
    settings = engine.Settings(engine="importance", progress=False)
    post = engine.fit_posterior(model, model.start_guess(wls.estimate), seed, settings,
                                pointwise=False)
    sigma_g = model.population_shift_covariance(post.u_map, post.cov, seed, pop_noise.N_BOOTSTRAP)
    u = pop_noise.carry(post.u, sigma_g, engine.stream_rng(seed, 1003), log_prior=model.log_prior)
    v = model.to_physical(u)
    w = post.weights / np.sum(post.weights)
    if wall_prior and cs.released("E0t", 1):
        new = wall_release.release({"P": v["P_phys__1"], "R0": v["R0__1"], "gamma": v["gamma"],
                                    "E0t": v["E0t"]}, wall_prior,
                                   engine.stream_rng(seed, 1010), models.P0, surrogate)
        v.update({"P_phys__1": new["P"], "R0__1": new["R0"], "gamma__1": new["gamma"],
                  "E0t__1": new["E0t"]})
        w = w * np.exp(new["log_weight"] - np.max(new["log_weight"]))
        w = w / np.sum(w)
    return [model.values(v, c) for c in (0, 1)], w, post.converged


def _score(x, w, truth):
    q = engine.weighted_quantiles(x, w, [0.05, 0.16, 0.5, 0.84, 0.95])
    return {"q05_q16_q50_q84_q95": np.asarray(q).tolist(), "in_90": bool(q[0] <= truth <= q[4]),
            "in_68": bool(q[1] <= truth <= q[3])}


def one_experiment(seed, truth, n_bulged, n_intact, surrogate, wall_prior):
    """Both numbers of one experiment, scored against its truth (two dicts)."""
    cells, (ratio, dgamma, change) = experiment(seed, truth, n_bulged, n_intact, surrogate,
                                                wall_prior)
    label = truth if truth == "prior" else ":".join(f"{x:g}" for x in truth)
    rows = []
    for name, prior in (("headline", wall_prior), ("shared_wall", None)):
        (wt, tr), w, ok = _posterior(cells, surrogate, prior, seed)
        rows.append({"seed": int(seed), "number": name, "truth_label": label,
                     "truth": {"E0t_ratio": ratio, "gamma_difference": dgamma, "change": change},
                     "difference_kPa": _score((tr[0] - wt[0]) / 1e3, w, 29.0 * change),
                     "prob_greater": float(np.sum(w * (tr[0] > wt[0]))),
                     "E0t_ratio": _score(tr[2] / wt[2], w, ratio), "converged": bool(ok)})
    return rows


def simulate_design(n_bulged=None, n_intact=42, truths=DEFAULT_TRUTHS, n_experiments=20,
                    seed=0, surrogate=None, wall_prior=None, progress_bar=True, on_row=None):
    """Simulate and fit experiments of one design (module docstring).

    Parameters
    ----------
    n_bulged : dict, optional
        ``{"wt": n, "treated": n}`` bulged cells per condition (default 72 in wt only, the
        paper's design).
    n_intact : int
        Intact cells per condition.
    truths : sequence
        ``(E0t ratio, gamma difference, relative turgor change)`` of treated, or ``"prior"``.
    n_experiments : int
        Experiments per truth (data seeds ``seed`` ...).
    seed : int
    surrogate : Surrogate, optional
    wall_prior : dict, optional
        Default :data:`turgorbayes.inference.conditions.WALL_PRIOR`.
    progress_bar : bool
    on_row : callable, optional
        Called with each result row as it is made (a study writes it to its file).

    Returns
    -------
    list of dict
        One row per experiment, truth and number (``headline``, ``shared_wall``).
    """
    from turgorbayes import surrogate as surrogate_module

    surrogate = surrogate_module.load() if surrogate is None else surrogate
    n_bulged = {"wt": 72} if n_bulged is None else dict(n_bulged)
    wall_prior = dict(conditions.WALL_PRIOR if wall_prior is None else wall_prior)
    rows = []
    jobs = [(s, t) for s in range(seed, seed + n_experiments) for t in truths]
    for s, t in progress(jobs, desc="experiments", unit="fit", enabled=progress_bar):
        for row in one_experiment(s, t, n_bulged, n_intact, surrogate, wall_prior):
            rows.append(row)
            if on_row is not None:
                on_row(row)
    return rows


def write_design(path, summary, rows):
    """Write a design's runs to the JSON file ``path``: ``provenance``
    (:func:`turgorbayes.provenance.run_record`), ``summary`` (:func:`design_summary`) and
    ``rows`` (:func:`simulate_design`)."""
    import json

    from turgorbayes.provenance import run_record

    with open(path, "w", encoding="utf-8") as f:
        json.dump({"provenance": run_record(), "summary": summary, "rows": rows}, f)


def design_summary(rows):
    """Per truth and number: experiments, converged, coverage of the 90 % and 68 % intervals of
    the turgor difference and of the E0t ratio (with binomial se), the rate of a claimed
    direction (probability > :data:`CLAIM` either way) and the mean 90 % width [kPa]."""
    out = {}
    for key in sorted({(r["truth_label"], r["number"]) for r in rows}):
        r = [x for x in rows if (x["truth_label"], x["number"]) == key]
        n = len(r)

        def rate(vals, n=n):
            p = float(np.mean(vals))
            return [p, float(np.sqrt(p * (1 - p) / n))]

        q = np.array([x["difference_kPa"]["q05_q16_q50_q84_q95"] for x in r])
        out[" ".join(key)] = {
            "n": n, "converged": sum(x["converged"] for x in r),
            "difference_coverage_90": rate([x["difference_kPa"]["in_90"] for x in r]),
            "difference_coverage_68": rate([x["difference_kPa"]["in_68"] for x in r]),
            "direction_claimed": rate([max(x["prob_greater"], 1 - x["prob_greater"]) > CLAIM
                                       for x in r]),
            "mean_width_90_kPa": float(np.mean(q[:, 4] - q[:, 0])),
            "E0t_ratio_coverage_90": rate([x["E0t_ratio"]["in_90"] for x in r])}
    return out


def summary_lines(summary):
    """The summary as a table of plain-text lines."""
    head = (f"{'truth (E0t ratio:gamma diff:turgor change)':<44}{'number':<13}{'n':>5}"
            f"{'covers 90%':>12}{'claims':>9}{'width90 kPa':>13}{'E0t ratio covers':>18}")
    lines = [head]
    for key, v in summary.items():
        truth, number = key.rsplit(" ", 1)
        lines.append(f"{truth:<44}{number:<13}{v['n']:>5}{v['difference_coverage_90'][0]:>12.2f}"
                     f"{v['direction_claimed'][0]:>9.2f}{v['mean_width_90_kPa']:>13.2f}"
                     f"{v['E0t_ratio_coverage_90'][0]:>18.2f}")
    return lines
