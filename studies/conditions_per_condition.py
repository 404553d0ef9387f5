"""The criticism with and without ``--per-condition E0t:treated`` on two conditions whose walls
differ (treated's E0t RATIO times wt's), bulged cells in both.

Arguments: RATIO N_BULGED N_INTACT FIRST_SEED STOP_SEED. Each data set:
:func:`turgorbayes.simulation.conditions.simulate_conditions` with wt at 29 kPa and treated at
22 kPa, N_BULGED bulged and N_INTACT intact cells in each (data seed = criticism seed), then
:func:`turgorbayes.workflows.criticize.criticize` without candidates (the baseline with
conditions, the settings of tests/criticism/test_conditions_criticism.py: 1000 draws, 700
replicates) once with the wall shared and once with E0t of treated freed. One line per data
set and model: the p-value of ``conditions_R_c_k_c``, flagged, treated's P_phys and, freed,
the E0t ratio (median [90 %]); then ``RATE``. docs/effects.md, "Several conditions".

Run: .venv/bin/python studies/conditions_per_condition.py 0.7 36 20 1 11 \\
         >> studies/results/conditions_per_condition_check.txt
"""

import argparse
import dataclasses
import time

from turgorbayes import provenance
from turgorbayes import surrogate as sm
from turgorbayes.provenance import header_line
from turgorbayes.simulation import cells as synthetic
from turgorbayes.simulation import conditions as sc
from turgorbayes.workflows.criticize import CriticismSettings, criticism_dict, criticize

SETTINGS = CriticismSettings(
    n_draws=1000, n_rep=700, max_refits=0, retry_factor=1,
    n_walkers=12, n_ensembles=4, tol=25, check_every=50,
                             max_steps=4000, progress=False, flag_draws=50, effects=())
#: The criticism's settings of a smoke run: few draws and replicates, short chains.
SMOKE_SETTINGS = {"n_draws": 200, "n_rep": 50, "ess_min": 20, "n_ensembles": 2, "tol": 5,
                  "check_every": 20, "max_steps": 200, "flag_draws": 20}


def main(ratio, n_bulged, n_intact, first, stop, smoke=False):
    table = sm.load()
    E0t = synthetic.PAPER_TRUTH.E0t
    settings = dataclasses.replace(SETTINGS, **SMOKE_SETTINGS) if smoke else SETTINGS
    flags = {(): 0, ("E0t:treated",): 0}
    for seed in range(first, stop):
        cells, _ = sc.simulate_conditions(
            {"wt": 29e3, "treated": 22e3}, n_intact=n_intact,
            n_bulged={"wt": n_bulged, "treated": n_bulged}, seed=seed, surrogate=table,
            walls={"treated": {"E0t": ratio * E0t}})
        for per_condition in flags:
            t = time.time()
            d = criticism_dict(criticize(cells, table, seed=seed, settings=dataclasses.replace(
                settings, per_condition=per_condition)))
            cond = d["verdict"]["conditions"]
            check = next(c for c in d["checks"] if c["name"] == "conditions_R_c_k_c")
            flags[per_condition] += check["flagged"]
            P = cond["values"]["adopted"]["treated"]["P_phys_kPa"]
            e0t = [c["ratio"] for c in cond["contrasts"]["adopted"]
                   if c["quantity"] == "E0t_N_per_m"]
            print(f"ratio {ratio:g} nb {n_bulged} seed {seed} per_condition "
                  f"{','.join(per_condition) or 'none'}: p {check['p_value']:.4f} flagged "
                  f"{check['flagged']} P_phys[treated] {P['q50']:.2f} [{P['q05']:.2f}, "
                  f"{P['q95']:.2f}] kPa"
                  + (f" E0t ratio {e0t[0]['q50']:.3f} [{e0t[0]['q05']:.3f}, {e0t[0]['q95']:.3f}]"
                     if e0t else "") + f" {time.time() - t:.0f}s", flush=True)
    n = stop - first
    print("RATE " + ", ".join(f"per_condition {','.join(k) or 'none'}: flagged {v} of {n}"
                              for k, v in flags.items()), flush=True)


def _arguments(smoke_values):
    """RATIO N_BULGED N_INTACT FIRST_SEED STOP_SEED (``smoke_values`` with ``--smoke``)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for name, kind in (("ratio", float), ("n_bulged", int), ("n_intact", int), ("first", int),
                       ("stop", int)):
        parser.add_argument(name, type=kind, nargs="?")
    args = provenance.add_output_options(parser).parse_args()
    values = [args.ratio, args.n_bulged, args.n_intact, args.first, args.stop]
    if args.smoke:
        values = [v if v is not None else s for v, s in zip(values, smoke_values, strict=True)]
    elif None in values:
        parser.error("give RATIO N_BULGED N_INTACT FIRST_SEED STOP_SEED")
    return args, values


if __name__ == "__main__":
    args, values = _arguments([0.7, 8, 6, 1, 2])  # smoke: one data set of 8 + 6 cells each
    provenance.tee_stdout(args, "conditions_per_condition.txt", append=True)
    print(header_line(), flush=True)
    main(*values, smoke=args.smoke)
