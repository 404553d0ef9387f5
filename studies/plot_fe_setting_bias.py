"""What the baseline gets wrong when the FE model's tip radius or wall thickness is wrong.

Reads the power study's rows (``studies/criticism_power.py`` records the baseline's 90 %
intervals of every data set: ``baseline``) for data simulated with a blunter or sharper tip
(``tip_radius``) or another wall thickness (``wall_thickness``) and for null data, and prints,
per simulated setting, the mean over the data sets of the baseline's posterior median of each
parameter relative to the truth (with its standard error) and how often its 90 % interval covers
the truth; draws the shifts against the setting (docs/effects.md, "tip_radius").

Run: .venv/bin/python studies/plot_fe_setting_bias.py ROWS.jsonl [MORE.jsonl ...]
     [--out docs/figures/fe_setting_bias.png] > studies/results/fe_setting_bias.txt
"""

import argparse
import json
from pathlib import Path

import matplotlib
import matplotlib.ticker

from turgorbayes import provenance

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from turgorbayes.physics.parameters import PUBLISHED, QUANTITIES  # noqa: E402

#: The baseline's parameters, their summary keys, and the truth (the paper's values).
PARAMS = ("gamma", "E0t", "R0", "P_phys")
#: Each effect's FE setting at the baseline's value [nm] (null data are drawn there).
NULL_NM = {"tip_radius": 7.5, "wall_thickness": 6.0}
#: The power study's recorded rows of the FE settings (what ``--smoke`` reads when given none).
SHIPPED_ROWS = Path(__file__).resolve().parent / "results" / "criticism_power_fe_settings.jsonl"


def load(paths):
    return [json.loads(line) for p in paths for line in Path(p).read_text().splitlines()
            if line.startswith("{")]


def shifts(rows):
    """``{effect: {setting_nm: {param: (mean rel shift, se, coverage, n)}}}``."""
    out = {}
    for effect, null_nm in NULL_NM.items():
        mine = [r for r in rows if r["effect"] in (effect, "null") and "baseline" in r
                and r.get("design", {}).get("n_bulged") == 72]  # the paper's design only
        by = {}
        for r in mine:
            by.setdefault(null_nm if r["effect"] == "null" else r["size"] * 1e9, []).append(r)
        out[effect] = {}
        for nm, rs in sorted(by.items()):
            out[effect][nm] = {}
            for name in PARAMS:
                q = QUANTITIES[name]
                truth = q.to_display(PUBLISHED[name])
                med = np.array([r["baseline"][q.key][1] for r in rs]) / truth - 1
                cov = np.mean([r["baseline"][q.key][0] <= truth <= r["baseline"][q.key][2]
                               for r in rs])
                out[effect][nm][name] = (med.mean(), med.std(ddof=1) / np.sqrt(len(med)), cov,
                                         len(med))
    return out


def report(s):
    lines = ["baseline posterior median relative to the truth, mean over data sets (+- se); "
             "90 % interval coverage"]
    for effect, by in s.items():
        for nm, d in by.items():
            n = next(iter(d.values()))[3]
            lines.append(f"{effect:<15}{nm:>6g} nm  n={n:<3}" + "  ".join(
                f"{p} {m:+.1%} +- {se:.1%} (cov {c:.2f})" for p, (m, se, c, _) in d.items()))
    return lines


def draw(s, out):
    fig, axes = plt.subplots(1, len(s), figsize=(10, 3.6), sharey=True)
    for ax, (effect, by) in zip(np.atleast_1d(axes), s.items(), strict=True):
        nm = np.array(list(by))
        for name in PARAMS:
            m = np.array([by[v][name][0] for v in nm])
            se = np.array([by[v][name][1] for v in nm])
            ax.errorbar(nm, 100 * m, yerr=100 * se, marker="o", capsize=3,
                        label=QUANTITIES[name].tex.split(" [")[0])
        ax.axhline(0, color="k", lw=0.6)
        ax.axvline(NULL_NM[effect], color="0.6", ls=":", lw=1)
        ax.set_xscale("log")
        ax.set_xticks(nm, [f"{v:g}" for v in nm])
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
        ax.set_xlabel(("indenter tip radius" if effect == "tip_radius" else "wall thickness")
                      + " in the simulated data [nm]")
        ax.set_title(f"baseline fit (FE: {NULL_NM[effect]:g} nm)", fontsize=10)
    np.atleast_1d(axes)[0].set_ylabel("posterior median / truth - 1 [%]")
    np.atleast_1d(axes)[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=120)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("rows", nargs="*")
    parser.add_argument("--out", default="docs/figures/fe_setting_bias.png")
    args = provenance.add_output_options(parser).parse_args()
    if args.smoke:  # the recorded rows, the figure into --output-dir
        if not (args.rows or SHIPPED_ROWS.is_file()):
            print(f"skipped: no rows given and {SHIPPED_ROWS.name} absent")
            return
        args.rows = args.rows or [str(SHIPPED_ROWS)]
        args.out = str(provenance.study_path(args, "fe_setting_bias.png"))
        provenance.tee_stdout(args, "fe_setting_bias.txt")
    elif not args.rows:
        parser.error("give the power study's rows (ROWS.jsonl)")
    print(provenance.header_line(), flush=True)
    s = shifts(load(args.rows))
    print("\n".join(report(s)))
    draw(s, args.out)


if __name__ == "__main__":
    main()
