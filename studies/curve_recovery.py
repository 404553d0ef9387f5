"""Recovery of k_c, k_b, h_b and the implied bulge pressure from single synthetic force curves,
at three noise levels x two contact-point methods, and the time per curve.

Curves are written by afmformats (.tab) and read back. Cells: k_c log-uniform 0.005-0.03 N/m,
R_c 450-600 nm, indented to 2 R_c/20 (law F = k_c h (h/h_ref)^0.1). Bulges: P log-uniform
5-25 kPa, R_b 400-700 nm, h_b/R_b 0.17-0.27 (the liquid-membrane law). Each curve draws its own
baseline offset, tilt and drift (turgorbayes.simulation.raw_dataset). P is implied with the true R_b.
Errors are single-curve relative errors (the pipeline averages 3 per cell, about 1/sqrt(3) of these).

Run: .venv/bin/python studies/curve_recovery.py [--n 40]  ->  studies/output/curve_recovery.txt
(studies/results/ with --update)
"""

import argparse
import functools
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from turgorbayes import __version__, provenance
from turgorbayes.curves import ReductionSettings, reduce_curve
from turgorbayes.physics import bulge
from turgorbayes.simulation.curves import DEFAULT_ACQUISITION, bulge_force, cell_force, synthetic_curve, write_curve
from turgorbayes.simulation.raw_dataset import baseline_draw

NOISE_PN = {"low": 2.0, "realistic": 6.7, "high": 20.0}
METHODS = ("powerlaw", "threshold")
NAME = "curve_recovery.txt"


def _cases(n, seed):
    rng = np.random.default_rng(seed)
    cells = [(float(np.exp(rng.uniform(np.log(0.005), np.log(0.03)))), rng.uniform(450e-9, 600e-9))
             for _ in range(n)]
    bulges = [(float(np.exp(rng.uniform(np.log(5e3), np.log(25e3)))), rng.uniform(400e-9, 700e-9),
               rng.uniform(0.17, 0.27)) for _ in range(n)]
    return cells, bulges


def _write(folder, cells, bulges, noise, seed):
    """Write every curve at one noise level; returns [(path, target, radius, truth dict)]."""
    rng = np.random.default_rng(seed)
    out = []
    for i, (k_c, R_c) in enumerate(cells):
        acq = replace(baseline_draw(DEFAULT_ACQUISITION, rng), noise_sd=noise)
        law = functools.partial(cell_force, k_c=k_c, h_ref=R_c / 20)
        path = folder / f"c{i}.tab"
        write_curve(synthetic_curve(law, 2 * R_c / 20, acq, int(rng.integers(2**31))), path)
        out.append((path, "cell", R_c, {"k": k_c}))
    for i, (P, R_b, y) in enumerate(bulges):
        acq = replace(baseline_draw(DEFAULT_ACQUISITION, rng), noise_sd=noise)
        law = functools.partial(bulge_force, P=P, R_b=R_b)
        path = folder / f"b{i}.tab"
        write_curve(synthetic_curve(law, y * R_b, acq, int(rng.integers(2**31))), path)
        out.append((path, "bulge", R_b, {"k": float(law(np.array(y * R_b))) / (y * R_b),
                                         "h": y * R_b, "P": P}))
    return out


def _summary(errors):
    e = np.asarray(errors)
    if e.size == 0:
        return "-"
    return f"{100 * np.mean(e):+.2f} / {100 * np.std(e):.2f} / {100 * np.median(np.abs(e)):.2f}"


def _run(curves, method):
    settings = ReductionSettings(method=method)
    err = {"k_c": [], "k_b": [], "h_b": [], "P": [], "z_c": []}
    rejected, elapsed = 0, 0.0
    for path, target, radius, truth in curves:
        t = time.perf_counter()
        res = reduce_curve(path, target, radius, settings)
        elapsed += time.perf_counter() - t
        if not res.accepted:  # ok or imprecise: the curves a cell uses
            rejected += 1
            continue
        if target == "cell":
            err["k_c"].append(res.k / truth["k"] - 1)
            err["z_c"].append((res.k - truth["k"]) / res.k_err)
        else:
            err["k_b"].append(res.k / truth["k"] - 1)
            err["h_b"].append(res.depth / truth["h"] - 1)
            P = float(bulge.pressure_from_bulge(res.k, radius, res.depth))
            err["P"].append(P / truth["P"] - 1)
    return err, rejected, elapsed / len(curves)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--n", type=int, default=40, help="cells and bulges per noise level")
    parser.add_argument("--seed", type=int, default=2011)
    args = provenance.add_output_options(parser).parse_args()
    if args.smoke:  # two cell and two bulge curves per noise level
        args.n = 2
    record = provenance.run_record()
    print(provenance.header_line(record), flush=True)
    cells, bulges = _cases(args.n, args.seed)
    lines = [f"# curve_recovery.py, turgorbayes {__version__}, {args.n} cell + {args.n} bulge "
             f"curves per noise level, seed {args.seed}",
             "# relative errors of single curves, mean / sd / median |.| in %; "
             "k_c z = (k - k_true)/k_err: sd ~ 1 if the reported errors are honest",
             f"{'noise':<19} {'method':<10} {'k_c':<22} {'k_b':<22} {'h_b':<22} {'P':<22} "
             f"{'sd(k_c z)':<10} {'rejected':<9} ms/curve"]
    for level, noise_pN in NOISE_PN.items():
        with tempfile.TemporaryDirectory() as tmp:
            curves = _write(Path(tmp), cells, bulges, noise_pN * 1e-12, args.seed + 1)
            for method in METHODS:
                err, rejected, per_curve = _run(curves, method)
                lines.append(f"{level + f' ({noise_pN:g} pN)':<19} {method:<10} "
                             f"{_summary(err['k_c']):<22} {_summary(err['k_b']):<22} "
                             f"{_summary(err['h_b']):<22} {_summary(err['P']):<22} "
                             f"{np.std(err['z_c']):<10.2f} {rejected:<9d} {1e3 * per_curve:.1f}")
                print(lines[-1], flush=True)
    out = provenance.study_path(args, NAME)
    out.write_text("\n".join([provenance.header_line(record), *lines]) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
