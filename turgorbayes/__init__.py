"""turgorbayes: Bayesian turgor pressure and cell-wall elasticity from AFM indentation.

Implements and extends Deng, Sun & Shaevitz, Phys. Rev. Lett. 107, 158101 (2011).
Layers (each depends only on those above it in this list):

``io`` (cells in) -> ``bulge``, ``wall`` (analytic physics) -> ``surrogate`` (FE table)
-> ``forward`` -> ``likelihood``/``models`` -> ``sampling`` -> ``criticism`` -> ``report``, ``cli``.
The finite-element code lives in ``turgorbayes.fem`` and is imported only by the surrogate builder.
"""

from importlib.metadata import PackageNotFoundError, version

from turgorbayes import _moved
from turgorbayes.errors import DataError, TurgorBayesError

_moved.install()

try:
    __version__ = version("turgorbayes")
except PackageNotFoundError:  # running from a source tree that was not installed
    __version__ = "0+unknown"

__all__ = ["DataError", "TurgorBayesError", "__version__"]
