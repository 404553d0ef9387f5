"""The example outputs README.md and docs/ quote are what the code prints.

Every block between ``<!-- example-output: NAME -->`` and ``<!-- /example-output -->`` must be
what ``scripts/example_outputs.py`` renders from ``example_outputs.txt``, the commands' own
output (the script writes it into ``studies/results/`` and this test's copy into
``tests/data/study_results/``; fast). The cheap examples are run again and compared with the
quoted blocks: ``validate`` (fast), the bundled example's ``fit`` (the session fixture
``conftest.example_fit``, shared with tests/browser) and the parameter rows of ``table`` on it
(slow). A change to what these commands print, or to a number of the bundled example beyond its
last printed digit, fails here until ``scripts/example_outputs.py --update`` is run.
``criticize`` and the conditions' fit (minutes) are compared with the result file only.

References: the result file, written by the commands themselves; the commands' output now.
"""

import contextlib
import importlib.util
import io
from pathlib import Path

import pytest

from turgorbayes.cli import main

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "tests" / "data" / "study_results" / "example_outputs.txt"


def _script():
    spec = importlib.util.spec_from_file_location("example_outputs",
                                                  ROOT / "scripts" / "example_outputs.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


ex = _script()


def _inside(body):
    """A block's lines inside its code fence."""
    assert body.startswith("```\n") and body.endswith("```\n"), body[:80]
    return body[4:-4].rstrip("\n")


def quoted(name):
    """``[(page, text)]`` of every block ``name`` that README.md and docs/ quote."""
    return [(page.relative_to(ROOT), _inside(body)) for page in ex.PAGES
            for n, body in ex.quoted_blocks(page.read_text(encoding="utf-8")) if n == name]


def _printed(*args):
    """What ``turgorbayes ARGS`` prints (stdout and stderr in order), without machine paths."""
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out), \
            pytest.raises(SystemExit) as exit_info:
        main(list(args))
    assert exit_info.value.code == 0, out.getvalue()[-3000:]
    return ex.normalize(out.getvalue())


def test_every_quoted_block_is_rendered_from_the_result_file():
    outputs, _ = ex.read_results(RESULTS)
    stale = []
    for page in ex.PAGES:
        for name, body in ex.quoted_blocks(page.read_text(encoding="utf-8")):
            assert name in ex.BLOCKS, f"{page.name}: unknown example output {name!r}"
            if body != ex.render_block(name, outputs):
                stale.append(f"{page.relative_to(ROOT)}: {name}")
    assert stale == [], "run scripts/example_outputs.py --from-results --update"


def test_every_example_is_quoted_and_its_commands_shown():
    texts = "\n".join(p.read_text(encoding="utf-8") for p in ex.PAGES)
    assert {name for name in ex.BLOCKS if quoted(name)} == set(ex.BLOCKS)
    # the commands run are the ones the pages show (as typed, without the log-only options)
    for commands in ex.EXAMPLES.values():
        for command in commands:
            assert command in texts, command
    outputs, records = ex.read_results(RESULTS)
    assert set(outputs) == set(ex.EXAMPLES)
    assert all(records[name]["commit"] for name in ex.EXAMPLES)  # each output's provenance


def test_the_comparison_ignores_times_and_the_last_digit_but_nothing_else():
    # reference: hand-made pairs; one unit of the last printed digit may differ (a 1e-4 change
    # of a number printed to 4 digits), times never count, words and other numbers do
    quote = "converged; 17.2 s\n  gamma        1.283 +- 0.04 [1.216, 1.349]\n  R0_nm  465 b015"
    same = "converged; 41.0 s\n  gamma        1.284 +- 0.04 [1.216, 1.349]\n  R0_nm  465.1 b015"
    assert ex.differences(quote, same) == []
    for changed in (quote.replace("1.283", "1.285"), quote.replace("[1.216", "[1.2"),
                    quote.replace("gamma", "Gamma"), quote.replace("b015", "b016"),
                    quote + "\nwarning: new line", quote.replace("+- 0.04 ", "")):
        assert ex.differences(quote, changed) != [], changed


def test_the_blocks_fail_loudly_when_the_output_changes_shape():
    # reference: the fit's output without its warning line: the block cannot be cut any more
    outputs, _ = ex.read_results(RESULTS)
    broken = {"fit": outputs["fit"].replace("warning: ", "caution: ")}
    with pytest.raises(ValueError, match="no line starting with 'warning: '"):
        ex.fit_block(broken)


def test_validate_prints_what_the_docs_quote(table):
    printed = "\n".join(ex.validate_block({"validate": "$ turgorbayes validate\n" + _printed("validate")}))
    for page, text in quoted("validate"):
        assert ex.differences(text, printed) == [], page


@pytest.mark.slow
@pytest.mark.xdist_group("example_fit")
def test_fit_prints_what_the_readme_quotes(example_fit):
    _, printed = example_fit
    now = "\n".join(ex.fit_block({"fit": "$ turgorbayes fit\n" + ex.normalize(printed)}))
    for page, text in quoted("fit"):
        assert ex.differences(text, now) == [], page


@pytest.mark.slow
@pytest.mark.xdist_group("example_fit")
def test_table_prints_the_parameter_rows_the_docs_quote(example_fit):
    fit_dir, _ = example_fit
    rows = [line for line in _printed("table", str(fit_dir), "--format", "markdown").splitlines()
            if line.startswith("| parameters |")]
    assert len(rows) == 6
    for page, text in quoted("table"):
        quoted_rows = [line for line in text.splitlines() if line.startswith("| parameters |")]
        assert ex.differences("\n".join(quoted_rows), "\n".join(rows)) == [], page
