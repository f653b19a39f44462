"""One view of one frame: segmentation followed by the ordering (:func:`process_view`)."""

from __future__ import annotations

import numpy as np

from tendrilkit.segmentation import segment_view
from tendrilkit.skeleton.results import ViewCenterline
from tendrilkit.skeleton.walk import order_skeleton

__all__ = ["process_view"]

_SEG_KEYS = ("channel", "threshold", "opening_radius_px", "min_component_px")
_ORDER_KEYS = (
    "prune_px",
    "method",
    "tangent_window_px",
    "overrides",
    "zone_width",
    "merge_width",
    "smooth_px",
    "tip_inset",
    "max_unused_fraction",
)


def process_view(
    image_bgr: np.ndarray,
    *,
    roi,
    keep_out,
    base_point_xy,
    prev_centroid_xy=None,
    frame: int = 0,
    view: int = 1,
    **options,
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
    **options
        Keyword options of :func:`~tendrilkit.segmentation.segment_view`
        (``channel``, ``threshold``, ``opening_radius_px``,
        ``min_component_px``) and of :func:`order_skeleton` (``prune_px``,
        ``method``, ``tangent_window_px``, ``overrides``, ...): the fields of
        the experiment file's ``segmentation``, ``skeleton`` and ``ordering``
        sections.

    Returns
    -------
    ViewCenterline

    Raises
    ------
    TendrilLostError, EmptySkeletonError, AmbiguousOrderingError
    """
    unknown = sorted(set(options) - set(_SEG_KEYS) - set(_ORDER_KEYS))
    if unknown:
        raise TypeError(f"process_view() got unknown option(s) {unknown}")
    seg = segment_view(
        image_bgr,
        roi=roi,
        keep_out=keep_out,
        base_point_xy=base_point_xy,
        prev_centroid_xy=prev_centroid_xy,
        **{k: options[k] for k in _SEG_KEYS if k in options},
    )
    oc = order_skeleton(
        seg.mask_roi,
        offset_xy=seg.roi_offset_xy,
        base_point_xy=base_point_xy,
        frame=frame,
        view=view,
        **{k: options[k] for k in _ORDER_KEYS if k in options},
    )
    return ViewCenterline(
        points_xy=oc.points_xy,
        centroid_xy=seg.centroid_xy,
        decisions=oc.decisions,
        n_crossings=oc.n_crossings,
        area_px=seg.area_px,
        width_px=oc.width_px,
    )
