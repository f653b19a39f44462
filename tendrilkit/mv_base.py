"""The multi-view method's base point, triangulated from the views' marks, and whether the marks were drawn loosely.

Used by :mod:`tendrilkit.pipeline` before :func:`tendrilkit.multiview.reconstruct_multiview`.
The user marks the tendril's base in every view (``base_point``). Marks
clicked with care agree to their rounding to whole pixels; marks drawn
loosely (blobs, a few pixels off in different directions: the paper's marks
at the base) triangulate to a point that can lie a millimetre or more beside
the tendril, mostly in depth, where some views show the board or the stem.
There the acquisition's first step is scored at its end only (``loose_base``
of :func:`tendrilkit.mv_acquire.grow_curve`).

Tried and not kept (2026-11-30, ``benchmarks/rerun_multiview.py``, dev seeds
9980-9999, 120 frames): moving a loose base point onto the tendril's axis
(of the few directions the views agree on from the base, the one whose
first 12 mm, fitted to every view's skeleton and extended straight back
into the keep-out box, passes nearest the marks). Alone: base within 2 mm
93.3 -> 99.2 % of frames (seed 9986: 2.4 -> 0.2-0.8 mm), all three
criteria unchanged (20.8 %); with the first step scored at its end: all
three 23.3 % against 24.2 % for that change alone, one more ``ok`` frame
with an end over 2 mm. On dev seed 0 (frame 5) it moved a base 0.3 mm from
the truth to 2.3 mm (the first millimetres lie where the views hardly
constrain depth: the straight extension back is off) and the frame failed.
"""

from __future__ import annotations

import numpy as np

from tendrilkit.camera import Camera
from tendrilkit.exceptions import DegenerateCurveError
from tendrilkit.triangulation import triangulate

__all__ = ["base_point_from_marks", "loose_marks", "MARKS_AGREE_PX"]

#: The views' base marks agree when they triangulate within this (pixels): their rounding to whole pixels. Marks
#: that disagree more were drawn loosely (:func:`loose_marks`).
MARKS_AGREE_PX = 1.0


def loose_marks(base_points_xy: list, cameras: list[Camera]) -> bool:
    """Whether the views' ``base_point`` marks disagree by more than their pixel rounding.

    The largest reprojection error (pixels) of their triangulation is over
    :data:`MARKS_AGREE_PX`: the marks were drawn loosely (blobs, a few
    pixels off in different directions), and their triangulation can lie a
    millimetre or more beside the tendril's base, mostly in depth.
    """
    tri = triangulate(np.array([[p] for p in base_points_xy], float), cameras)
    err = np.asarray(tri.reproj_err_px, float)
    return bool(not np.all(np.isfinite(err)) or err.max() > MARKS_AGREE_PX)


def base_point_from_marks(base_points_xy: list, cameras: list[Camera], *, max_px: float) -> np.ndarray:
    """The base point (3,) mm triangulated from every view's ``base_point`` mark.

    Raises
    ------
    DegenerateCurveError
        The marks do not triangulate to one point within ``max_px``.
    """
    tri = triangulate(np.array([[p] for p in base_points_xy], float), cameras)
    B = tri.points_mm[0]
    if not np.all(np.isfinite(B)) or np.nanmax(tri.reproj_err_px) > max_px:
        raise DegenerateCurveError(f"the base_point marks do not agree (reprojection "
                                   f"{np.nanmax(tri.reproj_err_px):.1f} px > {max_px} px)")
    return B
