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

``--study timing``: one experiment fitted twice, with its condition column and without it
(every cell in one condition), side by side; writes both times and their ratio.

Every result file starts with a ``# provenance:`` line
(:func:`turgorbayes.provenance.header_line`).

Run: .venv/bin/python benchmarks/condition_contrast.py --study calibration --n 10 \\
         --out benchmarks/results/condition_contrast_pilot.jsonl
     .venv/bin/python benchmarks/condition_contrast.py --study timing \\
         --out benchmarks/results/condition_contrast_timing.txt
"""

import argparse
import json
import time
from pathlib import Path

import numpy as np

from turgorbayes import provenance, surrogate
from turgorbayes.cells.table import CellData
from turgorbayes.inference import conditions
from turgorbayes.simulation import conditions as synthetic_conditions
from turgorbayes.workflows import fit as results
from turgorbayes.workflows.conditions import fit_conditions

P_REF = 29e3
TRUE_CHANGES = (0.0, -0.25)


#: The detection rule of the power table: prob_greater below 0.05 or above 0.95.
DETECT = (0.05, 0.95)
#: Standard normal quantiles of the one-sided 5 % threshold and of 80 % power.
Z_95, Z_80 = 1.6448536269514722, 0.8416212335729143


def experiment(seed, change, table, n_intact=42):
    """Cells of one two-condition experiment; the treated turgor is ``P_REF (1 + change)``."""
    return synthetic_conditions.simulate_conditions(
        {"wt": P_REF, "treated": P_REF * (1 + change)}, n_intact=n_intact, n_bulged={"wt": 72},
        seed=seed, surrogate=table)[0]


def one(seed, change, table, settings, n_intact=42):
    """Fit one experiment and score the P_phys contrast against its truth."""
    cells = experiment(seed, change, table, n_intact)
    t0 = time.perf_counter()
    fit = fit_conditions(cells, seed=seed, surrogate=table, settings=settings)
    elapsed = time.perf_counter() - t0
    d = (np.asarray(fit.draws["P_phys__1"]) - np.asarray(fit.draws["P_phys__0"])).ravel() / 1e3
    truth = P_REF * change / 1e3
    q = np.quantile(d, [0.05, 0.16, 0.5, 0.84, 0.95])
    (contrast,) = [c for c in conditions.contrasts(fit) if c["quantity"] == "P_phys_kPa"]
    return {"seed": seed, "n_intact": n_intact, "true_change": change,
            "true_difference_kPa": truth,
            "difference_q05_q16_q50_q84_q95": q.tolist(),
            "in_90": bool(q[0] <= truth <= q[4]), "in_68": bool(q[1] <= truth <= q[3]),
            "prob_greater": contrast["prob_greater"], "ratio": contrast["ratio"],
            "converged": bool(fit.converged), "seconds": round(elapsed, 1)}


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


def calibration(args, table, settings, out):
    rows = []
    with out.open("w") as f:
        f.write(provenance.header_line(provenance.run_record(args.argv)) + "\n")
        # seeds outer, truths inner: a run stopped early has both truths in equal numbers
        for seed in range(args.first_seed, args.first_seed + args.n):
            for change in args.changes:
                rows.append(one(seed, change, table, settings, args.n_intact))
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
    parser.add_argument("--out", default=None, help="result file (required unless --summarize)")
    parser.add_argument("--summarize", nargs="+", default=None, metavar="ROWS.jsonl",
                        help="print the summary of the JSON lines of these files (a run stopped "
                             "early has no summary line)")
    args = parser.parse_args(argv)
    if args.summarize:
        rows = [json.loads(line) for p in args.summarize for line in Path(p).read_text().splitlines()
                if line.startswith('{"seed"')]
        print(json.dumps(summarize(rows)))
        return
    if args.out is None:
        parser.error("--out is required")
    args.argv = ["benchmarks/condition_contrast.py", *(argv or [])] if argv else None
    table = surrogate.load()
    settings = results.FitSettings(progress=False)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    (calibration if args.study == "calibration" else timing)(args, table, settings, out)


if __name__ == "__main__":
    main()
