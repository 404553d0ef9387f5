"""Did the treatment change turgor, or the wall? The turgor contrast of two conditions whose
walls may differ, headline (wall prior) against the shared-wall number, on simulated
experiments with known truths (:mod:`turgorbayes.workflows.design`, also ``turgorbayes
design``).

Each experiment: wt at 29 kPa with the paper's wall; treated with its own turgor and wall.
``--design ref``: 72 bulged cells in wt only (the README's design), 42 intact cells per
condition; ``--design both``: ``--n-bulged-both`` (default 30) bulged cells in each condition.
``--truths`` lists (E0t ratio, gamma difference, turgor change) triples, e.g.
``0.7:0:0,1.3:0:0,1:0:-0.25``; ``prior`` draws the wall difference of each experiment from the
fit's own wall prior (the Bayesian calibration check). A JSON line per experiment and number
(the headline, the shared-wall number); the last line summarizes per truth and number
(:func:`~turgorbayes.workflows.design.design_summary`). Rows of the first runs carry ``model``
``wall``/``shared`` for ``number`` ``headline``/``shared_wall``; ``--summarize`` reads both.

Run: .venv/bin/python studies/wall_or_turgor.py --design ref --n 100 \\
         --truths 0.7:0:0,1.3:0:0,1:0:-0.25,prior --out studies/results/wall_or_turgor_ref.jsonl
     .venv/bin/python studies/wall_or_turgor.py --summarize studies/results/wall_or_turgor_ref*.jsonl
"""

import argparse
import json
from pathlib import Path

from turgorbayes import provenance
from turgorbayes.cli.design import parse_truths
from turgorbayes.workflows.design import design_summary, simulate_design, summary_lines

_OLD = {"wall": "headline", "shared": "shared_wall"}


def read_rows(path):
    """The experiment rows of a result file (older rows renamed to the current keys)."""
    rows = []
    for line in Path(path).read_text().splitlines():
        if line.startswith('{"seed"'):
            row = json.loads(line)
            if "model" in row:
                row["number"] = _OLD[row.pop("model")]
            rows.append(row)
    return rows


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--design", choices=("ref", "both"), default="ref")
    parser.add_argument("--n-bulged-both", type=int, default=30)
    parser.add_argument("--truths", type=parse_truths, default=parse_truths("0.7:0:0,1.3:0:0"))
    parser.add_argument("--n", type=int, default=20, help="experiments per truth")
    parser.add_argument("--first-seed", type=int, default=5100)
    parser.add_argument("--out", default=None)
    parser.add_argument("--summarize", nargs="+", default=None, metavar="ROWS.jsonl")
    provenance.add_output_options(parser)
    args = parser.parse_args(argv)
    n_intact = 42
    if args.smoke:  # one experiment of one truth, 8 bulged + 6 intact cells; then its summary
        args.n, args.truths, args.n_bulged_both, n_intact = 1, args.truths[:1], 8, 6
        args.out = args.out or str(provenance.study_path(args, "wall_or_turgor.jsonl"))
    if args.summarize:
        rows = [r for p in args.summarize for r in read_rows(p)]
        summary = design_summary(rows)
        print("\n".join(summary_lines(summary)))
        print(json.dumps(summary))
        return
    if args.out is None:
        parser.error("--out is required")
    n_bulged = ({"wt": 8 if args.smoke else 72} if args.design == "ref"
                else {"wt": args.n_bulged_both, "treated": args.n_bulged_both})
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("w") as f:
        f.write(provenance.header_line() + "\n")

        def write(row):
            f.write(json.dumps(dict(row, design=args.design)) + "\n")
            f.flush()

        rows = simulate_design(n_bulged, n_intact, args.truths, args.n, args.first_seed,
                               progress_bar=False, on_row=write)
        f.write(json.dumps(design_summary(rows)) + "\n")
    if args.smoke:  # the --summarize step on the rows just written
        print("\n".join(summary_lines(design_summary(read_rows(out)))))


if __name__ == "__main__":
    main()
