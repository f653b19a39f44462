"""The checks' reading of where the curve's tip stops in one view: at an object the tendril may cross.

A curve can stop where the tendril meets an object (the stem, a side shoot,
a leaf) while the tendril goes on across or behind it, its rest not seen as
dark pixels of the tendril's width: a pale coil over a dark shoot is not
segmented beyond it, the shoot's pixels hide its line. Every other check
then passes: the curve lies on the tendril's pixels, explains every thin
skeleton pixel (the rest of the tendril is not among them), no thin line
goes on beyond the tip (:mod:`tendrilkit.verify_tip`) or across the object
(:mod:`tendrilkit.verify_beyond`). On development seed 170 (a pale coil
over a shoot of the stem, multi-view) three frames were reported ``ok``
20-22 mm short of the tip (mean error 0.07-0.11 mm): in every view the
curve stopped at the shoot's edge.

Where a tendril's tip ends cannot be seen when, in two views or more, its
projection stops at or on pixels wider than the tendril: the frame is
``doubtful`` (a tip resting on a leaf is, for the same reason, by the tip's
wide pixels check).

The curve on random seed 170 stops 5-10 px before the shoot, where the pale
tendril, in front of it, cuts the shoot's dark band: the object is beside
the tendril's line rather than on it. :func:`tip_object_px` therefore looks
in a corridor ahead of the projected tip (along the curve's last
``direction_px``, ``corridor`` tendril half widths to either side) and returns
how far ahead the first pixel wider than the tendril lies (0: at the tip
itself), or None when none lies within ``reach_px``
(``verification.min_tip_object_px``, 30 px). On the multi-view curves of
development seeds 0-19, 21 seeds 41-170 with coils over a shoot, petioles
or second tendrils, and 7015 (242 frames; 3 half widths aside), the 60
frames right on all three accuracy criteria have no such pixel within
30 px in their second-best view but one (a tip over a leaf, 0 px, flagged
by the tip continuation too); the seven frames reported ``ok`` 18-108 mm
short of the tip (seeds 13, 74, 90, 170: a tip resting on a leaf, a coil
over a leaf, the pale coil in front of a shoot) 11-30 px. On the untouched
development seeds 9200-9239 (both new checks together, 240 frames per
method), multi-view: 5 frames no longer ``ok``, all by this check: one
3.1 mm wrong (mean; 71 mm short), two 8-15 mm short at the tip, but two
right on all three criteria (tips 13-24 px from a shoot in two views or
three);
chain: 5, all of one scene, 33 mm short of the tip, none right.
"""

from __future__ import annotations

import numpy as np

from tendrilkit.evidence import ViewEvidence
from tendrilkit.verify_tip import failing_views

__all__ = ["tip_object_px", "tip_object_message"]


def tip_object_px(ev: ViewEvidence, dense_xy: np.ndarray, inside_px: np.ndarray, radius_px: float, *,
                  wide_ratio: float, reach_px: float, corridor: float = 3.0, direction_px: int = 10) -> float | None:
    """Distance (px) from the projected tip, along its direction, to the first pixel wider than the tendril.

    Parameters
    ----------
    ev : ViewEvidence
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, base to tip, full-image px.
    inside_px : (h, w) float32 array
        Distance of every foreground pixel of the ROI crop to the background, px.
    radius_px : float
        The tendril's half width in this view, px (NaN: unknown; None is returned).
    wide_ratio : float
        A pixel is wider than the tendril where its inside distance exceeds
        this times ``radius_px`` (as :func:`tendrilkit.verify_tip.on_wide`).
    reach_px : float
        How far ahead of the tip to look, px.
    corridor : float
        Half width of the corridor, in tendril half widths (3: the object
        beside a pale tendril's line, whose crossing cuts the object's band).
    direction_px : int
        The tip's direction is that of the curve's last this many px.

    Returns
    -------
    float or None
        px (0: the tip lies on the object); None: no wider pixel within
        ``reach_px`` ahead of the tip (the tendril ends in the open, or the
        view cannot say).
    """
    if len(dense_xy) < 2 or not (np.isfinite(radius_px) and radius_px > 0):
        return None
    off = ev.roi_offset_xy
    h, w = ev.shape
    tip = dense_xy[-1]
    u = tip - dense_xy[max(len(dense_xy) - 1 - direction_px, 0)]
    if not np.hypot(*u) > 0:
        return None
    u = u / np.hypot(*u)
    n = np.array([-u[1], u[0]])
    half = int(np.ceil(corridor * radius_px))
    t = np.arange(0, int(np.ceil(reach_px)) + 1, dtype=float)
    s = np.arange(-half, half + 1, dtype=float)
    pts = tip + t[:, None, None] * u + s[None, :, None] * n  # (len t, len s, 2)
    rc = np.rint(pts - off).astype(int)
    inside_roi = (rc[..., 0] >= 0) & (rc[..., 0] < w) & (rc[..., 1] >= 0) & (rc[..., 1] < h)
    r = np.clip(rc[..., 1], 0, h - 1)
    c = np.clip(rc[..., 0], 0, w - 1)
    wide = inside_roi & (inside_px[r, c] > wide_ratio * radius_px)
    hit = np.flatnonzero(wide.any(axis=1))
    return float(t[hit[0]]) if hit.size else None


def tip_object_message(figures: dict, n_views: int, limit_px: float) -> str | None:
    """The check's message when the tip stops within ``limit_px`` of an object in two views or more, else None.

    Parameters
    ----------
    figures : dict
        ``tip_object_px_v<i>`` per view (1-based; None: no object within reach).
    n_views : int
    limit_px : float
        ``verification.min_tip_object_px``.
    """
    near = failing_views(figures, "tip_object_px", n_views, lambda x: x <= limit_px, min_views=2)
    if not near:  # in one view the tip may lie in front of an object
        return None
    return ("tip: the curve stops at an object the tendril may cross (the stem, a shoot, a leaf: where the tendril "
            "ends cannot be seen) in " + ", ".join(f"view {v} ({x:.0f} px ahead)" for v, x in near)
            + f" (limit {limit_px:g} px)")
