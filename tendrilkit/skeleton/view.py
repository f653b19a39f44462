"""One view of one frame: segmentation followed by the ordering (:func:`process_view`)."""

from __future__ import annotations

import numpy as np

from tendrilkit.segmentation import segment_view
from tendrilkit.skeleton.results import ViewCenterline
from tendrilkit.skeleton.walk import order_skeleton

__all__ = ["process_view"]

def process_view(
    image_bgr: np.ndarray,
    *,
    roi,
    keep_out,
    base_point_xy,
    prev_centroid_xy=None,
    frame: int = 0,
    view: int = 1,
    segmentation: dict | None = None,
    ordering: dict | None = None,
) -> ViewCenterline:
    """Segment, skeletonise and order one view of one frame.

    Parameters
    ----------
    image_bgr : (H, W, 3) uint8 array
        The full frame.
    roi, keep_out, base_point_xy, prev_centroid_xy
        As in :func:`tendrilkit.segmentation.segment_view`.
    frame, view : int
        Recorded in the decisions; select the ordering overrides.
    segmentation, ordering : dict, optional
        Keyword options of :func:`~tendrilkit.segmentation.segment_view` and
        of :func:`order_skeleton` (an experiment's:
        ``tendrilkit.options.stage_options(exp, "segmentation")`` and
        ``(exp, "ordering")``; None: the functions' defaults).

    Returns
    -------
    ViewCenterline

    Raises
    ------
    TendrilLostError, EmptySkeletonError, AmbiguousOrderingError
    """
    seg = segment_view(
        image_bgr,
        roi=roi,
        keep_out=keep_out,
        base_point_xy=base_point_xy,
        prev_centroid_xy=prev_centroid_xy,
        **(segmentation or {}),
    )
    oc = order_skeleton(
        seg.mask_roi,
        offset_xy=seg.roi_offset_xy,
        base_point_xy=base_point_xy,
        frame=frame,
        view=view,
        **(ordering or {}),
    )
    return ViewCenterline(
        points_xy=oc.points_xy,
        centroid_xy=seg.centroid_xy,
        decisions=oc.decisions,
        n_crossings=oc.n_crossings,
        area_px=seg.area_px,
        width_px=oc.width_px,
    )
