"""The finite-element stiffness table: the reduced stiffness ``k_c/(P R_c)`` as a function.

* :mod:`~turgorbayes.surrogate.table` reads a table file and interpolates it
  (:class:`Surrogate`);
* :mod:`~turgorbayes.surrogate.axes` adds FE settings as further axes, the wall thickness and
  the indenter's tip radius (:func:`load`, :class:`CorrectedSurrogate`);
* :mod:`~turgorbayes.surrogate.build` runs the FE sweep that writes a table (imported on use:
  it needs :mod:`turgorbayes.fem`).

The model and its verification: ``docs/fem.md``.
"""

from turgorbayes.surrogate import axes, table
from turgorbayes.surrogate.axes import AXES, CorrectedSurrogate, correction_factor
from turgorbayes.surrogate.table import *  # noqa: F403  (the face: the table's public names)

#: The face's ``load`` reads a table at any FE setting (``table.load`` reads one file).
load = axes.load

__all__ = [*table.__all__, "AXES", "CorrectedSurrogate", "correction_factor"]
