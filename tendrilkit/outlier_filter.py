"""The gross-outlier filter after triangulation: a wrong match triangulates anywhere.

A triangulated point is kept when it is finite and its largest reprojection
error over the views is at most :data:`GROSS_FACTOR` times the match
tolerance ``correspondence.max_distance_px``.
"""

from __future__ import annotations

import numpy as np

__all__ = ["GROSS_FACTOR", "triangulation_inliers"]

#: A point reprojecting further than this many match tolerances in some view is a gross outlier.
GROSS_FACTOR = 3.0


def triangulation_inliers(points_mm: np.ndarray, reproj_err_px: np.ndarray, *, max_distance_px: float) -> np.ndarray:
    """Which triangulated points to keep.

    Parameters
    ----------
    points_mm : (k, 3) float array
        Triangulated points, NaN where not triangulated.
    reproj_err_px : (n_views, k) float array
        Reprojection error per view, px (NaN: no observation).
    max_distance_px : float, keyword-only
        The match tolerance, px.

    Returns
    -------
    (k,) bool array

    Examples
    --------
    >>> P = np.array([[0.0, 0, 0], [1, 0, 0], [np.nan, 0, 0]])
    >>> err = np.array([[0.5, 30.0, np.nan], [0.2, np.nan, np.nan]])
    >>> triangulation_inliers(P, err, max_distance_px=8.0).tolist()
    [True, False, False]
    """
    good = np.all(np.isfinite(points_mm), axis=1)
    with np.errstate(invalid="ignore"):
        worst = np.nanmax(np.where(np.isfinite(reproj_err_px), reproj_err_px, -1.0), axis=0)
    return good & (worst <= GROSS_FACTOR * max_distance_px)
