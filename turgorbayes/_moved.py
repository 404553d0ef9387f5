"""Module paths that moved after version 0.2.0: still importable, with a ``DeprecationWarning``.

``import turgorbayes.likelihood`` (old) gives the very module
``turgorbayes.inference.likelihood`` (new), so attributes, monkeypatches and ``isinstance``
checks agree between the two names. This holds for nested old paths too
(``turgorbayes.curves.synthetic`` is ``turgorbayes.simulation.curves``) and for
``from turgorbayes import io``.

Names a package re-exported from a module that moved out of it (``turgorbayes.criticism.criticize``,
``turgorbayes.plots.curve_bands``, ...) keep working through :func:`deprecated_attributes`, which
imports them from their new home on first use, also with a ``DeprecationWarning``.

The old paths and names are deprecated in 0.3.0 and **removed in 0.4.0** (CHANGELOG.md,
docs/README.md).
"""

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

__all__ = ["MOVED", "REMOVED_IN", "deprecated_attributes", "install"]

#: The version whose release removes the old paths.
REMOVED_IN = "0.4.0"

#: Old module path -> new module path.
MOVED = {
    f"turgorbayes.{old}": f"turgorbayes.{new}"
    for old, new in {
        "likelihood": "inference.likelihood",
        "population": "inference.population",
        "priors": "inference.priors",
        "width_prior": "inference.width_prior",
        "models": "inference.models",
        "sampling": "inference.sampling",
        "diagnostics": "inference.diagnostics",
        "table_check": "inference.table_check",
        "surrogate_build": "surrogate.build",
        "surrogate_thickness": "surrogate.thickness",
        "plots_bulge": "plots.bulge",
        "plots_surrogate": "plots.surrogate",
        "report_fit": "report.fit",
        "report_criticism": "report.criticism",
        "checks": "criticism.checks",
        "stacking": "criticism.stacking",
        # 0.3.0: one package per layer (physics, cells, simulation, workflows; docs/README.md)
        "bulge": "physics.bulge",
        "wall": "physics.wall",
        "outer_membrane": "physics.outer_membrane",
        "forward": "physics.forward",
        "parameters": "physics.parameters",
        "io": "cells.table",
        "plausibility": "cells.plausibility",
        "data_summary": "cells.summary",
        "synthetic": "simulation.cells",
        "curves.synthetic": "simulation.curves",
        "curves.synthetic_map": "simulation.forcemap",
        "curves.dataset": "simulation.raw_dataset",
        "curves.contact": "curves.contact_point",
        "results": "workflows.fit",
        "sbc": "workflows.sbc",
        "criticism.workflow": "workflows.criticize",
        "plots.bands": "workflows.bands",
        "plots.data": "workflows.fit_data",
        # 0.3.0: one posterior engine for fit, criticism and SBC
        "criticism.posterior": "inference.engine",
    }.items()
}


class _Alias(importlib.abc.Loader):
    def __init__(self, target):
        self.target = target

    def create_module(self, spec):
        warnings.warn(f"{spec.name} has moved to {self.target}; the old path will be removed in "
                      f"{REMOVED_IN}",
                      DeprecationWarning, skip_file_prefixes=("<frozen importlib",))
        module = importlib.import_module(self.target)
        self._spec = module.__spec__  # the import system overwrites it with the alias's spec
        return module

    def exec_module(self, module):
        module.__spec__ = self._spec


class _Finder(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path=None, target=None):
        if name not in MOVED:
            return None
        return importlib.util.spec_from_loader(name, _Alias(MOVED[name]))


def install():
    """Put the alias finder first on ``sys.meta_path`` (once).

    First, so that an old path is always the alias, even where a stale file of that name can
    still be found (an old install's leftover ``turgorbayes/io.py``, or an editable install of
    another checkout); the finder answers only the names of :data:`MOVED`.
    """
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.insert(0, _Finder())


def deprecated_attributes(package, names):
    """A module ``__getattr__`` for names ``package`` re-exported from modules that moved out of it.

    Parameters
    ----------
    package : str
        The package whose ``__getattr__`` this is (for the message).
    names : dict
        Name -> the module path it now lives in; imported from there on first use (so the
        package does not import its new, higher home at import time), with a
        ``DeprecationWarning`` naming the new path.

    Returns
    -------
    callable
        ``__getattr__(name)``: raises ``AttributeError`` for any other name.
    """

    def __getattr__(name):
        if name not in names:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        warnings.warn(f"{package}.{name} has moved to {names[name]}.{name}; the old name will be "
                      f"removed in {REMOVED_IN}", DeprecationWarning, stacklevel=2)
        return getattr(importlib.import_module(names[name]), name)

    return __getattr__
