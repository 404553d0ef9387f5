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


def experiment(seed, change, table):
    """Cells of one two-condition experiment; the treated turgor is ``P_REF (1 + change)``."""
    return synthetic_conditions.simulate_conditions(
        {"wt": P_REF, "treated": P_REF * (1 + change)}, n_intact=42, n_bulged={"wt": 72},
        seed=seed, surrogate=table)[0]


def one(seed, change, table, settings):
    """Fit one experiment and score the P_phys contrast against its truth."""
    cells = experiment(seed, change, table)
    t0 = time.perf_counter()
    fit = fit_conditions(cells, seed=seed, surrogate=table, settings=settings)
    elapsed = time.perf_counter() - t0
    d = (np.asarray(fit.draws["P_phys__1"]) - np.asarray(fit.draws["P_phys__0"])).ravel() / 1e3
    truth = P_REF * change / 1e3
    q = np.quantile(d, [0.05, 0.16, 0.5, 0.84, 0.95])
    (contrast,) = [c for c in conditions.contrasts(fit) if c["quantity"] == "P_phys_kPa"]
    return {"seed": seed, "true_change": change, "true_difference_kPa": truth,
            "difference_q05_q16_q50_q84_q95": q.tolist(),
            "in_90": bool(q[0] <= truth <= q[4]), "in_68": bool(q[1] <= truth <= q[3]),
            "prob_greater": contrast["prob_greater"], "ratio": contrast["ratio"],
            "converged": bool(fit.converged), "seconds": round(elapsed, 1)}


def summarize(rows):
    """Per true change: coverage of the 90 % and 68 % intervals (+- binomial se) and, on the
    null, the rate of prob_greater > 0.95 (a one-sided 5 % test)."""
    out = {}
    for change in TRUE_CHANGES:
        r = [x for x in rows if x["true_change"] == change]
        if not r:
            continue
        n = len(r)
        entry = {"n": n, "converged": sum(x["converged"] for x in r)}
        for key in ("in_90", "in_68"):
            p = np.mean([x[key] for x in r])
            entry["coverage_" + key[3:]] = [float(p), float(np.sqrt(p * (1 - p) / n))]
        if change == 0.0:
            entry["rate_prob_greater_above_0.95"] = float(np.mean(
                [x["prob_greater"] > 0.95 for x in r]))
        out[str(change)] = entry
    return {"summary": out}


def calibration(args, table, settings, out):
    rows = []
    with out.open("w") as f:
        f.write(provenance.header_line(provenance.run_record(args.argv)) + "\n")
        # seeds outer, truths inner: a run stopped early has both truths in equal numbers
        for seed in range(args.first_seed, args.first_seed + args.n):
            for change in TRUE_CHANGES:
                rows.append(one(seed, change, table, settings))
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
