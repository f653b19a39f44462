"""Analyses over the frames of one experiment, and comparisons across sites.

Paper: "Reconstruction From a Sequence of Frames" and "Analysis of Tip
Motion" (Fan et al., IJCV 2025, Figures 7-9, Tables 1-3 and the Discussion's
response ~3 min / stable ~12 min). Pure functions on the result tables of the
pipeline (pandas DataFrames); no disk, no plotting. One module per concern:

==================  ==============================================================
``laws``            split points of the fitted laws, curvature/torsion maps (Figures 7, 8)
``change``          shape change against a reference frame, tip path (Figure 9), regions
``timing``          response onset and stabilisation times from the shape change
``tables``          the paper's Tables 1-3
``sites``           one experiment summarised; the comparison across sites
==================  ==============================================================

Input tables
------------
The result files as tendrilkit writes them, with the column names of
:mod:`tendrilkit.schema` (EXPERIMENT_FORMAT.md in code); a table missing a
column an analysis reads is a ``ValueError`` naming the table and the column.

``curves`` (also ``pwc_curves``)
    ``frame, time_s, point, x_mm, y_mm, z_mm``: point 0 = base ... tip, world
    frame of the marker (mm).
``segments``
    ``pwc_segments.csv``: ``frame, kind, segment, s0_mm, s1_mm, value_s0,
    value_s1``: the piece-wise linear laws of the fit, ``kind`` is ``kappa``
    or ``tau``, values in 1/mm.
``frames``
    ``frame, time_s, status`` (``ok``/``doubtful``/``failed``), ``message``, quality columns.
``reprojection``
    ``frame, view, section`` (``base``/``tip``/``entire``), ``mean_px, std_px``
    (and ``max_px, n_points``).
``fit metrics``
    ``pwc_metrics.csv``: ``frame`` and any of ``r2_entire, r2_base, r2_tip,
    sse_entire_mm2, sse_base_mm2, sse_tip_mm2, n_kappa, n_tau,
    penalty_kappa, penalty_tau``.

Failed and doubtful frames
--------------------------
Frames are 0-based video frame indices. Every function that takes an optional
``frames`` table drops the frames whose status is not ``ok`` (``failed``, and
``doubtful``: reconstructed but a check of :mod:`tendrilkit.verify` failed);
with ``include_doubtful=True`` (the experiment's ``analysis:
{include_doubtful: true}``) it keeps the ``doubtful`` ones; frames with
missing or non-finite coordinates are dropped too. Nothing is interpolated:
dropped frames are listed in a :class:`UserWarning` and in
``result.attrs["excluded_frames"]`` of the returned table (maps keep a NaN
column for each of them, so a gap stays visible).
"""

from tendrilkit.sequence._common import SECTION_FRACTION, frame_status, resample_normalised
from tendrilkit.sequence.change import (TipPathStats, region_response, shape_change, tip_path_stats,
                                        tip_trajectory)
from tendrilkit.sequence.laws import KTMaps, curvature_torsion_maps, segment_counts, split_points
from tendrilkit.sequence.sites import ExperimentSummary, compare_sites, summarize_experiment
from tendrilkit.sequence.tables import projection_errors, table1, table2, table3
from tendrilkit.sequence.timing import ResponseTimes, response_times, running_median

__all__ = [
    "SECTION_FRACTION", "frame_status", "resample_normalised",
    "split_points", "segment_counts", "KTMaps", "curvature_torsion_maps",
    "shape_change", "TipPathStats", "tip_trajectory", "tip_path_stats", "region_response",
    "ResponseTimes", "response_times", "running_median",
    "ExperimentSummary", "summarize_experiment", "compare_sites",
    "table1", "table2", "table3", "projection_errors",
]
