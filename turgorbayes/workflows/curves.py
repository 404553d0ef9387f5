"""Raw force curves to the tables a run writes: the per-curve table and the cell-data file.

``turgorbayes curves`` reduces every row of a manifest (:func:`reduce_to_tables`, which writes
``curves.csv`` and, for force maps, ``force_maps.csv`` and a pixel table per map beside it),
draws the figures it is asked for, and then writes the cells (:func:`write_cell_table`), so the
figures of the curves behind a failure are there when it fails (docs/curves.md).
"""

from pathlib import Path

__all__ = ["reduce_to_tables", "write_cell_table"]


def reduce_to_tables(manifest, curves_out, settings, **options):
    """Reduce every row of the manifest file ``manifest`` and write the per-curve table.

    Parameters
    ----------
    manifest : str or pathlib.Path
        The manifest CSV (:func:`turgorbayes.curves.read_manifest`).
    curves_out : str or pathlib.Path
        The per-curve table to write (its folder made); force-map tables go beside it.
    settings : turgorbayes.curves.ReductionSettings
    **options
        Keyword options of :func:`turgorbayes.curves.reduce_manifest` (``progress``,
        ``on_curve``, ``workers``, ``scheduler``, ``cache``).

    Returns
    -------
    turgorbayes.curves.pipeline.ManifestResult
    """
    from turgorbayes.curves import read_manifest, reduce_manifest, write_curves_table

    result = reduce_manifest(read_manifest(manifest), settings, **options)
    Path(curves_out).parent.mkdir(parents=True, exist_ok=True)
    write_curves_table(curves_out, result)
    return result


def write_cell_table(result, out, manifest, curves_out):
    """Write the cells of a reduction (``result.cells``) to the cell-data file ``out``.

    Raises
    ------
    turgorbayes.errors.TurgorBayesError
        When no cell has an accepted curve for every target it needs (the per-curve table
        ``curves_out`` says why, curve by curve).
    """
    from turgorbayes.cells.table import write_cells
    from turgorbayes.errors import TurgorBayesError

    if result.cells is None:
        raise TurgorBayesError(f"{manifest}: no cell has an accepted curve for every target it "
                               f"needs; see {curves_out}")
    write_cells(result.cells, out)
