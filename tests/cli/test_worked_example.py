"""The README's worked example on raw curves leaves a clone clean (``git status`` empty).

The commands are read from README.md (the code block after ``<!-- worked-example -->``) and run
in a fresh clone of this repository, as a new user would after cloning. To keep the test short,
the simulation is smaller (4 + 3 cells) and the fit shorter than the README's: where the
commands write is what is tested, and that does not depend on the sizes.
"""

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
#: Appended to each command of the example (same outputs, fewer cells and steps).
SHORTER = {"simulate": ["--n-bulged", "4", "--n-intact", "3"],
           "fit": ["--max-steps", "200", "--ensembles", "1", "--walkers", "10", "--no-progress"],
           "curves": ["--no-progress"]}


def worked_example():
    """The commands of the README's worked example, as argument lists."""
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"<!-- worked-example -->\s*```bash\n(.*?)```", text, re.S).group(1)
    commands = [shlex.split(line.split("#")[0]) for line in block.splitlines() if line.strip()]
    assert commands and all(c[0] == ".venv/bin/turgorbayes" for c in commands), commands
    return [c[1:] for c in commands]


@pytest.mark.slow
def test_the_worked_example_leaves_the_clone_clean(tmp_path):
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        pytest.skip("not a git checkout")
    clone = tmp_path / "clone"
    subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], check=True)
    env = dict(os.environ, PYTHONPATH=str(clone))
    for args in worked_example():
        run = subprocess.run([sys.executable, "-m", "turgorbayes", *args, *SHORTER[args[0]]],
                             cwd=clone, env=env, capture_output=True, text=True)
        assert run.returncode == 0, (args, run.stdout[-2000:], run.stderr[-2000:])
    # the example wrote its outputs (so the check below is not vacuous) ...
    assert (clone / "turgorbayes_example" / "fit" / "summary.json").is_file()
    assert (clone / "turgorbayes_example" / "cells.csv").is_file()
    # ... and nothing git would show: every output is in an ignored folder
    status = subprocess.run(["git", "status", "--porcelain", "--untracked-files=all"], cwd=clone,
                            capture_output=True, text=True, check=True).stdout
    assert status == "", status
