"""Where no pair of views fixes the curve's depth, a detour is seen by no image check.

Every image check compares the curve's projections with the views' pixels.
Two views fix a point of the curve only where both see the tendril's own
line there (thin dark pixels, not a leaf or a shoot wider than the tendril)
and the tendril does not run along their epipolar plane (the plane through
the point and the two cameras' centres): a line lying in that plane matches
itself at every depth along it. Cameras set side by side see a tendril that
runs sideways in the images (and every stretch crossing a leaf) unfixed:
there the multi-view fit may bend the curve out along the views' rays and
back, and every projection still lies on the tendril's pixels. Random
development seed 9242 frame 2 ran 17.8 mm out and back where the tendril runs
sideways onto a leaf (mean error 2.69 mm, 20 mm too long; reported ``ok``,
every image check passed).

A tendril is smooth: across a stretch no pair of views fixes, its length
barely exceeds the straight chord between the two fixed points on either
side (a bend of 20 degrees over 80 mm adds 0.4 mm). The detour is that excess.

Figure (column of ``frames.csv``)
    ``unseen_detour_mm``
        The largest excess of the curve's 3D length over the chord, mm,
        across a stretch no pair of views fixes, between two fixed points
        (:func:`fixed_points`, :func:`unseen_detour_mm`); 0: none. Stretches
        running to the base or the tip are not measured (the base's keep-out
        box; a tip resting on a leaf is the tip checks').

The check (``verification.max_unseen_detour_mm``, 3 mm): the frame is
``doubtful`` above it. Measured on the multi-view curves of today's defaults
(``benchmarks/rerun_multiview.py``, 2026-12-01): development seeds 1040-1079
(240 frames), the 98 frames right on all three accuracy criteria read at most
0.13 mm, the wrong ones up to 6.7 mm (all flagged by other checks already);
development seeds 9240-9299 (360 frames), the 159 right ones at most 0.71 mm
(seed 9273 frame 2), the wrong ones up to 57 mm, seed 9242 frame 2 (reported
``ok`` before, the only silent frame of both sets) 22.4 mm. The angle
:data:`MIN_EPIPOLAR_ANGLE_DEG` (10 degrees): with 0 the points where the tendril
runs along the epipolar plane count as fixed, and seed 9242 frame 2 reads
0.09 mm; with 15 degrees 23.5 mm and the right frames of seeds 1040-1079 at
most 0.15 mm. Validation seeds 1160-1199 (``bench_generalize``, 240 frames):
no status changed against main (all three 48.8 %, 1 silent, 14 ``ok`` with the
max or an end over 2 mm, 45 of 159 frames within 0.5 mm mean flagged, 9 of 117
right on all three); three frames read over 3 mm, all flagged by other checks
already. The site phantoms read at most 0.006 mm and stay ``ok``.

Not seen by it: a curve displaced smoothly across an unfixed stretch without
getting longer (development seed 1068 frames 1-2, 2.6 mm off over a leaf,
0.17 mm); a tight coil whose passes merge into one blob in two views would
read as unfixed, and its turns as a detour (none among the development seeds).
"""

from __future__ import annotations

import numpy as np

__all__ = ["MIN_EPIPOLAR_ANGLE_DEG", "line_seen", "fixed_points", "unseen_detour_mm", "unseen_detour_message"]

#: The smallest angle (degrees) between the curve's tangent and a pair's epipolar plane for the pair to fix the point.
MIN_EPIPOLAR_ANGLE_DEG = 10.0


def line_seen(in_view: np.ndarray, on_dark: np.ndarray, wide: np.ndarray) -> np.ndarray:
    """(n,) bool: the view sees the tendril's own line at each point of the curve.

    Parameters
    ----------
    in_view : (n,) bool array
        The point projects inside the view's image and ROI, outside the keep-out box.
    on_dark : (n,) bool array
        Its projection lies on the dark pixels (within the precision's tolerance).
    wide : (n,) bool array
        Those pixels are wider than the tendril (:func:`tendrilkit.verify_tip.on_wide`).
    """
    return np.asarray(in_view, bool) & np.asarray(on_dark, bool) & ~np.asarray(wide, bool)


def fixed_points(points_mm: np.ndarray, centres_world: list, seen: np.ndarray, *,
                 min_angle_deg: float = MIN_EPIPOLAR_ANGLE_DEG) -> np.ndarray:
    """(n,) bool: the points some pair of views fixes (both see the line, the tangent leaves their epipolar plane).

    Parameters
    ----------
    points_mm : (n, 3) float array
        The centreline, base to tip, world mm.
    centres_world : list of (3,) float arrays
        The cameras' optical centres, world mm, view order.
    seen : (V, n) bool array
        Per view, the points it sees on the tendril's line (:func:`line_seen`).
    min_angle_deg : float
        The smallest angle between the tangent and the pair's epipolar plane.

    Examples
    --------
    >>> X = np.column_stack([np.linspace(0, 10, 11), np.zeros(11), np.full(11, 300.0)])
    >>> seen = np.ones((2, 11), bool)
    >>> bool(fixed_points(X, [np.zeros(3), np.array([100.0, 0, 0])], seen).any())  # runs along the baseline
    False
    >>> bool(fixed_points(X, [np.zeros(3), np.array([0, 100.0, 0])], seen).all())  # square to it
    True
    """
    X = np.asarray(points_mm, float).reshape(-1, 3)
    fixed = np.zeros(len(X), bool)
    if len(X) < 2:  # (before the reshape below: an empty curve has no row length to read)
        return fixed
    seen = np.asarray(seen, bool).reshape(-1, len(X))
    T = np.gradient(X, axis=0)
    T /= np.maximum(np.linalg.norm(T, axis=1, keepdims=True), 1e-12)
    sin_min = np.sin(np.radians(min_angle_deg))
    C = [np.asarray(c, float).reshape(3) for c in centres_world]
    for a in range(len(C)):
        for b in range(a + 1, len(C)):
            both = seen[a] & seen[b]
            if not both.any():
                continue
            n = np.cross(X - C[a], C[b] - C[a])  # the epipolar plane's normal at every point
            n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)
            fixed |= both & (np.abs(np.sum(T * n, axis=1)) >= sin_min)
    return fixed


def unseen_detour_mm(points_mm: np.ndarray, fixed: np.ndarray) -> float:
    """The largest excess of arc length over chord across a stretch of unfixed points between two fixed ones.

    Parameters
    ----------
    points_mm : (n, 3) float array
        The centreline, base to tip, world mm.
    fixed : (n,) bool array
        The points the views fix (:func:`fixed_points`).

    Returns
    -------
    float
        mm (0 when no unfixed stretch lies between two fixed points; NaN, nothing measured, when fewer
        than two points are fixed: the views fix no stretch to measure from); points with a NaN
        coordinate are dropped first.

    Examples
    --------
    >>> X = np.array([[0, 0, 0], [1, 0, 0], [1.5, 0, 3], [2, 0, 0], [3, 0, 0]], float)
    >>> round(unseen_detour_mm(X, np.array([1, 1, 0, 1, 1], bool)), 3)  # 2 x sqrt(0.25 + 9) - 1
    5.083
    """
    X = np.asarray(points_mm, float).reshape(-1, 3)
    fixed = np.asarray(fixed, bool).reshape(len(X))
    finite = np.all(np.isfinite(X), axis=1)  # a point missing from the curve is neither fixed nor a detour
    X, fixed = X[finite], fixed[finite]
    idx = np.flatnonzero(fixed)
    if len(idx) < 2:
        return float("nan")
    gaps = np.flatnonzero(np.diff(idx) > 1)
    if not len(gaps):
        return 0.0
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(X, axis=0), axis=1))])
    a, b = idx[gaps], idx[gaps + 1]  # a fixed point, unfixed ones, the next fixed point
    excess = (arc[b] - arc[a]) - np.linalg.norm(X[b] - X[a], axis=1)
    return float(max(np.max(excess), 0.0))


def unseen_detour_message(detour_mm: float | None, max_mm: float) -> str | None:
    """The check's message when the detour exceeds ``max_mm`` (else None)."""
    if detour_mm is None or not np.isfinite(detour_mm) or detour_mm <= max_mm:
        return None
    return (f"unseen detour: where no two views fix its depth (the tendril's line unseen, or along their epipolar "
            f"plane) the curve runs {detour_mm:.1f} mm longer than the straight chord (limit {max_mm:g} mm)")
