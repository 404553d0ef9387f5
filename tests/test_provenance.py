"""The run record every study writes (turgorbayes.provenance)."""

import json
import subprocess
from pathlib import Path

import pytest

import turgorbayes
from turgorbayes import provenance


def _git(repo, *args):
    return subprocess.run(["git", "-C", str(repo), *args], capture_output=True, text=True,
                          check=True).stdout.strip()


@pytest.fixture
def repo(tmp_path):
    """A git repository with one commit of one file."""
    _git(tmp_path, "init", "-q")
    (tmp_path / "a.txt").write_text("one\n")
    _git(tmp_path, "add", "a.txt")
    _git(tmp_path, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", "first")
    return tmp_path


def test_record_names_the_commit_and_is_clean(repo):
    record = provenance.run_record(["study.py", "--n", "3"], directory=repo)
    assert record["commit"] == _git(repo, "rev-parse", "HEAD")
    assert record["dirty"] is False
    assert record["argv"] == ["study.py", "--n", "3"]
    assert set(record) == {"commit", "dirty", "argv", "date", "machine", "python", "version",
                           "dependencies"}
    assert record["version"] == turgorbayes.__version__
    assert record["date"].endswith("+00:00")


def test_record_is_dirty_after_an_edit(repo):
    (repo / "a.txt").write_text("two\n")
    assert provenance.run_record([], directory=repo)["dirty"] is True


def test_untracked_files_count_only_when_asked(repo):
    (repo / "new.txt").write_text("x\n")
    assert provenance.git_state(repo)["changes"] == []
    assert provenance.git_state(repo, untracked=True)["changes"] == ["?? new.txt"]


def test_outside_a_checkout_the_commit_is_unknown(tmp_path):
    record = provenance.run_record([], directory=tmp_path)
    assert record["commit"] is None and record["dirty"] is None


@pytest.mark.parametrize("suffix", [".txt", ".json", ".jsonl", "header.jsonl"])
def test_read_header_finds_the_record_in_each_format(tmp_path, repo, suffix):
    record = provenance.run_record(["s.py"], directory=repo)
    path = tmp_path / f"result{suffix}"
    if suffix == "header.jsonl":  # JSON lines printed by a study after its header line
        path.write_text('{"x": 0}\n' + provenance.header_line(record) + '\n{"x": 1}\n')
    elif suffix == ".txt":
        path.write_text(provenance.header_line(record) + "\nx = 1\n")
    elif suffix == ".json":
        path.write_text(json.dumps({"x": 1, "provenance": record}))
    else:
        path.write_text('{"x": 0}\n' + json.dumps({"x": 1, "provenance": record}) + "\n")
    assert provenance.read_header(path) == record


def test_read_header_of_a_file_without_a_record_is_none(tmp_path):
    path = tmp_path / "old.txt"
    path.write_text("x = 1\n# a comment\n")
    assert provenance.read_header(path) is None


def test_run_record_names_the_dependency_versions_and_the_lock(tmp_path):
    # reference: importlib.metadata (what pip installed) and hashlib over the lock file's bytes
    import hashlib
    from importlib.metadata import version

    deps = provenance.run_record([])["dependencies"]
    for name in ("numpy", "scipy", "arviz-stats", "emcee", "scikit-fem"):
        assert deps[name] == version(name), name
    lock = provenance.LOCK_FILE
    if lock.is_file():  # a source checkout
        assert deps["lock_sha256"] == hashlib.sha256(lock.read_bytes()).hexdigest()
    assert provenance.dependency_versions(tmp_path / "none.txt")["lock_sha256"] is None



def test_a_study_writes_its_tracked_results_only_when_told(tmp_path):
    # Reference: git itself says which folder is ignored (git check-ignore) and which is
    # tracked (studies/results holds committed files)
    import argparse

    from turgorbayes.provenance import STUDY_OUTPUT, STUDY_RESULTS, add_output_options, study_path

    parser = add_output_options(argparse.ArgumentParser())
    args = parser.parse_args(["--output-dir", str(tmp_path / "o")])
    assert study_path(args, "x.txt") == tmp_path / "o" / "x.txt" and (tmp_path / "o").is_dir()
    assert study_path(parser.parse_args(["--update"]), "x.txt") == STUDY_RESULTS / "x.txt"
    default = parser.parse_args([])
    assert Path(default.output_dir) == STUDY_OUTPUT
    root = STUDY_RESULTS.parents[1]
    ignored = subprocess.run(["git", "check-ignore", "-q", str(STUDY_OUTPUT / "x.txt")], cwd=root)
    tracked = subprocess.run(["git", "ls-files", "--error-unmatch", str(STUDY_RESULTS)],
                             cwd=root, capture_output=True)
    assert ignored.returncode == 0 and tracked.returncode == 0


def test_a_smoke_run_never_writes_the_tracked_results():
    # reference: the rule itself: a smoke run's numbers mean nothing (add_output_options)
    import argparse

    import pytest

    from turgorbayes.provenance import add_output_options, study_path

    parser = add_output_options(argparse.ArgumentParser())
    with pytest.raises(SystemExit, match="--smoke and --update"):
        study_path(parser.parse_args(["--smoke", "--update"]), "x.txt")


def test_no_study_defaults_to_writing_the_tracked_results():
    # Reference: the scripts' own text: an output default inside studies/results (a path
    # constant or an option default; scripts written before the rename say benchmarks/results)
    # would rewrite a tracked file on every re-run
    import re

    bench = Path(__file__).resolve().parents[1] / "studies"
    writes = re.compile(r'default="(?:studies|benchmarks)/results|^OUT = .*"results"', re.M)
    offenders = [p.name for p in sorted(bench.glob("*.py")) if writes.search(p.read_text())]
    assert offenders == []


def test_source_digest_changes_with_every_edit_of_the_sources(tmp_path):
    # reference: a throwaway git repository; a clean tree gives its commit (git rev-parse),
    # any edit of a tracked file, or a new file, another digest, and the same edit the same one
    import subprocess

    from turgorbayes.provenance import source_digest

    def git(*args):
        subprocess.run(["git", "-C", str(tmp_path), *args], check=True, capture_output=True)

    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "a.py").write_text("x = 1\n")
    git("init", "-q")
    git("add", ".")
    git("-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "one")
    commit = subprocess.run(["git", "-C", str(tmp_path), "rev-parse", "HEAD"], check=True,
                            capture_output=True, text=True).stdout.strip()
    assert source_digest(pkg) == commit
    (pkg / "a.py").write_text("x = 2\n")
    edited = source_digest(pkg)
    assert edited.startswith(commit + "+") and edited == source_digest(pkg)
    (pkg / "a.py").write_text("x = 3\n")
    assert source_digest(pkg) not in (edited, commit)
    (pkg / "a.py").write_text("x = 1\n")
    (pkg / "new.py").write_text("y = 1\n")
    assert source_digest(pkg) not in (edited, commit)


def test_tee_stdout_copies_what_a_study_prints_into_its_result_file(tmp_path, capsys):
    # reference: the printed text itself; append=True keeps what the file held
    import argparse
    import sys

    from turgorbayes.provenance import add_output_options, tee_stdout

    args = add_output_options(argparse.ArgumentParser()).parse_args(
        ["--output-dir", str(tmp_path)])
    stdout = sys.stdout
    try:
        path = tee_stdout(args, "r.txt")
        print("first line")
        sys.stdout = stdout
        tee_stdout(args, "r.txt", append=True)
        print("second line")
    finally:
        sys.stdout = stdout
    assert path.read_text() == "first line\nsecond line\n"
    assert capsys.readouterr().out == "first line\nsecond line\n"
