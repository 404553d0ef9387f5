"""The finite-element stiffness table: the reduced stiffness ``k_c/(P R_c)`` as a function.

* :mod:`~turgorbayes.surrogate.table` reads a table file and interpolates it
  (:func:`load`, :class:`Surrogate`);
* :mod:`~turgorbayes.surrogate.thickness` adds the wall thickness as a third axis;
* :mod:`~turgorbayes.surrogate.build` runs the FE sweep that writes a table (imported on use:
  it needs :mod:`turgorbayes.fem`).

The model and its verification: ``docs/fem.md``.
"""

from turgorbayes.surrogate import table
from turgorbayes.surrogate.table import *  # noqa: F403  (the face: the table's public names)

__all__ = list(table.__all__)
