"""Clutter crossing the tendril, and breaks in it: what the coverage counts as the tendril's skeleton.

The coverage (:mod:`tendrilkit.verify`) counts the tendril's skeleton that
the projected curve leaves unexplained. A thin line crossing the tendril (a
second tendril, a petiole, a marker card's stalk) joins the tendril's dark
pixels and leaves two unexplained arms, one on each side of the curve, that
continue each other in a straight line. A part of the tendril the curve
misses does not: beyond the tip it is one arm; where the curve turns off the
tendril onto clutter, the tendril's missed arm continues the curve's way in,
not another unexplained arm. So an arm whose straight continuation across
the curve is another unexplained arm is clutter crossing, not tendril
(:func:`crossing_branches`). On the multi-view curves of random seeds 5000-5039
right frames (within 0.1-0.2 mm of the truth) crossed by a thin line inside
the ROI, which does not reach the border to be left out as the stem, scored
a coverage of 0.56-0.74 in every view.

A pale crossing line may itself be broken in the dark pixels: its pieces
beyond the breaks, bridged from its arm by :func:`across_gaps`, are left out
with the arm (:func:`tendrilkit.verify_coverage.coverage_frac` bridges again
without the arms; development seed 9811, a petiole crossing the tendril in
one view: two right frames at 0.63-0.64, 1.0 so).

A line running out of the ROI (the stem, a shoot, a second tendril's arm)
comes from outside the region the tendril moves in: only its own skeleton
segments, between junctions, are left out (:func:`border_segments`), not a
missed part of the tendril crossing it. Where lines cross, the dark pixels
often break: the tendril's pieces beyond such a break still count
(:func:`across_gaps`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["crossing_branches", "border_segments", "across_gaps"]

#: Largest break in the dark pixels, px, bridged between the tendril's pieces (:func:`across_gaps`).
GAP_PX = 10.0

#: Whether a crossing line's other side may be any unexplained thin pixels on its straight continuation.
CROSSING_PIXELS = True

#: Largest turn of the curve through a crossing (deg, chords over 25 px either side) for which a partner-only
#: side (a segment running out of the ROI, thin pixels on the arm's straight continuation) pairs an arm.
STRAIGHT_THROUGH_DEG = 30.0

#: Smallest sine of the angle between an arm and the curve for which a partner-only side pairs it (0.7: 44 deg).
#: The turn above is read on chords that span the crossing's band, so a curve leaving the tendril at 15-35 deg
#: for a line running out of the ROI looks straight enough; the missed tendril then runs on at that shallow angle
#: to the curve, while a line crossing it stands at a real angle.
PARTNER_MIN_SIN = 0.7


def across_gaps(labels: np.ndarray, sk_xy: np.ndarray, sr: np.ndarray, sc: np.ndarray, thin: np.ndarray,
                touched: np.ndarray, dense_xy: np.ndarray, *, gap_px: float = GAP_PX) -> np.ndarray:
    """``touched`` and the components whose thin skeleton ends within ``gap_px`` of the curve or of theirs.

    Where lines cross, the dark pixels break (6-10 px gaps on random
    scenes): the rest of the tendril beyond the point where the curve left
    it (onto a petiole, a second tendril) falls into components the curve
    does not run on, yet it is tendril the curve leaves unexplained (random
    seed 25, multi-view: four frames 11 mm off reported ``ok``, coverage
    0.86-0.94, 0.40-0.76 with the break bridged). Bridged are the ends (one
    skeleton neighbour) of thin skeleton, repeatedly, from the curve and the
    pieces reached. A line crossing the tendril, broken on both sides, is
    then left out by :func:`crossing_branches`. On development seeds 0-39
    (6 frames each) the frames reported ``ok`` with a mean error over
    1.5 mm went from 4 to 0 (multi-view), those with the max or an end over
    2 mm from 29 to 19 (multi-view) and 18 to 15 (chain: curves stopping
    14-30 mm short of the tip); frames right on all three criteria flagged:
    9 of 85 (multi-view) and 1 of 28 (chain), as before.

    Parameters
    ----------
    labels : (h, w) int array
        The ROI's dark components (0: background).
    sk_xy : (m, 2) float array
        The skeleton pixels, px (image coordinates).
    sr, sc : (m,) int arrays
        Their row and column in ``labels``.
    thin : (m,) bool array
        Whether each lies on the tendril's thin line (not a leaf's blob, the stem).
    touched : (k,) int array
        The components counted already (the curve's, the base mark's).
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, px.
    gap_px : float
        Largest break bridged, px.

    Returns
    -------
    (k',) int array
        Sorted component labels, ``touched`` among them.
    """
    from scipy.spatial import cKDTree

    lab = labels[sr, sc]
    n_nb = _neighbour_counts(sr, sc, labels.shape)
    end = np.nonzero((n_nb == 1) & thin & (lab > 0))[0]
    done = {int(k) for k in touched}
    pts = np.vstack([dense_xy.reshape(-1, 2), sk_xy[np.isin(lab, touched) & thin]])
    while len(pts):
        todo = end[~np.isin(lab[end], list(done))]
        if len(todo) == 0:
            break
        hit = cKDTree(pts).query(sk_xy[todo], distance_upper_bound=gap_px + 1e-9)[0] <= gap_px
        new = {int(k) for k in lab[todo[hit]]} - done
        if not new:
            break
        done |= new
        pts = np.vstack([pts, sk_xy[np.isin(lab, list(new)) & thin]])
    return np.array(sorted(done), int)


def _neighbour_counts(sr: np.ndarray, sc: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(m,) int: how many of the (distinct) pixels ``(sr, sc)`` are 8-neighbours of each (none outside ``shape``).

    The pixels painted on their box grown by a pixel (background there: a
    neighbour outside ``shape`` is none of them), and the eight shifted
    views of it summed at each pixel: the same counts as a look-up of each
    neighbour among the pixels, at a fraction of the cost.
    """
    sr, sc = np.asarray(sr, np.int64), np.asarray(sc, np.int64)
    n_nb = np.zeros(len(sr), np.int64)
    if len(sr) == 0:
        return n_nb
    r0, c0 = int(sr.min()) - 1, int(sc.min()) - 1
    img = np.zeros((int(sr.max()) - r0 + 2, int(sc.max()) - c0 + 2), np.uint8)
    rr, cc = sr - r0, sc - c0
    img[rr, cc] = 1
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr or dc:
                n_nb += img[rr + dr, cc + dc]
    return n_nb


def border_segments(img: np.ndarray, edge: np.ndarray) -> np.ndarray:
    """The pixels of a skeleton's segments (between junctions) that themselves reach the region's border.

    A line running out of the ROI (the stem, a shoot, a second tendril's
    arm) comes from outside the region the tendril moves in. Only the
    segments of it that reach the border are clutter: a part of the tendril
    the curve missed that crosses or touches such a line keeps its own
    segments. A junction is a pixel with three or more runs of neighbours
    around it (the crossing number, which a staircase step of a thin line
    does not reach); its 3 x 3 neighbourhood separates the segments meeting
    there and stays with the pixels that are not dropped.

    Parameters
    ----------
    img : (h, w) uint8 array
        The skeleton pixels (1), 0 elsewhere.
    edge : (h, w) bool array
        Pixels at the border (only read where ``img`` is 1).

    Returns
    -------
    (h, w) bool array
        True on the pixels of segments with a pixel on ``edge``.

    Examples
    --------
    A vertical line from the border (row 0) down to a horizontal one that stays inside: only the vertical segment
    is dropped (rows 0-4; the junction at row 6 and its neighbour above stay).

    >>> img = np.zeros((12, 20), np.uint8); img[0:6, 10] = 1; img[6, 2:18] = 1
    >>> edge = np.zeros(img.shape, bool); edge[0] = True
    >>> drop = border_segments(img, edge)
    >>> int(drop[:, 10].sum()), int(drop[6].sum())
    (5, 0)
    """
    import cv2

    on = img > 0
    p = np.pad(on, 1)
    # the crossing number at the skeleton's pixels only (a few thousand, not the whole box): the eight
    # neighbours in order around the pixel; a run starts where a 0 is followed by a 1
    rr, cc = np.nonzero(on)
    ring = [p[rr + r, cc + c] for r, c in ((0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0), (1, 0), (0, 0))]
    runs = sum((~ring[k] & ring[(k + 1) % 8]).astype(np.uint8) for k in range(8))
    junction = np.zeros(on.shape, np.uint8)
    junction[rr[runs >= 3], cc[runs >= 3]] = 1
    zone = cv2.dilate(junction, np.ones((3, 3), np.uint8)).astype(bool) & on
    in_zone = zone[rr, cc]
    rest = np.zeros(on.shape, np.uint8)
    rest[rr[~in_zone], cc[~in_zone]] = 1
    n, seg = cv2.connectedComponents(rest, connectivity=8, ltype=cv2.CV_32S)
    out_zone = ~in_zone & edge[rr, cc]
    at_edge = np.bincount(seg[rr[out_zone], cc[out_zone]], minlength=n) > 0
    at_edge[0] = False
    drop = np.zeros(on.shape, bool)
    drop[rr, cc] = at_edge[seg[rr, cc]]
    if (zone & edge).any():  # a junction on the border itself: the segments meeting there reach it too
        zl = cv2.connectedComponents(zone.astype(np.uint8), connectivity=8, ltype=cv2.CV_32S)[1]
        hit = np.unique(zl[zone & edge])
        near = cv2.dilate(np.isin(zl, hit).astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
        drop |= np.isin(seg, np.unique(seg[near & (seg > 0)])) & (seg > 0)
        drop |= np.isin(zl, hit) & zone
    return drop


def _straight_through(dense_xy: np.ndarray, j: int, *, max_turn_deg: float, half_px: int = 25) -> bool:
    """Whether the curve (resampled every pixel) runs straight on through its sample ``j``: its chords over
    ``half_px`` before and after it turn by at most ``max_turn_deg``."""
    a, b = dense_xy[j] - dense_xy[max(j - half_px, 0)], dense_xy[min(j + half_px, len(dense_xy) - 1)] - dense_xy[j]
    na, nb = float(np.hypot(*a)), float(np.hypot(*b))
    if na == 0 or nb == 0:
        return False  # the curve's end: nothing to run straight on through
    return float(a @ b) / (na * nb) >= np.cos(np.radians(max_turn_deg))


def crossing_branches(dense_xy: np.ndarray, free_xy: np.ndarray, free_branch: np.ndarray, branches: np.ndarray, *,
                      cov_tol: float, width_px: float = 0.0, arm_px: tuple[float, float] = (5.0, 25.0),
                      min_sin: float = 0.25,
                      max_cos: float = -0.8, gap_px: float = 6.0,
                      nearest: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Which unexplained branches continue, across the curve, in another unexplained branch.

    A branch's end is its pixel nearest the curve (it must lie within
    ``cov_tol + 3`` px: attached), its direction that from the end to the
    mean of its pixels between ``arm_px`` from the end. A branch that comes
    back to the curve farther than ``arm_px[1]`` from its end is no arm:
    it is a piece of the tendril between two explained parts (a turn of a
    coil the curve skips, whose pieces cross each other where the coil is
    seen end-on). Two branches are the
    two arms of a line crossing the curve when their directions are opposite
    (cosine at most ``max_cos``) and their ends lie on either side of the
    band the curve explains and of the pixels the two lines share: at most
    ``2 * (cov_tol + width_px) / sin(a) + gap_px`` px apart, ``a`` the angle
    between the branch and the curve (its sine at least ``min_sin``: lines
    crossing at a shallow angle stay merged and explained longer). With no
    such arm across, and only where the curve runs straight on through the
    crossing (its chords over 25 px either side turn by at most
    :data:`STRAIGHT_THROUGH_DEG`: where it turns it may have left the
    tendril's end for a line that happens to continue it) and the arm
    stands at a real angle to it (sine at least :data:`PARTNER_MIN_SIN`: a
    curve that left the tendril at a shallow angle has the missed tendril
    running on beside it at that angle), the other arm
    may be a partner-only branch (``free_branch`` labels not in
    ``branches``: a segment running out of the ROI), and a branch is an arm
    still when at least
    ``arm_px[1] - arm_px[0]`` unexplained thin pixels of other branches lie on
    its straight continuation across the curve (within that reach plus
    ``arm_px[1]`` along it, half the width + 2 px beside it;
    :data:`CROSSING_PIXELS`): the line's other side split beyond the curve by
    a third line, or the piece between two crossings of a loop the line
    crosses twice, which comes back to the curve and is no arm (pale options
    and kink choice, dev seeds 9240-9299: seeds 9268 and 9289, three right
    frames flagged at 0.67-0.71 read 0.78-0.94 and pass, and seed 9268
    frame 2, tracked from a passing frame now, is right (max 3.99 -> 0.28 mm);
    dev seeds 1040-1079: no status changed; no wrong frame flagged by the
    coverage alone lost).

    Parameters
    ----------
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, px.
    free_xy : (m, 2) float array
        Unexplained skeleton pixels (farther than ``cov_tol`` from the
        curve), px.
    free_branch : (m,) int array
        Each one's branch label (8-connected runs of thin unexplained
        pixels, >= 1), 0 for pixels in no branch (wider than the tendril).
    branches : (k,) int array
        The branch labels to test; any other label may be the other arm.
    cov_tol : float
        A skeleton pixel within this distance of the curve is explained, px.
    width_px : float
        The tendril's width, px.
    arm_px, min_sin, max_cos, gap_px : float
        See above.
    nearest : ((m,) float array, (m,) int array), optional
        Each unexplained pixel's distance to ``dense_xy`` (px) and the index
        of its nearest curve point, as ``cKDTree.query`` gives them (when the
        caller has them already); only those within ``cov_tol + 3`` px are
        read, farther ones may be ``inf``. Default: queried here.

    Returns
    -------
    (k,) bool array
        Per branch in ``branches``: True when it is an arm of a crossing line.

    Examples
    --------
    A horizontal curve, a vertical line crossing it (two arms) and a
    vertical branch leaving it upwards only:

    >>> curve = np.column_stack([np.arange(0.0, 100.0), np.full(100, 50.0)])
    >>> up = np.column_stack([np.full(40, 30.0), np.linspace(10.0, 45.0, 40)])
    >>> down = np.column_stack([np.full(40, 30.0), np.linspace(55.0, 90.0, 40)])
    >>> lone = np.column_stack([np.full(40, 70.0), np.linspace(10.0, 45.0, 40)])
    >>> xy = np.vstack([up, down, lone]); lab = np.repeat([1, 2, 3], 40)
    >>> crossing_branches(curve, xy, lab, np.array([1, 2, 3]), cov_tol=4.0).tolist()
    [True, True, False]
    """
    from scipy.spatial import cKDTree

    out = np.zeros(len(branches), bool)
    if len(dense_xy) < 2 or len(free_xy) == 0:
        return out
    d_all, j_all = cKDTree(dense_xy).query(free_xy) if nearest is None else nearest
    arms = {}  # label -> (end, direction, sine of its angle to the curve)
    for k in np.unique(free_branch[free_branch > 0]):
        mine = np.nonzero(free_branch == k)[0]
        i = mine[int(np.argmin(d_all[mine]))]
        if d_all[i] > cov_tol + 3.0:  # not attached to the curve
            continue
        end = free_xy[i]
        r = np.hypot(*(free_xy[mine] - end).T)
        if np.any((d_all[mine] <= cov_tol + 3.0) & (r > arm_px[1])):
            continue  # it comes back to the curve elsewhere: a piece of the tendril between two explained parts
        arm = free_xy[mine][(r >= arm_px[0]) & (r <= arm_px[1])]
        if len(arm) == 0:
            continue
        u = arm.mean(axis=0) - end
        if not np.hypot(*u) > 0:
            continue
        u = u / np.hypot(*u)
        jc = int(j_all[i])
        tang = dense_xy[min(jc + 3, len(dense_xy) - 1)] - dense_xy[max(jc - 3, 0)]
        sin = abs(float(tang[0] * u[1] - tang[1] * u[0])) / max(float(np.hypot(*tang)), 1e-9)
        arms[int(k)] = (end, u, sin, jc)
    tested = {int(k) for k in branches}
    for n, k in enumerate(branches):
        if int(k) not in arms:
            continue
        end, u, sin, jc = arms[int(k)]
        reach = 2.0 * (cov_tol + width_px) / max(sin, min_sin) + gap_px
        pair = [m for m, (e2, u2, _, _) in arms.items()
                if m != int(k) and float(u @ u2) <= max_cos and float(np.hypot(*(end - e2))) <= reach]
        out[n] = any(m in tested for m in pair)
        if out[n] or sin < PARTNER_MIN_SIN or not _straight_through(dense_xy, jc, max_turn_deg=STRAIGHT_THROUGH_DEG):
            # the other side only partner-only pixels (a segment running out of the ROI, a split line): only
            # where the curve runs straight on through the crossing, not where it turns (where it may have
            # left the tendril's end for a line that happens to continue it; dev seed 1063 frame 4)
            continue
        out[n] = bool(pair)
        if not out[n] and CROSSING_PIXELS:
            # the line's other side need not be one arm: a piece between two crossings (a loop the line crosses
            # twice), a piece running into a third line; its pixels lie on the straight continuation
            w = free_xy[(free_branch > 0) & (free_branch != int(k))] - end
            along = -(w @ u)
            perp = np.abs(w[:, 0] * u[1] - w[:, 1] * u[0])
            ahead = (along > 0) & (along <= reach + arm_px[1]) & (perp <= 0.5 * width_px + 2.0)
            out[n] = int(ahead.sum()) >= arm_px[1] - arm_px[0]
    return out
