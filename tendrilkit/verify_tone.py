"""The checks' reading of the image's tone and colour, not of its dark pixels: a tendril going on unsegmented, a curve onto another organ.

Every other check reads the dark pixels (:mod:`tendrilkit.evidence`). Two
ways a curve can be wrong leave them agreeing with it:

* **Tone ahead of the tip** (``tip_tone_frac_v<i>``, :func:`tip_tone_frac`).
  A pale tendril whose dense coil is not segmented (the local background of
  the faint-pixel test is the coil itself) ends, in the dark pixels, where
  the coil starts; the curve stops there and explains every dark pixel.
  The image still shows the coil: as dark against the board as the tendril
  before it. The figure is the fraction of a corridor ahead of the projected
  tip (``reach_px`` along the tip's direction, ``corridor`` tendril half
  widths to either side, the curve's own footprint, :data:`FOOTPRINT`, left out) whose pixels
  are darker than the board near the tip by at least half the tendril's own
  darkness (the curve's proximal third against the board near it). The
  board is the 75th percentile of the grey of the pixels that are not dark
  within ``board_px`` (the raw grey, not a local median: a dense coil cannot
  hide itself). Dark pixels ahead count as well: the figure does not rest
  on the segmentation missing the tendril's rest.
* **Off-colour run** (``off_colour_run_px_v<i>``, :func:`off_colour_run_px`).
  A tendril is one organ of one colour; a leaf seen edge-on is as thin as
  the tendril and passes every width check, but it is another colour. The
  figure is the longest run (px) of the projected curve on pixels whose
  chromaticity ``(b, g, r) / (b + g + r)`` differs from that of the curve's
  proximal third by more than ``max_chroma`` (largest of the three
  differences).

Both count in two views or more (one view may see the tip in front of a
dark object, or the tendril in front of a leaf).
"""

from __future__ import annotations

import cv2
import numpy as np

from tendrilkit.evidence import ViewEvidence
from tendrilkit.segmentation import grey_image
from tendrilkit.verify_tip import failing_views, wide_run_px

__all__ = ["tip_tone_frac", "off_colour_run_px", "tip_tone_message", "off_colour_message", "BOARD_PX", "MAX_CHROMA"]

#: Half side of the square around a point whose pixels that are not dark give the board's grey there, px.
BOARD_PX = 80
#: The curve's footprint, left out of the corridor ahead of its tip: this many tendril half widths (and 2 px) to
#: either side of it. A thick tendril's rounded end and blurred edges reach beyond one half width and a pixel: the
#: S4 site phantom's right curves read up to 0.058 in their second-worst view with that footprint, 0.016 with this one.
FOOTPRINT = 1.5
#: A pixel's chromaticity differs from the tendril's when one of its three components does by more than this.
MAX_CHROMA = 0.06


def _grey_at(crop_bgr: np.ndarray, rc: np.ndarray, channel: str) -> np.ndarray:
    """(n,) float: the grey level (the segmentation's ``channel``) of the crop's pixels ``rc`` (n, 2) (row, col)."""
    return grey_image(np.ascontiguousarray(crop_bgr[rc[:, 0], rc[:, 1]][None]), channel=channel)[0].astype(float)


def _board_grey(crop_bgr: np.ndarray, fg: np.ndarray, rc: np.ndarray, channel: str, half: int = BOARD_PX) -> float:
    """75th percentile grey of the pixels that are not dark in the square of half side ``half`` around ``rc``."""
    h, w = fg.shape
    r, c = int(rc[0]), int(rc[1])
    r0, r1, c0, c1 = max(r - half, 0), min(r + half + 1, h), max(c - half, 0), min(c + half + 1, w)
    if r1 <= r0 or c1 <= c0:
        return float("nan")
    # every other row and column: the percentile of a board is as steady, at a quarter of the cost
    g = grey_image(np.ascontiguousarray(crop_bgr[r0:r1:2, c0:c1:2]), channel=channel)[~fg[r0:r1:2, c0:c1:2]]
    return float(np.percentile(g, 75)) if g.size else float("nan")


def _crop_rc(ev: ViewEvidence, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rounded crop ``(row, col)`` (n, 2) int of full-image points (n, 2), and which lie inside the crop."""
    h, w = ev.shape
    rc = np.rint(xy[:, ::-1] - ev.roi_offset_xy[::-1]).astype(int)
    inside = (rc[:, 0] >= 0) & (rc[:, 0] < h) & (rc[:, 1] >= 0) & (rc[:, 1] < w)
    return rc, inside


def tip_tone_frac(crop_bgr: np.ndarray, ev: ViewEvidence, dense_xy: np.ndarray, on: np.ndarray, radius_px: float, *,
                  channel: str = "blue", reach_px: float = 30.0, corridor: float = 3.0,
                  direction_px: int = 10) -> float | None:
    """Fraction of the corridor ahead of the projected tip as dark as the tendril (see the module).

    Parameters
    ----------
    crop_bgr : (h, w, 3) or (h, w) uint8 array
        The view's image, ROI crop (BGR, or grey).
    ev : ViewEvidence
        The view's evidence (its dark pixels and crop).
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, base to tip, full-image px.
    on : (n,) bool array
        Which samples of ``dense_xy`` lie on the tendril's dark pixels (and are seen).
    radius_px : float
        The tendril's half width in this view, px (NaN: unknown; None is returned).
    reach_px : float
        Length of the corridor ahead of the tip, px.
    corridor : float
        Half width of the corridor, in tendril half widths.
    channel : str
        The segmentation's grey channel (``segmentation.channel``).
    direction_px : int
        The tip's direction is that of the curve's last this many px.

    Returns
    -------
    float or None
        Fraction in [0, 1]; None where it cannot be read (no direction, no
        proximal sample on the tendril, no board, the tendril not darker
        than the board, no corridor pixel in the ROI).
    """
    n = len(dense_xy)
    if n < 3 or not (np.isfinite(radius_px) and radius_px > 0):
        return None
    fg = ev.foreground
    tip = dense_xy[-1]
    u = tip - dense_xy[max(n - 1 - direction_px, 0)]
    if not np.hypot(*u) > 0:
        return None
    u = u / np.hypot(*u)
    # the tendril's own darkness: its proximal third against the board near its middle
    prox = np.zeros(n, bool)
    prox[: max(n // 3, 1)] = True
    rc, inside = _crop_rc(ev, dense_xy)
    sel = prox & on & inside
    if not sel.any():
        return None
    rcp = rc[sel]
    board_p = _board_grey(crop_bgr, fg, rcp[len(rcp) // 2], channel)
    tip_rc, _ = _crop_rc(ev, tip[None])
    board_t = _board_grey(crop_bgr, fg, np.clip(tip_rc[0], 0, np.array(fg.shape) - 1), channel)
    if not (np.isfinite(board_p) and np.isfinite(board_t) and board_p > 0 and board_t > 0):
        return None
    own = float(np.median((board_p - _grey_at(crop_bgr, rcp, channel)) / board_p))
    if not own > 0:
        return None
    # the corridor's pixels, the curve's footprint (its half width and a pixel of blur) left out
    half = int(np.ceil(corridor * radius_px))
    t = np.arange(1, int(np.ceil(reach_px)) + 1, dtype=float)
    s = np.arange(-half, half + 1, dtype=float)
    nrm = np.array([-u[1], u[0]])
    pts = (tip + t[:, None, None] * u + s[None, :, None] * nrm).reshape(-1, 2)
    crc, cin = _crop_rc(ev, pts)
    h, w = fg.shape
    lin = np.unique(crc[cin, 0] * w + crc[cin, 1])
    crc = np.column_stack([lin // w, lin % w])
    if not len(crc):
        return None
    # the footprint: the curve drawn 1.5 half widths and 2 px to either side (its blurred edges, and the
    # rounded end of a thick tendril beyond the centreline's last point), on the corridor's box
    r0, c0 = crc.min(axis=0)
    r1, c1 = crc.max(axis=0) + 1
    foot = np.zeros((r1 - r0, c1 - c0), np.uint8)
    line = np.rint((dense_xy - ev.roi_offset_xy - [c0, r0]) * 4).astype(np.int32)
    cv2.polylines(foot, [line], False, 1, 2 * int(np.ceil(FOOTPRINT * radius_px + 2.0)) + 1, cv2.LINE_8, 2)
    crc = crc[foot[crc[:, 0] - r0, crc[:, 1] - c0] == 0]
    if ev.keep_out is not None:
        crc = crc[~ev.in_keep_out(crc[:, ::-1] + ev.roi_offset_xy)]
    if not len(crc):
        return None
    dark = (board_t - _grey_at(crop_bgr, crc, channel)) / board_t
    return float(np.mean(dark >= 0.5 * own))


def off_colour_run_px(crop_bgr: np.ndarray, ev: ViewEvidence, dense_xy: np.ndarray, seen: np.ndarray, on: np.ndarray,
                      *, max_chroma: float = MAX_CHROMA) -> float | None:
    """Longest run of the projected curve on pixels of another colour than its proximal third, px (see the module).

    Parameters
    ----------
    crop_bgr : (h, w, 3) uint8 array
        The view's colour image, ROI crop.
    ev : ViewEvidence
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, base to tip, full-image px.
    seen, on : (n,) bool arrays
        Which samples the view sees (in the ROI, out of the keep-out box), and
        which of those lie on the dark pixels.
    max_chroma : float
        A sample is off-colour where a component of its chromaticity differs
        from the reference's by more than this.

    Returns
    -------
    float or None
        px (samples are 1 px apart; unseen samples end a run); None without
        colour or without a proximal sample on the tendril.
    """
    if crop_bgr is None or crop_bgr.ndim != 3 or len(dense_xy) < 3:
        return None
    n = len(dense_xy)
    rc, inside = _crop_rc(ev, dense_xy)
    use = seen & inside
    prox = np.zeros(n, bool)
    prox[: max(n // 3, 1)] = True
    ref_sel = prox & on & use
    if not ref_sel.any():
        return None
    rcu = rc.copy()
    rcu[~inside] = 0
    chroma = _chroma(crop_bgr[rcu[:, 0], rcu[:, 1]])
    ref = np.median(chroma[ref_sel], axis=0)
    off = np.abs(chroma - ref).max(axis=1) > max_chroma
    return wide_run_px(off, use)  # the longest run of seen samples off-colour


def _chroma(bgr: np.ndarray) -> np.ndarray:
    """(n, 3) chromaticity ``(b, g, r) / (b + g + r)`` of (n, 3) BGR pixels (+ 1 each: black has a colour too)."""
    bgr = bgr.astype(float) + 1.0
    return bgr / bgr.sum(axis=1, keepdims=True)


def tip_tone_message(figures: dict, n_views: int, limit: float) -> str | None:
    """The message when the image ahead of the tip is as dark as the tendril in two views or more, else None."""
    hits = failing_views(figures, "tip_tone_frac", n_views, lambda x: x > limit, min_views=2)
    if not hits:
        return None
    return ("tip: the image ahead of the curve's tip is as dark as the tendril (the tendril may go on, unsegmented) "
            "in " + ", ".join(f"view {v} ({100 * x:.0f} % of the corridor)" for v, x in hits)
            + f" (limit {100 * limit:.0f} %)")


def off_colour_message(figures: dict, n_views: int, limit_px: float) -> str | None:
    """The message when the curve runs on another colour than the tendril's in two views or more, else None."""
    hits = failing_views(figures, "off_colour_run_px", n_views, lambda x: x > limit_px, min_views=2)
    if not hits:
        return None
    return ("colour: the curve runs on pixels of another colour than the tendril's (a leaf, a shoot) in "
            + ", ".join(f"view {v} ({x:.0f} px in a row)" for v, x in hits) + f" (limit {limit_px:g} px)")
