"""Raw AFM force curves -> the cell-data table (docs/curves.md).

Layers inside: ``load`` (afmformats, calibration; ``nanoscope``: Bruker files) -> ``baseline`` -> ``contact_point`` ->
``stiffness`` -> ``reduce`` (one curve, with ``qc`` statuses) -> ``glass`` (a session's
sensitivity reference) -> ``combine`` -> ``manifest``, ``pipeline`` (a manifest to cells).
``forcemap`` reduces a whole force map (``crosssection``: R_c from its height map; the crest
curves' k_c; ``forcemap_tables``: its outputs). Simulated curves and maps are written by
:mod:`turgorbayes.simulation` (``curves``, ``raw_dataset``, ``forcemap``; until 0.3.0 they were
``curves.synthetic``, ``curves.dataset``, ``curves.synthetic_map``). ``contact_point`` was
``curves.contact`` (the contact point of a curve; contact mechanics is :mod:`turgorbayes.fem.contact`).
Depends on numpy, scipy, afmformats and :mod:`turgorbayes.cells.table` only.
"""

from turgorbayes.curves.glass import reduce_glass_curve
from turgorbayes.curves.manifest import read_manifest
from turgorbayes.curves.pipeline import reduce_manifest, write_curves_table
from turgorbayes.curves.qc import STATUSES, CurveRejected
from turgorbayes.curves.reduce import CurveResult, ReductionSettings, reduce_curve

__all__ = ["STATUSES", "CurveRejected", "CurveResult", "ReductionSettings", "read_manifest",
           "reduce_curve", "reduce_glass_curve", "reduce_manifest", "write_curves_table"]
