"""``turgorbayes curves`` keeps each reduced row in ``OUT/.cache/curves`` (turgorbayes.cache):
a run that is killed, or re-run after rows were added, reduces only the rows missing there,
and writes the very bytes of a run without the cache; a damaged entry is reported in one line
and reduced again, never used (docs/curves.md, "The cache").

Reference: the same manifest reduced with ``--no-cache`` (which leaves no cache behind); the
rows reduced are counted on the pipeline's worker task.
"""

import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

from turgorbayes.cli import main
from turgorbayes.cli.curves import CACHE_DIR
from turgorbayes.curves import pipeline

N_ROWS = 3 * 3 + 2 * 3  # 2 bulged + 1 intact cells, 3 cell-body curves each, 3 bulge curves each


class Killed(Exception):
    """Stands for the run being killed half-way."""


@pytest.fixture(scope="module")
def raw(tmp_path_factory):
    """A small simulated data set's raw curves."""
    folder = tmp_path_factory.mktemp("raw")
    with pytest.raises(SystemExit) as exit_info:
        main(["simulate", "--raw-curves", str(folder), "--n-bulged", "2", "--n-intact", "1",
              "--P-range-kPa", "5", "25", "--seed", "4"])
    assert exit_info.value.code == 0
    return folder


@pytest.fixture(scope="module")
def reference(raw, tmp_path_factory):
    """The outputs of a run without the cache."""
    out = tmp_path_factory.mktemp("ref")
    assert _curves(raw, out, "--no-cache") == 0
    assert not (out / ".cache").exists()
    return out


def _curves(raw, out, *options):
    with pytest.raises(SystemExit) as exit_info:
        main(["curves", str(raw / "manifest.csv"), "--out", str(out / "cells.csv"), "--no-progress",
              "--workers", "1", "--figures", "none", *options])
    return exit_info.value.code


def _counting(monkeypatch, kill_after=None):
    """The rows the pipeline reduces from now on (a list of file names), raising
    :class:`Killed` at row ``kill_after`` + 1."""
    reduced, job = [], pipeline._reduce_job

    def counted(args, progress=False):
        if kill_after is not None and len(reduced) == kill_after:
            raise Killed
        reduced.append(args[0].name)
        return job(args, progress)

    monkeypatch.setattr(pipeline, "_reduce_job", counted)
    return reduced


def _same_outputs(out, reference):
    for name in ("cells.csv", "curves.csv"):
        assert (out / name).read_bytes() == (reference / name).read_bytes(), name


def test_a_killed_run_resumes_with_only_the_missing_rows(raw, reference, tmp_path, monkeypatch,
                                                         capsys):
    reduced = _counting(monkeypatch, kill_after=6)
    with pytest.raises(Killed):
        _curves(raw, tmp_path)
    assert len(reduced) == 6 and len(list((tmp_path / CACHE_DIR).glob("*.pkl"))) == 6
    monkeypatch.undo()
    reduced = _counting(monkeypatch)
    assert _curves(raw, tmp_path) == 0
    assert len(reduced) == N_ROWS - 6  # only the rows the killed run had not done
    out = capsys.readouterr().out
    assert f"reduced {N_ROWS - 6} of {N_ROWS} rows; 6 from the cache" in out
    _same_outputs(tmp_path, reference)
    reduced.clear()
    assert _curves(raw, tmp_path) == 0 and reduced == []  # a third run reduces nothing
    _same_outputs(tmp_path, reference)


def test_rows_added_to_the_manifest_are_the_only_ones_reduced(raw, reference, tmp_path,
                                                              monkeypatch):
    # the first run sees the manifest without its last cell's rows (a copy of the data: the
    # key holds each file's path)
    copy = tmp_path / "raw"
    shutil.copytree(raw, copy)
    lines = (raw / "manifest.csv").read_text().splitlines(keepends=True)
    last = lines[-1].split(",")[1]  # the last row's cell_id
    kept = [line for line in lines if line.split(",")[1:2] != [last]]
    (copy / "short.csv").write_text("".join(kept))
    with pytest.raises(SystemExit) as exit_info:
        main(["curves", str(copy / "short.csv"), "--out", str(tmp_path / "cells.csv"),
              "--no-progress", "--workers", "1", "--figures", "none"])
    assert exit_info.value.code == 0
    reduced = _counting(monkeypatch)
    assert _curves(copy, tmp_path) == 0
    assert len(reduced) == len(lines) - len(kept) > 0
    _same_outputs(tmp_path, reference)


def test_a_damaged_entry_is_reported_and_reduced_again(raw, reference, tmp_path, monkeypatch,
                                                       capsys):
    assert _curves(raw, tmp_path) == 0
    entries = sorted((tmp_path / CACHE_DIR).glob("*.pkl"))
    assert len(entries) == N_ROWS
    truncated, altered = entries[0], entries[1]
    truncated.write_bytes(truncated.read_bytes()[:-7])
    data = bytearray(altered.read_bytes())
    data[-20] ^= 0x01  # one bit of the payload
    altered.write_bytes(bytes(data))
    capsys.readouterr()
    reduced = _counting(monkeypatch)
    assert _curves(raw, tmp_path) == 0
    assert len(reduced) == 2
    out = capsys.readouterr().out.splitlines()
    damaged = [line for line in out if line.startswith("warning: damaged cache entry")]
    assert len(damaged) == 2
    assert any(str(truncated) in line and "bytes of" in line for line in damaged)
    assert any(str(altered) in line and "sha256 mismatch" in line for line in damaged)
    _same_outputs(tmp_path, reference)
    assert len(list((tmp_path / CACHE_DIR).glob("*.pkl"))) == N_ROWS  # both written again


def test_a_real_kill_leaves_only_whole_entries(raw, reference, tmp_path, monkeypatch, capsys):
    # a real SIGKILL, at a known row: the child stalls before its 5th row once 4 are stored
    script = (
        "import sys, time\n"
        "from turgorbayes.curves import pipeline\n"
        "from turgorbayes.cli import main\n"
        "job, n = pipeline._reduce_job, []\n"
        "def slow(args, progress=False):\n"
        "    if len(n) == 4:\n"
        "        time.sleep(600)\n"
        "    n.append(1)\n"
        "    return job(args, progress)\n"
        "pipeline._reduce_job = slow\n"
        "main(sys.argv[1:])\n")
    argv = [sys.executable, "-c", script, "curves", str(raw / "manifest.csv"), "--out",
            str(tmp_path / "cells.csv"), "--no-progress", "--workers", "1", "--figures", "none"]
    child = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    folder = tmp_path / CACHE_DIR
    deadline = time.monotonic() + 120
    while len(list(folder.glob("*.pkl"))) < 4 and child.poll() is None:
        assert time.monotonic() < deadline, "the child stored no 4 entries in 120 s"
        time.sleep(0.1)
    assert child.poll() is None, child.stderr.read().decode()
    os.kill(child.pid, signal.SIGKILL)
    child.wait()
    assert child.returncode == -signal.SIGKILL
    assert not (tmp_path / "cells.csv").exists()
    assert len(list(folder.glob("*.pkl"))) == 4
    capsys.readouterr()
    reduced = _counting(monkeypatch)
    assert _curves(raw, tmp_path) == 0
    assert len(reduced) == N_ROWS - 4
    assert f"reduced {N_ROWS - 4} of {N_ROWS} rows; 4 from the cache" in capsys.readouterr().out
    _same_outputs(tmp_path, reference)
