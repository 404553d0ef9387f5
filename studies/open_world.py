"""Open-world honesty of the criticism: leave the true effect out of the candidates.

For each effect of :mod:`turgorbayes.effects` that names a cause, simulate ``--n`` data sets
of the paper's design (72 bulged + 42 intact cells, seeds ``--first-seed`` ...) with that effect
at its realistic size, then run :func:`turgorbayes.workflows.criticize.criticize` with every OTHER
effect as a candidate (the generic ``discrepancy`` candidate included), and count

* **wrong explained**: the verdict is ``explained`` (a cause is stated as fact, and the true
  one was not a candidate) by an effect outside the true effect's family (effects that
  describe the same data near-equally, ``Effect.family``, count as one); target <= 0.10;
* **honest**: among the data sets where the baseline's checks flag misfit, the share whose
  verdict is ``partly_explained`` or ``unexplained``; target >= 0.8;
* **P cov**: the 90 % interval of the quoted P_phys (the verdict's headline, the model
  average) covers the truth; target >= 0.85; also the baseline's and the adopted model's;
* **gross**: data sets where a reading is called a gross error (the effect is not one);
* with ``null`` in ``--effects``: data from the baseline criticized with every candidate,
  the share whose verdict is ``no_misfit`` (target >= 0.9).

Scenarios outside the library (every candidate fitted, nothing to leave out), named in
:data:`SCENARIOS`: e.g. ``understated_k_c_errors``, baseline data whose reported ``k_c`` errors
are half the true ones (a lab that quotes the repeatability of one curve, not the cell-to-cell
scatter of its readings); ``wall_spread`` and ``compliant_support`` are two causes of our own
design that no candidate names (cells whose walls differ; cells on a support that gives).

Designs: ``calibration`` data are measured in 6 sessions (it needs them); ``radius_spread``
data have 8-12 nm radius errors (its realistic size hides in larger ones; docs/effects.md).
Every row records the commit, the arguments, the date, the machine and the package version.

Usage::

    python studies/open_world.py --n 20 [--effects turgor_spread,null] [--first-seed 1000] \
        [--json studies/results/open_world.jsonl]
    python studies/open_world.py --summarize ROWS.jsonl [MORE.jsonl ...]
"""

import argparse
import dataclasses
import json
import sys
import time
from pathlib import Path

import numpy as np

from turgorbayes import effects, provenance, surrogate
from turgorbayes.simulation.cells import simulate_cells
from turgorbayes.simulation.planted import planted_cells
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

TRUE_P_PHYS_KPA = 29.0


#: A smoke run: one data set of 24 bulged + 14 intact cells, one candidate, few draws and
#: replicates, short chains.
SMOKE_CELLS = (24, 14)
SMOKE_SETTINGS = {"n_rep": 50, "ess_min": 20, "n_ensembles": 2, "tol": 5, "check_every": 20,
                  "max_steps": 200, "flag_draws": 20, "max_refits": 0}

#: Scenarios that no effect describes: name -> what they do to baseline data.
SCENARIOS = {
    "understated_k_c_errors": "reported k_c errors half the true ones",
    "late_contact_point": ("every cell's contact point read late by a skewed amount "
                           "e = 0.12 |N(0, 1)|: R_c x exp(-0.3 e), k_c x exp(e)"),
    "stiffness_drift": ("every stiffness (k_c, k_b) drifting by 30 % over the session, the "
                        "rows in measurement order (bulged cells first)"),
    # two causes of our own design that no candidate names (docs/validation.md, "When the cause
    # is not in the library"):
    "wall_spread": ("every cell's wall stiffness E0t its own, lognormal about the population's "
                    "with a log-sd of 0.2 (sacculi differing in thickness or cross-linking)"),
    "compliant_support": ("every cell rests on a compliant support in series with it (an "
                          "agarose pad, a soft coating, a cell only partly attached): each "
                          "stiffness read as k k_s / (k + k_s), k_s lognormal per cell with a "
                          "median of 0.08 N/m (about 2 E a for a 1.5 % agarose pad, E about "
                          "130 kPa, under a contact 0.3 um wide) and a log-sd of 0.3"),
}

#: The causes of our own design outside the library (module docstring).
OWN_DESIGN = ("wall_spread", "compliant_support")
#: ``wall_spread``: log-sd of a cell's E0t about the population's.
WALL_SPREAD_LOG_SD = 0.2
#: ``compliant_support``: median [N/m] and log-sd of the support's stiffness k_s.
SUPPORT_K_MEDIAN, SUPPORT_K_LOG_SD = 0.08, 0.3


@dataclasses.dataclass
class _WallSpread:
    """A simulation injection (:func:`turgorbayes.simulation.cells.simulate_cells`): every
    cell's E0t times ``exp(log_sd z)``, z standard normal per cell."""

    log_sd: float = WALL_SPREAD_LOG_SD

    def cell_parameters(self, params, design, rng):
        out = dict(params)
        out["E0t"] = params["E0t"] * np.exp(self.log_sd * rng.standard_normal(design.P.size))
        return out

    def describe(self):
        return {"effect": "wall_spread (open_world study)", "E0t_log_sd": self.log_sd}


def _compliant_support(cells, seed):
    """Each stiffness (k_c, k_b and their errors) in series with a support of stiffness k_s
    (:data:`SUPPORT_K_MEDIAN`, :data:`SUPPORT_K_LOG_SD`), drawn per cell from stream
    ``[seed, 2]``: a spring ``k`` on a spring ``k_s`` reads ``k k_s / (k + k_s)``."""
    rng = np.random.default_rng([seed, 2])
    k_s = SUPPORT_K_MEDIAN * np.exp(SUPPORT_K_LOG_SD * rng.standard_normal(len(cells.k_c)))
    out = {}
    for name in ("k_c", "k_b"):
        k = getattr(cells, name)
        factor = np.where(np.isfinite(k), k_s / (k + k_s), 1.0)
        out[name] = k * factor
        out[f"{name}_err"] = getattr(cells, f"{name}_err") * factor
    return dataclasses.replace(cells, **out)


def named_effects():
    """The effects that name a cause (every candidate but the generic ones)."""
    return [n for n in effects.effect_names() if effects.get_effect(n).names_cause]


def simulate(name, seed, table, n_cells=()):
    """One data set with ``name`` at its realistic size (``"null"``: the baseline; a name of
    :data:`SCENARIOS`: baseline data changed as it says); ``n_cells``: (bulged, intact), or
    empty for the paper's."""
    if name == "wall_spread":
        return simulate_cells(*(n_cells or (72, 42)), seed=seed, surrogate=table,
                              effects=[_WallSpread()])[0]
    cells = planted_cells("null" if name in SCENARIOS else name, seed, table, *n_cells)
    if name == "compliant_support":
        cells = _compliant_support(cells, seed)
    if name == "understated_k_c_errors":
        cells = dataclasses.replace(cells, k_c_err=0.5 * cells.k_c_err)
    if name == "late_contact_point":
        e = 0.12 * np.abs(np.random.default_rng([seed, 1]).standard_normal(len(cells.k_c)))
        cells = dataclasses.replace(cells, R_c=cells.R_c * np.exp(-0.3 * e),
                                    k_c=cells.k_c * np.exp(e))
    if name == "stiffness_drift":
        drift = np.exp(np.log(1.3) * (np.arange(len(cells.k_c)) / (len(cells.k_c) - 1) - 0.5))
        cells = dataclasses.replace(cells, k_c=cells.k_c * drift, k_c_err=cells.k_c_err * drift,
                                    k_b=cells.k_b * drift, k_b_err=cells.k_b_err * drift)
    return cells


def _covered(entry):
    return bool(entry["q05"] <= TRUE_P_PHYS_KPA <= entry["q95"])


def one(name, seed, table, draws, smoke=False):
    """Criticize one data set with ``name`` left out of the candidates; a dict of outcomes
    (``smoke``: :data:`SMOKE_SETTINGS`, the first applicable candidate only)."""
    cells = simulate(name, seed, table, SMOKE_CELLS if smoke else ())
    candidates = tuple(n for n in effects.effect_names() if n != name)
    settings = CriticismSettings(
        n_draws=draws, n_rep=700, max_refits=3, effects=candidates,
        n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                                 max_steps=4000, progress=False)
    skipped = [n for n in candidates if effects.get_effect(n).not_applicable_reason(cells)]
    settings.effects = tuple(n for n in candidates if n not in skipped)
    if smoke:
        settings = dataclasses.replace(settings, effects=settings.effects[:1], **SMOKE_SETTINGS)
    t0 = time.perf_counter()
    res = criticize(cells, table, seed=seed, settings=settings)
    d = criticism_dict(res)
    v = d["verdict"]
    params = d["parameters"]
    return {
        "effect": name, "seed": seed, "status": v["status"], "selected": v["selected"],
        "remaining_checks": v["remaining_checks"], "text": v["text"],
        "baseline_flagged": [c["name"] for c in d["checks"] if c["flagged"]],
        "P_covered_headline": _covered(params[d["headline"]]["P_phys_kPa"]),
        "P_covered_baseline": _covered(params["baseline"]["P_phys_kPa"]),
        "P_covered_adopted": _covered((params["extended"] or params["baseline"])["P_phys_kPa"]),
        "P_headline": [params[d["headline"]]["P_phys_kPa"][q] for q in ("q05", "q50", "q95")],
        "headline": d["headline"],
        "P_covered_model_average": _covered(params["model_average"]["P_phys_kPa"]),
        "P_width": {k: params[k]["P_phys_kPa"]["q95"] - params[k]["P_phys_kPa"]["q05"]
                    for k in ("baseline", "model_average", "widened") if params.get(k)},
        "gross_errors_named": bool(d["flagged_cells"]) and "gross error" in " ".join(
            f["reason"] for f in d["flagged_cells"]),
        "n_flagged_readings": len(d["flagged_cells"]),
        "weights": res.stacking["weights"],
        "delta_elpd": {c["effect"]: None if c["delta_elpd"] is None else round(c["delta_elpd"], 2)
                       for c in d["candidates"]},
        "n_fits": len(res.posteriors),
        "n_converged": sum(bool(p.converged) for p in res.posteriors.values()),
        "time_s": round(time.perf_counter() - t0, 1),
    }


#: Scenarios that an effect of the library now describes: scenario -> that effect (its
#: cause is the scenario's: a drift of the stiffness with measurement order; one contact point
#: setting a cell's R_c and k_c, so their errors correlate).
SCENARIO_EFFECT = {"stiffness_drift": "drift", "late_contact_point": "correlated_errors"}


def same_family(hidden, selected):
    """True when the selected model holds an effect of the hidden effect's family
    (:attr:`turgorbayes.effects.base.Effect.family`): a near-equivalent description; for a
    scenario of :data:`SCENARIO_EFFECT`, the effect that describes it (or its family)."""
    hidden = SCENARIO_EFFECT.get(hidden, hidden)
    if hidden == "null" or hidden in SCENARIOS or not selected:
        return False
    names = effects.parse_model_name(selected)
    fam = effects.get_effect(hidden).family
    return hidden in names or bool(fam) and any(effects.get_effect(n).family == fam
                                                for n in names)


def read_rows(paths):
    """The JSON rows of JSON-lines files."""
    return [json.loads(line) for p in paths
            for line in Path(p).read_text().splitlines() if line.startswith("{")]


def pooled_first_rule(rows, first):
    """Rows of the first verdict rule whose status the current rule gives too: the current
    rule differs only by turning some ``explained`` into ``partly_explained`` (a named effect
    must also beat the generic description), so every other status stands; data sets
    already in ``rows`` are left out."""
    have = {(r["effect"], r["seed"]) for r in rows}
    return [dict(r, rule="first") for r in first
            if r["status"] != "explained" and (r["effect"], r["seed"]) not in have]


def _wrong_cause(row):
    """The row's verdict states as fact a cause outside the hidden one's family."""
    return row["status"] == "explained" and not same_family(row["effect"], row["selected"])


def _by_effect(rows):
    """``{effect: [rows]}``, effects in their first row's order."""
    by = {}
    for r in rows:
        by.setdefault(r["effect"], []).append(r)
    return by


def _median_widths(rows):
    """``quoted / baseline`` median 90 % widths [kPa], ``-`` for rows of a study version that
    did not record them."""
    if not all("P_headline" in r and "P_width" in r for r in rows):
        return "-"
    quoted = np.median([r["P_headline"][2] - r["P_headline"][0] for r in rows])
    return f"{quoted:.1f} / {np.median([r['P_width']['baseline'] for r in rows]):.1f}"


def summarize(rows):
    """Rates per left-out effect as printable lines."""
    lines = ["| effect left out (and simulated) | n | wrong explained | honest where flagged | "
             "P cov (quoted) | P cov baseline | P cov adopted | gross errors named | "
             "median 90 % width, quoted / baseline [kPa] | statuses |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, rs in _by_effect(rows).items():
        n = len(rs)
        flagged = [r for r in rs if r["baseline_flagged"] or r["status"] != "no_misfit"]
        honest = sum(r["status"] in ("partly_explained", "unexplained") for r in flagged)
        statuses = {}
        for r in rs:
            statuses[r["status"]] = statuses.get(r["status"], 0) + 1
        wrong = sum(_wrong_cause(r) for r in rs)
        if name == "null":
            wrong_txt, honest_txt = "-", f"no_misfit {statuses.get('no_misfit', 0)}/{n}"
        else:
            wrong_txt = f"{wrong}/{n}"
            honest_txt = f"{honest}/{len(flagged)}" if flagged else "- (none flagged)"
        lines.append(
            f"| {name} | {n} | {wrong_txt} | {honest_txt} | "
            f"{sum(r['P_covered_headline'] for r in rs)}/{n} | "
            f"{sum(r['P_covered_baseline'] for r in rs)}/{n} | "
            f"{sum(r['P_covered_adopted'] for r in rs)}/{n} | "
            f"{sum(r['gross_errors_named'] for r in rs)}/{n} | "
            f"{_median_widths(rs)} | "
            + ", ".join(f"{k} {v}" for k, v in sorted(statuses.items())) + " |")
    return lines


def _rate(k, n):
    return f"{k}/{n} = {k / n:.2f}" if n else "-"


def _headline_covers(r, no_misfit_headline):
    """The quoted interval covers the truth, with ``no_misfit_headline`` (``"model_average"``
    or ``"baseline"``) quoted under ``no_misfit`` and the row's own headline otherwise."""
    if r["status"] == "no_misfit" and no_misfit_headline == "baseline":
        return r["P_covered_baseline"]
    return r["P_covered_headline"]


def done_when(rows, no_misfit_headline="model_average"):
    """The open-world-II targets over ``rows`` (docs/validation.md, "When the cause is not in
    the library"): the quoted P_phys's 90 % coverage overall and per cause whose misfit the
    baseline's checks flag (in most of its data sets), wrong causes stated as fact, and on
    nulls the ``no_misfit`` rate, the headline's coverage and its width against the
    baseline's (median of the per-data-set ratios)."""
    effect_rows = [r for r in rows if r["effect"] != "null"]
    nulls = [r for r in rows if r["effect"] == "null"]
    covered = sum(_headline_covers(r, no_misfit_headline) for r in effect_rows)
    wrong = sum(_wrong_cause(r) for r in effect_rows)
    known = [r for r in effect_rows if r["effect"] not in OWN_DESIGN]
    lines = [f"headline under no_misfit: {no_misfit_headline}",
             f"  quoted P_phys covers the truth: {_rate(covered, len(effect_rows))} "
             "(target >= 0.85); without the causes of our own design "
             f"({', '.join(OWN_DESIGN)}): "
             f"{_rate(sum(_headline_covers(r, no_misfit_headline) for r in known), len(known))}",
             f"  wrong cause stated as fact: {_rate(wrong, len(effect_rows))} (target <= 0.05)"]
    low = []
    for name, rs in sorted(_by_effect(effect_rows).items()):
        flagged = sum(bool(r["baseline_flagged"]) for r in rs)
        cov = sum(_headline_covers(r, no_misfit_headline) for r in rs)
        if 2 * flagged > len(rs) and cov < 0.7 * len(rs):
            low.append(f"{name} {cov}/{len(rs)} (flagged {flagged})")
    lines.append("  causes flagged in most data sets with coverage below 0.7: "
                 + (", ".join(low) or "none"))
    lines += _by_what_the_checks_saw(effect_rows, no_misfit_headline)
    if nulls:
        quiet = sum(r["status"] == "no_misfit" for r in nulls)
        cov = sum(_headline_covers(r, no_misfit_headline) for r in nulls)
        key = "baseline" if no_misfit_headline == "baseline" else "model_average"
        ratios = [r["P_width"][key] / r["P_width"]["baseline"] for r in nulls
                  if r["status"] == "no_misfit"]
        lines.append(f"  nulls: no_misfit {_rate(quiet, len(nulls))} (target >= 0.9); headline "
                     f"covers {_rate(cov, len(nulls))} (target 0.85-0.95); width / baseline's "
                     f"under no_misfit: median {np.median(ratios):.2f} (target <= 1.1)")
    return lines


def _by_what_the_checks_saw(rows, no_misfit_headline):
    """Coverage of the quoted P_phys split by the verdict: where it reports misfit (any status
    but ``no_misfit``) and where it sees none; for the second, per effect, the median shift of
    the quoted median from the truth against the median half-width of the quoted interval
    (an effect that leaves no trace the checks see, and shifts P_phys by more than that
    half-width, is missed by any interval no wider than on data without misfit)."""
    seen = [r for r in rows if r["status"] != "no_misfit"]
    unseen = [r for r in rows if r["status"] == "no_misfit"]

    def covered(rs):
        return _rate(sum(_headline_covers(r, no_misfit_headline) for r in rs), len(rs))

    lines = [f"  where the verdict reports misfit: covers {covered(seen)}; where it sees none "
             f"(no_misfit): {covered(unseen)}"]
    if no_misfit_headline != "model_average":  # the rows record the quoted interval only
        return lines
    for name, rs in _by_effect(unseen).items():
        if not all("P_headline" in r for r in rs):
            continue
        q = np.array([r["P_headline"] for r in rs]) / TRUE_P_PHYS_KPA * 100
        shift, half = np.median(q[:, 1] - 100), np.median((q[:, 2] - q[:, 0]) / 2)
        cov = sum(_headline_covers(r, no_misfit_headline) for r in rs)
        lines.append(f"    no_misfit, {name}: {cov}/{len(rs)} covered; median shift "
                     f"{shift:+.1f} % against a median half-width of {half:.1f} %")
    return lines


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=20, help="data sets per effect")
    parser.add_argument("--effects", default=None,
                        help="comma-separated effects to leave out, and 'null' (default: every "
                             "effect that names a cause, then null)")
    parser.add_argument("--first-seed", type=int, default=1000)
    parser.add_argument("--draws", type=int, default=1000, help="importance draws per round")
    parser.add_argument("--json", default=None, help="append every outcome to this JSON-lines file")
    parser.add_argument("--summarize", nargs="+", default=None, metavar="ROWS.jsonl")
    parser.add_argument("--first-rule", nargs="+", default=(), metavar="ROWS.jsonl",
                        help="with --summarize: also count rows of the first verdict rule "
                             "(before a named effect had to beat the generic description) whose "
                             "status cannot differ under the current rule (not 'explained') and "
                             "whose data set is not in the current rows")
    args = provenance.add_output_options(parser).parse_args(argv)
    if args.smoke:  # one data set with one effect left out (see one()), rows in --output-dir
        args.n, args.draws = 1, 200
        args.effects = (args.effects or named_effects()[0]).split(",")[0]
        args.json = args.json or str(provenance.study_path(args, "open_world.jsonl"))
        open(args.json, "w").close()
    if args.summarize:
        rows = read_rows(args.summarize)
        rows += pooled_first_rule(rows, read_rows(args.first_rule))
        print("\n".join(summarize(rows)))
        if not args.first_rule:  # the targets need every row under one rule
            for headline in ("model_average", "baseline"):
                print("\n".join(done_when(rows, headline)))
        return
    table = surrogate.load()
    names = args.effects.split(",") if args.effects else named_effects() + ["null"]
    prov = provenance.run_record(argv)
    rows = []
    for name in names:
        for seed in range(args.first_seed, args.first_seed + args.n):
            row = dict(one(name, seed, table, args.draws, args.smoke), provenance=prov)
            rows.append(row)
            print(json.dumps(row), flush=True)
            if args.json:
                with open(args.json, "a") as f:
                    f.write(json.dumps(row) + "\n")
    print("\n".join(summarize(rows)))


if __name__ == "__main__":
    main()
