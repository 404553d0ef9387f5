"""Run the example commands that README.md and docs/ quote, and write what they print.

A quoted output sits in README.md or docs/*.md between ``<!-- example-output: NAME -->`` and
``<!-- /example-output -->``. This script runs the commands of :data:`EXAMPLES` in a
temporary folder (fixed seeds: the commands' defaults), writes their full output to
``example_outputs.txt`` (studies/output/, or with ``--update`` studies/results/ and the tests'
copy :data:`TEST_COPY`, with the provenance of the run) and, with ``--update``, rewrites every
marked block from it (:data:`BLOCKS` says which lines each block quotes).
``tests/docs/test_example_outputs.py`` fails when a block differs from the result file, and
re-runs the cheap examples (``fit``, ``validate``, the table's parameter rows) to compare them
with what the code prints now.

Run: .venv/bin/python scripts/example_outputs.py [--update] [--only fit,validate]
(all examples: about 6 minutes on 2 cores, most of it ``criticize``).
"""

import argparse
import json
import os
import re
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
#: The pages that may quote an example output.
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
RESULT = "example_outputs.txt"
#: The copy that ``tests/docs/test_example_outputs.py`` reads (tests never read studies/results).
TEST_COPY = ROOT / "tests" / "data" / "study_results" / RESULT
#: example -> its commands as the README and docs show them, run in order in one folder
#: (``turgorbayes`` is this Python's ``-m turgorbayes``; :data:`QUIET` is added to them).
EXAMPLES = {
    "validate": ["turgorbayes validate"],
    "fit": ["turgorbayes fit"],
    "criticize": ["turgorbayes criticize"],
    "table": ["turgorbayes table turgorbayes_fit --format markdown"],
    "conditions": ["turgorbayes simulate --out exp.csv --conditions wt:29,treated:29 "
                   "--condition-wall treated:E0t=0.7",
                   "turgorbayes fit exp.csv --out exp_fit"],
    "series": ["turgorbayes simulate --out series.csv --osmotic-series 0,50,100,150 "
               "--n-bulged 0 --n-intact 120",
               "turgorbayes fit series.csv --out series_fit"],
}
#: Options added to a command when it is run here: no progress bar in a log.
QUIET = {"fit": ["--no-progress"], "criticize": ["--no-progress"]}
MARK = re.compile(r"(<!-- example-output: (?P<name>[\w-]+) -->\n)(?P<body>.*?)(<!-- /example-output -->)",
                  re.S)
#: A time the commands print ("converged; 17.2 s", "(155 s)"): never compared.
TIME = re.compile(r"\b\d+(?:\.\d+)? (?:s|ms)\b")
#: A printed number, not part of a name (b015, E0t) or of a hash.
NUMBER = re.compile(r"(?<![\w.])-?\d+(?:\.\d+)?(?:e[-+]?\d+)?(?![\w.])")


# ------------------------------------------------------------------------------ running
def normalize(text, folder=None):
    """Output without this machine's paths (the repository's and the run folder's)."""
    for path in (folder, ROOT):
        if path is not None:
            text = text.replace(f"{Path(path).resolve()}/", "").replace(f"{path}/", "")
    return text


def run_example(name, folder):
    """Run the commands of example ``name`` in ``folder``; return what they printed, each
    command after a ``$ command`` line (stdout and stderr in the order written)."""
    env = dict(os.environ, PYTHONUNBUFFERED="1", MPLBACKEND="Agg")
    parts = []
    for command in EXAMPLES[name]:
        args = shlex.split(command)[1:]
        run = subprocess.run([sys.executable, "-m", "turgorbayes", *args, *QUIET.get(args[0], [])],
                             cwd=folder, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             text=True, check=False)
        if run.returncode != 0:
            raise SystemExit(f"example {name}: `{command}` exited {run.returncode}:\n{run.stdout[-3000:]}")
        parts.append(f"$ {command}\n{normalize(run.stdout, folder)}")
    return "".join(parts)


def read_results(path):
    """From a result file: example -> its recorded output (the ``$ command`` lines included),
    and example -> the provenance record of the run that printed it."""
    out, records, name = {}, {}, None
    for line in Path(path).read_text(encoding="utf-8").splitlines(keepends=True):
        if line.startswith("## example: "):
            name = line[len("## example: "):].strip()
            out[name] = ""
        elif line.startswith("# provenance: ") and (name or "run") not in records:
            records[name or "run"] = json.loads(line[len("# provenance: "):])
        elif name is not None:
            out[name] += line
    return out, records


def write_results(path, outputs, records):
    """The result file: the run's provenance, then per example its own provenance and output."""
    from turgorbayes.provenance import header_line

    lines = [header_line(records["run"]) + "\n",
             "# The example commands README.md and docs/ quote (scripts/example_outputs.py)\n"]
    for name in EXAMPLES:
        if name in outputs:
            lines += [f"## example: {name}\n", header_line(records.get(name, records["run"])) + "\n",
                      outputs[name]]
    Path(path).write_text("".join(lines), encoding="utf-8")


# ------------------------------------------------------------------------------ blocks
def _command_output(output, command):
    """The lines one command printed in an example's output."""
    block = output.split(f"$ {command}\n", 1)[1]
    return block.split("\n$ ", 1)[0].splitlines()


def _first(lines, prefix):
    i = next((i for i, line in enumerate(lines) if line.startswith(prefix)), None)
    if i is None:
        raise ValueError(f"no line starting with {prefix!r} in the output (has the format changed? "
                         "update BLOCKS in scripts/example_outputs.py)")
    return i


def _cut(line, marker, tail):
    """``line`` up to ``marker`` (included), then ``tail``."""
    return line[:line.index(marker) + len(marker)] + tail


def fit_block(outputs):
    """The fit's summary: the cells, convergence, the six quantities, the first warning."""
    lines = _command_output(outputs["fit"], EXAMPLES["fit"][0])
    start, end = _first(lines, "fitting "), _first(lines, "warning: ")
    return lines[start:end] + [_cut(lines[end], "for their cell:", " ...")]


def validate_block(outputs):
    """``turgorbayes validate`` on the bundled example, all of it."""
    return _command_output(outputs["validate"], EXAMPLES["validate"][0])


def criticize_block(outputs):
    """What was flagged, the best named effect and the verdict's lines."""
    lines = _command_output(outputs["criticize"], EXAMPLES["criticize"][0])
    return [lines[_first(lines, "checks flagged")], lines[_first(lines, "best named effect")],
            "...", *lines[_first(lines, "verdict: "):]]


def table_block(outputs):
    """The markdown table without its provenance rows."""
    lines = _command_output(outputs["table"], EXAMPLES["table"][0])
    return [line for line in lines if line.startswith("|") and not line.startswith("| provenance |")]


def conditions_block(outputs):
    """The turgor contrast of the conditions, headline and shared-wall number."""
    lines = _command_output(outputs["conditions"], EXAMPLES["conditions"][1])
    c, s = _first(lines, "contrasts ("), _first(lines, "if the wall were the same")
    assumes = next(line for line in lines[c:s] if line.startswith("    ") and " assumes: " in line)
    return [lines[c], lines[c + 1], "  ...", assumes, lines[s],
            _cut(lines[s + 1], "(not checked: ", "...)")]


def series_block(outputs):
    """An osmotic series without bulged cells: the turgor in the growth medium, the inactive
    fraction, the buffering and each level's turgor."""
    lines = _command_output(outputs["series"], EXAMPLES["series"][1])
    table = _first(lines, "  medium_mOsm")
    return [lines[_first(lines, "fitting ")], *lines[_first(lines, "osmotic series ("):table + 5]]


#: block name -> the function that selects its lines from the examples' outputs.
BLOCKS = {"validate": validate_block, "fit": fit_block, "criticize": criticize_block,
          "table": table_block, "conditions": conditions_block,
          "series": series_block}


def render_block(name, outputs):
    """The text between a block's markers: a fenced code block."""
    return "```\n" + "\n".join(BLOCKS[name](outputs)) + "\n```\n"


def quoted_blocks(text):
    """``[(name, body)]`` of the marked blocks of a page's text."""
    return [(m.group("name"), m.group("body")) for m in MARK.finditer(text)]


def rewrite(text, outputs):
    """``text`` with every marked block rendered anew from ``outputs``."""
    return MARK.sub(lambda m: m.group(1) + render_block(m.group("name"), outputs) + m.group(4), text)


# ------------------------------------------------------------------------------ comparing
def differences(quoted, printed):
    """Where ``printed`` differs from ``quoted`` beyond the printing's precision: the words
    must be the same and each number within one unit of its last printed digit (a number that
    moves at the 1e-4 level with the dependencies' versions may round either way); times are
    not compared. Returns a list of the differing lines (empty: the same)."""
    out = []
    a_lines, b_lines = quoted.splitlines(), printed.splitlines()
    if len(a_lines) != len(b_lines):
        return [f"{len(a_lines)} lines quoted, {len(b_lines)} printed"]
    for a, b in zip(a_lines, b_lines, strict=True):
        a, b = TIME.sub("<time>", a), TIME.sub("<time>", b)
        na, nb = NUMBER.findall(a), NUMBER.findall(b)
        same = NUMBER.sub("#", a) == NUMBER.sub("#", b) and len(na) == len(nb) and all(
            abs(float(x) - float(y)) <= _unit(x, y) * (1 + 1e-9) for x, y in zip(na, nb, strict=True))
        if not same:
            out.append(f"quoted:  {a}\nprinted: {b}")
    return out


def _unit(*numbers):
    """One unit of the last printed digit of the finer of two printed numbers ("465" and
    "465.1": 0.1; trailing zeros are not printed, so "1.2" against "1.216" is 0.001)."""
    def digits(x):
        mantissa, _, exponent = x.lower().partition("e")
        decimals = len(mantissa.partition(".")[2])
        return decimals - int(exponent or 0)
    return 10.0 ** -max(digits(x) for x in numbers)


# ------------------------------------------------------------------------------ main
def main(argv=None):
    sys.path.insert(0, str(ROOT))
    from turgorbayes.provenance import add_output_options, run_record, study_path

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--only", default=",".join(EXAMPLES),
                        help="comma-separated examples to run (default: all); the others are "
                             "kept from the result file")
    parser.add_argument("--from-results", action="store_true",
                        help="run nothing: rewrite the marked blocks from the tracked result file "
                             "(after moving or adding a marker)")
    add_output_options(parser)
    args = parser.parse_args(argv)
    names = [n for n in args.only.split(",") if n]
    unknown = sorted(set(names) - set(EXAMPLES))
    if unknown:
        parser.error(f"unknown example(s) {', '.join(unknown)}; known: {', '.join(EXAMPLES)}")
    tracked = ROOT / "studies" / "results" / RESULT
    outputs, records = read_results(tracked) if tracked.is_file() else ({}, {})
    if not args.from_results:
        records["run"] = run_record(["scripts/example_outputs.py", *(argv or sys.argv[1:])])
        with tempfile.TemporaryDirectory() as folder:
            for name in [n for n in EXAMPLES if n in names]:  # in order: table reads fit's folder
                print(f"running {name}: {'; '.join(EXAMPLES[name])}", flush=True)
                outputs[name] = run_example(name, folder)
                records[name] = records["run"]
        path = study_path(args, RESULT)
        write_results(path, outputs, records)
        print(f"wrote {path}")
        if args.update:
            write_results(TEST_COPY, outputs, records)
            print(f"wrote {TEST_COPY.relative_to(ROOT)}")
    for page in PAGES:
        text = page.read_text(encoding="utf-8")
        new = rewrite(text, outputs)
        if new != text:
            if args.update:
                page.write_text(new, encoding="utf-8")
            print(f"{'rewrote' if args.update else 'would rewrite (run with --update)'} the "
                  f"example outputs of {page.relative_to(ROOT)}")


if __name__ == "__main__":
    main()
