"""The package's layout: layers import downward only, no import cycles, no private names across
modules, no module over 600 lines, and a small public face.

The layer order is read from the package docstring (``turgorbayes/__init__.py``, "Layers"), so
the documentation and this test cannot disagree; a new top-level module or package must be
placed in a layer there. Imports are found with ``ast`` in every module, at module level and
inside functions. Not counted: the bodies of a package's module-level ``__getattr__`` (the
lazy public face of ``turgorbayes`` and the deprecated re-exports of ``criticism`` and
``plots``, which import from a higher layer on first use only).
"""

import ast
import re
import subprocess
import sys
from pathlib import Path

import pytest

import turgorbayes

PACKAGE = Path(turgorbayes.__file__).parent


def _module_name(path):
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _is_module(name):
    return name in MODULES


class _Imports(ast.NodeVisitor):
    """Every ``turgorbayes`` import of a module: (line, imported module, names)."""

    def __init__(self, module, is_package):
        self.module, self.is_package = module, is_package
        self.found = []  # (lineno, target module, imported names or None)
        self.bound = {}  # local name -> turgorbayes module it is bound to
        self._in_getattr = 0

    def visit_FunctionDef(self, node):
        shim = self.is_package and node.name == "__getattr__" and node.col_offset == 0
        self._in_getattr += shim
        self.generic_visit(node)
        self._in_getattr -= shim

    def visit_Import(self, node):
        for alias in node.names:
            if alias.name.split(".")[0] == "turgorbayes":
                self._add(node.lineno, alias.name, None)
                self.bound[alias.asname or "turgorbayes"] = (alias.name if alias.asname
                                                             else "turgorbayes")

    def visit_ImportFrom(self, node):
        base = node.module or ""
        if node.level:  # relative import: resolve against this module's package
            package = self.module if self.is_package else self.module.rpartition(".")[0]
            for _ in range(node.level - 1):
                package = package.rpartition(".")[0]
            base = f"{package}.{base}" if base else package
        if base.split(".")[0] != "turgorbayes":
            return
        for alias in node.names:
            full = f"{base}.{alias.name}"
            if _is_module(full):
                self._add(node.lineno, full, None)
                self.bound[alias.asname or alias.name] = full
            else:
                self._add(node.lineno, base, alias.name)

    def _add(self, lineno, target, name):
        if not self._in_getattr:
            self.found.append((lineno, target, name))


def _parse(module):
    path = MODULES[module]
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    visitor = _Imports(module, path.name == "__init__.py")
    visitor.visit(tree)
    return tree, visitor


PARSED = {m: _parse(m) for m in MODULES}


def _private(name):
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _inside_package_of(importer, target):
    """``target`` lives in ``importer``'s package or one enclosing it: a private module
    (``turgorbayes._moved``, ``surrogate._x``) is private to its package, not to itself."""
    package = target.rpartition(".")[0]
    return importer == package or importer.startswith(package + ".")


def private_uses(module, parsed=None):
    """``"line: what"`` for each private name ``module`` takes from another turgorbayes module
    (``parsed``: its ``(tree, visitor)``, default the package's own parse)."""
    tree, visitor = PARSED[module] if parsed is None else parsed
    problems = []
    for lineno, target, name in visitor.found:
        if target == module:
            continue
        if name is not None and _private(name):
            problems.append(f"{lineno}: from {target} import {name}")
        last = target.rpartition(".")[2]
        if name is None and _private(last) and not _inside_package_of(module, target):
            problems.append(f"{lineno}: imports the private module {target} from outside its package")
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Attribute) and _private(node.attr)):
            continue
        chain, base = [node.attr], node.value
        while isinstance(base, ast.Attribute):
            chain.append(base.attr)
            base = base.value
        if not (isinstance(base, ast.Name) and base.id in visitor.bound):
            continue
        # ``mod.sub._x``: the owner is the longest module prefix of the chain
        owner = visitor.bound[base.id]
        for part in reversed(chain[1:]):
            if not _is_module(f"{owner}.{part}"):
                break
            owner = f"{owner}.{part}"
        if owner != module:
            problems.append(f"{node.lineno}: {base.id}.{'.'.join(reversed(chain))} "
                            f"(private to {owner})")
    return problems


def import_graph():
    """Module -> {imported turgorbayes module: first line}."""
    graph = {}
    for module, (_, visitor) in PARSED.items():
        edges = graph.setdefault(module, {})
        for lineno, target, _ in visitor.found:
            if target != module:
                edges.setdefault(target, lineno)
    return graph


def _layers_from_docstring():
    """Top-level name -> layer number, from the "Layers" list of the package docstring."""
    layers = {}
    for number, names in re.findall(r"^(\d+)\.\s+((?:``[\w.]+``(?:,\s*)?)+):", turgorbayes.__doc__,
                                    flags=re.MULTILINE):
        for name in re.findall(r"``([\w.]+)``", names):
            layers[name] = int(number)
    return layers


LAYERS = _layers_from_docstring()


def layer_of(module):
    """The layer of a module: its top-level subpackage's (the package itself: 0)."""
    parts = module.split(".")
    if len(parts) == 1:
        return 0
    if parts[1] == "__main__":
        return LAYERS["cli"]
    return LAYERS[parts[1]]


def test_layers_are_documented_for_every_top_level_module():
    assert LAYERS, "no 'Layers' list in the turgorbayes docstring"
    top = {m.split(".")[1] for m in MODULES if "." in m} - {"__main__"}
    assert top - set(LAYERS) == set(), "place these in a layer of the package docstring"
    assert set(LAYERS) - top == set(), "the docstring lists layers that do not exist"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_private_name_from_another_module(module):
    assert private_uses(module) == [], (
        f"{MODULES[module]} uses private names of other modules: make them public (and "
        f"documented) in their owner, or move them where they belong")


#: Studies and scripts: users of the package like any other, so public names only.
STUDIES = sorted([*(PACKAGE.parent / "studies").glob("*.py"),
                  *(PACKAGE.parent / "scripts").glob("*.py")])


@pytest.mark.parametrize("path", STUDIES, ids=lambda p: f"{p.parent.name}/{p.name}")
def test_studies_and_scripts_use_only_public_names(path):
    module = f"{path.parent.name}.{path.stem}"
    visitor = _Imports(module, False)
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    visitor.visit(tree)
    assert private_uses(module, (tree, visitor)) == [], (
        f"{path} uses private names of the package: make them public in their owner")


def test_no_upward_imports():
    upward = [f"{MODULES[a]}:{line}: {a} (layer {layer_of(a)}) imports {b} (layer {layer_of(b)})"
              for a, edges in import_graph().items() for b, line in edges.items()
              if layer_of(b) > layer_of(a)]
    assert upward == [], "a module imports from a higher layer:\n" + "\n".join(upward)


def test_no_two_modules_import_each_other():
    graph = import_graph()
    mutual = sorted(f"{a} <-> {b} ({MODULES[a].name}:{graph[a][b]}, {MODULES[b].name}:{graph[b][a]})"
                    for a in graph for b in graph[a] if a < b and a in graph.get(b, {}))
    assert mutual == [], "modules that import each other:\n" + "\n".join(mutual)


def test_no_import_cycles():
    graph = import_graph()
    index, low, stack, on_stack, cycles = {}, {}, [], set(), []

    def strongly_connected(v):  # Tarjan
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in graph.get(v, ()):
            if w not in index:
                strongly_connected(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            strongly_connected(v)
    assert cycles == [], f"import cycles: {cycles}"


def test_the_checks_see_violations():
    """The checks above would fail on the kinds of import they are meant to catch."""
    source = ("from turgorbayes.criticism.posterior import _rng\n"
              "from turgorbayes.curves import load\n"
              "def f():\n"
              "    from turgorbayes.workflows import fit\n"
              "    return load._curves, fit\n")
    visitor = _Imports("turgorbayes.criticism.loo", False)
    tree = ast.parse(source)
    visitor.visit(tree)
    assert ("turgorbayes.criticism.posterior", "_rng") in {(t, n) for _, t, n in visitor.found}
    assert "turgorbayes.workflows.fit" in {t for _, t, _ in visitor.found}
    assert layer_of("turgorbayes.workflows.fit") > layer_of("turgorbayes.criticism.loo")
    PARSED["turgorbayes.criticism.loo"], saved = (tree, visitor), PARSED["turgorbayes.criticism.loo"]
    try:
        problems = private_uses("turgorbayes.criticism.loo")
    finally:
        PARSED["turgorbayes.criticism.loo"] = saved
    assert any("_rng" in p for p in problems) and any("load._curves" in p for p in problems)


#: The longest a module may be, in lines (STYLE.md, "One concept per module"): a longer one
#: holds more than one concept, so split it along them and import the names back where
#: callers use them.
MAX_MODULE_LINES = 600
#: Modules over the limit for now, each with the reason (a test fails once one is back
#: under it, so that its entry is dropped).
OVER_THE_LIMIT = {}


def modules_over_the_limit(lengths, allowed=()):
    """``"module: N lines"`` for each module of ``lengths`` (module -> lines) longer than
    :data:`MAX_MODULE_LINES`, except those in ``allowed``."""
    return sorted(f"{m}: {n} lines" for m, n in lengths.items()
                  if n > MAX_MODULE_LINES and m not in allowed)


def test_no_module_is_longer_than_the_limit():
    lengths = {m: len(path.read_text(encoding="utf-8").splitlines()) for m, path in MODULES.items()}
    assert modules_over_the_limit(lengths, OVER_THE_LIMIT) == [], (
        f"modules over {MAX_MODULE_LINES} lines: split each along its concepts")
    back = sorted(m for m in OVER_THE_LIMIT if lengths.get(m, 0) <= MAX_MODULE_LINES)
    assert back == [], "back under the limit (or gone): drop them from OVER_THE_LIMIT"


def test_the_line_limit_sees_a_long_module():
    # reference: hand-made lengths on both sides of the limit
    lengths = {"a": MAX_MODULE_LINES, "b": MAX_MODULE_LINES + 1, "c": 2000}
    assert modules_over_the_limit(lengths) == [f"b: {MAX_MODULE_LINES + 1} lines", "c: 2000 lines"]
    assert modules_over_the_limit(lengths, {"c": "allowed"}) == [f"b: {MAX_MODULE_LINES + 1} lines"]


FACE = {
    "read_cells": "turgorbayes.cells.table.read_cells",
    "fit": "turgorbayes.workflows.fit.fit_cells",
    "criticize": "turgorbayes.workflows.criticize.criticize",
    "simulate": "turgorbayes.simulation.cells.simulate_cells",
    "load_surrogate": "turgorbayes.surrogate.axes.load",
}


@pytest.mark.parametrize("name", sorted(FACE))
def test_public_face_is_the_function_it_names(name):
    import importlib

    module, _, attribute = FACE[name].rpartition(".")
    assert getattr(turgorbayes, name) is getattr(importlib.import_module(module), attribute)
    assert name in turgorbayes.__all__
    assert name in dir(turgorbayes)


def test_unknown_attribute_of_the_package_raises_attribute_error():
    with pytest.raises(AttributeError):
        turgorbayes.no_such_name  # noqa: B018


def test_import_turgorbayes_stays_light():
    code = ("import sys, turgorbayes; "
            "print(' '.join(m for m in ('arviz', 'emcee', 'skfem', 'matplotlib', 'scipy', "
            "'turgorbayes.workflows', 'turgorbayes.cells') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         cwd=PACKAGE.parent)
    assert out.stdout.split() == []


def _old_path_imports(path, module):
    """``"line: old path"`` for each import of a moved module's old path in ``path``."""
    from turgorbayes._moved import MOVED

    visitor = _Imports(module, path.name == "__init__.py")
    visitor.visit(ast.parse(path.read_text(encoding="utf-8"), filename=str(path)))
    hits = [(line, target if name is None else f"{target}.{name}")
            for line, target, name in visitor.found]
    return [f"{line}: {full}" for line, full in hits
            if any(full == old or full.startswith(old + ".") for old in MOVED)]


@pytest.mark.parametrize("path", sorted(
    [*MODULES.values(), *STUDIES, *(PACKAGE.parent / "tests").rglob("*.py")]),
    ids=lambda p: str(p.relative_to(PACKAGE.parent)))
def test_nothing_of_ours_imports_a_moved_path(path):
    # reference: turgorbayes._moved.MOVED, the old paths kept for users until their removal
    # (the tests of the deprecation itself build their imports from MOVED, not as statements)
    if path.name in ("_moved.py", "test_moved.py"):
        pytest.skip("the deprecation mechanism and its own tests")
    assert _old_path_imports(path, f"x.{path.stem}") == []


#: Strings outside ``effects/`` that equal an effect's name but mean something else: the FE
#: table's tip-radius axis and setting, and the old path of the outer-membrane physics module.
NOT_AN_EFFECT = {"turgorbayes/fem/config.py": {"tip_radius"},
                 "turgorbayes/surrogate/axes.py": {"tip_radius"},
                 "turgorbayes/surrogate/_mesh_points.py": {"tip_radius"},
                 "turgorbayes/_moved.py": {"outer_membrane"}}


def effect_name_strings(source, names):
    """``(line, name)`` of every string constant of ``source`` (docstrings aside) that is one of
    ``names``."""
    tree = ast.parse(source)
    docs = {id(n.value) for n in ast.walk(tree)
            if isinstance(n, ast.Expr) and isinstance(n.value, ast.Constant)}
    return sorted((n.lineno, n.value) for n in ast.walk(tree)
                  if isinstance(n, ast.Constant) and isinstance(n.value, str)
                  and id(n) not in docs and n.value in names)


def test_no_effect_is_named_by_a_string_outside_effects():
    # reference: the house rule (docs/effects.md, "Adding an effect"): an effect declares what it
    # touches (changes_wall, realistic_design, ...), lower and higher layers never list names
    from turgorbayes import effects

    names = set(effects.effect_names())
    assert len(names) >= 12
    found = {}
    for module, path in MODULES.items():
        rel = str(path.relative_to(PACKAGE.parent))
        if module.startswith("turgorbayes.effects"):
            continue
        hits = [h for h in effect_name_strings(path.read_text(encoding="utf-8"), names)
                if h[1] not in NOT_AN_EFFECT.get(rel, set())]
        if hits:
            found[rel] = hits
    assert found == {}


def test_the_effect_name_scan_sees_a_name_and_spares_docstrings():
    # reference: a hand-made source; its line numbers by reading
    source = ('"""About radius_spread."""\n'
              'def f(x):\n'
              '    """Uses "radius_spread"."""\n'
              '    return x == "radius_spread" or {"drift": 1}\n')
    assert effect_name_strings(source, {"radius_spread", "drift"}) == [
        (4, "drift"), (4, "radius_spread")]


#: Calls that write a data file (JSON, netCDF, CSV, the cell table, the per-curve table).
_DATA_WRITES = re.compile(r"\bjson\.dump\(|\.to_netcdf\(|\bcsv\.writer\(|\.to_csv\(|"
                          r"\bwrite_cells\(|\bwrite_curves_table\(")
#: The layers that draw, word and parse commands: they write documents and figures, never data.
NO_DATA_WRITERS = ("turgorbayes.cli", "turgorbayes.report", "turgorbayes.plots")


def data_writes(source):
    """``(line, text)`` of every call in ``source`` that writes a data file."""
    return [(i, line.strip()) for i, line in enumerate(source.splitlines(), 1)
            if _DATA_WRITES.search(line) and not line.lstrip().startswith("#")]


def test_data_files_are_written_below_the_command_line_and_the_reports():
    # reference: the house rule (docs/README.md, "Layers"): workflows write every output data
    # file (or the format module of the layer below they call: cells.table, surrogate); the
    # command line, the reports and the figures read them
    found = {m: data_writes(p.read_text(encoding="utf-8")) for m, p in MODULES.items()
             if m.startswith(NO_DATA_WRITERS)}
    assert {m: w for m, w in found.items() if w} == {}


def test_the_data_write_scan_sees_each_writer():
    # reference: hand-made lines, one writer each; a comment and a read are not writes
    source = ("json.dump(x, f)\nds.to_netcdf(p)\nw = csv.writer(fh)\nwrite_cells(c, p)\n"
              "# json.dump(x, f)\njson.load(f)\ndf.to_csv(p)\n")
    assert [i for i, _ in data_writes(source)] == [1, 2, 3, 4, 7]
