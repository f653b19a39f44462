"""Extension of a triangulated centreline to the base marks (``triangulation.base_from_marks``).

The keep-out box hides the first millimetres of the tendril in every view.
The ``base_point`` marks of the views are triangulated; when they agree
(reprojection within ``correspondence.max_distance_px``), lie within
:data:`BASE_MAX_MM` of the curve's first point and continue the curve without
folding back (the gap points the way of the curve's first 3 mm, or its first
quarter if shorter), the curve is extended to them.
"""

from __future__ import annotations

import numpy as np

from tendrilkit.camera import Camera
from tendrilkit.triangulation import triangulate

__all__ = ["BASE_MAX_MM", "base_from_marks"]

#: Largest gap, mm, between the triangulated base marks and the curve's first point.
BASE_MAX_MM = 10.0


def base_from_marks(base_points_xy: list, cameras: list[Camera], points_mm: np.ndarray, *,
                    max_distance_px: float) -> np.ndarray | None:
    """The triangulated base marks if they agree and continue the curve, else None.

    Parameters
    ----------
    base_points_xy : list of (2,) sequence of float
        Every view's ``base_point`` mark, pixels, view order.
    cameras : list of Camera
        The rig, view order.
    points_mm : (n, 3) float array
        The triangulated centreline, base first, mm.
    max_distance_px : float, keyword-only
        Largest reprojection error of the triangulated marks, px.

    Returns
    -------
    (3,) float array or None
        The base point, world mm; None when the marks disagree, lie further
        than :data:`BASE_MAX_MM` from ``points_mm[0]``, coincide with it, or
        the gap turns back against the curve.

    Examples
    --------
    >>> cams = [Camera(K=np.array([[1000.0, 0, 500], [0, 1000, 500], [0, 0, 1]]), t_mm=np.array([tx, 0.0, 200.0]))
    ...         for tx in (-40.0, 40.0)]
    >>> curve = np.c_[np.linspace(0, 50, 51), np.zeros(51), np.zeros(51)]
    >>> marks = [c.project(np.array([[-2.0, 0.0, 0.0]]))[0] for c in cams]
    >>> np.round(base_from_marks(marks, cams, curve, max_distance_px=8.0), 3) + 0.0
    array([-2.,  0.,  0.])
    """
    marks = np.array([[p] for p in base_points_xy], dtype=float)  # (V, 1, 2)
    tri = triangulate(marks, cameras)
    B = tri.points_mm[0]
    if not np.all(np.isfinite(B)) or np.nanmax(tri.reproj_err_px) > max_distance_px:
        return None
    d = points_mm[0] - B
    gap = float(np.linalg.norm(d))
    if gap > BASE_MAX_MM:
        return None
    if gap < 1e-6:
        return None
    # no folding back: the gap must go on in the direction of the curve's first millimetres
    # (the hidden part may bend: on the phantoms the angle reaches 70 degrees)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points_mm, axis=0), axis=1))])
    j = int(np.searchsorted(s, min(3.0, s[-1] / 4)))
    t = points_mm[max(j, 1)] - points_mm[0]
    if np.dot(d, t) <= 0.0:  # the gap turns back against the curve
        return None
    return B
