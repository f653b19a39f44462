"""Lines the darkness rule cannot see (steps 4c-4d of :func:`tendrilkit.segmentation.segment_view`).

They work on the ROI's foreground as steps 2-4b leave it (the thresholded
and faint pixels):

* :func:`light_line_pixels`: a thin line *lighter* than the dark object it
  crosses and darker than the board: a pale tendril in front of a leaf or a
  shoot cuts a light gap through the object's dark pixels, and its own pixels
  there are lighter than the threshold (they belong to neither);
  :func:`lines_in_front` adds them in front of the object (a one-pixel rim of
  the object cleared around them: the line stays a line);
* :func:`bridge_line_gaps`: a line that stops and goes on straight a few
  pixels further (where it crosses another line, each loses its pixels near
  the other: the faint-pixel rule keeps its distance from darker pixels)
  is joined across the gap, at its own width, so that the skeleton, the
  ordering and the multi-view method see one continuous line.

Light lines are on by default since 2026-12-01 (``segmentation.line_width_px``
11, with ``local_exclude_dark``; README, Options, has the figures), the joins off
(``bridge_gap_px`` 0). The figures below are those of the first measurement:
Measured 2026-11-30 by ground truth on the 20 pale dev scenes of seeds 0-39
(6 frames each, ``benchmarks/bench_generalize``'s scoring), frames right on
all three criteria / within 0.5 mm mean / failed / reported ok but wrong,
silent failures 0 throughout: chain 5.8 / 71.7 / 5.0 % / 9 -> 6.7 / 72.5 /
7.5 % / 7 with light lines, 5.8 / 42.5 / 23.3 % / 6 with joins (the joins make
crossings the walk cannot take); multi-view 17.5 / 68.3 / 0 % / 15 -> 17.5 /
60.8 / 0 % / 8 with light lines, 19.2 / 61.7 / 0 % / 17 with joins, 19.2 /
55.8 / 0 % / 9 with both. On the 20 other dev scenes light lines change the
chain by one frame and cost the multi-view one silent frame (seed 2, 6 px
added in one view); on the 13 untouched pale scenes of 9100-9139: chain 2.6 /
93.6 / 0 % / 15 -> 5.1 / 73.1 / 6.4 % / 1, multi-view 12.8 / 62.8 / 0 % / 12
(2 silent) -> 15.4 / 42.3 / 0 % / 3 (0 silent). The evidence is better (the
centre line found 0.79 -> 0.91 on pale scenes, ``benchmarks/bench_evidence.py
lines``); the methods do not yet use it better: more of the tendril is seen,
so fewer wrong frames pass as ok, but a curve that follows it over a leaf is
less often within 0.5 mm.
"""

from __future__ import annotations

import cv2
import numpy as np

from tendrilkit.segmentation.faint import reduce_grey
from tendrilkit.segmentation.kernels import binary_morphology

__all__ = ["light_line_pixels", "vein_pixels", "lines_in_front", "bridge_line_gaps", "board_level"]


def board_level(grey: np.ndarray, *, window_px: int = 124, reduced: np.ndarray | None = None) -> np.ndarray:
    """The board's grey level at every pixel: the upper envelope of the image over a wide window.

    The board is the brightest thing around a tendril; its level (vignetting,
    uneven light) varies over hundreds of pixels. On the 4x area-reduced image
    (median of 3 x 3 against noise) the largest value over a square of
    ``window_px`` (reduced), smoothed by a box of the same size, interpolated
    back. A window wider than a leaf keeps the board's level over the leaf.

    Parameters
    ----------
    grey : (h, w) uint8 array
        Or (h, w, 3): the level of each channel at once (the same pixels as each channel's own, in one pass
        of each step).
    window_px : int
        Side of the square window, full-resolution pixels.
    reduced : (h // 4, w // 4) uint8 array, optional
        The 4x area-reduced image when already made
        (:func:`tendrilkit.segmentation.faint.reduce_grey`).

    Returns
    -------
    (h, w) uint8 array
        1-255 (``grey``'s shape).
    """
    h, w = grey.shape[:2]
    small = reduce_grey(grey) if reduced is None else reduced
    if small.shape[:2] != (max(h // 4, 1), max(w // 4, 1)) or small.ndim != grey.ndim:
        raise ValueError(f"reduced must have the shape {(max(h // 4, 1), max(w // 4, 1))} (grey's 4x reduction), "
                         f"got {small.shape}")
    if min(small.shape[:2]) >= 3:
        small = cv2.medianBlur(small, 3)
    k = max(3, (int(window_px) // 4) | 1)
    env = cv2.blur(cv2.dilate(small, cv2.getStructuringElement(cv2.MORPH_RECT, (k, k))), (k, k))
    level = cv2.resize(env, (w, h), interpolation=cv2.INTER_LINEAR)
    # floored at 1 on a one-channel view of the level (h, w * c): a Python number is a scalar (1, 0, 0, 0) to
    # OpenCV, the first channel's only, and np.maximum with a uint8 scalar is 10 times slower (0.5 ms on a 1080p
    # view's ROI crop of three channels)
    flat = level.reshape(h, -1)
    if flat.size > 1:
        cv2.max(flat, 1, dst=flat)
    else:  # OpenCV takes a 1 x 1 array for a scalar
        np.maximum(flat, np.uint8(1), out=flat)
    return level


def light_line_pixels(grey: np.ndarray, foreground: np.ndarray, *, width_px: int = 11, contrast: float = 0.1,
                      min_width_px: int = 3, reduced: np.ndarray | None = None) -> np.ndarray:
    r"""Pixels of thin lines lighter than the dark pixels on both sides of them, and darker than the board.

    A pale tendril in front of a leaf (or a shoot, the stem) is lighter than
    the leaf, so the threshold leaves a light gap in the leaf's dark pixels,
    while a darkness rule (:func:`tendrilkit.segmentation.faint_pixels`)
    cannot see it. Its pixels are:

    1. in a gap of the foreground narrower than ``width_px``: the pixels a
       morphological closing by a disk of diameter ``width_px`` adds (dark on
       both sides across the line: an object's *edge* has dark on one side
       only, and is never in such a gap);
    2. darker than the board (:func:`board_level`, :math:`b`) by the relative
       ``contrast``: :math:`g < (1 - c)\,b` (a gap through which the board
       shows, between two objects, is at the board's level);
    3. in a gap at least ``min_width_px`` wide (an opening by a square of
       that side): a leaf's vein, one or two pixels wide, and the rims of
       anti-aliased edges are left out;
    4. in a (8-connected) piece of such gap that runs *through a wide object*
       somewhere: one with pixels the closing of the wide objects (what an
       opening by the same disk keeps of the foreground: a leaf, the stem)
       adds. The piece keeps its stretches beside the object (where the line
       enters the leaf from the board); the wedge between the stem and a thin
       line leaving it, or between two thin lines, is left out.

    Parameters
    ----------
    grey : (h, w) uint8 array
        The grey image in which the tendril is dark
        (:func:`tendrilkit.segmentation.grey_image`).
    foreground : (h, w) uint8 array
        Nonzero on the pixels already found dark (threshold and faint pixels).
    width_px : int
        The widest light line found, px (about the tendril's width plus the
        blur on both sides; odd).
    contrast : float
        Least relative darkness against the board, 0-1.
    min_width_px : int
        The narrowest light line found, px (1: no limit).
    reduced : (h // 4, w // 4) uint8 array, optional
        ``grey``'s 4x area reduction when already made (:func:`board_level`).

    Returns
    -------
    (h, w) uint8 array
        255 on the light lines' pixels (none of ``foreground``), 0 elsewhere.

    Notes
    -----
    About 1.5 ms on a 1080p phantom view's region of interest where no gap
    runs through a wide object, 3-5 ms where one does (one core; the
    closings and the opening by the disk, the envelope, the labels):
    :func:`tendrilkit.segmentation.label_foreground` 4.2 -> 9.0 ms CPU per
    view on pale random scenes, 3.3 -> 5.9 ms on the others, at a load of 20
    (``benchmarks/bench_evidence.py lines``).

    Example
    -------
    >>> g = np.full((60, 80), 220, np.uint8)
    >>> g[10:50, 20:60] = 60                 # a dark leaf
    >>> g[28:33, :] = 170                    # a pale line across it, 5 px wide
    >>> fg = np.where(g < 120, 255, 0).astype(np.uint8)
    >>> out = light_line_pixels(g, fg)
    >>> int(out[30, 40] > 0), int(out[30, 5] > 0), int(out[20, 40] > 0)
    (1, 0, 0)
    """
    if grey.shape != foreground.shape:
        raise ValueError(f"foreground must have the shape of grey {grey.shape}, got {foreground.shape}")
    if width_px < 3:
        raise ValueError(f"width_px must be >= 3, got {width_px}")
    if not 0 <= contrast < 1:
        raise ValueError(f"contrast must be in [0, 1), got {contrast}")
    if min_width_px < 1:
        raise ValueError(f"min_width_px must be >= 1, got {min_width_px}")
    fg = cv2.compare(foreground, 0, cv2.CMP_GT)
    x, y, w, h = cv2.boundingRect(fg)
    out = np.zeros(grey.shape, np.uint8)
    if w == 0:
        return out
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (int(width_px) | 1,) * 2)
    free = cv2.compare(fg, 0, cv2.CMP_EQ)
    wide = _on_box(fg, cv2.MORPH_OPEN, disk)  # leaves, the stem: what a line can cross in front of
    through = cv2.bitwise_and(_on_box(wide, cv2.MORPH_CLOSE, disk), free)
    if not through.any():  # no gap through a wide object: no line in front of one (most views; exact)
        return out
    gap = cv2.bitwise_and(_on_box(fg, cv2.MORPH_CLOSE, disk), free)
    b = board_level(grey, reduced=reduced)
    # g < (1 - c) b for an integer g  <=>  g < ceil((1 - c) b): one table over the board's 256 levels
    limit = np.ceil((1.0 - float(contrast)) * np.arange(256)).astype(np.uint8)
    darker = cv2.compare(grey, cv2.LUT(b, limit), cv2.CMP_LT)
    gap = cv2.bitwise_and(gap, darker)
    if min_width_px > 1:
        gap = cv2.morphologyEx(gap, cv2.MORPH_OPEN, np.ones((int(min_width_px),) * 2, np.uint8))
    through = cv2.bitwise_and(through, gap)
    if not through.any():
        return out
    # the gap's pieces labelled on the gap's box (every piece lies in it whole: the same pieces)
    x, y, w, h = cv2.boundingRect(gap)
    n, lab = cv2.connectedComponents(np.ascontiguousarray(gap[y:y + h, x:x + w]), connectivity=8)
    keep = np.zeros(n, bool)
    keep[np.unique(lab[through[y:y + h, x:x + w] > 0])] = True
    keep[0] = False
    out[y:y + h, x:x + w][keep[lab]] = 255
    return out


#: A light line's pixels lie along an object's own vein (:func:`vein_pixels`) where the object's depth (distance to
#: its edge, the line counted as the object's), smoothed over ``VEIN_SIGMA_PX``, changes by less than this per pixel.
VEIN_SLOPE = 0.5
VEIN_SIGMA_PX = 2.0
#: The ray along a vein's axis looks for the object's end this many times the depth at the flat stretch's end (plus
#: two line widths) beyond it: the stretch ends where the line stops being seen, and a leaf is longer than it is
#: wide (its end along the axis lies farther than its edge across).
RAY_DEPTHS = 4.0
#: ... and finds it where the ray reaches the board (or the image's edge) after at most this many half widths of a
#: line thinner than the object (its rim: long at a pointed tip); a longer thin run is a line going on beyond it.
THIN_RUN = 3.0


def vein_pixels(lines: np.ndarray, foreground: np.ndarray, *, width_px: int = 11) -> np.ndarray:
    """The light lines' pixels that are a wide object's own vein (a leaf's midrib), not a line in front of it.

    A leaf's midrib is lighter than the leaf on both sides and darker than
    the board: :func:`light_line_pixels` finds it as it finds a pale tendril
    in front of the leaf, and the skeleton then holds a thin line along the
    leaf that every view sees where the leaf is (a 3D line the multi-view
    method follows off the tendril). A vein runs along the middle of its
    object: with the line counted as the object's, the object's depth (the
    distance to its edge) is at its ridge there and hardly changes along the
    line or across it. A line in front of the object crosses it, or runs
    beside its middle: the depth changes by about a pixel per pixel along
    or across it. Pixels of ``lines`` at least ``width_px`` deep where the
    depth (smoothed over :data:`VEIN_SIGMA_PX`) changes by less than
    :data:`VEIN_SLOPE` per pixel, in a stretch of at least three times
    ``width_px`` along the line, mark a vein's middle; the line's pixels
    within half ``width_px`` (and a pixel) of that stretch's axis, from
    before its first pixel to beyond its last as far as the ray below
    (where the object's ends draw near, the depth falls off and the vein
    goes on to them; the light lines lie inside the object), are returned (where a tendril crosses a vein, a few pixels of it
    go with the vein: a covered gap the other views bridge). A vein ends in
    its object at one end at least (the leaf's tip, or where the ROI cuts the
    leaf; the other end may go on as the petiole): a line along the middle
    whose axis, followed past both ends of the flat stretch for
    :data:`RAY_DEPTHS` times the depth there and two widths more, reaches
    the board from the object at neither end (:func:`_ends_free`: it runs on
    as a thin line, or meets another object) goes through the object and on
    beyond it, a tendril lying along a leaf's middle, and is kept.

    Parameters
    ----------
    lines : (h, w) uint8 array
        Nonzero on the light lines' pixels (:func:`light_line_pixels`).
    foreground : (h, w) uint8 array
        Nonzero on the dark pixels (the objects the lines are in).
    width_px : int
        The light lines' widest width, px (``segmentation.line_width_px``).

    Returns
    -------
    (h, w) uint8 array
        255 on the veins' pixels (a subset of ``lines``), 0 elsewhere.

    Example
    -------
    >>> fg = np.zeros((120, 200), np.uint8)
    >>> _ = cv2.ellipse(fg, (100, 60), (90, 40), 0, 0, 360, 255, -1)   # a leaf
    >>> vein = np.zeros_like(fg); vein[58:63, 30:170] = 255; fg[vein > 0] = 0   # its midrib, lighter
    >>> cross = np.zeros_like(fg); cross[25:95, 58:63] = 255; fg[cross > 0] = 0  # a pale line across it
    >>> out = vein_pixels(cv2.bitwise_or(vein, cross), fg)
    >>> int(out[60, 120] > 0), int(out[35, 60] > 0), int(out[85, 60] > 0)
    (1, 0, 0)
    """
    ln = cv2.compare(lines, 0, cv2.CMP_GT)
    out = np.zeros(ln.shape, np.uint8)
    x, y, w, h = cv2.boundingRect(ln)
    if w == 0:
        return out
    # a vein's flat stretch lies in one piece of the lines three widths long or more: none, no vein (most views;
    # exact, and the depth over the whole image is not taken)
    _, _, st, _ = cv2.connectedComponentsWithStats(ln[y:y + h, x:x + w], connectivity=8)
    if not (np.maximum(st[1:, cv2.CC_STAT_WIDTH], st[1:, cv2.CC_STAT_HEIGHT]) >= 3 * int(width_px)).any():
        return out
    H, W = ln.shape
    m = 4 * int(width_px)  # the ridge is read within this margin of the line
    r0, r1, c0, c1 = max(y - m, 0), min(y + h + m, H), max(x - m, 0), min(x + w + m, W)
    obj = cv2.bitwise_or(cv2.compare(foreground, 0, cv2.CMP_GT), ln)
    # a slit the darkness rule left between the line and the object (its lightest core, a pixel or two) is the
    # object's: closed, or the depth would read the slit as the object's edge
    obj = cv2.morphologyEx(obj, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5)))
    if obj.all():  # no edge: nothing to measure the depth from
        return out
    # on the whole image (the ray below goes on to the object's end); OpenCV reads beyond the image as the object
    depth = cv2.distanceTransform(obj, cv2.DIST_L2, 5)
    smooth = cv2.GaussianBlur(depth[r0:r1, c0:c1], (0, 0), VEIN_SIGMA_PX)
    gx = cv2.Sobel(smooth, cv2.CV_32F, 1, 0, ksize=3, scale=0.125)
    gy = cv2.Sobel(smooth, cv2.CV_32F, 0, 1, ksize=3, scale=0.125)
    flat = (gx * gx + gy * gy < VEIN_SLOPE ** 2) & (depth[r0:r1, c0:c1] >= width_px) & (ln[r0:r1, c0:c1] > 0)
    if not flat.any():
        return out
    n, lab, stats, _ = cv2.connectedComponentsWithStats(flat.astype(np.uint8), connectivity=8)
    long_ = np.zeros(n, bool)
    long_[1:] = np.maximum(stats[1:, cv2.CC_STAT_WIDTH], stats[1:, cv2.CC_STAT_HEIGHT]) >= 3 * int(width_px)
    if not long_[1:].any():
        return out
    # the vein: the line's pixels near the ridge's axis, which goes on past the flat stretch (where the object's
    # ends draw near and the depth falls) as far as the ray that finds the object's end
    lr, lc = np.nonzero(ln[r0:r1, c0:c1])
    pts = np.column_stack([lc, lr]).astype(np.float64)
    vein = np.zeros(len(pts), bool)
    half = int(width_px) / 2.0 + 1.0
    fr, fc = np.nonzero(flat)
    at = lab[fr, fc]
    for k in np.flatnonzero(long_):
        rr, cc = fr[at == k], fc[at == k]
        q = np.column_stack([cc, rr]).astype(np.float64)
        c = q.mean(axis=0)
        u = np.linalg.svd(q - c, full_matrices=False)[2][0]  # the ridge's direction
        t = (q - c) @ u
        ends = (t <= t.min() + 2.0) | (t >= t.max() - 2.0)
        reach = float(depth[r0 + rr[ends], c0 + cc[ends]].max()) + half
        ray = RAY_DEPTHS * reach + 2 * width_px
        full = c + np.array([c0, r0], float)  # the axis's point on the whole image
        if not (_ends_free(depth, full, u, t.min(), -1.0, ray, half)
                or _ends_free(depth, full, u, t.max(), 1.0, ray, half)):
            continue  # a line through the object along its middle, going on at both ends: in front of it
        tp = (pts - c) @ u
        across = np.abs((pts - c) @ np.array([-u[1], u[0]]))
        vein |= (tp >= t.min() - ray) & (tp <= t.max() + ray) & (across <= half)
    out[r0 + lr[vein], c0 + lc[vein]] = 255
    return out


def _ends_free(depth: np.ndarray, c: np.ndarray, u: np.ndarray, t_end: float, sign: float, length: float,
               half: float) -> bool:
    """Whether the ray from the point ``c + t_end u`` (x, y) on, along ``sign u``, leaves its object straight onto
    the board within ``length`` px: the line ends in its object (a vein at its leaf's tip), rather than going on
    beyond it as a thin line (a tendril across the leaf, a leaf's petiole). ``depth``: the object's distance to the
    board per pixel; under ``half`` (a line's half width and a pixel) the ray is on something thin: the object's
    rim (long at a pointed leaf's tip) or a line going on. The board must come within ``THIN_RUN`` times ``half``
    of thin pixels. A ray leaving the image (the ROI) from the object or its rim: free too (an object the ROI cuts:
    a line along its middle is its vein, not a tendril, which would run thin beyond the object first). A ray
    entering another wide object after the rim: not free (unknown)."""
    h, w = depth.shape
    thin = 0
    for s in np.arange(1.0, length + 1.0):
        x, y = c + (t_end + sign * s) * u
        col, row = int(round(x)), int(round(y))
        if not (0 <= row < h and 0 <= col < w):
            return True
        d = depth[row, col]
        if d == 0:
            return True
        if d < half:
            thin += 1
            if thin > THIN_RUN * half:
                return False  # a thin line goes on from the object
        elif thin:
            return False  # into another object
    return False


def _on_box(mask: np.ndarray, op: int, kernel: np.ndarray) -> np.ndarray:
    """``cv2.morphologyEx(mask, op, kernel)`` for ``op`` ``cv2.MORPH_OPEN`` or ``cv2.MORPH_CLOSE`` (uint8, a
    centred kernel of odd sides, half side ``r``) on the box of ``mask``'s nonzero pixels grown by ``2 r``, zero
    elsewhere: the same image, bit for bit.

    Both passes read at most ``r`` from a pixel. Opening: a pixel whose erosion would read beyond the grown box
    lies outside the mask's box, itself 0, and the erosion is 0 outside that box (beyond which the dilation
    reads nothing). Closing: the dilation reaches at most ``r`` beyond the mask's box; a pixel whose erosion
    would read beyond the grown box lies more than ``r`` from the mask's box, 0 in the dilation and with it.
    Outside the grown box both are 0. A leaf's or the stem's opening (the light lines' wide objects) spans
    about half a view's region of interest. On the box, the binary image's rows are packed 64 pixels to a word
    (:func:`tendrilkit.segmentation.kernels.binary_morphology`: OpenCV's pixels for a 0 / 255 mask, about 3
    times faster for the disk of 11 px).
    """
    x, y, w, h = cv2.boundingRect(mask)
    out = np.zeros_like(mask)
    if w == 0:
        return out
    m = 2 * max(kernel.shape[0] // 2, kernel.shape[1] // 2)
    H, W = mask.shape
    r0, r1, c0, c1 = max(y - m, 0), min(y + h + m, H), max(x - m, 0), min(x + w + m, W)
    out[r0:r1, c0:c1] = binary_morphology(np.ascontiguousarray(mask[r0:r1, c0:c1]), op, kernel)
    return out


def lines_in_front(foreground: np.ndarray, lines: np.ndarray, behind: np.ndarray) -> np.ndarray:
    """The foreground with light lines in front of the darker objects they cross: one line, not one blob.

    A pale tendril lighter than the leaf it crosses lies in front of it. Its
    pixels (``lines``, :func:`light_line_pixels`) are added, and the darker
    objects' pixels (``behind``: the thresholded ones) that touch them are
    cleared: a one-pixel rim between the line and the object behind it. The
    line is then a thin line of its own across the leaf (its skeleton, its
    component, its width), as it is seen, instead of a part of the leaf's
    blob; the leaf keeps its other pixels, and the line's faint pixels beyond
    the object (not thresholded) stay joined to it.

    Parameters
    ----------
    foreground : (h, w) uint8 array
        Nonzero on the pixels found dark (threshold and faint pixels).
    lines : (h, w) uint8 array
        Nonzero on the light lines' pixels (none of ``foreground``).
    behind : (h, w) uint8 array
        Nonzero on the darker objects' pixels (the threshold's).

    Returns
    -------
    (h, w) uint8 array
        255 on the new foreground, 0 elsewhere.

    Example
    -------
    >>> fg = np.zeros((40, 60), np.uint8); fg[5:35, 10:50] = 255; fg[18:23, :] = 0
    >>> ln = np.zeros_like(fg); ln[18:23, 10:50] = 255
    >>> out = lines_in_front(fg, ln, fg)
    >>> int(out[20, 30] > 0), int(out[17, 30] > 0), int(out[23, 30] > 0), int(out[16, 30] > 0)
    (1, 0, 0, 1)
    """
    fg = cv2.compare(foreground, 0, cv2.CMP_GT)
    ln = cv2.compare(lines, 0, cv2.CMP_GT)
    if not ln.any():
        return fg
    rim = cv2.bitwise_and(cv2.dilate(ln, np.ones((3, 3), np.uint8)), cv2.compare(behind, 0, cv2.CMP_GT))
    out = cv2.bitwise_or(fg, ln)
    out[(rim > 0) & (ln == 0)] = 0
    return out


#: Regions wider than this (px) are not lines (:func:`bridge_line_gaps` leaves them out of its skeleton).
WIDE_PX = 12


def bridge_line_gaps(foreground: np.ndarray, *, gap_px: int = 30, back_px: int = 12,
                     max_angle_deg: float = 30.0) -> np.ndarray:
    """The foreground with line ends that face each other across a short gap joined.

    Where two lines cross, the one behind (or a pale one, whose faint pixels
    keep their distance from darker ones) loses its pixels over and beside the
    other; the line goes on straight on the far side. Here:

    1. the skeleton (:func:`tendrilkit.skeleton.thinning.thin_strips`) of
       the foreground without its wide regions (farther than
       :data:`WIDE_PX` / 2 from the board, grown by a pixel: leaves, markers)
       and its end pixels (one skeleton neighbour) on branches of at least
       ``back_px`` pixels;
    2. each end's outward direction: the principal axis of its own line's
       skeleton pixels within ``back_px`` of it (noise leaves spurs on a
       thinned line, and thinning bends its last pixels: a walk along the
       skeleton would stop or turn there);
    3. two ends are joined when they are at most ``gap_px`` apart and the
       segment between them deviates by at most ``max_angle_deg`` from both
       directions (the line continues straight through; two ends side by side,
       or a line's tip pointing at another line's side, are not joined);
       closest pairs first, each end once;
    4. the join: a straight segment between the two ends, as wide as the
       narrower of the two lines near its end (twice the distance
       from the skeleton to the board there less two pixels, cv2.line's rounding adds them, at least 1 px). Nothing is removed: the
       line crossed keeps its pixels.

    Parameters
    ----------
    foreground : (h, w) uint8 array
        Nonzero on foreground pixels.
    gap_px : int
        The longest join, px (between the two skeleton ends: the gap plus
        about the line's width).
    back_px : int
        Skeleton pixels over which an end's direction is taken.
    max_angle_deg : float
        Largest angle between the join and either end's direction, degrees.

    Returns
    -------
    (h, w) uint8 array
        255 on the foreground and the joins, 0 elsewhere (a new array).

    Notes
    -----
    About 4-6 ms on a 1080p phantom view's region of interest (one core, at
    a load of 20: ``benchmarks/bench_evidence.py lines``), most of it the
    thinning: over the 5 ms a view may add, so it is off by default.

    Example
    -------
    >>> fg = np.zeros((30, 80), np.uint8)
    >>> fg[14:17, 2:35] = 255; fg[14:17, 45:78] = 255   # a line broken for 10 px
    >>> fg[2:28, 38:42] = 255                           # by a line across it, not touching
    >>> out = bridge_line_gaps(fg)
    >>> int(out[15, 36] > 0), int(out[15, 43] > 0), int(out[5, 36] > 0)
    (1, 1, 0)
    """
    from tendrilkit.skeleton.thinning import thin_strips  # here: tendrilkit.skeleton imports the segmentation

    if gap_px < 1:
        raise ValueError(f"gap_px must be >= 1, got {gap_px}")
    if back_px < 3:
        raise ValueError(f"back_px must be >= 3, got {back_px}")
    fg = cv2.compare(foreground, 0, cv2.CMP_GT)
    # the lines only: wide regions (leaves, markers: over WIDE_PX across) left out of the thinning, a third of its
    # cost; their rims stay (a ring has no ends)
    inside_all = cv2.distanceTransform(fg, cv2.DIST_L2, 3)
    lines = cv2.bitwise_and(fg, cv2.compare(cv2.dilate(cv2.compare(inside_all, 0.5 * WIDE_PX, cv2.CMP_GT),
                                                       np.ones((3, 3), np.uint8)), 0, cv2.CMP_EQ))
    x0, y0, w, h = cv2.boundingRect(lines)
    if w == 0:
        return fg
    sub = lines[y0:y0 + h, x0:x0 + w]
    skel = thin_strips(sub > 0).view(np.uint8)
    count = cv2.filter2D(skel, cv2.CV_8U, np.ones((3, 3), np.float32), borderType=cv2.BORDER_CONSTANT)
    ends = np.argwhere((skel > 0) & (count == 2))
    if len(ends) < 2:
        return fg
    inside = cv2.distanceTransform(sub, cv2.DIST_L2, 5)
    _, lab = cv2.connectedComponents(skel, connectivity=8)
    sk_rc = np.argwhere(skel > 0)
    sk_lab = lab[sk_rc[:, 0], sk_rc[:, 1]]
    pos, dirs, widths = [], [], []
    for r, c in ends:
        # the skeleton of the end's own line within back_px of it: its principal axis, pointing out at the end
        # (robust to the spurs noise leaves on a thinned line and to the bend thinning gives its last pixels)
        near = sk_rc[(sk_lab == lab[r, c]) & (np.abs(sk_rc[:, 0] - r) <= back_px) & (np.abs(sk_rc[:, 1] - c) <= back_px)]
        near = near[np.hypot(near[:, 0] - r, near[:, 1] - c) <= back_px]
        if len(near) < back_px // 2 + 1:  # a speck, not a line
            continue
        centre = near.mean(axis=0)
        _, _, vt = np.linalg.svd(near - centre, full_matrices=False)
        axis = vt[0] if np.dot(vt[0], (r - centre[0], c - centre[1])) >= 0 else -vt[0]
        pos.append((float(c), float(r)))
        dirs.append((float(axis[1]), float(axis[0])))
        mid = near[np.argmin(np.hypot(near[:, 0] - centre[0], near[:, 1] - centre[1]))]
        widths.append(2.0 * float(inside[mid[0], mid[1]]) - 2.0)  # the line's width back from its end
    if len(pos) < 2:
        return fg
    P, D = np.array(pos), np.array(dirs)
    diff = P[None, :, :] - P[:, None, :]  # [i, j] = P[j] - P[i]
    dist = np.hypot(diff[..., 0], diff[..., 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        u = diff / dist[..., None]
    cos_min = np.cos(np.radians(max_angle_deg))
    out_i = np.einsum("ijk,ik->ij", u, D)   # end i's direction along the join to j
    in_j = -np.einsum("ijk,jk->ij", u, D)   # end j's direction along the join back to i
    ok = (dist <= gap_px) & (dist > 0) & (out_i >= cos_min) & (in_j >= cos_min)
    ii, jj = np.nonzero(np.triu(ok, 1))
    if len(ii) == 0:
        return fg
    used = np.zeros(len(P), bool)
    out = fg.copy()
    for k in np.argsort(dist[ii, jj], kind="stable"):
        i, j = int(ii[k]), int(jj[k])
        if used[i] or used[j]:
            continue
        used[i] = used[j] = True
        width = max(1, int(round(min(widths[i], widths[j]))))
        a = (int(P[i, 0]) + x0, int(P[i, 1]) + y0)
        b = (int(P[j, 0]) + x0, int(P[j, 1]) + y0)
        cv2.line(out, a, b, 255, width, cv2.LINE_8)
    return out
