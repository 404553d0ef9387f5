"""The notebooks use only the public API, as they say ("Everything used here is the public
Python API of `turgorbayes`"): every name they import from turgorbayes, and every attribute
they read from a turgorbayes module, is exported by that module's ``__all__`` (or is a public
subpackage or module of it), and no module path has a private part (``_moved``, ``_version``).

Reference: the modules' own ``__all__``, read by importing them; the notebooks' code parsed
with ``ast`` (IPython magics and shell lines, none today, would be skipped).
"""

import ast
import importlib
import inspect
import json
import pkgutil
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))


def code_of(path):
    """The notebook's code cells joined into one module's source."""
    cells = json.loads(path.read_text(encoding="utf-8"))["cells"]
    lines = ["".join(c["source"]) for c in cells if c["cell_type"] == "code"]
    return "\n".join(line for cell in lines for line in cell.splitlines()
                     if not line.lstrip().startswith(("%", "!")))


def _public_module(name):
    return name.split(".")[0] == "turgorbayes" and not any(p.startswith("_") for p in name.split("."))


def _exports(module):
    """The names ``module`` exports: its ``__all__`` and its public submodules."""
    mod = importlib.import_module(module)
    names = set(getattr(mod, "__all__", ()))
    if hasattr(mod, "__path__"):  # a package: its modules and subpackages
        names |= {m.name for m in pkgutil.iter_modules(mod.__path__) if not m.name.startswith("_")}
    return names


def _maybe_module(name):
    """The module ``name`` if there is one (imported), else None."""
    try:
        return importlib.import_module(name)
    except ImportError:
        return None


def private_uses(source):
    """``"module.name"`` of every import or module attribute the public API does not export."""
    tree = ast.parse(source)
    bad, modules = [], {}  # modules: local name -> the turgorbayes module it is bound to
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] == "turgorbayes":
                    bad += [] if _public_module(a.name) else [a.name]
                    modules[a.asname or "turgorbayes"] = a.name if a.asname else "turgorbayes"
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "turgorbayes":
            exported = _exports(node.module) if _public_module(node.module) else set()
            for a in node.names:
                if a.name not in exported:
                    bad.append(f"{node.module}.{a.name}")
                elif inspect.ismodule(importlib.import_module(node.module).__dict__.get(a.name)
                                      or _maybe_module(f"{node.module}.{a.name}")):
                    modules[a.asname or a.name] = f"{node.module}.{a.name}"
    # attributes read from a module (turgorbayes.fit, plots.fig3, report.fit.PUBLISHED_TABLE),
    # each chain from its outermost node
    inner = {id(c) for n in ast.walk(tree) if isinstance(n, ast.Attribute)
             for c in ast.iter_child_nodes(n) if isinstance(c, ast.Attribute)}
    for node in ast.walk(tree):
        if not isinstance(node, ast.Attribute) or id(node) in inner:
            continue
        chain, base = [], node
        while isinstance(base, ast.Attribute):
            chain.insert(0, base.attr)
            base = base.value
        if not (isinstance(base, ast.Name) and base.id in modules):
            continue
        module = modules[base.id]
        for attr in chain:
            if attr not in _exports(module):
                bad.append(f"{module}.{attr}")
                break
            target = _maybe_module(f"{module}.{attr}") or getattr(importlib.import_module(module), attr)
            if not inspect.ismodule(target):
                break
            module = target.__name__
    return sorted(set(bad))


def test_the_check_finds_private_names():
    # reference: names that exist but are not exported (numpy as workflows.fit imports it,
    # the private _moved module, an inner helper of report.html, a private module path)
    source = ("import turgorbayes\nfrom turgorbayes.workflows.fit import np, fit_cells\n"
              "from turgorbayes import _moved, report\nreport.html._png\nturgorbayes.fit\n"
              "import turgorbayes._version\nreport.fit.PUBLISHED_TABLE\n")
    assert private_uses(source) == ["turgorbayes._moved", "turgorbayes._version",
                                    "turgorbayes.report.html._png", "turgorbayes.workflows.fit.np"]


@pytest.mark.parametrize("notebook", NOTEBOOKS, ids=lambda p: p.name)
def test_notebooks_use_only_the_public_api(notebook):
    source = code_of(notebook)
    assert "turgorbayes" in source
    assert private_uses(source) == []
