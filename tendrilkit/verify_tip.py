"""Checks of a reconstructed curve's tip in one view: does the tendril end where the curve ends?

Two ways a curve's tip can be wrong while the rest of the curve lies on the
tendril (:mod:`tendrilkit.verify` applies both in every view):

* the curve stops short: the tendril's skeleton goes on beyond the projected
  tip (:func:`tip_continuation`);
* the curve runs on past the tendril's end along clutter the tip touches (a
  leaf the tip rests on, a stem, a second tendril's blob): its last pixels lie
  on a dark region wider than the tendril (:func:`tip_wide_fraction`), where
  the images cannot show where the tendril ends. On random seed 214 (a hook
  whose tip rests on a leaf) the multi-view curve follows the leaf's middle
  12 mm past the true tip, on the tendril's pixels and covering its skeleton
  in every view.
"""

from __future__ import annotations

import heapq

import numpy as np

from tendrilkit.evidence import ViewEvidence

__all__ = ["TIP_PX", "tip_continuation", "tip_wide_fraction", "turn_off_deg"]

#: The curve's tip, in :func:`tip_wide_fraction`: its last this many pixels of projection (px).
TIP_PX = 20


def tip_continuation(ev: ViewEvidence, dense_xy: np.ndarray, cov_tol: float) -> float:
    """Length in px of the tendril's skeleton that goes on beyond the projected tip, unexplained.

    From the skeleton pixels near the projected tip (within ``cov_tol + 3``
    px) that the curve does not explain (farther than ``cov_tol``), the
    longest 8-connected path over unexplained skeleton pixels (steps of 1 or
    1.41 px). A curve that stops short of the tendril's tip (shrunk, or
    stuck at a crossing) leaves the rest of the tendril here; a right curve
    leaves 0 (or the few pixels of the skeleton's end spur).

    Parameters
    ----------
    ev : ViewEvidence
        With its skeleton.
    dense_xy : (n, 2) float array
        The projected curve, resampled every pixel, base to tip, full-image px.
    cov_tol : float
        A skeleton pixel within this distance of the curve is explained.
    """
    from scipy.spatial import cKDTree

    sk = ev.skeleton_xy
    if sk is None or len(sk) == 0 or len(dense_xy) == 0:
        return 0.0
    dist, _ = cKDTree(dense_xy).query(sk, distance_upper_bound=cov_tol + 1e-9)
    free = ~np.isfinite(dist)
    # not restricted to a line of the tendril's width: where the tendril goes on merged with clutter (along a
    # shoot, over a leaf) its skeleton is wider, and a shrunk chain curve (random seed 214) went unflagged
    tip = dense_xy[-1]
    start = np.nonzero(free & (np.hypot(*(sk - tip).T) <= cov_tol + 3.0))[0]
    if len(start) == 0:
        return 0.0
    idx = {(int(x), int(y)): i for i, (x, y) in enumerate(sk) if free[i]}
    best = {int(i): 0.0 for i in start}
    heap = [(0.0, int(i)) for i in start]
    steps = [(dx, dy, float(np.hypot(dx, dy))) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]
    while heap:  # Dijkstra over the unexplained skeleton pixels (a few hundred at most)
        g, i = heapq.heappop(heap)
        if g > best[i]:
            continue
        x, y = int(sk[i, 0]), int(sk[i, 1])
        for dx, dy, w in steps:
            j = idx.get((x + dx, y + dy))
            if j is not None and g + w < best.get(j, np.inf):
                best[j] = g + w
                heapq.heappush(heap, (g + w, j))
    return float(max(best.values()))


def tip_wide_fraction(ev: ViewEvidence, dense_xy: np.ndarray, on: np.ndarray, inside_px: np.ndarray,
                      radius_px: float, *, wide_ratio: float = 1.5, tip_px: int = TIP_PX) -> float | None:
    """Fraction of the curve's last ``tip_px`` pixels (those on the tendril) lying on pixels wider than the tendril.

    A sample is on wide pixels when the largest inside distance (distance
    to the background) in the 3 x 3 pixels around it exceeds ``wide_ratio``
    times the tendril's half width ``radius_px`` (the median inside distance
    of the skeleton along the curve): it lies inside a leaf's blob, the stem
    or two structures merged, not on the tendril's thin line. The tendril's
    tip tapers, so a curve ending on it scores 0.

    Parameters
    ----------
    ev : ViewEvidence
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, base to tip, full-image px.
    on : (n,) bool array
        Which samples the view sees on the dark pixels (within the tolerance);
        only those count.
    inside_px : (h, w) float32 array
        Distance of every foreground pixel of the ROI crop to the background, px.
    radius_px : float
        The tendril's half width in this view, px (NaN: unknown).
    wide_ratio : float
    tip_px : int

    Returns
    -------
    float or None
        None when the view sees none of the tip's samples on the dark pixels
        or the tendril's width is unknown.
    """
    if not (np.isfinite(radius_px) and radius_px > 0) or len(dense_xy) == 0:
        return None
    tip = dense_xy[-tip_px:][on[-tip_px:]]
    if len(tip) == 0:
        return None
    h, w = inside_px.shape
    off = ev.roi_offset_xy
    r = np.rint(tip[:, 1] - off[1]).astype(int)
    c = np.rint(tip[:, 0] - off[0]).astype(int)
    local = np.zeros(len(tip), np.float32)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            local = np.maximum(local, inside_px[np.clip(r + dr, 0, h - 1), np.clip(c + dc, 0, w - 1)])
    return float(np.mean(local > wide_ratio * radius_px))


def turn_off_deg(dense_xy: np.ndarray, branches: list[np.ndarray], *, attach_px: float, arm_px: int = TIP_PX
                 ) -> float:
    """How much more the curve turns at a junction than an unexplained branch of the tendril going on there, deg.

    At a crossing a tendril goes on nearly straight. A curve that turns off
    there onto clutter (a second tendril, a shoot) leaves the tendril's
    distal part as an unexplained thin branch that continues the curve's
    incoming direction, while the curve itself turns sharply: on random seed
    21 it turns back up a second tendril, skipping the coil, 6 mm wrong and
    every other check passed. For every branch (each of ``branches``, the
    tendril's unexplained thin skeleton, :func:`tendrilkit.verify._coverage`)
    attached to the curve at least ``arm_px`` from both of its ends: the
    curve's turn from ``arm_px`` before the attachment to ``arm_px`` after
    it, less the turn from the incoming direction to the branch's (its
    pixels ``arm_px / 2`` to ``arm_px`` from the attachment). A right curve
    crossing clutter goes straight on while the clutter's branches turn
    away: negative. Branches attached at the tip are
    :func:`tip_continuation`'s.

    Parameters
    ----------
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, base to tip, full-image px.
    branches : list of (k, 2) float arrays
        The unexplained branches' pixels, full-image ``(x, y)``.
    attach_px : float
        A branch pixel within this of the curve attaches the branch to it.
    arm_px : int

    Returns
    -------
    float
        The largest such excess turn over the branches, deg (0 without any).
    """
    from scipy.spatial import cKDTree

    n = len(dense_xy)
    if n < 2 * arm_px + 1 or not branches:
        return 0.0
    tree = cKDTree(dense_xy)

    def angle(a, b):
        na, nb = np.linalg.norm(a), np.linalg.norm(b)
        if na < 1e-9 or nb < 1e-9:
            return float("nan")
        return float(np.degrees(np.arccos(np.clip(a @ b / (na * nb), -1.0, 1.0))))

    worst = 0.0
    for br in branches:
        if len(br) < arm_px:
            continue
        dist, k = tree.query(br)
        i = int(np.argmin(dist))
        k = int(k[i])
        if dist[i] > attach_px or k < arm_px or k > n - 1 - arm_px:
            continue
        j = dense_xy[k]
        r = np.hypot(*(br - j).T)
        arm = br[(r >= 0.5 * arm_px) & (r <= arm_px)]
        if len(arm) == 0:
            continue
        inc = j - dense_xy[k - arm_px]
        excess = angle(inc, dense_xy[k + arm_px] - j) - angle(inc, arm.mean(axis=0) - j)
        if np.isfinite(excess):
            worst = max(worst, excess)
    return float(worst)
