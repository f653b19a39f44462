"""The multi-view method's base point: triangulated from the views' marks, refined on the evidence where they disagree.

Used by :mod:`tendrilkit.pipeline` before :func:`tendrilkit.multiview.reconstruct_multiview`.
The user marks the tendril's base in every view (``base_point``). Marks
clicked with care agree to their rounding to whole pixels; marks drawn
loosely (blobs, a few pixels off in different directions: the paper's marks
at the base) triangulate to a point that can lie a millimetre or more beside
the tendril, mostly in depth, where the views show the board or the stem.
There the base point is moved onto the tendril's axis (:func:`_base_on_axis`),
and the acquisition's first step is scored at its end only (``loose_base``
of :func:`tendrilkit.mv_acquire.grow_curve`).
"""

from __future__ import annotations

import numpy as np

from tendrilkit.camera import Camera
from tendrilkit.exceptions import DegenerateCurveError
from tendrilkit.multiview import refine_curve
from tendrilkit.mv_acquire import ON_PX, point_costs, seed_directions
from tendrilkit.mv_evidence import SkeletonEvidence
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


def base_point_from_marks(base_points_xy: list, cameras: list[Camera], *, max_px: float,
                          evidence: list[SkeletonEvidence | None] | None = None) -> np.ndarray:
    """The base point (3,) mm triangulated from every view's ``base_point`` mark, refined where they disagree.

    Parameters
    ----------
    base_points_xy : list of (2,) pixels
        Every view's mark, full-image ``(x, y)``.
    cameras : list of Camera
    max_px : float
        The marks must triangulate to one point within this (pixels).
    evidence : list of SkeletonEvidence or None, optional
        Per view (None: the view has none). With two views or more and
        marks that disagree (:func:`loose_marks`), the point is moved onto
        the tendril's axis (:func:`_base_on_axis`).

    Raises
    ------
    DegenerateCurveError
        The marks do not triangulate to one point within ``max_px``.
    """
    marks = np.array([[p] for p in base_points_xy], float)
    tri = triangulate(marks, cameras)
    B = tri.points_mm[0]
    if not np.all(np.isfinite(B)) or np.nanmax(tri.reproj_err_px) > max_px:
        raise DegenerateCurveError(f"the base_point marks do not agree (reprojection "
                                   f"{np.nanmax(tri.reproj_err_px):.1f} px > {max_px} px)")
    if evidence is not None and np.max(tri.reproj_err_px) > MARKS_AGREE_PX:
        used = [v for v, ev in enumerate(evidence) if ev is not None]
        if len(used) >= 2:
            B = _base_on_axis([evidence[v] for v in used], marks[used, 0], B, max_px=max_px)
    return B


def _base_on_axis(evidence: list[SkeletonEvidence], marks_xy: np.ndarray, B_mm: np.ndarray, *, max_px: float,
                  reach_mm: float = 12.0, n_axes: int = 3) -> np.ndarray:
    """The point (3,) of the tendril's axis, extended back into the keep-out box, that best fits the marks.

    Along each of the ``n_axes`` directions the views agree on best from
    ``B_mm`` (:func:`tendrilkit.mv_acquire.seed_directions`: the tendril, and
    often the stem or a shoot through the base), the first ``reach_mm`` are
    fitted to every view's skeleton (:func:`refine_curve`, a weak pull to
    ``B_mm``); the straight extension back from the first millimetres the
    views see is searched for the point whose projections lie nearest the
    marks (sum of squares, pixels). The marks are drawn on the tendril's
    base: the axis that fits them best is the tendril's (the stem passes the
    base beside the marks). ``B_mm`` is kept when no axis is seen on two
    views' skeletons from its third millimetre on, or none comes within
    ``max_px`` of every mark.

    Parameters
    ----------
    evidence : list of SkeletonEvidence
    marks_xy : (V, 2) float array
        The views' marks, pixels.
    B_mm : (3,) float array
        The marks' triangulation, world mm.
    max_px, reach_mm : float
    n_axes : int
    """
    best, best_err = B_mm, np.inf
    s = np.arange(-4.0, 6.0 + 1e-9, 0.05)  # mm back from the first node the views see
    for axis in seed_directions(evidence, B_mm, n_axes):
        X = B_mm + np.arange(0.0, reach_mm + 0.5)[:, None] * axis
        X = refine_curve(X, evidence, base_mm=B_mm, segment_mm=1.0, base_weight=0.0, iterations=15)
        d, seen = point_costs(evidence, X)
        if np.mean(((seen & (d <= ON_PX)).sum(axis=0) >= 2)[3:]) < 0.8:
            continue  # the views do not agree on this start
        t = X[3] - X[7]
        L = X[3] + s[:, None] * t / max(np.linalg.norm(t), 1e-9)
        e2 = np.stack([np.sum((ev.camera.project(L) - m) ** 2, axis=1) for ev, m in zip(evidence, marks_xy)])
        i = int(np.argmin(e2.sum(axis=0)))
        if np.all(np.sqrt(e2[:, i]) <= max_px) and e2[:, i].sum() < best_err:
            best, best_err = L[i], float(e2[:, i].sum())
    return best
