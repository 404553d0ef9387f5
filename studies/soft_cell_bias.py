"""Bias of a single curve's k_c when the force at h = R_c/20 is only a few times the noise.

The recovery table (``curve_recovery.py``) draws cells of 5-30 mN/m, 19x the thermal noise or
more at R_c/20. A simulated experiment's softest bulged cells (1-4 kPa) are 0.5-2 mN/m: 2-8x
the noise. Here cells of R_c = 500 nm are made at given ratios F(R_c/20)/noise, indented as
``turgorbayes.simulation.raw_dataset`` does (to 2 R_c/20, deeper on soft cells until the force reaches
150 pN, at most 6 R_c/20), each with its own baseline draw, written by afmformats and reduced by
the package; the mean, sd and mean z of k_c/k_true - 1 over the accepted curves, and the share
rejected, are printed per ratio, and beside them the mean over the same curves read without
the ``stiffness_undetermined`` rule (what the rule's selection adds); then the same for cells
of three curves combined as ``turgorbayes curves`` combines them (plain mean, Birge-ratio
error), beside their inverse-variance weighted mean (the combination before 0.3).

Run: .venv/bin/python studies/soft_cell_bias.py [--n 60] > studies/results/soft_cell_bias.txt
"""

import argparse
import functools
import tempfile
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np

from turgorbayes import __version__, provenance
from turgorbayes.curves import reduce_curve
from turgorbayes.curves.combine import combine_stiffness
from turgorbayes.curves.reduce import ReductionSettings
from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, cell_force, synthetic_curve, write_curve
from turgorbayes.simulation.raw_dataset import MIN_SETPOINT, baseline_draw

R_C = 500e-9
RATIOS = (1, 1.5, 2, 3, 5, 8, 12, 20, 50)
EXPONENT = 0.1
NO_RULE = ReductionSettings(max_relative_error=np.inf)


def one_ratio(ratio, n, rng, folder):
    noise = DEFAULT_ACQUISITION.noise_sd
    h_ref = R_C / 20
    k_c = ratio * noise / h_ref
    depth = np.clip((MIN_SETPOINT / k_c) ** (1 / (1 + EXPONENT)) * h_ref
                    ** (EXPONENT / (1 + EXPONENT)), 2 * h_ref, 6 * h_ref)
    law = functools.partial(cell_force, k_c=k_c, h_ref=h_ref, a=EXPONENT)
    rel, z, status, ks, unruled = [], [], Counter(), [], []
    for i in range(n):
        acq = replace(baseline_draw(DEFAULT_ACQUISITION, rng), noise_sd=noise)
        path = folder / f"r{ratio}_{i}.tab"
        write_curve(synthetic_curve(law, float(depth), acq, int(rng.integers(2**31))), path)
        res = reduce_curve(path, "cell", R_C)
        status[res.status] += 1
        if res.status == "stiffness_undetermined":  # the same reading without the rule
            free = reduce_curve(path, "cell", R_C, settings=NO_RULE)
            unruled.append(free.k / k_c - 1)
        elif res.accepted:  # ok or imprecise: the curves a cell uses
            unruled.append(res.k / k_c - 1)
        ks.append((res.k, res.k_err) if res.accepted else None)
        if res.accepted:
            rel.append(res.k / k_c - 1)
            z.append((res.k - k_c) / res.k_err)
    cells = []
    for i in range(0, n - 2, 3):
        ok = [c for c in ks[i:i + 3] if c is not None]
        if ok:
            k, err, _ = combine_stiffness([c[0] for c in ok], [c[1] for c in ok])
            weighted, _, _ = combine_stiffness([c[0] for c in ok], [c[1] for c in ok],
                                               weights="inverse_variance")
            cells.append((k / k_c - 1, (k - k_c) / err, weighted / k_c - 1))
    return k_c, depth, np.array(rel), np.array(z), status, np.array(cells), np.array(unruled)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=60)
    ap.add_argument("--seed", type=int, default=7)
    args = provenance.add_output_options(ap).parse_args()
    ratios = RATIOS
    if args.smoke:  # six curves (two cells) at two ratios
        args.n, ratios = 6, (3, 50)
    provenance.tee_stdout(args, "soft_cell_bias.txt")
    print(provenance.header_line(), flush=True)
    rng = np.random.default_rng(args.seed)
    print(f"# soft_cell_bias.py, turgorbayes {__version__}, R_c 500 nm, noise "
          f"{DEFAULT_ACQUISITION.noise_sd * 1e12:.1f} pN, {args.n} curves per ratio, seed "
          f"{args.seed}")
    print(f"{'F(R/20)/noise':>14}{'k_c mN/m':>10}{'depth/h_ref':>12}{'mean err':>10}"
          f"{'sd':>8}{'mean z':>8}{'sd z':>7}  statuses")
    combined = []
    with tempfile.TemporaryDirectory() as tmp:
        for ratio in ratios:
            k_c, depth, rel, z, status, cells, unruled = one_ratio(ratio, args.n, rng, Path(tmp))
            print(f"{ratio:>14}{k_c * 1e3:>10.3g}{depth / (R_C / 20):>12.2f}"
                  f"{100 * rel.mean():>9.1f}%{100 * rel.std(ddof=1):>7.1f}%"
                  f"{z.mean():>8.2f}{z.std(ddof=1):>7.2f}  {dict(status)}; without the "
                  f"stiffness_undetermined rule {100 * unruled.mean():+.1f}% "
                  f"(sd {100 * unruled.std(ddof=1):.1f}%, {unruled.size})", flush=True)
            combined.append((ratio, cells))
    print("cells of 3 curves combined:")
    for ratio, c in combined:
        print(f"{ratio:>14}{'':>22}{100 * c[:, 0].mean():>9.1f}%{100 * c[:, 0].std(ddof=1):>7.1f}%"
              f"{c[:, 1].mean():>8.2f}{c[:, 1].std(ddof=1):>7.2f}  {len(c)} cells; inverse-variance mean "
              f"{100 * c[:, 2].mean():+.1f}% (sd {100 * c[:, 2].std(ddof=1):.1f}%)")


if __name__ == "__main__":
    main()
