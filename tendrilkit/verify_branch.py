"""The checks' reading of a curve that turns off a line onto another at a junction of the tendril's pixels.

A curve can run onto a second tendril (or a stalk) where it touches the
tendril: at the junction it turns off the line it arrived on onto the other
line, and follows that one to its free end. Every other check then passes:
the curve lies on dark pixels of the tendril's width in every view, the
part of the tendril it leaves (a coil, the tip's last millimetres) is short
enough for the coverage, and the second line's other arm, which runs on out
of the region the tendril moves in, is left out of the coverage as clutter
(:func:`tendrilkit.verify_crossing.border_segments`). On the untouched
development seeds 9413 and 9415 (multi-view) frames 4-5 were reported ``ok``
with mean errors 3.6-5.7 mm, their tips 33-56 mm off: one curve skips the
tendril's coil and runs along a second tendril crossing it, the other
reaches the tendril's tip, where it touches a second tendril, turns back
(a hairpin, smoothed over 10 mm by the fit) and runs up the second tendril.

What the images show at such a junction is a turn of the projected curve
(at least ``min_turn_deg`` between its two sides' directions over
``arm_px``) where a thin line of unexplained skeleton leaves the curve
straight on from one of its sides: the line the curve arrived on goes on
beyond the turn, or the line it leaves on goes on back across the junction.
A tendril that bends sharply (a hook, a coil) has no such line: its
skeleton follows the curve; a line crossing the tendril meets it at the
crossing's angle, not along the curve's sides.
:func:`turn_branch_px` returns the longest such line (px) in one view; the
frame is ``doubtful`` when one is found in two views or more (in one view a
crossing line may happen to lie along one side of a bend).

Measured (main of this round plus this check; 60 degrees, cosine 0.9 and
15 px chosen once from seeds 9413/9415, not tuned): on development seeds
0-39 and 9400-9422 (multi-view, 378 frames) and 0-19 (chain, 120 frames) it
fires on 21 frames, every one wrong (mean error 2.3-13.7 mm), none of the
146 frames right on all three accuracy criteria, none within 0.5 mm mean;
on 9413/9415 it alone flags frames 4 of both (``ok`` before, 3.6-5.7 mm);
the site phantoms (chain and multi-view) stay ``ok`` in every frame.
"""

from __future__ import annotations

import numpy as np

from tendrilkit.evidence import ViewEvidence
from tendrilkit.verify_tip import failing_views

__all__ = ["turn_branch_px", "turn_branch_message"]


def turn_branch_px(ev: ViewEvidence, dense_xy: np.ndarray, inside_px: np.ndarray, radius_px: float,
                   sk_dist: np.ndarray | None, *, wide_ratio: float, cov_tol: float, arm_px: int = 25,
                   min_turn_deg: float = 60.0, min_cos: float = 0.9, min_branch_px: float = 15,
                   branch_arm_px: tuple[float, float] = (5.0, 25.0)) -> float | None:
    """Length (px) of the longest unexplained thin line leaving a turn of the curve straight on from one side.

    Parameters
    ----------
    ev : ViewEvidence
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, base to tip, full-image px.
    inside_px : (h, w) float32 array
        Distance of every foreground pixel of the ROI crop to the background, px.
    radius_px : float
        The tendril's half width in this view, px (NaN: unknown; None is returned).
    sk_dist : (m,) float array or None
        Each skeleton pixel's distance to the curve, px, inf beyond ``cov_tol``
        (:func:`tendrilkit.verify_tip.skeleton_to_curve_px`); None: None is returned.
    wide_ratio : float
        Skeleton pixels whose inside distance exceeds this times ``radius_px``
        are clutter wider than the tendril (a leaf, the stem), not a line.
    cov_tol : float
        A skeleton pixel within this distance of the curve is explained, px.
    arm_px : int
        Length of each side of the curve at a junction, px (its direction).
    min_turn_deg : float
        Smallest turn of the curve at the junction, degrees (0: straight on).
    min_cos : float
        Smallest cosine between the line's direction and the side's
        direction continued beyond the junction.
    min_branch_px : float
        Lines of fewer skeleton pixels are spurs.
    branch_arm_px : (float, float)
        The line's direction is that from its end nearest the curve to the
        mean of its pixels between these distances from that end, px.

    Returns
    -------
    float or None
        px; None: no such line (or the view cannot say).
    """
    if sk_dist is None or len(dense_xy) < 2 * arm_px + 1 or not (np.isfinite(radius_px) and radius_px > 0):
        return None
    import cv2
    from scipy.spatial import cKDTree

    sk = ev.skeleton_xy
    off = ev.roi_offset_xy
    sr = (sk[:, 1] - off[1]).astype(int)
    sc = (sk[:, 0] - off[0]).astype(int)
    free = ~np.isfinite(sk_dist) & (inside_px[sr, sc] <= wide_ratio * radius_px)
    if free.sum() < min_branch_px:
        return None
    fr, fc, fxy = sr[free], sc[free], sk[free]
    r0, c0 = fr.min() - 1, fc.min() - 1  # label on the free pixels' box (a 1 px rim), not on the whole crop
    img = np.zeros((fr.max() - r0 + 2, fc.max() - c0 + 2), np.uint8)
    img[fr - r0, fc - c0] = 1
    nb, lab = cv2.connectedComponents(img, connectivity=8, ltype=cv2.CV_32S)
    b = lab[fr - r0, fc - c0]
    tree = cKDTree(dense_xy)
    n = len(dense_xy)
    best = None
    for k in range(1, nb):
        pix = fxy[b == k]
        if len(pix) < min_branch_px:
            continue
        dist, idx = tree.query(pix)
        e = int(np.argmin(dist))
        if dist[e] > cov_tol + 3.0:  # not attached to the curve
            continue
        j = int(idx[e])
        if j < arm_px or j > n - 1 - arm_px:  # at the curve's ends: the base's and the tip's checks
            continue
        r = np.hypot(*(pix - pix[e]).T)
        arm = pix[(r >= branch_arm_px[0]) & (r <= branch_arm_px[1])]
        if len(arm) < 3:
            continue
        u = arm.mean(axis=0) - pix[e]
        back = dense_xy[j - arm_px] - dense_xy[j]
        ahead = dense_xy[j + arm_px] - dense_xy[j]
        nu, nb_, na = np.hypot(*u), np.hypot(*back), np.hypot(*ahead)
        if not (nu > 0 and nb_ > 0 and na > 0):
            continue
        u, back, ahead = u / nu, back / nb_, ahead / na
        turn = 180.0 - np.degrees(np.arccos(np.clip(float(back @ ahead), -1.0, 1.0)))
        if turn < min_turn_deg:
            continue
        if max(float(u @ -back), float(u @ -ahead)) >= min_cos:
            best = max(best or 0.0, float(len(pix)))
    return best


def turn_branch_message(figures: dict, n_views: int) -> str | None:
    """The check's message when such a line is found in two views or more, else None.

    Parameters
    ----------
    figures : dict
        ``turn_branch_px_v<i>`` per view (1-based; None: none found).
    n_views : int
    """
    found = failing_views(figures, "turn_branch_px", n_views, lambda x: True, min_views=2)
    if not found:  # in one view a crossing line may lie along one side of a bend
        return None
    return ("junction: the curve turns off a line that goes on beyond the turn (it may run onto a second tendril) "
            "in " + ", ".join(f"view {v} ({x:.0f} px of line)" for v, x in found))
