"""Coverage of P_phys and E0t under the calibration effect: the sessions' common factor.

Why: the data see only the sessions' spring-constant factors relative to each other; their
geometric mean rescales the whole experiment (P_phys, E0t, moduli; R0, the radius at the
reference pressure, moves with it) and is not identifiable.
Sampled P_phys, E0t are in that apparent scale. The model now reports them divided by the
common factor ``exp(sigma_cal mean(z))``, whose posterior is its prior N(0, sigma_cal^2/S)
(docs/effects.md, calibration). "apparent" below is the sampled value (the version before this
change fixed the common factor at 1 and reported exactly that), "reported" the value the
package reports now; both come from the same posterior draws, so the comparison is paired.

Per data set: the paper's design (72 bulged + 42 intact cells, P_phys = 29 kPa, E0t =
0.026 N/m), ``--n-sessions`` sessions, calibration injected at ``--size`` (each session's
ln c ~ N(0, size^2), so the sessions' mean is off by sd size/sqrt(S)); the calibration model
is fitted by ``criticism.fit_posterior`` (Laplace + importance sampling, CLI default draws,
emcee where that does not converge). Printed per data set and summarized: 90 % coverage of
P_phys, E0t, R0 (apparent and reported) and sigma_cal, with the binomial 95 % interval.

Usage::

    python studies/calibration_common_scale.py --seeds 3000-3039 \
        > studies/results/calibration_common_scale.txt
"""

import argparse
import json
import time

import numpy as np
from scipy import stats

from turgorbayes import __version__, criticism, effects, provenance, surrogate
from turgorbayes.criticism.stacking import weighted_quantiles
from turgorbayes.inference import models
from turgorbayes.simulation import cells as synthetic
from turgorbayes.workflows.criticize import CriticismSettings

TRUE = {k: getattr(synthetic.PAPER_TRUTH, k) for k in ("P_phys", "E0t", "R0")}


def one(seed, table, size, n_sessions):
    """Coverage outcomes of one data set (dict)."""
    inj = effects.get_effect("calibration").injection(size)
    cells, truths = synthetic.simulate_cells(seed=seed, surrogate=table, effects=[inj],
                                             n_sessions=n_sessions)
    model = effects.ExtendedModel(cells, table, ["calibration"])
    start = model.start_values(models.PaperWLS(cells, table).fit().estimate)
    t0 = time.perf_counter()
    post = criticism.fit_posterior(model, start, seed, CriticismSettings())
    w = post.weights / post.weights.sum()
    rng = np.random.default_rng(seed)
    apparent, reported = model.to_physical(post.u), post.physical(rng)
    log_c = np.array(list(truths["effects"][0]["log_factors"].values()))
    out = {"seed": seed, "version": __version__, "converged": bool(post.converged),
           "engine": post.engine, "time_s": time.perf_counter() - t0,
           "true_common_log_factor": float(log_c.mean())}
    for name in ("P_phys", "E0t", "R0", "sigma_cal"):
        truth = size if name == "sigma_cal" else TRUE[name]
        for tag, values in (("apparent", apparent), ("reported", reported)):
            if name == "sigma_cal" and tag == "reported":
                continue
            q = [float(v) for v in weighted_quantiles(values[name], w, (0.05, 0.5, 0.95))]
            out[f"{name}_{tag}"] = q
            out[f"{name}_{tag}_covered"] = bool(q[0] <= truth <= q[2])
    return out


def summarize(rows):
    conv = [r for r in rows if r["converged"]]
    lines = [f"# {len(rows)} data sets, {len(conv)} converged (coverage over converged fits)",
             f"{'quantity':<22}{'covered':>9}{'rate':>7}{'95 % binomial':>17}"]
    for key in ("P_phys_apparent", "P_phys_reported", "E0t_apparent", "E0t_reported",
                "R0_apparent", "R0_reported", "sigma_cal_apparent"):
        k = sum(r[f"{key}_covered"] for r in conv)
        n = len(conv)
        lo, hi = stats.binomtest(k, n).proportion_ci(0.95) if n else (np.nan, np.nan)
        lines.append(f"{key:<22}{f'{k}/{n}':>9}{k / max(n, 1):>7.2f}{f'[{lo:.2f}, {hi:.2f}]':>17}")
    width = [np.log(r["P_phys_reported"][2] / r["P_phys_reported"][0])
             / np.log(r["P_phys_apparent"][2] / r["P_phys_apparent"][0]) for r in conv]
    lines.append(f"median width of the 90 % P_phys interval, reported / apparent: "
                 f"{np.median(width):.2f}")
    lines.append(f"sd of the true common log factor over data sets: "
                 f"{np.std([r['true_common_log_factor'] for r in rows]):.3f}")
    return lines


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", default="3000-3039")
    ap.add_argument("--size", type=float, default=0.15)
    ap.add_argument("--n-sessions", type=int, default=6)
    ap.add_argument("--summarize", nargs="+", default=None, metavar="ROWS")
    provenance.add_output_options(ap)
    a = ap.parse_args(argv)
    if a.smoke:  # one data set
        a.seeds = "3000"
    provenance.tee_stdout(a, "calibration_common_scale.txt")
    print(provenance.header_line(), flush=True)
    if a.summarize:
        rows = [json.loads(line) for p in a.summarize for line in open(p) if line.startswith("{")]
        print("\n".join(summarize(rows)))
        return
    lo, _, hi = a.seeds.partition("-")
    table = surrogate.load()
    print(f"# turgorbayes {__version__}; calibration size {a.size}, {a.n_sessions} sessions; "
          f"paper design")
    rows = []
    for seed in range(int(lo), int(hi or lo) + 1):
        rows.append(one(seed, table, a.size, a.n_sessions))
        print(json.dumps(rows[-1]), flush=True)
    print("\n".join(summarize(rows)))


if __name__ == "__main__":
    main()
