"""How often do gross errors leave the published least-squares start impossible, and where does
the robust start go? (docs/statistics.md, "Sampling").

For each effect of ``--effects`` (default ``outliers``, ``bad_curves`` and ``null``) and seeds
``--first-seed`` ... (``--n`` each), simulate the paper's design with the effect at its
realistic size (:func:`turgorbayes.simulation.planted.planted_cells`; truth P_phys = 29 kPa),
fit the published least squares and count the cells whose baseline log-likelihood is ``-inf``
at its estimate; then take the fit's start (:meth:`BaselineModel.start_guess`) and record
whether it is the published estimate or the robust (soft-L1) one, its P_phys and its impossible
cells. Target: a start with every cell possible wherever the robust fit gives one, and the
published estimate kept wherever it is finite.

Run: .venv/bin/python studies/robust_start.py [--n 20] [--first-seed 3000] [--update | --smoke]
"""

import argparse

import numpy as np

from turgorbayes import provenance, surrogate
from turgorbayes.inference import models
from turgorbayes.simulation.planted import planted_cells

TRUE_P_PHYS_KPA = 29.0


def impossible(model, values):
    """Cells whose log-likelihood is not finite at physical ``values``."""
    with np.errstate(all="ignore"):
        ll = model.pointwise_log_likelihood(model.to_u(values)[0][None])[0]
    return int(np.count_nonzero(~np.isfinite(ll)))


def one(name, seed, table):
    cells = planted_cells(name, seed, table)
    model = models.BaselineModel(cells, table)
    published = models.PaperWLS(cells, table).fit().estimate
    start = model.start_guess(published)
    return {"effect": name, "seed": seed,
            "published_P_kPa": published["P_phys"] / 1e3,
            "published_impossible": impossible(model, published),
            "robust": start != published, "start_P_kPa": start["P_phys"] / 1e3,
            "start_impossible": impossible(model, start)}


def summarize(rows):
    lines = ["| effect | n | published start impossible (cells) | robust start taken | "
             "start impossible | median abs error of the start's P_phys, published / start "
             "[kPa] |", "|---|---|---|---|---|---|"]
    for name in dict.fromkeys(r["effect"] for r in rows):
        rs = [r for r in rows if r["effect"] == name]
        bad = [r["published_impossible"] for r in rs if r["published_impossible"]]
        err = [np.median([abs(r[k] - TRUE_P_PHYS_KPA) for r in rs])
               for k in ("published_P_kPa", "start_P_kPa")]
        lines.append(f"| {name} | {len(rs)} | {len(bad)} ({', '.join(map(str, bad)) or '-'}) | "
                     f"{sum(r['robust'] for r in rs)} | "
                     f"{sum(r['start_impossible'] > 0 for r in rs)} | "
                     f"{err[0]:.2f} / {err[1]:.2f} |")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=20)
    ap.add_argument("--first-seed", type=int, default=3000)
    ap.add_argument("--effects", default="outliers,bad_curves,null")
    provenance.add_output_options(ap)
    args = ap.parse_args(argv)
    if args.smoke:
        args.n, args.effects = 1, "null"
    provenance.tee_stdout(args, "robust_start.txt")
    print(provenance.header_line(provenance.run_record()), flush=True)
    table = surrogate.load()
    rows = []
    for seed in range(args.first_seed, args.first_seed + args.n):
        for name in args.effects.split(","):
            rows.append(one(name, seed, table))
            print(rows[-1], flush=True)
    print(summarize(rows))


if __name__ == "__main__":
    main()
