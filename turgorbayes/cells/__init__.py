"""The cell-data table: one row per cell (docs/data_format.md).

* :mod:`~.table`: read and write the CSV file (:func:`~.table.read_cells`,
  :func:`~.table.write_cells`, :class:`~.table.CellData`), the bundled example;
* :mod:`~.cell_data`: the data set, :class:`~.cell_data.CellData` (re-exported by ``table``);
* :mod:`~.columns`: the file's columns and the parsing of the optional ones;
* :mod:`~.plausibility`: values no bacterium can have;
* :mod:`~.summary`: a table's one-screen summary (``turgorbayes validate``).

Old paths (``turgorbayes.io``, ``turgorbayes.plausibility``, ``turgorbayes.data_summary``) work
with a ``DeprecationWarning`` until 0.4.0.
"""
