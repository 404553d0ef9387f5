"""Simulated data with known truths (``turgorbayes simulate``; docs/validation.md).

* :mod:`~.cells`: a cell-data table from the baseline model, with injected effects
  (:func:`~.cells.simulate_cells`, also ``turgorbayes.simulate``);
* :mod:`~.curves`: force-distance curves of given force laws, written as afmformats files;
* :mod:`~.raw_dataset`: a simulated data set as raw curve files, their manifest and the truths;
* :mod:`~.forcemap`: simulated force maps;
* :mod:`~.planted`: data of the paper's design with one effect planted at its realistic size,
  each with the design it needs (the criticism's studies).

The package is ``simulation`` (not ``simulate``) so that ``turgorbayes.simulate``, the
function, is not shadowed by a subpackage of the same name. Old paths
(``turgorbayes.synthetic``, ``turgorbayes.curves.synthetic``, ``turgorbayes.curves.synthetic_map``,
``turgorbayes.curves.dataset``) work with a ``DeprecationWarning`` until 0.4.0.
"""
