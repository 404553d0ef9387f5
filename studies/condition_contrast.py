"""Calibration of the turgor difference between two conditions, and the run time of a
two-condition fit against a one-condition fit of the same cells.

``--study calibration``: ``--n`` simulated two-condition experiments per true difference (wt
at 29 kPa with 72 bulged + 42 intact cells, treated with 42 intact cells at 29 kPa (difference
0) or 21.75 kPa (-25 %); the paper's wall shared; data seeds from ``--first-seed``), each
fitted by :func:`turgorbayes.workflows.conditions.fit_conditions` with the CLI's settings.
A JSON line per fit: the contrast of P_phys (difference, ratio, prob_greater), whether the
true difference lies in the 90 % and 68 % intervals of the difference (quantiles of the draws),
convergence and the time. The last line summarizes, per truth: coverage of both intervals
(with the binomial standard error) and, on the null, the rate of prob_greater > 0.95.

``--n-intact N`` sets the intact cells per condition (default 42) and ``--changes`` the true
relative differences (default ``0,-0.25``): the power design runs the null at 42, 84 and 168
intact cells (the posterior sd of the difference and the scatter of its z-score there give the
smallest change detected in 80 % of experiments) and checks that prediction directly at the
predicted change.

``--engine importance`` fits each experiment with the criticism's posterior engine (Laplace
proposal, Pareto-smoothed importance sampling accepted only with k-hat <= 0.7 and ESS >= 400,
emcee where it fails; :func:`turgorbayes.inference.engine.fit_posterior`) on the same
:class:`~turgorbayes.inference.conditions.ConditionsModel`, with the bulge population's noise
carried as the fit carries it; cheap enough for hundreds of experiments. ``--compare A B``
prints the agreement of two runs on their common (seed, change) pairs (the engine check).
``--design lognormal`` draws the bulged cells' pressures from a smooth population instead of
the paper's log-uniform one with hard edges.

``--study timing``: one experiment fitted twice, with its condition column and without it
(every cell in one condition), side by side; writes both times and their ratio.

Every result file starts with a ``# provenance:`` line
(:func:`turgorbayes.provenance.header_line`).

Run: .venv/bin/python studies/condition_contrast.py --study calibration --n 10 \\
         --out studies/results/condition_contrast_pilot.jsonl
     .venv/bin/python studies/condition_contrast.py --engine importance --n 150 \\
         --first-seed 4150 --out studies/results/condition_contrast_is_loguniform_b.jsonl
     .venv/bin/python studies/condition_contrast.py --engine importance --n 100 \\
         --first-seed 5000 --n-intact 84 --changes 0 \\
         --out studies/results/condition_contrast_is_power84.jsonl
     .venv/bin/python studies/condition_contrast.py --compare \\
         studies/results/condition_contrast_calibration.jsonl \\
         studies/results/condition_contrast_is_check_b.jsonl
     .venv/bin/python studies/condition_contrast.py --study timing \\
         --out studies/results/condition_contrast_timing.txt
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np

from turgorbayes import provenance, surrogate
from turgorbayes.cells.table import CellData
from turgorbayes.inference import conditions, engine, models
from turgorbayes.inference import population_noise as pop_noise
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation import conditions as synthetic_conditions
from turgorbayes.workflows import fit as results
from turgorbayes.workflows.conditions import fit_conditions

P_REF = 29e3
TRUE_CHANGES = (0.0, -0.25)
#: The sampler's settings of a smoke run: short chains, a few bootstrap populations.
SMOKE_SAMPLER = {"n_walkers": 12, "n_ensembles": 2, "tol": 5, "check_every": 20, "max_steps": 40,
                 "max_draws_per_chain": 50, "population_noise_bootstrap": 4}


#: The detection rule of the power table: prob_greater below 0.05 or above 0.95.
DETECT = (0.05, 0.95)
#: Standard normal quantiles of the one-sided 5 % threshold and of 80 % power.
Z_95, Z_80 = 1.6448536269514722, 0.8416212335729143


def experiment(seed, change, table, n_intact=42, design="loguniform"):
    """Cells of one two-condition experiment; the treated turgor is ``P_REF (1 + change)``;
    ``design`` the bulged cells' pressure population."""
    return synthetic_conditions.simulate_conditions(
        {"wt": P_REF, "treated": P_REF * (1 + change)}, n_intact=n_intact, n_bulged={"wt": 72},
        seed=seed, surrogate=table, design_kwargs={"P_distribution": design})[0]


def _emcee_pair(cells, seed, table, settings):
    """P_phys of (wt, treated) [Pa] from ``turgorbayes fit``'s posterior, equal weights."""
    fit = fit_conditions(cells, seed=seed, surrogate=table, settings=settings)
    pair = [np.asarray(fit.draws[f"P_phys__{c}"], float).ravel() for c in (0, 1)]
    return pair, np.ones(pair[0].size), fit.converged


def _importance_pair(cells, seed, table, settings):
    """P_phys of (wt, treated) [Pa] and weights from the criticism's engine on the same model,
    the population noise carried as :func:`turgorbayes.workflows.fit.fit_cells` carries it."""
    model = conditions.ConditionsModel(cells, table, conditions.condition_set(cells))
    wls = models.PaperWLS(cells, table).fit()
    post = engine.fit_posterior(model, model.start_values(wls.estimate), seed,
                                engine.Settings(engine="importance", progress=False),
                                pointwise=False)
    u = post.u
    if settings.population_noise:
        sigma_g = model.population_shift_covariance(post.u_map, post.cov, seed,
                                                    settings.population_noise_bootstrap)
        u = pop_noise.carry(u, sigma_g, engine.stream_rng(seed, 1003),
                            log_prior=model.log_prior)
    v = model.to_physical(u)
    return [v["P_phys__0"], v["P_phys__1"]], post.weights, post.converged


def one(seed, change, table, settings, n_intact=42, engine_name="emcee", design="loguniform"):
    """Fit one experiment and score the P_phys contrast against its truth."""
    cells = experiment(seed, change, table, n_intact, design)
    t0 = time.perf_counter()
    fitter = _emcee_pair if engine_name == "emcee" else _importance_pair
    (wt, treated), w, converged = fitter(cells, seed, table, settings)
    elapsed = time.perf_counter() - t0
    d = (treated - wt) / 1e3
    truth = P_REF * change / 1e3
    q = engine.weighted_quantiles(d, w, [0.05, 0.16, 0.5, 0.84, 0.95])
    w = w / np.sum(w)
    ratio = engine.weighted_stats(treated / wt, w)
    return {"seed": seed, "n_intact": n_intact, "true_change": change, "engine": engine_name,
            "design": design, "true_difference_kPa": truth,
            "difference_q05_q16_q50_q84_q95": np.asarray(q).tolist(),
            "in_90": bool(q[0] <= truth <= q[4]), "in_68": bool(q[1] <= truth <= q[3]),
            "prob_greater": float(np.sum(w * (treated > wt))),
            "ratio": {k: ratio[k] for k in ("mean", "q05", "q50", "q95")},
            "converged": bool(converged), "seconds": round(elapsed, 1)}


def _sd_and_z(row):
    """The posterior sd of the difference (from its 90 % interval, normal) and the z-score of
    the posterior median against the truth."""
    q = row["difference_q05_q16_q50_q84_q95"]
    sd = (q[4] - q[0]) / (2 * Z_95)
    return sd, (q[2] - row["true_difference_kPa"]) / sd


def summarize(rows):
    """Per intact-cell count and true change: coverage of the 90 % and 68 % intervals (+-
    binomial se), the rate of detection (prob_greater outside :data:`DETECT`; on the null the
    rate of prob_greater > 0.95, a one-sided 5 % test), the mean posterior sd of the difference
    and the sd of the z-scores; per intact-cell count the predicted smallest change detected in
    80 % of experiments, ``(Z_95 + s_z Z_80) sd / P_REF`` (the z-scores' scatter ``s_z`` pooled
    over every row, 1 for a calibrated posterior)."""
    out, power = {}, {}
    s_z = float(np.std([_sd_and_z(x)[1] for x in rows], ddof=1)) if len(rows) > 1 else 1.0
    for n_intact in sorted({x.get("n_intact", 42) for x in rows}):
        at_n = [x for x in rows if x.get("n_intact", 42) == n_intact]
        for change in sorted({x["true_change"] for x in at_n}, reverse=True):
            r = [x for x in at_n if x["true_change"] == change]
            n = len(r)
            sd, z = np.array([_sd_and_z(x) for x in r]).T
            entry = {"n": n, "converged": sum(x["converged"] for x in r),
                     "mean_sd_difference_kPa": float(np.mean(sd)),
                     "sd_z": float(np.std(z, ddof=1)) if n > 1 else None}
            for key in ("in_90", "in_68"):
                p = np.mean([x[key] for x in r])
                entry["coverage_" + key[3:]] = [float(p), float(np.sqrt(p * (1 - p) / n))]
            entry["rate_detected"] = float(np.mean(
                [not DETECT[0] <= x["prob_greater"] <= DETECT[1] for x in r]))
            if change == 0.0:
                entry["rate_prob_greater_above_0.95"] = float(np.mean(
                    [x["prob_greater"] > 0.95 for x in r]))
            out[f"{n_intact} intact, change {change:g}"] = entry
        sd_n = float(np.mean([_sd_and_z(x)[0] for x in at_n]))
        power[str(n_intact)] = {"mean_sd_difference_kPa": sd_n,
                                "smallest_change_80pct_kPa": (Z_95 + s_z * Z_80) * sd_n,
                                "smallest_change_80pct_percent":
                                    100 * (Z_95 + s_z * Z_80) * sd_n / (P_REF / 1e3)}
    return {"summary": out, "power": {"sd_z_pooled": s_z, "per_intact": power}}


def read_rows(path):
    """The result lines of one experiment each in a result file."""
    return [json.loads(line) for line in Path(path).read_text().splitlines()
            if line.startswith('{"seed"')]


def compare(a_rows, b_rows):
    """Agreement of two runs on their common (seed, change, n_intact): the mean absolute
    difference of the posterior medians in posterior sds (of the first run), the correlation
    of the z-scores, the ratio of the interval widths and how often the 90 % / 68 % interval
    decisions agree."""
    key = lambda r: (r["seed"], r["true_change"], r.get("n_intact", 42))  # noqa: E731
    b = {key(r): r for r in b_rows}
    pairs = [(r, b[key(r)]) for r in a_rows if key(r) in b]
    if not pairs:
        return {"n": 0}
    (sd_a, z_a), (sd_b, z_b) = (np.array([_sd_and_z(p[i]) for p in pairs]).T for i in (0, 1))
    med = np.array([[p[i]["difference_q05_q16_q50_q84_q95"][2] for i in (0, 1)] for p in pairs])
    return {"n": len(pairs),
            "mean_abs_median_difference_sd": float(np.mean(np.abs(med[:, 0] - med[:, 1]) / sd_a)),
            "z_correlation": float(np.corrcoef(z_a, z_b)[0, 1]) if len(pairs) > 2 else None,
            "width_ratio_b_over_a": float(np.mean(sd_b / sd_a)),
            "same_in_90": sum(p[0]["in_90"] == p[1]["in_90"] for p in pairs),
            "same_in_68": sum(p[0]["in_68"] == p[1]["in_68"] for p in pairs)}


def calibration(args, table, settings, out):
    rows = []
    with out.open("w") as f:
        f.write(provenance.header_line(provenance.run_record(args.argv)) + "\n")
        # seeds outer, truths inner: a run stopped early has both truths in equal numbers
        for seed in range(args.first_seed, args.first_seed + args.n):
            for change in args.changes:
                rows.append(one(seed, change, table, settings, args.n_intact, args.engine,
                                args.design))
                f.write(json.dumps(rows[-1]) + "\n")
                f.flush()
        f.write(json.dumps(summarize(rows)) + "\n")


def without_conditions(cells):
    """The same cells without their condition column (one condition)."""
    fields = ("R_c", "R_c_err", "k_c", "k_c_err", "R_b", "R_b_err", "k_b", "k_b_err", "h_b")
    extra = {k: v for k, v in cells.extra.items() if k != conditions.CONDITION_COLUMN}
    return CellData(cell_id=cells.cell_id, group=cells.group, extra=extra,
                    comments=cells.comments, **{f: getattr(cells, f) for f in fields})


def timing(args, table, settings, out):
    cells = experiment(args.first_seed, TRUE_CHANGES[1], table)
    times = {}
    for name, data in (("one condition", without_conditions(cells)), ("two conditions", cells)):
        t0 = time.perf_counter()
        fit = fit_conditions(data, seed=1, surrogate=table, settings=settings)
        times[name] = (time.perf_counter() - t0, fit.sampler["n_steps"], fit.converged)
    lines = [provenance.header_line(provenance.run_record(args.argv)),
             f"# {len(cells)} cells (wt 72 bulged + 42 intact, treated 42 intact), data seed "
             f"{args.first_seed}, fit seed 1, CLI settings, run one after the other on this "
             "machine (2 shared cores)"]
    for name, (sec, steps, ok) in times.items():
        lines.append(f"{name}: {sec:.1f} s, {steps} steps per ensemble, converged {ok}")
    ratio = times["two conditions"][0] / times["one condition"][0]
    lines.append(f"ratio two / one: {ratio:.2f}")
    out.write_text("\n".join(lines) + "\n")


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", choices=("calibration", "timing"), default="calibration")
    parser.add_argument("--n", type=int, default=100, help="experiments per true difference")
    parser.add_argument("--first-seed", type=int, default=3000)
    parser.add_argument("--n-intact", type=int, default=42, help="intact cells per condition")
    parser.add_argument("--changes", type=lambda t: [float(x) for x in t.split(",")],
                        default=list(TRUE_CHANGES),
                        help="true relative turgor changes, comma-separated (default 0,-0.25)")
    parser.add_argument("--engine", choices=("emcee", "importance"), default="emcee",
                        help="emcee (turgorbayes fit) or the criticism's importance sampling")
    parser.add_argument("--design", choices=synthetic.P_DISTRIBUTIONS, default="loguniform",
                        help="the bulged cells' pressure population")
    parser.add_argument("--compare", nargs=2, default=None, metavar="ROWS.jsonl",
                        help="print the agreement of two runs on their common experiments")
    parser.add_argument("--out", default=None, help="result file (required unless --summarize)")
    parser.add_argument("--summarize", nargs="+", default=None, metavar="ROWS.jsonl",
                        help="print the summary of the JSON lines of these files (a run stopped "
                             "early has no summary line)")
    provenance.add_output_options(parser)
    args = parser.parse_args(argv)
    if args.smoke:  # one experiment, 10 intact cells per condition, short chains
        args.n, args.changes, args.n_intact = 1, [TRUE_CHANGES[1]], 10
        args.out = args.out or str(provenance.study_path(args, f"condition_contrast_{args.study}.jsonl"))
    if args.summarize:
        print(json.dumps(summarize([r for p in args.summarize for r in read_rows(p)])))
        return
    if args.compare:
        print(json.dumps(compare(*(read_rows(p) for p in args.compare))))
        return
    if args.out is None:
        parser.error("--out is required")
    args.argv = ["studies/condition_contrast.py", *(argv or [])] if argv else None
    table = surrogate.load()
    settings = results.FitSettings(progress=False, **(SMOKE_SAMPLER if args.smoke else {}))
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    (calibration if args.study == "calibration" else timing)(args, table, settings, out)


if __name__ == "__main__":
    main()
