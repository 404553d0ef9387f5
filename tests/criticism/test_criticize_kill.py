"""A running ``turgorbayes criticize`` killed with SIGKILL resumes from its cache: the second run
fits only the candidates the killed one had not stored in ``OUT/.cache/criticize``, and writes
the criticism.json of a run without the cache (docs/outputs.md, "The cache").

Reference: the same command with ``--no-cache``; the candidates fitted are counted on the
workflow's worker task (as tests/criticism/test_candidate_cache.py does in one process), the
ones taken from the cache by the run's own message and by the entries the kill left.
"""

import os
import signal
import subprocess
import sys
import time

import pytest

from turgorbayes.cli import main
from turgorbayes.cli.criticize import CACHE_DIR
from turgorbayes.workflows import criticize as workflow

EFFECTS = ("pressure_error", "turgor_spread", "bad_curves")
# few draws and no exact refits (tests/cli/test_cli_outputs.py: one cheap candidate in ~10 s)
OPTIONS = ["--effects", ",".join(EFFECTS), "--draws", "400", "--max-refits", "0", "--seed", "2"]


@pytest.fixture(scope="module")
def data(tmp_path_factory):
    """A small simulated cell table (12 bulged + 8 intact cells, as test_candidate_cache.py's)."""
    path = tmp_path_factory.mktemp("data") / "cells.csv"
    assert _main("simulate", "--out", str(path), "--n-bulged", "12", "--n-intact", "8",
                 "--seed", "5") == 0
    return path


def _main(*args):
    with pytest.raises(SystemExit) as exit_info:
        main(list(args))
    return exit_info.value.code


def _entries(out):
    """The whole entries of the cache in ``out`` (a killed write leaves only a ``.tmp``)."""
    return sorted((out / CACHE_DIR).glob("*.pkl"))


def _counting(monkeypatch):
    """The candidates fitted from now on (their names)."""
    fitted, fit = [], workflow._fit_candidate

    def counted(job):
        fitted.append(job[2])
        return fit(job)

    monkeypatch.setattr(workflow, "_fit_candidate", counted)
    return fitted


def _kill_after_first_entry(data, out):
    """Start ``turgorbayes criticize`` in a child process and SIGKILL it once its cache holds an
    entry (the next candidate's fit then running); the number of entries it left."""
    argv = [sys.executable, "-m", "turgorbayes", "criticize", str(data), "--out", str(out),
            "--no-progress", *OPTIONS]
    with open(out.parent / "child.err", "wb") as err:
        child = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=err)
        deadline = time.monotonic() + 120
        while not _entries(out) and child.poll() is None:
            assert time.monotonic() < deadline, "the child stored no candidate in 120 s"
            time.sleep(0.05)
        running = child.poll() is None
        os.kill(child.pid, signal.SIGKILL)
        child.wait()
    assert running, (out.parent / "child.err").read_text()  # killed, not finished
    assert child.returncode == -signal.SIGKILL
    assert not (out / "criticism.json").exists()
    return len(_entries(out))


@pytest.mark.slow
def test_a_killed_criticize_fits_only_the_missing_candidates(data, tmp_path, monkeypatch,
                                                             capsys):
    out = tmp_path / "killed" / "criticism"
    out.parent.mkdir()
    stored = _kill_after_first_entry(data, out)
    # one candidate at least was stored, and the kill came before the last one was
    assert 1 <= stored < len(EFFECTS)
    fitted = _counting(monkeypatch)
    capsys.readouterr()
    assert _main("criticize", str(data), "--out", str(out), *OPTIONS) == 0
    # candidates are fitted in their order on one worker: the first `stored` were cached
    assert fitted == list(EFFECTS[stored:])
    message = f"{stored} of {len(EFFECTS)} candidates from the cache {out / CACHE_DIR}"
    assert message in capsys.readouterr().out
    assert len(_entries(out)) == len(EFFECTS)  # the resumed run stored the others
    fitted.clear()
    reference = tmp_path / "reference"
    assert _main("criticize", str(data), "--out", str(reference), "--no-progress", "--no-cache",
                 *OPTIONS) == 0
    assert fitted == list(EFFECTS)  # the reference fitted every candidate itself
    assert not (reference / ".cache").exists()
    # criticism.json holds no timing (the candidates' seconds are only printed)
    assert (out / "criticism.json").read_bytes() == (reference / "criticism.json").read_bytes()
