"""turgorbayes: Bayesian turgor pressure and cell-wall elasticity from AFM indentation.

Implements and extends Deng, Sun & Shaevitz, Phys. Rev. Lett. 107, 158101 (2011).

The public face (imported on first use, so ``import turgorbayes`` stays light)::

    cells = turgorbayes.read_cells("cells.csv")    # turgorbayes.cells.table.read_cells
    result = turgorbayes.fit(cells)                 # turgorbayes.workflows.fit.fit_cells
    table = turgorbayes.load_surrogate()            # turgorbayes.surrogate.load
    verdict = turgorbayes.criticize(cells, table)   # turgorbayes.workflows.criticize.criticize
    cells, truths = turgorbayes.simulate(72, 42)    # turgorbayes.simulation.cells.simulate_cells

Layers, lowest first; a module imports only from its own layer or lower ones
(``tests/test_layout.py`` checks it, and that no two modules import each other):

0. ``errors``, ``_moved``, ``_version``, ``provenance``, ``progress``, ``parallel``, ``cache``,
   ``formatting``: the exceptions; old module paths (deprecated in 0.3.0, removed in 0.4.0); the version; the
   provenance record of a run (commit, arguments, date, machine, dependency versions); progress
   of a loop (a bar on a terminal, whole lines in a log); independent work in order on every
   core or a Dask cluster; sha256-checked cache entries that make a killed run resumable; numbers
   and p-values as text (one rule for reports, figures and the command line).
1. ``fem``: finite-element indentation of a pressurized capsule (used by the surrogate builder only).
2. ``surrogate``: the FE stiffness table ``k_c/(P R_c)`` and its builder.
3. ``physics``: ``parameters``, the analytic ``bulge`` and ``wall`` laws, ``outer_membrane``, and
   ``forward`` (wall law + FE table -> a cell's radius and stiffness).
4. ``cells``: the cell-data table (``table``: read/write, ``plausibility``, ``summary``).
5. ``curves``: raw AFM force curves and force maps -> the cell-data table.
6. ``inference``: likelihood, priors, models, posterior mode and emcee sampling.
7. ``effects``: model extensions, one cause each.
8. ``criticism``: the parts of model criticism (checks, posterior, loo, selection, stacking, verdict).
9. ``simulation``: simulated cells, force curves, raw data sets and force maps.
10. ``workflows``: the runs end to end (``fit``, ``criticize``, ``curves``, ``design``, ``sbc``,
    ``simulated``) and what they compute for outputs (``bands``, ``fit_data``); they write every
    output data file (JSON, netCDF, CSV), through the format modules below where a format has
    one (``cells.table``, the FE table's ``surrogate``).
11. ``plots``: figures only.
12. ``report``: reports rendered from finished outputs (documents: Markdown, HTML; no data).
13. ``cli``: the ``turgorbayes`` command (parses options, calls the layers below; writes no data file
    itself).
"""

from turgorbayes import _moved
from turgorbayes._version import __version__
from turgorbayes.errors import DataError, TurgorBayesError

_moved.install()

#: The public face: name -> (module, attribute), imported on first use.
_FACE = {
    "read_cells": ("turgorbayes.cells.table", "read_cells"),
    "fit": ("turgorbayes.workflows.fit", "fit_cells"),
    "criticize": ("turgorbayes.workflows.criticize", "criticize"),
    "simulate": ("turgorbayes.simulation.cells", "simulate_cells"),
    "load_surrogate": ("turgorbayes.surrogate", "load"),
}

__all__ = ["DataError", "TurgorBayesError", "__version__", *_FACE]


def __getattr__(name):
    # only the face; any other name raises AttributeError, so ``from turgorbayes import io``
    # falls through to importing the submodule (an old path is aliased by ``_moved``)
    if name not in _FACE:
        raise AttributeError(f"module 'turgorbayes' has no attribute {name!r}")
    import importlib

    module, attribute = _FACE[name]
    value = getattr(importlib.import_module(module), attribute)
    globals()[name] = value  # once: later lookups do not come here
    return value


def __dir__():
    return sorted(set(globals()) | set(_FACE))
