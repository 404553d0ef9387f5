"""The release: one version, and an sdist and a wheel that work away from the repository.

``turgorbayes --version`` must be the version heading CHANGELOG.md's top section (read here with
a regular expression, not through the package). The slow tests build the sdist and, from it, the
wheel, as a maintainer releasing would (``python -m build`` in a clean copy of the working
tree; ``--no-isolation`` uses the setuptools and build of the test extra, so no network), then
install the wheel into a fresh virtual environment outside the repository and run
``turgorbayes fit`` there on the bundled example (about 30 s of CPU in all, most of it the fit).
"""

import hashlib
import json
import math
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import tarfile
import zipfile
from pathlib import Path

import pytest
from packaging.version import InvalidVersion, Version

import turgorbayes
from turgorbayes import _moved

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "turgorbayes"
#: The command a user types: the console script the installation put beside the interpreter.
ENTRY_POINT = Path(sys.executable).parent / "turgorbayes"
#: The slow tests share one build (module fixture), so under ``--dist loadgroup`` one process.
RELEASE_GROUP = pytest.mark.xdist_group("release")


def changelog_version(text):
    """The version heading the top section (``## 0.3.0`` or ``## 0.3.0.dev0 (unreleased)``).

    Raises
    ------
    ValueError
        If there is no ``## `` heading, or the top one is not a PEP 440 version in its
        canonical spelling (``## Unreleased``, ``## v0.3``).
    """
    heading = re.search(r"^## +(\S+)", text, re.MULTILINE)
    if heading is None:
        raise ValueError("CHANGELOG.md has no '## ' section heading")
    word = heading.group(1)
    try:
        canonical = str(Version(word))
    except InvalidVersion:
        canonical = None
    if canonical != word:
        raise ValueError(f"CHANGELOG.md's top section must be headed by the version being made "
                         f"(turgorbayes/_version.py), in canonical PEP 440 spelling, got {word!r}")
    return word


def test_changelog_version_reads_the_top_heading():
    text = "# Changelog\n\n## 0.3.0.dev0 (unreleased)\n\n- a\n\n## 0.2.0\n\n- b\n"
    assert changelog_version(text) == "0.3.0.dev0"
    assert changelog_version("## 1.0.0\n") == "1.0.0"
    for bad in ("# Changelog\n\n## Unreleased\n\n## 0.2.0\n", "## v0.3\n", "# Changelog\n"):
        with pytest.raises(ValueError, match="CHANGELOG.md"):
            changelog_version(bad)


def test_version_is_the_changelog_top_heading():
    top = changelog_version((ROOT / "CHANGELOG.md").read_text(encoding="utf-8"))
    assert ENTRY_POINT.is_file(), f"no console script {ENTRY_POINT} (run scripts/bootstrap)"
    run = subprocess.run([str(ENTRY_POINT), "--version"], capture_output=True, text=True,
                         timeout=120, check=True)
    assert run.stdout.strip() == f"turgorbayes, version {top}"


def test_version_is_below_the_removal_of_the_deprecated_paths():
    # the old module paths (turgorbayes._moved) still ship, so this cannot be their removal's
    # release or a later one; a dev release of it would be (0.4.0.dev0 < 0.4.0) but says the same
    assert Version(turgorbayes.__version__) < Version(_moved.REMOVED_IN)


def _git_files(*args):
    """Files ``git ls-files ARGS`` lists that exist, or None outside a git checkout."""
    if shutil.which("git") is None or not (ROOT / ".git").exists():
        return None
    out = subprocess.run(["git", "-C", str(ROOT), "ls-files", *args], capture_output=True,
                         text=True, check=True).stdout
    return {line for line in out.splitlines() if (ROOT / line).is_file()}  # not deleted ones


def _copy_source_tree(dest):
    """Copy the working tree without what git ignores (``*.egg-info``, ``.venv``, ``build/``).

    A release is built from a clean tree: in the checkout, setuptools would read the
    ``turgorbayes.egg-info/SOURCES.txt`` of earlier builds and ship every file listed there,
    whatever MANIFEST.in and the package data say now.
    """
    files = _git_files("--cached", "--others", "--exclude-standard")
    if files is None:  # e.g. an unpacked sdist
        shutil.copytree(ROOT, dest, ignore=shutil.ignore_patterns(
            ".git", ".venv", "build", "dist", "*.egg-info", "__pycache__", "*.pyc"))
        return
    for name in files:
        (dest / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(ROOT / name, dest / name)


@pytest.fixture(scope="module")
def dist(tmp_path_factory):
    """The sdist and the wheel built from it: ``{"sdist": path, "wheel": path}``."""
    source, out = tmp_path_factory.mktemp("source"), tmp_path_factory.mktemp("dist")
    _copy_source_tree(source)
    run = subprocess.run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out),
                          str(source)], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    sdists, wheels = sorted(out.glob("*.tar.gz")), sorted(out.glob("*.whl"))
    assert len(sdists) == 1 and len(wheels) == 1, sorted(p.name for p in out.iterdir())
    return {"sdist": sdists[0], "wheel": wheels[0]}


@pytest.mark.slow
@RELEASE_GROUP
def test_sdist_is_the_tracked_tree(dist):
    version = turgorbayes.__version__
    assert dist["sdist"].name == f"turgorbayes-{version}.tar.gz"
    top = f"turgorbayes-{version}/"
    with tarfile.open(dist["sdist"]) as tar:
        names = {n.removeprefix(top) for n in tar.getnames() if n.startswith(top)}
    # what a user needs to install the locked versions and run the suite (checked even
    # outside a git checkout)
    for needed in ("README.md", "CHANGELOG.md", "pyproject.toml", "MANIFEST.in",
                   "requirements/lock.txt", "scripts/bootstrap", "tests/conftest.py",
                   "tests/test_release.py", "docs/README.md", "turgorbayes/_version.py",
                   "turgorbayes/data/k_over_PR.nc"):
        assert needed in names, needed
    tracked = _git_files()
    if tracked is not None:
        assert sorted(tracked - names) == []


@pytest.mark.slow
@RELEASE_GROUP
def test_wheel_holds_the_package_and_its_data(dist):
    version = turgorbayes.__version__
    assert dist["wheel"].name == f"turgorbayes-{version}-py3-none-any.whl"
    with zipfile.ZipFile(dist["wheel"]) as wheel:
        names = set(wheel.namelist())
        metadata = wheel.read(f"turgorbayes-{version}.dist-info/METADATA").decode()
        entry_points = wheel.read(f"turgorbayes-{version}.dist-info/entry_points.txt").decode()
    # every file of the package's source folder (data tables included), none left behind
    source = {p.relative_to(ROOT).as_posix() for p in PACKAGE.rglob("*")
              if p.is_file() and "__pycache__" not in p.parts}
    assert {"turgorbayes/data/example_cells.csv", "turgorbayes/data/example_cells.json",
            "turgorbayes/data/k_over_PR.nc"} <= source  # so the comparison is not vacuous
    assert sorted(source - names) == []
    assert f"\nVersion: {version}\n" in metadata
    assert "turgorbayes = turgorbayes.cli:main" in entry_points


def _sha256(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


@pytest.mark.slow
@RELEASE_GROUP
def test_the_installed_wheel_fits_the_example_outside_the_repository(dist, tmp_path):
    venv, elsewhere = tmp_path / "fresh", tmp_path / "elsewhere"
    elsewhere.mkdir()
    # a venv made from a venv's interpreter is based on the base interpreter, not on .venv;
    # this environment's pip installs into it (--python), which saves the venv its own pip
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True,
                   timeout=300)
    python = venv / "bin" / "python"
    subprocess.run([sys.executable, "-m", "pip", "--python", str(python), "install", "-q",
                    "--no-index", "--no-deps", "--disable-pip-version-check", str(dist["wheel"])],
                   check=True, timeout=300)
    # the dependencies from this environment (offline and fast), appended after the fresh
    # site-packages by a .pth line; .pth files in that folder (the editable install's hook,
    # which points at the source tree) are not processed for such a line
    site = Path(subprocess.run([str(python), "-c", "import sysconfig; print(sysconfig.get_path("
                                "'purelib'))"], capture_output=True, text=True,
                               check=True).stdout.strip())
    (site / "_test_release_dependencies.pth").write_text(sysconfig.get_path("purelib") + "\n")
    env = {k: v for k, v in os.environ.items()
           if k not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "PYTHONSTARTUP")}
    env["MPLBACKEND"] = "Agg"

    where = subprocess.run(
        [str(python), "-c", "import importlib.metadata as m, json, sys, turgorbayes; print(json."
         "dumps([turgorbayes.__file__, turgorbayes.__version__, m.version('turgorbayes'), "
         "sys.path]))"], cwd=elsewhere, env=env, capture_output=True, text=True, check=True)
    module_file, version, dist_version, path = json.loads(where.stdout)
    assert Path(module_file).is_relative_to(site), module_file  # the wheel's, not the source's
    assert not any(Path(p).resolve() in (ROOT, PACKAGE) for p in path if p), path
    assert version == dist_version == turgorbayes.__version__

    run = subprocess.run([str(venv / "bin" / "turgorbayes"), "fit", "--out", "run",
                          "--no-progress"], cwd=elsewhere, env=env, capture_output=True,
                         text=True, timeout=900)
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    summary = json.loads((elsewhere / "run" / "summary.json").read_text())
    assert summary["version"] == turgorbayes.__version__
    assert summary["converged"] is True
    # the installed copies of the bundled example and table, the very bytes of the source tree
    data = site / "turgorbayes" / "data"
    assert summary["data"]["sha256"] == _sha256(data / "example_cells.csv")
    assert summary["data"]["sha256"] == _sha256(PACKAGE / "data" / "example_cells.csv")
    assert summary["surrogate"]["sha256"] == _sha256(PACKAGE / "data" / "k_over_PR.nc")
    # no lock outside a source checkout: the run read nothing from the repository
    assert summary["dependencies"]["lock_sha256"] is None
    for name, entry in summary["parameters"].items():
        assert all(math.isfinite(entry[k]) for k in ("mean", "sd", "q05", "q95")), (name, entry)
    # reference: the simulation's truths, which the example ships beside its cells. 10 %: at
    # seed 0 the posterior means lie within 5.2 % (gamma, 1.283 against 1.22: 1.6 posterior sd)
    # and 2 % (E0t, R0, P_phys) of them
    truths = json.loads((data / "example_cells.json").read_text())["parameters"]
    for name in ("gamma", "E0t_N_per_m", "R0_nm", "P_phys_kPa"):
        assert summary["parameters"][name]["mean"] == pytest.approx(truths[name], rel=0.10), name
