"""Power of the criticism when the data's effect has another form than the extension assumes.

Every effect's hidden-effect test plants it in exactly the form its likelihood assumes. Real
effects are not so kind. Each form below is a generator the likelihood does not contain; the
effect expected to catch it is named beside it:

================== ===================================================== ==========================
form               what the simulator does                               expected selection
================== ===================================================== ==========================
heavy_tailed_kc    k_c noise Student-t (3 dof, same sd) instead of       outliers or bad_curves
                   normal
uniform_corruption 10 % of the k_c readings times U[0.2, 0.6] (not the    bad_curves or outliers
                   likelihood's lognormal around 0.5)
gamma_spread       R0 per cell gamma-distributed (cv 0.02), not           radius_spread
                   lognormal; radius errors 8-12 nm
linear_softening   bulged cells' E0t times 1 - 0.6 (P - 1 kPa)/(24 kPa)   wall_softening
                   (softening grows with pressure) instead of a constant
uniform_bulge      bulge pressures off by a factor e^u, u uniform on      pressure_error
                   +-0.52 (sd 0.3, the effect's size) instead of normal
uniform_sessions   6 sessions, each session's stiffnesses times a factor  calibration
                   uniform on 1 +- 0.26 (sd 0.15) instead of lognormal
factor_slips       2 % of the R_c, k_c and k_b readings times 4 or 1/4    outliers or bad_curves
                   (a fixed factor) instead of lognormal around the value
================== ===================================================== ==========================

For each form ``--n`` data sets (seeds 2000, 2001, ...) of the paper's design are criticized
blind with every effect as a candidate; the script counts how often an expected effect is
selected (alone or paired: power), another one (wrong), whether the adopted model's (and the
model average's) 90 % interval of P_phys covers the truth (P cov; rows written before this
was recorded show "-"), and the converged fits. Targets
(dirty-data issue): power >= 0.9, false selection of the null <= 0.1
(``studies/criticism_power.py`` gives the null).

Usage::

    python studies/mismatched_forms.py --n 20 [--forms heavy_tailed_kc,gamma_spread] \
        > studies/results/mismatched_forms.jsonl
    python studies/mismatched_forms.py --summarize studies/results/mismatched_forms.jsonl
    python studies/mismatched_forms.py --coverage --n 40 --forms heavy_tailed_kc

Heavy: like the power study, 1-3 min per data set on two cores.
"""

import argparse
import dataclasses
import json
import time
from pathlib import Path

import numpy as np

from turgorbayes import __version__, criticism, effects, provenance, surrogate
from turgorbayes.errors import DataError
from turgorbayes.inference import models
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

TRUE_P_PHYS_KPA = 29.0

#: form -> effects whose selection counts as found
EXPECTED = {"heavy_tailed_kc": ("heavy_tails", "outliers", "bad_curves"),
            "uniform_corruption": ("bad_curves", "outliers"),
            "gamma_spread": ("radius_spread",),
            "linear_softening": ("wall_softening",),
            "uniform_bulge": ("pressure_error",),
            "uniform_sessions": ("calibration",),
            "factor_slips": ("outliers", "bad_curves")}
#: A smoke run: one data set of 24 bulged + 14 intact cells, the form's first expected effect the
#: only candidate, few draws and replicates, short chains.
SMOKE_CELLS = (24, 14)
SMOKE_SETTINGS = {"n_draws": 200, "n_rep": 50, "ess_min": 20, "n_ensembles": 2, "tol": 5,
                  "check_every": 20, "max_steps": 200, "flag_draws": 20, "max_refits": 0}
#: Forms whose data are measured in sessions (``simulate_cells(n_sessions=...)``).
N_SESSIONS = {"uniform_sessions": 6}
#: Half-widths of the uniform forms: sd 0.3 in ln P (pressure_error's realistic size) and 0.15
#: in the session factor (calibration's), the sd of U[-a, a] being a / sqrt(3).
UNIFORM_HALF_WIDTH = {"uniform_bulge": 0.3 * np.sqrt(3.0), "uniform_sessions": 0.15 * np.sqrt(3.0)}


class Form:
    """An effect in a form no likelihood assumes, in the protocol of
    :func:`turgorbayes.simulation.cells.simulate_cells` (``cell_parameters``, ``observations``)."""

    def __init__(self, name):
        self.name = name

    def cell_parameters(self, params, design, rng):
        out = dict(params)
        if self.name == "gamma_spread":
            cv = 0.02
            out["R0"] = params["R0"] * rng.gamma(1 / cv**2, cv**2, design.P.shape)
        elif self.name == "linear_softening":
            s = 1 - 0.6 * (design.P - 1e3) / 24e3
            out["E0t"] = np.where(design.is_bulged, params["E0t"] * s, params["E0t"])
        return out

    def observations(self, obs, design, rng):
        obs = dict(obs)
        k_true = obs["k_c_err"] / design.k_c_rel_sd  # reported as rel_sd x true k_c
        if self.name == "heavy_tailed_kc":
            t = rng.standard_t(3, k_true.shape) / np.sqrt(3.0)  # unit variance
            obs["k_c"] = k_true * (1 + design.k_c_rel_sd * t)
        elif self.name == "uniform_corruption":
            bad = rng.random(k_true.shape) < 0.1
            obs["k_c"] = np.where(bad, k_true * rng.uniform(0.2, 0.6, k_true.shape), obs["k_c"])
        elif self.name == "uniform_bulge":  # k_b and its reported error, as pressure_error does
            a = UNIFORM_HALF_WIDTH[self.name]
            f = np.where(design.is_bulged, np.exp(rng.uniform(-a, a, k_true.shape)), 1.0)
            obs["k_b"], obs["k_b_err"] = obs["k_b"] * f, obs["k_b_err"] * f
        elif self.name == "factor_slips":  # each reading on its own, up or down by 4
            for key in ("R_c", "k_c", "k_b"):
                ok = np.isfinite(obs[key])
                slip = ok & (rng.random(ok.shape) < 0.02)
                obs[key] = np.where(slip, obs[key] * 4.0 ** rng.choice([-1.0, 1.0], ok.shape),
                                    obs[key])
        elif self.name == "uniform_sessions":  # every stiffness of a session, as calibration
            labels = obs["extra"]["session"]
            sessions = sorted(set(labels))
            a = UNIFORM_HALF_WIDTH[self.name]
            factor = dict(zip(sessions, 1 + rng.uniform(-a, a, len(sessions)), strict=True))
            c = np.array([factor[x] for x in labels])
            for key in ("k_c", "k_c_err", "k_b", "k_b_err"):
                obs[key] = obs[key] * c
        return obs

    def describe(self):
        return {"form": self.name, "expected": list(EXPECTED[self.name])}


def one(form, seed, table, settings, smoke=False):
    """Criticize one data set simulated with ``form``; a dict of outcomes (``smoke``: see
    :data:`SMOKE_SETTINGS`)."""
    errors = synthetic.ErrorModel(R_c_sd=(8e-9, 12e-9)) if form == "gamma_spread" else \
        synthetic.ErrorModel()
    if smoke:
        settings = dataclasses.replace(settings, effects=EXPECTED[form][:1], **SMOKE_SETTINGS)
    cells, _ = synthetic.simulate_cells(*(SMOKE_CELLS if smoke else ()), seed=seed,
                                        surrogate=table, effects=[Form(form)], errors=errors,
                                        n_sessions=N_SESSIONS.get(form))
    t0 = time.perf_counter()
    res = criticize(cells, table, seed=seed, settings=settings)
    sel = res.selected
    names = effects.parse_model_name(sel) if sel else []
    found = any(n in EXPECTED[form] for n in names)
    d = criticism_dict(res)
    P = (d["parameters"]["extended"] or d["parameters"]["baseline"])["P_phys_kPa"]
    A = res.stacking["parameters"]["P_phys_kPa"]
    return {"form": form, "seed": seed, "version": __version__, "selected": sel,
            "found": bool(found), "wrong": bool(sel is not None and not found),
            "time_s": time.perf_counter() - t0,
            "n_fits": len(res.posteriors),
            "n_converged": sum(bool(p.converged) for p in res.posteriors.values()),
            "P_covered": bool(P["q05"] <= TRUE_P_PHYS_KPA <= P["q95"]),
            "P_covered_avg": bool(A["q05"] <= TRUE_P_PHYS_KPA <= A["q95"])}


def _rate(rs, key):
    vals = [r[key] for r in rs if key in r]
    return f"{np.mean(vals):.2f}" if vals else "-"


def baseline_coverage(form, seed, table):
    """Does the baseline alone still cover the truth under ``form``? 90 % intervals of the
    baseline posterior (Laplace + importance sampling, emcee fallback) for the four wall
    parameters (``--coverage``: a form the selection does not name may still be harmless)."""
    errors = synthetic.ErrorModel(R_c_sd=(8e-9, 12e-9)) if form == "gamma_spread" else \
        synthetic.ErrorModel()
    try:
        cells, _ = synthetic.simulate_cells(seed=seed, surrogate=table, errors=errors,
                                            effects=[] if form == "null" else [Form(form)])
    except DataError as err:  # a heavy tail can draw a negative stiffness: no data set
        return {"form": form, "seed": seed, "converged": False, "coverage": True,
                "error": str(err)}
    model = effects.ExtendedModel(cells, table, [])
    start = model.start_values(models.PaperWLS(cells, table).fit().estimate)
    try:
        post = criticism.fit_posterior(model, start, seed, CriticismSettings())
    except ValueError as err:  # e.g. no finite starting point: counted, not hidden
        return {"form": form, "seed": seed, "converged": False, "coverage": True,
                "error": str(err)}
    s = post.summary(np.random.default_rng(seed))
    truth = synthetic.PAPER_TRUTH
    keys = {"gamma": ("gamma", 1.0), "E0t": ("E0t_N_per_m", 1.0), "R0": ("R0_nm", 1e9),
            "P_phys": ("P_phys_kPa", 1e-3)}
    out = {"form": form, "seed": seed, "converged": bool(post.converged), "coverage": True}
    for name, (key, f) in keys.items():
        out[f"{name}_covered"] = bool(s[key]["q05"] <= getattr(truth, name) * f <= s[key]["q95"])
    return out


def summarize(rows):
    lines = [f"{'form':<20}{'n':>4}{'power':>7}{'wrong':>7}{'P cov':>7}{'avg P cov':>10}"
             f"{'converged':>11}{'median s':>9}"]
    for form in dict.fromkeys(r["form"] for r in rows):
        rs = [r for r in rows if r["form"] == form]
        conv = f"{sum(r['n_converged'] for r in rs)}/{sum(r['n_fits'] for r in rs)}"
        lines.append(f"{form:<20}{len(rs):>4}{np.mean([r['found'] for r in rs]):>7.2f}"
                     f"{np.mean([r['wrong'] for r in rs]):>7.2f}{_rate(rs, 'P_covered'):>7}"
                     f"{_rate(rs, 'P_covered_avg'):>10}{conv:>11}"
                     f"{np.median([r['time_s'] for r in rs]):>9.0f}")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--forms", default=",".join(EXPECTED))
    ap.add_argument("--first-seed", type=int, default=2000)
    ap.add_argument("--summarize", nargs="+", default=None, metavar="ROWS.jsonl")
    ap.add_argument("--coverage", action="store_true",
                    help="only the baseline's 90 %% coverage of the wall parameters per form "
                         "('null' in --forms: data without any effect, the reference)")
    a = provenance.add_output_options(ap).parse_args(argv)
    if a.smoke:  # one data set of one form (see one())
        a.n, a.forms = 1, a.forms.split(",")[0]
    provenance.tee_stdout(a, "mismatched_forms.txt")
    print(provenance.header_line(), flush=True)
    if a.summarize:
        rows = [json.loads(line) for p in a.summarize for line in Path(p).read_text().splitlines()
                if line.startswith("{")]
        print("\n".join(summarize(rows)))
        return
    table = surrogate.load()
    if a.coverage:
        for form in a.forms.split(","):
            rs = [baseline_coverage(form, a.first_seed + i, table) for i in range(a.n)]
            for r in rs:
                print(json.dumps(r), flush=True)
            conv = [r for r in rs if r["converged"]]
            print(f"{form}: baseline 90 % coverage over {len(conv)} converged of {len(rs)}: " +
                  ", ".join(f"{p} {np.mean([r[p + '_covered'] for r in conv]):.2f}"
                            for p in ("gamma", "E0t", "R0", "P_phys")), flush=True)
        return
    settings = CriticismSettings(
        n_draws=1000, n_rep=700, max_refits=3,
        n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                                 max_steps=4000, progress=False)
    rows = []
    for form in a.forms.split(","):
        if form not in EXPECTED:
            ap.error(f"unknown form {form!r}; known: {', '.join(EXPECTED)}")
        for i in range(a.n):
            rows.append(one(form, a.first_seed + i, table, settings, a.smoke))
            print(json.dumps(rows[-1]), flush=True)
    print("\n".join(summarize(rows)))


if __name__ == "__main__":
    main()
