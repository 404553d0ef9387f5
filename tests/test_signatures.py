"""One argument order for the physics: ``(P, gamma, E0t, R0, ...)`` everywhere in the package.

``gamma`` (~1.2) and ``E0t`` (~0.026 N/m) are both plain floats, so a call that swaps them runs
and returns wrong numbers. Every function and method of ``turgorbayes`` that takes some of the
parameters ``P``, ``gamma``, ``E0t``, ``R0`` must take them in that relative order
(``docs/physics.md``, "Parameter order", in the introduction). Each module is imported and its functions, methods
(static, class, properties) and, through the source, nested functions and lambdas are checked.
"""

import ast
import functools
import importlib
import inspect
import pkgutil
import textwrap

import pytest

import turgorbayes

ORDER = ("P", "gamma", "E0t", "R0")


def order_violation(names):
    """The parameters of ``ORDER`` among ``names`` if they are out of order, else None."""
    present = [n for n in names if n in ORDER]
    expected = [n for n in ORDER if n in present]
    return None if present == expected else present


def signature_violation(func):
    """``"qualname(a, b, ...)"`` if ``func``'s parameters break :data:`ORDER`, else None."""
    try:
        names = list(inspect.signature(func).parameters)
    except (TypeError, ValueError):  # no introspectable signature (C code): nothing to check
        return None
    if order_violation(names) is None:
        return None
    return f"{getattr(func, '__qualname__', func)}({', '.join(names)})"


def _walk_errors():
    failed = []
    names = [m.name for m in pkgutil.walk_packages(turgorbayes.__path__, "turgorbayes.",
                                                   onerror=failed.append)]
    return sorted(set(names) | set(failed))


MODULES = ["turgorbayes", *_walk_errors()]


def _import(name):
    try:
        return importlib.import_module(name)
    except ModuleNotFoundError as err:
        missing = err.name or ""
        if missing == "turgorbayes" or missing.startswith("turgorbayes."):
            raise
        pytest.skip(f"{name} needs the optional dependency {missing!r}")


def _class_members(cls, seen):
    """Functions in a class's own namespace (methods, static/class methods, property accessors,
    nested classes), whatever module the function objects were generated in (dataclasses)."""
    if id(cls) in seen:
        return
    seen.add(id(cls))
    for obj in vars(cls).values():
        if isinstance(obj, (staticmethod, classmethod)):
            obj = obj.__func__
        if isinstance(obj, property):
            yield from (f for f in (obj.fget, obj.fset, obj.fdel) if f is not None)
        elif isinstance(obj, functools.cached_property):
            yield obj.func
        elif inspect.isclass(obj) and obj.__module__ == cls.__module__:
            yield obj
            yield from _class_members(obj, seen)
        elif inspect.isroutine(obj):
            yield obj


def defined_functions(module):
    """Every function, class and method whose home is ``module`` (not names it imports)."""
    seen = set()
    for obj in vars(module).values():
        if getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isclass(obj):
            yield obj  # its constructor's signature (dataclasses, NamedTuples)
            yield from _class_members(obj, seen)
        elif inspect.isroutine(obj):
            yield obj


def _reachable_by_import(body):
    """Ids of the defs at module or class level (those :func:`defined_functions` sees)."""
    for node in body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield id(node)
        elif isinstance(node, ast.ClassDef):
            yield from _reachable_by_import(node.body)


def source_violations(source, where):
    """Nested functions and lambdas in ``source`` (out of reach of :func:`defined_functions`)
    that break :data:`ORDER`."""
    out = []
    tree = ast.parse(textwrap.dedent(source))
    top = set(_reachable_by_import(tree.body))
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)) and id(node) not in top:
            a = node.args
            names = [x.arg for x in (*a.posonlyargs, *a.args, *a.kwonlyargs)]
            if order_violation(names) is not None:
                label = getattr(node, "name", "<lambda>")
                out.append(f"{where}:{node.lineno} {label}({', '.join(names)})")
    return out


@pytest.mark.parametrize("name", MODULES)
def test_parameter_order(name):
    module = _import(name)
    bad = sorted({v for f in defined_functions(module) if (v := signature_violation(f))})
    try:
        source = inspect.getsource(module)
    except (OSError, TypeError):
        source = ""
    bad += source_violations(source, name)
    assert not bad, (f"{len(bad)} signature(s) in {name} not in the order (P, gamma, E0t, R0, ...):\n"
                     + "\n".join(bad))


def test_modules_are_found():
    # the walk must see the physics modules, or the test above would pass vacuously
    assert {"turgorbayes.physics.wall", "turgorbayes.physics.outer_membrane", "turgorbayes.physics.forward",
            "turgorbayes.inference.likelihood", "turgorbayes.inference.models"} <= set(MODULES)
    from turgorbayes.physics import wall
    names = {getattr(f, "__name__", "") for f in defined_functions(wall)}
    assert {"radius_at_pressure", "check_parameters", "anisotropy"} <= names


# ------------------------------------------------------------------ the checker itself can fail


def _swapped(P, E0t, gamma, R0, P0=5e3):
    return P, E0t, gamma, R0, P0


def _pressure_last(gamma, E0t, R0, P):
    return gamma, E0t, R0, P


def _good(P, R_c, gamma, E0t, R0, Y_om=0.0, *, P0=5e3):
    return P, R_c, gamma, E0t, R0, Y_om, P0


class _Fake:
    def method(self, R0, gamma):
        return R0, gamma

    @staticmethod
    def static(gamma, E0t):
        return gamma, E0t

    @property
    def prop(self):
        return None


def test_checker_flags_wrong_orders():
    assert signature_violation(_swapped) == "_swapped(P, E0t, gamma, R0, P0)"
    assert signature_violation(_pressure_last) is not None
    assert signature_violation(_Fake.method) == "_Fake.method(self, R0, gamma)"
    assert signature_violation(_good) is None
    assert signature_violation(_Fake.static) is None
    assert order_violation(["E0t", "gamma"]) == ["E0t", "gamma"]
    assert order_violation(["x", "gamma", "y", "R0"]) is None


def test_collection_reaches_methods_and_nested_functions():
    import sys
    module = sys.modules[__name__]
    found = {getattr(f, "__qualname__", "") for f in defined_functions(module)}
    assert {"_swapped", "_Fake", "_Fake.method", "_Fake.static", "_Fake.prop"} <= found
    bad = {v for f in defined_functions(module) if (v := signature_violation(f))}
    assert bad == {"_swapped(P, E0t, gamma, R0, P0)", "_pressure_last(gamma, E0t, R0, P)",
                   "_Fake.method(self, R0, gamma)"}
    source = ("def top(E0t, gamma):\n    def inner(E0t, gamma):\n        pass\n    f = lambda R0, P: 0\n"
              "class C:\n    def m(self, R0, P):\n        pass\n")
    # module- and class-level defs are the signature check's; nested ones and lambdas the source's
    assert source_violations(source, "m") == ["m:2 inner(E0t, gamma)", "m:4 <lambda>(R0, P)"]
