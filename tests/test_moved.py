"""Old module paths keep working after the move into subpackages, with a DeprecationWarning."""

import importlib
import re
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

import turgorbayes
from turgorbayes._moved import MOVED


def _module_file(package, name):
    """The file of the module ``name`` (``turgorbayes.a.b``) under ``package``."""
    parts = name.split(".")[1:]
    path = package.joinpath(*parts)
    return path / "__init__.py" if path.is_dir() else path.with_suffix(".py")


@pytest.mark.parametrize("old", sorted(MOVED))
def test_old_path_is_the_new_module_and_warns(old):
    new = importlib.import_module(MOVED[old])
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=MOVED[old]):
        aliased = importlib.import_module(old)
    # the same module object, so attributes and monkeypatches agree between the two names
    assert aliased is new
    # the alias must not overwrite the real module's identity (its spec keeps the new name)
    assert new.__spec__.name == MOVED[old]


def test_from_import_of_an_old_name_warns_at_the_callers_line():
    import turgorbayes

    sys.modules.pop("turgorbayes.report_fit", None)
    # an earlier import of the old path leaves it as an attribute of the package
    turgorbayes.__dict__.pop("report_fit", None)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        from turgorbayes import report_fit  # noqa: F401
    deprecations = [w for w in caught if issubclass(w.category, DeprecationWarning)]
    assert len(deprecations) == 1
    # the warning points at this file, not into importlib's frames
    assert deprecations[0].filename == __file__


def test_new_paths_import_without_warnings():
    # In a fresh interpreter: in this one earlier tests have imported the new paths already,
    # so a module-level warning would not be raised again and the test could not fail
    new = sorted(set(MOVED.values()))
    code = ("import importlib, sys\n"
            f"for name in {new!r}:\n"
            "    importlib.import_module(name)\n")
    run = subprocess.run([sys.executable, "-W", "error::DeprecationWarning", "-c", code],
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]
    # the new paths are real modules of the package (reference: the files on disk), not
    # names the alias machinery answers for
    package = Path(turgorbayes.__file__).parent
    missing = [name for name in new if not _module_file(package, name).is_file()]
    assert missing == []


def test_nested_old_path_of_an_existing_package():
    """``turgorbayes.curves`` still exists; its old submodule ``synthetic`` moved out of it."""
    import turgorbayes.curves
    import turgorbayes.simulation.curves as new

    sys.modules.pop("turgorbayes.curves.synthetic", None)
    turgorbayes.curves.__dict__.pop("synthetic", None)
    with pytest.warns(DeprecationWarning, match="turgorbayes.simulation.curves"):
        from turgorbayes.curves import synthetic
    assert synthetic is new
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        from turgorbayes.curves.synthetic import cell_force
    assert cell_force is new.cell_force


def test_from_package_import_of_a_moved_top_level_module():
    """``from turgorbayes import io`` (a name the package's lazy ``__getattr__`` does not know)."""
    import turgorbayes
    import turgorbayes.cells.table as new

    sys.modules.pop("turgorbayes.io", None)
    turgorbayes.__dict__.pop("io", None)
    with pytest.warns(DeprecationWarning, match="turgorbayes.cells.table"):
        from turgorbayes import io
    assert io is new
    assert io.read_cells is turgorbayes.read_cells


@pytest.mark.parametrize("package, name, new", [
    ("turgorbayes.criticism", "criticize", "turgorbayes.workflows.criticize"),
    ("turgorbayes.criticism", "CriticismSettings", "turgorbayes.workflows.criticize"),
    ("turgorbayes.criticism", "CRITICISM_KEYS", "turgorbayes.workflows.criticize"),
    ("turgorbayes.plots", "curve_bands", "turgorbayes.workflows.bands"),
    ("turgorbayes.plots", "posterior_tree", "turgorbayes.workflows.fit_data"),
])
def test_names_re_exported_from_a_moved_module_warn_and_are_the_same(package, name, new):
    module = importlib.import_module(package)
    with pytest.warns(DeprecationWarning, match=f"{new}.{name}"):
        value = getattr(module, name)
    assert value is getattr(importlib.import_module(new), name)
    with pytest.raises(AttributeError):
        module.no_such_name  # noqa: B018


def test_old_paths_are_removed_in_the_announced_version():
    # Reference: the version announced to users in docs/README.md and in the CHANGELOG entry
    # of the move; the warning must name it, and a release at or past it must not still
    # carry the aliases
    from turgorbayes._moved import REMOVED_IN

    root = Path(__file__).parents[1]
    docs = (root / "docs" / "README.md").read_text(encoding="utf-8")
    announced = set(re.findall(r"removed in\s+(\d+\.\d+\.\d+)", docs))
    changelog = (root / "CHANGELOG.md").read_text(encoding="utf-8")
    announced |= set(re.findall(r"they are removed in\s+(\d+\.\d+\.\d+)", changelog))
    assert announced == {REMOVED_IN}
    release = tuple(int(p) for p in re.match(r"(\d+)\.(\d+)\.(\d+)",
                                             turgorbayes.__version__).groups())
    assert release < tuple(int(p) for p in REMOVED_IN.split(".")), (
        f"version {turgorbayes.__version__} has reached {REMOVED_IN}: remove the old paths")
