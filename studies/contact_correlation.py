"""One contact point, one covariance: how correlated are a force map's R_c and k_c errors, and
does the propagated covariance (turgorbayes.curves.contact_covariance) say so?

Each map (turgorbayes.simulation.forcemap): a rod-shaped cell of R = 450 nm on a 16 x 16 grid
over 3 um, crest k_c as given, noise as given, a new noise seed per map (the contact points
found in each map's curves carry the noise's errors; the simulated heights carry no
calibration error). Per setting: the empirical correlation of the errors (R_c fit - truth,
k_c - truth) over the maps, with its Fisher 95 % interval; the mean correlation the
propagation gives (the contact points' covariance) over the radius' fit error alone and the
combined k error, and over the radius error ``curves`` writes (the fit's and the 1 % height
calibration's: the ``rho_R_c_k_c`` column); and the correlation over all maps, the errors
standardized within each setting.
docs/curves.md, "Correlated readings".

Run: nice .venv/bin/python studies/contact_correlation.py [--n 40] [--update]
  -> studies/output/contact_correlation.json (studies/results/ with --update)
"""

import argparse
import json
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from turgorbayes.curves.contact_covariance import contact_covariance
from turgorbayes.curves.forcemap import reduce_map
from turgorbayes.provenance import add_output_options, run_record, study_path
from turgorbayes.simulation.curves import DEFAULT_ACQUISITION
from turgorbayes.simulation.forcemap import RodCell, write_force_map

#: (label, crest k_c [N/m], force noise [pN])
SETTINGS = (("k_c 0.01 N/m, 6.7 pN (thermal)", 0.01, 6.7), ("k_c 0.02 N/m, 6.7 pN", 0.02, 6.7),
            ("k_c 0.01 N/m, 20 pN", 0.01, 20.0))


def one_map(folder, k_c, noise, seed):
    cell = RodCell(k_c=k_c)
    path = Path(folder) / f"map{seed}.h5"
    acq = replace(DEFAULT_ACQUISITION, noise_sd=noise * 1e-12)
    write_force_map(path, cell, n=16, extent=3.0e-6, acquisition=acq, seed=seed)
    r = reduce_map(path)
    path.unlink()
    if not r.ok:
        return None
    fit_err = r.section.R_err
    cov = contact_covariance(r.pixels, r.section, r.crest)
    return {"seed": seed, "e_R_nm": (r.R_c - cell.R) * 1e9, "e_k_rel": r.k / k_c - 1,
            "R_fit_err_nm": fit_err * 1e9, "R_err_written_nm": r.R_c_err * 1e9,
            "k_err_rel": r.k_err / k_c,
            "rho_fit": cov / (fit_err * r.k_err),
            "rho_written": r.rho_R_k}


def fisher_interval(r, n):
    if n <= 3:  # no interval (a smoke run's two maps)
        return [np.nan, np.nan]
    z, half = np.arctanh(r), 1.96 / np.sqrt(n - 3)
    return [float(np.tanh(z - half)), float(np.tanh(z + half))]


def summary(label, rows):
    eR = np.array([r["e_R_nm"] for r in rows])
    ek = np.array([r["e_k_rel"] for r in rows])
    corr = float(np.corrcoef(eR, ek)[0, 1])
    return {"setting": label, "n_maps": len(rows),
            "empirical_correlation": round(corr, 3),
            "empirical_95": [round(v, 3) for v in fisher_interval(corr, len(rows))],
            "propagated_rho_fit_mean": round(float(np.mean([r["rho_fit"] for r in rows])), 3),
            "written_rho_mean": round(float(np.nanmean([r["rho_written"] for r in rows])), 4),
            "sd_e_R_nm": round(float(eR.std(ddof=1)), 3),
            "mean_R_fit_err_nm": round(float(np.mean([r["R_fit_err_nm"] for r in rows])), 3),
            "mean_R_err_written_nm": round(float(np.mean([r["R_err_written_nm"] for r in rows])), 3),
            "sd_e_k_rel": round(float(ek.std(ddof=1)), 4),
            "mean_k_err_rel": round(float(np.mean([r["k_err_rel"] for r in rows])), 4)}


def pooled(settings):
    """The correlation of the errors standardized within each setting, over every map."""
    z = []
    for s in settings:
        e = np.array([[m["e_R_nm"], m["e_k_rel"]] for m in s["maps"]])
        z.append((e - e.mean(axis=0)) / e.std(axis=0))
    z = np.vstack(z)
    corr = float(np.corrcoef(z.T)[0, 1])
    return {"n_maps": len(z), "correlation": round(corr, 3),
            "95": [round(v, 3) for v in fisher_interval(corr, len(z))]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=40, help="maps per setting")
    add_output_options(parser)
    args = parser.parse_args()
    settings = SETTINGS
    if args.smoke:  # two maps of the first setting (a correlation; its interval is then nan)
        args.n, settings = 2, SETTINGS[:1]
    out = {"provenance": run_record(), "settings": []}
    start = time.time()
    with tempfile.TemporaryDirectory() as folder:
        for label, k_c, noise in settings:
            rows = [r for seed in range(1, args.n + 1)
                    if (r := one_map(folder, k_c, noise, seed)) is not None]
            out["settings"].append(dict(summary(label, rows), maps=rows))
            print(json.dumps({k: v for k, v in out["settings"][-1].items() if k != "maps"}),
                  flush=True)
    out["pooled"] = pooled(out["settings"])
    print(json.dumps({"pooled": out["pooled"]}))
    out["seconds"] = round(time.time() - start, 1)
    path = study_path(args, "contact_correlation.json")
    Path(path).write_text(json.dumps(out, indent=1) + "\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
