"""The checks' reading of what lies ahead of the curve's tip in one view: the tendril going on across an object.

A curve that stops where the tendril passes behind (or over) an object, a
leaf between a camera and the tendril, a shoot of the stem it passes behind,
leaves the rest of the tendril beyond the object. That rest is a dark line
of its own, a component the curve does not touch, so neither the coverage
(which counts the components the curve runs along) nor the tip continuation
(the unexplained skeleton connected to the tip) sees it: on random scenes
such curves were reported ``ok`` 15-74 mm short of the tip (seeds 14, 22:
an occluding leaf, a shoot; every image check passed).

:func:`beyond_tip_px` looks along the curve's direction at its projected tip:
as far as the dark pixels there reach (the object, and the tendril's own
pixels up to it), across gaps of at most ``gap_px`` light pixels, it
collects, within a cone about that direction, the thin
unexplained skeleton branches it meets (8-connected runs of skeleton pixels
farther than the coverage tolerance from the curve, no wider than the
tendril) that do not run out of the ROI (the stem, a shoot, a stalk come
from outside it) and do not start at the tip (those are the tip
continuation's, :func:`tendrilkit.verify_tip.tip_continuation`). Their length is the figure ``beyond_tip_px_v<i>``; the
check (in two views or more, as the tip continuation: a second tendril or a
petiole crosses the tendril in one view only) reads it against
``verification.max_beyond_tip_px`` (10 px). On the multi-view curves of
development seeds 0-39, the 85 frames right on all three criteria score 0 px
in their second-worst view (one frame 134 px in one view: a second tendril
ahead of its tip); curves stopping at an occluding leaf, a shoot or a leaf
their coil rests on, 17-74 mm short of the tip and reported ``ok`` before,
70-780 px in two views or more.
"""

from __future__ import annotations

import numpy as np

from tendrilkit.evidence import ViewEvidence
from tendrilkit.verify_tip import skeleton_to_curve_px

__all__ = ["beyond_tip_px"]


def beyond_tip_px(ev: ViewEvidence, dense_xy: np.ndarray, inside_px: np.ndarray, radius_px: float, *,
                  cov_tol: float, tol: float, wide_ratio: float, gap_px: float = 6.0, border_px: float = 2.0,
                  direction_px: int = 10, cone_deg: float = 35.0, sk_dist: np.ndarray | None = None) -> float:
    """Length (px) of thin, unexplained skeleton branches met ahead of the projected tip, across dark pixels.

    Parameters
    ----------
    ev : ViewEvidence
        With its skeleton.
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, base to tip, full-image px.
    inside_px : (h, w) float32 array
        Distance of every foreground pixel of the ROI crop to the background, px.
    radius_px : float
        The tendril's half width in this view, px (NaN: unknown; 0 is returned).
    cov_tol : float
        A skeleton pixel within this distance of the curve is explained, px;
        a skeleton pixel within it of the ray is met.
    tol : float
        A ray sample within this distance of a dark pixel is on the dark pixels, px.
    wide_ratio : float
        Skeleton pixels whose inside distance exceeds this times ``radius_px``
        are wider than the tendril (the object's middle): not met.
    gap_px : float
        The ray stops after this many light pixels in a row (6 px: the light
        rim between an object and the tendril behind it, a faint stretch).
    border_px : float
        A branch whose line comes this close to the ROI's border runs out of it.
    direction_px : int
        The tip's direction is that of the curve's last this many px.
    cone_deg : float
        Skeleton pixels within this angle of the tip's direction, and no
        farther from the tip than the ray's dark pixels reach (plus
        ``gap_px`` and ``cov_tol``), are met (35 degrees: the tendril bends
        on behind the object).
    sk_dist : (m,) float array, optional
        :func:`tendrilkit.verify_tip.skeleton_to_curve_px` of the skeleton,
        ``dense_xy`` and ``cov_tol``, when the caller has it (one query for
        this and the tip continuation).

    Returns
    -------
    float
        Total pixel count of the branches met (0: none; a right curve's
        tip is the tendril's end, the ray leaves the dark pixels at once).
    """
    sk = ev.skeleton_xy
    if (sk is None or len(sk) == 0 or len(dense_xy) < 2 or not np.isfinite(radius_px) or radius_px <= 0):
        return 0.0
    off = ev.roi_offset_xy
    h, w = ev.shape
    tip = dense_xy[-1]
    u = tip - dense_xy[max(len(dense_xy) - 1 - direction_px, 0)]
    if not np.hypot(*u) > 0:
        return 0.0
    u = u / np.hypot(*u)
    # the ray, one sample per pixel, up to the ROI's border; cut after gap_px light pixels in a row
    n_max = int(np.hypot(h, w))
    ray = tip + np.arange(1, n_max + 1)[:, None] * u
    rc = np.rint(ray - off).astype(int)
    inside_roi = (rc[:, 0] >= 0) & (rc[:, 0] < w) & (rc[:, 1] >= 0) & (rc[:, 1] < h)
    n_in = int(np.argmin(inside_roi)) if not inside_roi.all() else len(ray)
    ray, rc = ray[:n_in], rc[:n_in]
    if len(ray) == 0:
        return 0.0
    k = int(np.floor(gap_px)) + 1  # the ray stops where a run of more than gap_px light samples starts
    stop = _ray_stop(ev, rc, tol, k)
    if stop == 0:
        return 0.0
    # met: thin skeleton pixels ahead of the tip (within ``cone_deg`` of its direction: the tendril bends a little
    # behind the object), no farther than the dark pixels along the ray reach, plus a gap and the coverage tolerance
    sr = (sk[:, 1] - off[1]).astype(int)
    sc = (sk[:, 0] - off[0]).astype(int)
    thin = inside_px[sr, sc] <= wide_ratio * radius_px
    rel = sk - tip
    r = np.hypot(*rel.T)
    ahead = thin & (r <= stop + gap_px + cov_tol) & (rel @ u >= np.cos(np.radians(cone_deg)) * r)
    if not ahead.any():
        return 0.0
    # the unexplained thin skeleton pixels and their branches
    if sk_dist is None:
        sk_dist = skeleton_to_curve_px(sk, dense_xy, cov_tol)
    free = thin & (sk_dist > cov_tol)
    if not (ahead & free).any():
        return 0.0
    fxy = sk[free]
    hit = np.nonzero(ahead[free])[0]
    import cv2

    img = np.zeros((h, w), np.uint8)
    fr, fc = sr[free], sc[free]
    img[fr, fc] = 1
    _, lab = cv2.connectedComponents(img, connectivity=8, ltype=cv2.CV_32S)
    b = lab[fr, fc]
    size = np.bincount(b)
    # a skeleton stops about its line's half width short of where the line leaves the crop
    edge = np.minimum(np.minimum(fr, h - 1 - fr), np.minimum(fc, w - 1 - fc)) <= inside_px[fr, fc] + border_px
    out_of_roi = np.bincount(b, weights=edge, minlength=len(size)) > 0
    # a branch starting at the tip is the tip continuation's (:func:`tendrilkit.verify_tip.tip_continuation`)
    at_tip = np.bincount(b, weights=np.hypot(*(fxy - tip).T) <= cov_tol + 3.0, minlength=len(size)) > 0
    labels = np.unique(b[hit])
    return float(sum(size[k] for k in labels if k > 0 and not out_of_roi[k] and not at_tip[k]))


#: Ray samples whose lightness :func:`_ray_stop` reads per box (a right curve's ray stops within a few).
RAY_CHUNK = 48


def _ray_stop(ev: ViewEvidence, rc: np.ndarray, tol: float, k: int) -> int:
    """Index of the first of ``k`` light ray samples in a row (distance to the dark pixels above ``tol``), or ``len(rc)``.

    ``rc``: (n, 2) int array, the ray's crop pixels ``(column, row)``. The
    same as reading ``ev.distance_px`` along the ray, without the whole
    crop's distance transform: the samples are read in chunks of
    :data:`RAY_CHUNK`, each from the transform of its box grown by
    ``ceil(tol) + 1`` px, and the reading stops at the first run found. Bit
    for bit the same answers: a box's distance up to its margin is the whole
    crop's (a dark pixel outside the box is farther than the margin: the
    chamfer distance is at least the chessboard one; inside the box the
    chamfer paths stay in it), and a larger one is above ``tol`` in both.
    """
    import cv2

    n = len(rc)
    if "distance_px" in ev.__dict__:  # made already (by another reader): read it
        light = ev.distance_px[rc[:, 1], rc[:, 0]] > tol
    else:
        h, w = ev.shape
        m = int(np.ceil(tol)) + 1
        light = np.zeros(n, bool)
        for s in range(0, n, RAY_CHUNK):
            part = rc[s:s + RAY_CHUNK]
            r0, r1 = max(int(part[:, 1].min()) - m, 0), min(int(part[:, 1].max()) + m + 1, h)
            c0, c1 = max(int(part[:, 0].min()) - m, 0), min(int(part[:, 0].max()) + m + 1, w)
            sub = np.ascontiguousarray(ev.foreground[r0:r1, c0:c1]).view(np.uint8)
            if sub.any():
                D = cv2.distanceTransform(cv2.compare(sub, 0, cv2.CMP_EQ), cv2.DIST_L2, 5)
                light[s:s + len(part)] = D[part[:, 1] - r0, part[:, 0] - c0] > tol
            else:  # no dark pixel within the margin
                light[s:s + len(part)] = True
            e = s + len(part)
            runs = np.flatnonzero(np.convolve(light[:e].astype(np.int32), np.ones(k, np.int32), "valid") == k)
            if runs.size:  # a run wholly inside the samples read: none can start earlier
                return int(runs[0])
        # (every sample read: the last check covered them all)
        return n
    runs = np.flatnonzero(np.convolve(light.astype(np.int32), np.ones(k, np.int32), "valid") == k)
    return int(runs[0]) if runs.size else n
