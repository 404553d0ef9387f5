"""Module paths that moved after version 0.2.0: still importable, with a ``DeprecationWarning``.

``import turgorbayes.likelihood`` (old) gives the very module
``turgorbayes.inference.likelihood`` (new), so attributes, monkeypatches and ``isinstance``
checks agree between the two names.
"""

import importlib
import importlib.abc
import importlib.util
import sys
import warnings

__all__ = ["MOVED"]

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
    }.items()
}


class _Alias(importlib.abc.Loader):
    def __init__(self, target):
        self.target = target

    def create_module(self, spec):
        warnings.warn(f"{spec.name} has moved to {self.target}; the old path will be removed",
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
    """Put the alias finder on ``sys.meta_path`` (once)."""
    if not any(isinstance(f, _Finder) for f in sys.meta_path):
        sys.meta_path.append(_Finder())
