"""What a newcomer reads first: ``turgorbayes --help`` and ``turgorbayes surrogate info``.

References: click's own truncation marker ("..."), the shipped table's metadata as the file
stores it, and a hand-made convergence record whose lines are written out here.
"""

import json

import pytest

from turgorbayes import surrogate
from turgorbayes.cli import main
from turgorbayes.cli.surrogate import INFO_WIDTH, convergence_lines
from turgorbayes.report.fit import cells_phrase, counted


def _run(args, capsys):
    with pytest.raises(SystemExit) as exc:
        main(args)
    return exc.value.code, capsys.readouterr().out


def test_top_level_help_has_whole_sentences(capsys):
    code, out = _run(["--help"], capsys)
    assert code == 0
    commands = out.split("Commands:")[1]
    assert "..." not in commands  # click marks a cut description with "..."
    names = [line.split()[0] for line in commands.splitlines() if line.startswith("  ") and
             not line.startswith("   ")]
    assert names == ["criticize", "curves", "design", "fit", "report", "simulate", "surrogate", "table",
                     "validate"]


def test_convergence_lines_by_hand():
    conv = {"date": "2026-01-02", "benchmark": "b.py", "production": {"dofs": 100},
            "estimate_rel_error_k": 0.003, "estimate_rel_error_k_linear": 0.04,
            "points": [{"variant": "half", "rel_diff_k": 0.0004}],
            "surrogate_mesh": {"mesh_scale": 3.0, "dofs": 50, "estimate_rel_error_k": 0.008,
                               "points": [{"rel_diff_k": -0.011}, {"rel_diff_k": 0.003}]}}
    assert convergence_lines(conv) == [
        "convergence error of k about 0.3 %, of k_linear about 4 % (100 DOF; b.py, 2026-01-02)",
        "  variants  half +0.04 %",
        "  table     mesh_scale 3.0 (50 DOF) against a finer mesh: largest |k difference| 1.1 % "
        "over 2 points, error estimate 0.8 %"]
    # a table whose mesh has a check of its own: that check first, as "this" mesh
    conv["table_mesh"] = {"mesh_scale": 2.0, "dofs": 70, "points": [{"rel_diff_k": 0.002}]}
    assert convergence_lines(conv, dofs=70) == [
        "convergence against a finer mesh (k at h = R/20; tip radius: the elements under the tip "
        "halved, others: every size halved)",
        "  this      mesh_scale 2.0 (70 DOF) against a finer mesh: largest |k difference| 0.2 % "
        "over 1 points",
        "  earlier   mesh_scale 3.0 (50 DOF) against a finer mesh: largest |k difference| 1.1 % "
        "over 2 points, error estimate 0.8 %"]
    # a correction table's check says where its largest difference is and what it means
    conv["thickness_tables_mesh"] = {"mesh_scale": 3.0, "dofs": 40, "points": [
        {"x": 0.07, "rel_diff_k": 0.013}, {"x": 0.52, "rel_diff_k": -0.12}]}
    assert convergence_lines(conv, dofs=70)[-2:] == [
        "  thickness mesh_scale 3.0 (40 DOF) against a finer mesh: largest |k difference| 12 % "
        "(at x 0.52) over 2 points",
        "            the thickness tables enter only as ratios to a 6 nm table on this same mesh, "
        "where most of this error cancels (docs/fem.md, Wall thickness)"]
    assert convergence_lines(None) == ["convergence not recorded"]
    assert convergence_lines("not recorded (why)") == ["convergence not recorded (why)"]


def test_surrogate_info_is_one_screen_of_words(capsys):
    path = surrogate.default_path()
    if not path.is_file():
        pytest.skip("shipped surrogate table not built yet")
    code, out = _run(["surrogate", "info", str(path)], capsys)
    lines = out.splitlines()
    assert code == 0 and len(lines) <= 50  # 45 before the FE axes, then the thickness note
    assert max(map(len, lines)) <= INFO_WIDTH
    assert '{"' not in out  # no JSON
    code, raw = _run(["surrogate", "info", "--json", str(path)], capsys)
    record = json.loads(raw)
    table = surrogate.load(path)
    assert code == 0 and record["sha256"] == table.sha256
    assert record["mesh_convergence"] == table.metadata["mesh_convergence"]


@pytest.mark.parametrize(("n", "text"), [(0, "0 cells"), (1, "1 cell"), (2, "2 cells")])
def test_counts_agree_with_their_noun(n, text):
    assert counted(n, "cell") == text
    assert cells_phrase(n, 0) == f"{n} bulged + 0 intact {text.split()[1]}"


@pytest.mark.parametrize("command, option", [("simulate", "--effect"), ("fit", "--model")])
def test_help_lists_every_registered_effect(capsys, command, option):
    # reference: the effect registry (a new effect appears in the help without editing it)
    from turgorbayes import effects

    code, out = _run([command, "--help"], capsys)
    assert code == 0
    text = " ".join(out.split(option, 1)[1].split())  # click wraps lines: join the words
    for name in effects.effect_names():
        assert name in text.replace("- ", "-"), name


@pytest.mark.parametrize("command", [["fit"], ["criticize"], ["curves"], ["surrogate", "build"]])
def test_every_command_that_shows_progress_has_the_same_flag(command, capsys):
    # one progress flag name on every command (--no-progress); fit and surrogate build
    # called it --quiet before, which is kept hidden for one release
    code, out = _run([*command, "--help"], capsys)
    assert code == 0
    assert "--no-progress" in out
    assert "--quiet" not in out


def test_the_old_quiet_flag_still_works_and_says_its_new_name():
    import click
    from click.testing import CliRunner

    from turgorbayes.cli.progress import PROGRESS

    seen = []

    @click.command()
    @PROGRESS
    def cmd(progress):
        seen.append(progress)

    runner = CliRunner()
    assert runner.invoke(cmd, []).exit_code == 0
    assert runner.invoke(cmd, ["--no-progress"]).exit_code == 0
    old = runner.invoke(cmd, ["--quiet"])
    assert old.exit_code == 0 and "--no-progress" in old.output
    assert seen == [True, False, False]
