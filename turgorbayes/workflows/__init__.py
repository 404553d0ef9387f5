"""The runs end to end, and what they compute for their outputs.

* :mod:`~.fit`: fit a model and write ``posterior.nc``, ``summary.json``
  (:func:`~.fit.fit_cells`, also ``turgorbayes.fit``; ``turgorbayes fit``);
* :mod:`~.criticize`: check the baseline, fit every effect, compare, select
  (:func:`~.criticize.criticize`, also ``turgorbayes.criticize``; ``turgorbayes criticize``);
* :mod:`~.sbc`: simulation-based calibration;
* :mod:`~.design`: what a planned two-condition design can tell (``turgorbayes design``);
* :mod:`~.curves`: raw force curves to the per-curve table and the cell-data file
  (``turgorbayes curves``);
* :mod:`~.simulated`: simulated cells and the JSON file of their truths (``turgorbayes simulate``);
* :mod:`~.bands`: posterior bands of the model curves and their JSON files;
* :mod:`~.fit_data`: what figures and bands read from a finished fit's DataTree.

A workflow may import every layer below it (``criticism``, ``effects``, ``inference``, ...);
nothing below imports it. Old paths (``turgorbayes.results``, ``turgorbayes.sbc``,
``turgorbayes.criticism.workflow``, ``turgorbayes.plots.bands``, ``turgorbayes.plots.data``)
work with a ``DeprecationWarning`` until 0.4.0.
"""
