"""Output folders of ``fit``, ``criticize`` and ``report``: checked before any computation, found
by each other with the defaults, and free of the writing machine's absolute paths.

References: folders the operating system refuses (a path under a regular file, ``/proc``,
``/sys``, a folder without write permission), checked independently with ``os``; the files the
commands are documented to write (README "What you get"); the tmp folder's own absolute path.
"""

import contextlib
import io
import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import pytest

from turgorbayes import surrogate
from turgorbayes.cli import main
from turgorbayes.cli.criticize import DEFAULT_OUT
from turgorbayes.cli.validate import check_output_dir, check_output_file
from turgorbayes.errors import TurgorBayesError
from turgorbayes.report import criticism_dir_of

SHORT_FIT = ["--max-steps", "200", "--ensembles", "1", "--walkers", "10", "--no-progress"]
# one cheap candidate, no exact refits: a criticism in about 10 s
SHORT_CRITICISM = ["--effects", "wall_softening", "--draws", "400", "--max-refits", "0"]


def run_cli(*args, cwd=None):
    """The command line as a user runs it, in a fresh interpreter; returns (result, seconds)
    (the seconds for the caller's messages only: tests never assert wall time)."""
    start = time.perf_counter()
    result = subprocess.run([sys.executable, "-m", "turgorbayes", *args], capture_output=True,
                            text=True, timeout=120, check=False, cwd=cwd)
    return result, time.perf_counter() - start


def _refused(path):
    """Whether the operating system refuses to create a file in (or the folder) ``path``."""
    try:
        os.makedirs(path, exist_ok=True)
        probe = os.path.join(path, ".probe")
        with open(probe, "w"):
            pass
        os.remove(probe)
        return False
    except OSError:
        return True


def _bad_outs(tmp_path):
    """Output folders that cannot be written, each checked to be refused by ``os`` itself."""
    (tmp_path / "a_file").write_text("x")
    outs = [str(tmp_path / "a_file" / "sub"), "/proc/forbidden", "/sys"]
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)  # refused to a normal user; root writes anyway and _refused says so
    outs.append(str(locked))
    return [o for o in outs if _refused(o)]


@pytest.mark.parametrize("command", ["fit", "criticize"])
def test_unwritable_out_fails_at_once_with_one_line(tmp_path, command):
    outs = _bad_outs(tmp_path)
    assert outs  # at least the path under a regular file is refused everywhere
    for out in outs:
        result, _ = run_cli(command, "--out", out)
        assert result.returncode == 2, (out, result.stderr)
        lines = result.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: ") and out in lines[0], lines
        for raw in ("Traceback", "o_flags", "Unable to", "Errno"):
            assert raw not in result.stderr, (out, result.stderr)
        # nothing was started: a fit or criticism prints its data summary on stdout first
        assert result.stdout == ""


def test_bad_data_leaves_no_output_folder(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("cell_id,group\nc1,intact\n")
    result, _ = run_cli("fit", str(bad), "--out", str(tmp_path / "out" / "fit"))
    assert result.returncode == 2 and "bad.csv" in result.stderr
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv"]


def test_report_out_unwritable_fails_before_reading_the_fit(tmp_path):
    # the fit folder is empty: reading it would fail differently ("is not a fit output directory")
    (tmp_path / "fit").mkdir()
    (tmp_path / "a_file").write_text("x")
    result, _ = run_cli("report", str(tmp_path / "fit"), "--out",
                        str(tmp_path / "a_file" / "report.html"))
    assert result.returncode == 2
    assert result.stderr == f"error: output folder {tmp_path / 'a_file'} (--out) is a file, not a folder\n"


def test_check_output_dir_leaves_nothing_and_names_the_problem(tmp_path):
    (tmp_path / "kept").mkdir()
    assert check_output_dir(tmp_path / "kept") == tmp_path / "kept"
    assert check_output_dir(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"
    # the folders made for the check and the write probe are gone again
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["kept"]
    (tmp_path / "f").write_text("x")
    with pytest.raises(TurgorBayesError, match=r"output folder .*f \(--out\) is a file, not a folder"):
        check_output_dir(tmp_path / "f")
    with pytest.raises(TurgorBayesError, match=r"output file .* \(--out\) is a folder, not a file"):
        check_output_file(tmp_path)


def test_report_finds_the_criticism_by_default(tmp_path):
    fit = tmp_path / "fit"
    (fit / "criticism").mkdir(parents=True)
    assert criticism_dir_of(fit) is None
    (fit / "criticism.json").write_text("{}")  # the old layout: criticism inside FIT_DIR
    assert criticism_dir_of(fit) == fit
    (fit / "criticism" / "criticism.json").write_text("{}")  # criticize's default wins
    assert criticism_dir_of(fit) == fit / "criticism"
    other = tmp_path / "elsewhere"
    other.mkdir()
    with pytest.raises(TurgorBayesError, match="elsewhere holds no criticism.json"):
        criticism_dir_of(fit, other)
    (other / "criticism.json").write_text("{}")
    assert criticism_dir_of(fit, other) == other  # --criticism DIR still wins


def _main(*args):
    """``turgorbayes ARGS`` in this process; returns the exit status."""
    with pytest.raises(SystemExit) as exc:
        main(list(args))
    return exc.value.code


#: Tests of the module-scoped ``default_run`` carry this ``xdist_group``: one process of
#: ``pytest -n 2 --dist loadgroup`` runs the three commands once.
DEFAULT_RUN_GROUP = pytest.mark.xdist_group("cli_default_run")


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    """fit, criticize and report with their default folders, run from an empty folder."""
    if not surrogate.default_path().is_file():
        pytest.skip("shipped surrogate table not built yet")
    root = tmp_path_factory.mktemp("defaults")
    printed = io.StringIO()
    with pytest.MonkeyPatch.context() as mp, contextlib.redirect_stdout(printed):
        mp.chdir(root)
        codes = [_main("fit", *SHORT_FIT), _main("criticize", *SHORT_CRITICISM),
                 _main("report")]  # FIT_DIR defaults to turgorbayes_fit, fit's default
    return root, codes, printed.getvalue()


@pytest.mark.slow
@DEFAULT_RUN_GROUP
def test_defaults_give_one_report_with_the_criticism(default_run):
    root, codes, _ = default_run
    assert codes == [0, 0, 0]
    assert Path(DEFAULT_OUT) == Path("turgorbayes_fit") / "criticism"
    crit = json.loads((root / DEFAULT_OUT / "criticism.json").read_text())
    page = (root / "turgorbayes_fit" / "report.html").read_text()
    assert "No <code>criticism.json</code> found" not in page
    assert f"best named effect: <b>{crit['selected_effect'] or 'none'}</b>" in page
    # the verdict's status and paragraph, as criticism.json has them, lead the page: its
    # section comes before every other one (tests/browser checks where a browser draws it)
    import html

    assert page.count("<h2>Verdict</h2>") == 1
    verdict = page.split("<h2>Verdict</h2>", 1)[1].split("<h2>", 1)[0]
    assert "<h2>" not in page.split("<h2>Verdict</h2>", 1)[0]
    assert crit["verdict"]["status"].upper().replace("_", " ") in verdict
    assert html.escape(crit["verdict"]["text"])[:60] in verdict


@pytest.mark.slow
@DEFAULT_RUN_GROUP
def test_criticize_names_each_candidate_as_it_starts(default_run):
    # reference: the candidates criticism.json lists (what the workflow actually fitted), and
    # the workflow's own end-of-step messages ("checks: ...", "NAME: delta elpd ...")
    root, _, printed = default_run
    crit = json.loads((root / DEFAULT_OUT / "criticism.json").read_text())
    fitted = [c["effect"] for c in crit["candidates"]]
    assert fitted == ["wall_softening"]  # SHORT_CRITICISM's one candidate
    lines = printed.splitlines()
    start = lines.index("  candidate 1/1: wall_softening ...")
    assert lines[start - 1].startswith("  checks: ")  # it starts after the baseline's checks
    assert lines[start + 1].startswith("  wall_softening: delta elpd")  # and ends next


@pytest.mark.slow
@DEFAULT_RUN_GROUP
def test_outputs_hold_no_absolute_path(default_run):
    root, _, _ = default_run
    files = [p for p in root.rglob("*") if p.is_file()]
    assert {"summary.json", "report.md", "report.html", "criticism.json", "posterior.nc"} <= \
        {p.name for p in files}
    package = Path(surrogate.__file__).resolve().parents[1]  # where the example and table live
    for p in files:
        data = p.read_bytes()
        for absolute in (str(root), str(package)):
            assert absolute.encode() not in data, (p, absolute)
    summary = json.loads((root / "turgorbayes_fit" / "summary.json").read_text())
    assert summary["data"]["path"] == "example_cells.csv"
    assert summary["surrogate"]["path"] == surrogate.default_path().name
    assert len(summary["data"]["sha256"]) == 64


def _significant_digits(number):
    """Significant digits of a JSON number as written ("464.20000000000005" -> 17)."""
    mantissa = re.split(r"[eE]", number.lstrip("-"))[0].replace(".", "").lstrip("0")
    return len(mantissa)


def test_simulate_sidecar_has_no_float_noise(tmp_path):
    if not surrogate.default_path().is_file():
        pytest.skip("shipped surrogate table not built yet")
    assert _main("simulate", "--out", str(tmp_path / "s.csv"), "--seed", "1",
                 "--n-bulged", "5", "--n-intact", "3") == 0
    text = (tmp_path / "s.json").read_text()
    numbers = re.findall(r"-?\d+\.\d+(?:[eE][-+]?\d+)?", text)
    assert numbers and max(map(_significant_digits, numbers)) <= 12
    # the paper's R0 = 464.2 nm (Deng et al. 2011), which 464.2e-9 * 1e9 turns into 464.20000000000005
    assert json.loads(text)["parameters"]["R0_nm"] == 464.2


def test_simulate_warns_when_radius_spread_keeps_the_default_radius_errors(tmp_path, capsys):
    # the help of --Rc-err-nm advises smaller errors with radius_spread (README "Command line"):
    # the default warns once on stderr, explicit errors do not
    if not surrogate.default_path().is_file():
        pytest.skip("shipped surrogate table not built yet")
    args = ("simulate", "--seed", "1", "--n-bulged", "5", "--n-intact", "3",
            "--effect", "radius_spread", "--effect-size", "0.02")
    assert _main(*args, "--out", str(tmp_path / "a.csv")) == 0
    assert "--Rc-err-nm 8 12" in capsys.readouterr().err
    assert _main(*args, "--out", str(tmp_path / "b.csv"), "--Rc-err-nm", "8", "12") == 0
    assert "warning" not in capsys.readouterr().err
