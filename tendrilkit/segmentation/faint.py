"""Faint pixels: darker than their local background by a relative contrast (step 4b of
:func:`tendrilkit.segmentation.segment_view`)."""

from __future__ import annotations

import cv2
import numpy as np

from tendrilkit.segmentation.kernels import grow_fill

__all__ = ["faint_pixels", "drop_unanchored", "reduce_grey"]

_BAND_ROWS = 64  # rows per band of faint_pixels' float work


def faint_pixels(
    grey: np.ndarray,
    *,
    local_contrast: float = 0.1,
    local_noise_k: float = 5.0,
    background_px: int = 36,
    local_window_px: int = 9,
    exclude: np.ndarray | None = None,
    at: np.ndarray | None = None,
    reduced: np.ndarray | None = None,
) -> np.ndarray:
    r"""Pixels darker than their local background by a relative contrast: thin, pale structures.

    A global threshold (Otsu's) on a region that holds a dark stem or leaf
    falls between those and the board, and a pale tendril (a blue level 0.75-0.9
    of the board's) is lost with the board; vignetting and uneven light move
    the board's own level across the region. Here the board's level is
    estimated locally and divided out:

    1. background :math:`b`: the median of the grey level over a window of
       ``background_px`` pixels (on the 4x area-reduced image, then
       interpolated back: a structure narrower than half the window, as the
       tendril is, does not move it);
    2. the relative darkness :math:`1 - g / b`; its noise :math:`\sigma`:
       1.4826 times the median absolute deviation of :math:`g / b` over the
       region (the board is most of it);
    3. faint pixels: :math:`d = 1 - g / b > \max(c, k \sigma, d_{max} / 2)`
       with ``c = local_contrast``, ``k = local_noise_k`` and :math:`d_{max}`
       the largest :math:`d` within ``local_window_px`` (a square): a
       structure's pixels down to half its own depth (its edge at half
       maximum). A pale tendril (:math:`d` 0.1-0.3) is found whole; a dark one
       (0.7-0.9) keeps about the width the global threshold gives it, and a
       soft shadow beside it stays out.

    With ``exclude`` (the pixels of other, darker objects: the thresholded
    leaf, stem or node and their rim), the board beside them is the
    reference: the background :math:`b` is the median of the board's pixels
    only (on the 4x reduced image, a reduced pixel is the mean of its board
    pixels; one less than half board is filled in with the brightest board
    pixel next to it, :func:`_fill_from_board`), and :math:`d_{max}` is taken over the window's
    board pixels only. A pale tendril running beside a leaf or the stem is
    then measured against the board next to it and its own depth, not the
    leaf's (without, the leaf pulls :math:`b` down by a third within half a
    window of it, and a tendril of :math:`d` 0.2 within ``local_window_px``
    of a leaf of :math:`d` 0.8 is dropped: exactly where it passes the leaf).

    Parameters
    ----------
    grey : (h, w) uint8 array
        The grey image in which the tendril is dark (:func:`grey_image`).
    local_contrast : float
        Least relative darkness, 0-1.
    local_noise_k : float
        Least relative darkness in units of the region's noise.
    background_px : int
        Window of the background's median, pixels (>= 4).
    local_window_px : int
        Side of the square over which a pixel's structure depth
        :math:`d_{max}` is taken, pixels (about a tube's width and a half).
    exclude : (h, w) uint8 array, optional
        Nonzero on pixels whose depth does not count in :math:`d_{max}`
        (their own depth counts as 0 there, so they are never faint pixels
        themselves unless darker than ``local_contrast``; the caller drops
        them, as :func:`foreground_roi` does).
    at : (h, w) uint8 array, optional
        Nonzero on the only pixels to decide (the others are 0 in the
        result): each of them gets the value it gets without ``at``, bit for
        bit (the depth is computed only in the bands of rows holding them, on
        the columns of the candidates within ``local_window_px // 2`` of
        them). :func:`drop_unanchored` reads the plain rule at the faint
        pixels only.
    reduced : (h // 4, w // 4) uint8 array, optional
        ``cv2.resize(grey, (w // 4, h // 4), interpolation=cv2.INTER_AREA)``
        when already made (:func:`reduce_grey`; the light lines' board level
        reads it too); used without ``exclude`` (or with an empty one).

    Returns
    -------
    (h, w) uint8 array
        255 on faint pixels, 0 elsewhere.

    Notes
    -----
    About 3 ms on an 800 x 800 px region (one core), most of it the 4x area
    reduction and the median of step 1. The result does not depend on how it
    is computed: the noise is taken from the histogram of (grey, background)
    pairs (:math:`g / b` has one value per pair), and the float work of step 3
    is done only in bands of rows around pixels whose grey level is below the
    background's level at which :math:`d > c` (read from the table of
    :math:`d` over all pairs), on the columns those span; the mask is the same,
    bit for bit, as with every pixel computed. ``exclude`` adds a masked 4x
    reduction, the hole filling and a masked copy of each band's depth: about
    1.7 ms more per 1080p phantom view's ROI (median CPU of
    :func:`segment_view` 4.9 -> 6.6 ms, ``bench_evidence.py masks``, load 10);
    the plain reduction it replaces is not made (since 2026-12-01: about 1 ms
    per view less). With ``at`` only the bands holding its pixels are worked
    (the pale options' plain pass at the faint pixels, absent where no pixel
    is faint: about half the whole pass's cost per view, and no pass in a third
    of the views); the holes' filling is compiled (:func:`_fill_from_board`).

    Example
    -------
    >>> g = np.full((60, 80), 200, np.uint8)
    >>> g[:, :40] = 120                      # uneven light: left half darker
    >>> g[30:33, 5:75] -= 30                 # a pale line, 15-25 % darker than its surroundings
    >>> f = faint_pixels(g)
    >>> int(f[31, 10] > 0), int(f[31, 70] > 0), int(f[10, 10] > 0), int(f[10, 70] > 0)
    (1, 1, 0, 0)
    """
    h, w = grey.shape
    if exclude is not None and exclude.shape != grey.shape:
        raise ValueError(f"exclude must have the shape of grey {grey.shape}, got {exclude.shape}")
    if at is not None and at.shape != grey.shape:
        raise ValueError(f"at must have the shape of grey {grey.shape}, got {at.shape}")
    step = 4
    size = (max(w // step, 1), max(h // step, 1))
    if reduced is not None and reduced.shape != size[::-1]:
        raise ValueError(f"reduced must have the shape {size[::-1]} (grey's 4x reduction), got {reduced.shape}")
    if at is not None:
        at = cv2.compare(at, 0, cv2.CMP_GT)
        if not at.any():
            return np.zeros((h, w), np.uint8)
    if exclude is not None and exclude.any():  # the board's level only: the other objects' pixels filled in from it
        valid = cv2.compare(exclude, 0, cv2.CMP_EQ)
        # 0 or 1 exactly (255 / 255), in one pass
        share = cv2.resize(np.divide(valid, 255, dtype=np.float32), size, interpolation=cv2.INTER_AREA)
        total = cv2.resize(cv2.bitwise_and(grey, valid).astype(np.float32), size, interpolation=cv2.INTER_AREA)
        hole = cv2.compare(share, 0.5, cv2.CMP_LT)
        small = np.clip(np.round(total / np.maximum(share, np.float32(0.5))), 0, 255).astype(np.uint8)
        small = _fill_from_board(small, hole)
    else:
        small = reduced if reduced is not None else reduce_grey(grey)
    k = max(3, (int(background_px) // step) | 1)
    bg_small = cv2.medianBlur(small, k) if min(small.shape) >= 2 else small
    bg = cv2.max(cv2.resize(bg_small, (w, h), interpolation=cv2.INTER_LINEAR), 1)  # uint8, 1-255
    sigma = 1.4826 * _ratio_mad(grey[::3, ::3], bg[::3, ::3])
    c = max(float(local_contrast), float(local_noise_k) * sigma)
    # d > c only where grey < darker[bg] (d falls as grey rises; d(255, bg) <= 0 < c, so darker <= 255)
    levels = np.arange(256, dtype=np.float32)[:, None]
    table = np.float32(1.0) - levels / np.maximum(levels.T, np.float32(1.0))  # d of every (grey, bg) pair
    darker = np.count_nonzero(cv2.compare(table, c, cv2.CMP_GT), axis=0).astype(np.uint8)
    candidate = cv2.compare(grey, cv2.LUT(bg, darker), cv2.CMP_LT)
    out = np.zeros((h, w), np.uint8)
    kernel = cv2.getStructuringElement(cv2.MORPH_RECT, (int(local_window_px),) * 2)
    r = int(local_window_px) // 2
    # The float work in bands of rows, on the columns of their candidates only: at a pixel with d > c the
    # window's largest d is at a pixel with d > c (d itself is one), within r rows of the band.
    # With ``at``: only the bands holding its pixels, and the candidates within r columns of them (all those a
    # pixel of ``at`` sees in its window).
    for y0 in range(0, h, _BAND_ROWS):
        y1 = min(y0 + _BAND_ROWS, h)
        e0, e1 = max(y0 - r, 0), min(y1 + r, h)
        if at is not None:
            ax, _, aw, _ = cv2.boundingRect(at[y0:y1])
            if aw == 0:
                continue
        bx, _, bw, _ = cv2.boundingRect(candidate[y0:y1])
        if bw == 0:
            continue
        bx, _, bw, _ = cv2.boundingRect(candidate[e0:e1])
        if at is not None:
            lo, hi = max(bx, ax - r), min(bx + bw, ax + aw + r)
            if hi <= lo:
                continue
            bx, bw = lo, hi - lo
        g, b = grey[e0:e1, bx:bx + bw], bg[e0:e1, bx:bx + bw]
        depth = np.float32(1.0) - g.astype(np.float32) / b.astype(np.float32)
        if exclude is None:
            half = np.float32(0.5) * cv2.dilate(depth, kernel)
        else:  # the other objects' depth does not count (a candidate outside them still sees its own depth)
            own = depth.copy()
            own[exclude[e0:e1, bx:bx + bw] > 0] = 0
            half = np.float32(0.5) * cv2.dilate(own, kernel)
        out[y0:y1, bx:bx + bw] = cv2.bitwise_and(cv2.compare(depth, c, cv2.CMP_GT),
                                                 cv2.compare(depth, half, cv2.CMP_GT))[y0 - e0:y1 - e0]
    return out if at is None else cv2.bitwise_and(out, at)


def reduce_grey(grey: np.ndarray) -> np.ndarray:
    """The 4x area reduction of a grey image (``(h // 4, w // 4)``, at least 1 x 1) from which
    :func:`faint_pixels` (without ``exclude``) and the light lines' board level
    (:func:`tendrilkit.segmentation.lines.board_level`) take their local levels: made once, read by both.
    An (h, w, c) image is reduced channel by channel (the same pixels as each channel's own reduction)."""
    h, w = grey.shape[:2]
    return cv2.resize(grey, (max(w // 4, 1), max(h // 4, 1)), interpolation=cv2.INTER_AREA)


def drop_unanchored(faint: np.ndarray, plain: np.ndarray, *, min_plain_frac: float = 0.5) -> np.ndarray:
    """The faint pixels without those that only ``exclude`` found in regions mostly its own: an object's pale part.

    With ``exclude`` (:func:`faint_pixels`) a pixel beside a darker object
    is measured against its own depth, not the object's, so a pale tendril
    running beside a leaf or the stem is kept: it goes on over the board,
    where the plain rule (without ``exclude``) finds it too, and its faint
    region is mostly the plain rule's. A pale *part* of the object next to
    its dark pixels is found by ``exclude`` alone: the stem under translucent
    tape, whose ends next to the dark stem it adds as blocks as wide as the
    stem (phantom S2, view 3: their skeletons, a break away from the stem at
    the base mark, counted as the tendril's and failed its coverage check).
    In every faint region (8-connected) of which less than ``min_plain_frac``
    is in ``plain``, the pixels that only ``exclude`` found are dropped.

    Parameters
    ----------
    faint : (h, w) uint8 array
        Nonzero on faint pixels (:func:`faint_pixels` with ``exclude``,
        without the excluded pixels).
    plain : (h, w) uint8 array
        Nonzero on faint pixels found without ``exclude``.
    min_plain_frac : float
        The least share of a faint region the plain rule must find for its
        other pixels to stay, 0-1.

    Returns
    -------
    (h, w) uint8 array
        255 on the faint pixels kept, 0 elsewhere (a new array).

    Notes
    -----
    Only where ``exclude`` found pixels: one labelling of the faint pixels
    on their box and two counts per region at their pixels (about 0.3 ms on
    a 1080p phantom view's region of interest; 1-2 ms when the whole crop was
    labelled and counted, before 2026-12-01's issue 17 work). ``plain`` is
    read at the faint pixels only: :func:`foreground_roi` decides the plain
    rule there alone (:func:`faint_pixels`' ``at``).

    Example
    -------
    >>> fa = np.zeros((40, 120), np.uint8)
    >>> fa[12:28, 30:40] = 255                       # a taped stretch's end beside the dark stem: exclude's alone
    >>> fa[2:6, :] = 255                             # a pale tendril: beside the stem up to x = 60, then on the board
    >>> pl = np.zeros_like(fa); pl[2:6, 60:] = 255   # what was found without exclude
    >>> out = drop_unanchored(fa, pl)
    >>> int(out[20, 35] > 0), int(out[4, 100] > 0), int(out[4, 10] > 0)
    (0, 1, 1)
    """
    if faint.shape != plain.shape:
        raise ValueError(f"plain must have the shape of faint {faint.shape}, got {plain.shape}")
    if not 0.0 <= min_plain_frac <= 1.0:
        raise ValueError(f"min_plain_frac must be in [0, 1], got {min_plain_frac}")
    fa = cv2.compare(faint, 0, cv2.CMP_GT)
    pl = cv2.compare(plain, 0, cv2.CMP_GT)
    extra = cv2.bitwise_and(fa, cv2.compare(pl, 0, cv2.CMP_EQ))
    if not extra.any():
        return fa
    # the regions labelled on the faint pixels' box (each lies in it whole: the same regions), counted at their
    # pixels only
    x, y, w, h = cv2.boundingRect(fa)
    sub = fa[y:y + h, x:x + w]
    n, lab = cv2.connectedComponents(sub, connectivity=8)
    rc = cv2.findNonZero(sub).reshape(-1, 2)
    r, c = rc[:, 1], rc[:, 0]
    at = lab[r, c]
    total = np.bincount(at, minlength=n)
    found = np.bincount(at[pl[y:y + h, x:x + w][r, c] > 0], minlength=n)
    alone = found < min_plain_frac * total
    alone[0] = False
    drop = alone[at] & (extra[y:y + h, x:x + w][r, c] > 0)
    sub[r[drop], c[drop]] = 0
    return fa


def _fill_from_board(small: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """``small`` (uint8) with its ``hole`` pixels (uint8, nonzero) filled by the brightest board pixel next to them.

    Grown in from the hole's rim one pixel a step (3 x 3 dilation of the
    board's levels): the board is the brightest thing in a view, so a pale
    tendril beside a leaf never lends its level to the leaf's hole (as an
    interpolation from every side would); what is left after as many steps as
    the image's longer side (no board at all) is 255. Compiled
    (:func:`tendrilkit.segmentation.kernels.grow_fill`: each step visits the
    hole pixels next to the last step's only; the same levels as the
    whole-image dilations, test).
    """
    if not hole.any():
        return small
    return grow_fill(small, hole)


def _weighted_median(values: np.ndarray, counts: np.ndarray) -> np.float32:
    """``np.median`` of the float32 multiset holding ``values[i]`` ``counts[i]`` times (same value, bit for bit)."""
    order = np.argsort(values)
    cum = np.cumsum(counts[order], dtype=np.int64)
    n = int(cum[-1])
    ranks = [n // 2 - 1, n // 2] if n % 2 == 0 else [n // 2]
    middle = values[order[np.searchsorted(cum, ranks, side="right")]]
    return np.mean(middle)  # as np.median: the mean of the one or two middle values, in float32


def _ratio_mad(grey: np.ndarray, bg: np.ndarray) -> float:
    """Median absolute deviation of ``grey / bg`` (float32), from the histogram of the (grey, bg) pairs.

    Equal to ``np.median(np.abs(r - np.median(r)))`` with
    ``r = grey.astype(np.float32) / bg.astype(np.float32)``: ``r`` takes one
    value per (grey, bg) pair, so the two medians are taken over the few
    thousand pairs present, weighted by their counts, not over every pixel.

    Parameters
    ----------
    grey, bg : (h, w) uint8 arrays
        Grey level and background (1-255) of the sampled pixels.
    """
    if grey.size < 2 ** 24:  # calcHist counts in float32: exact below 2**24
        counts = cv2.calcHist([np.ascontiguousarray(grey), np.ascontiguousarray(bg)], [0, 1], None, [256, 256],
                              [0, 256, 0, 256]).ravel()
    else:
        counts = np.bincount((grey.astype(np.int64) << 8 | bg).ravel(), minlength=65536)
    pairs = np.flatnonzero(counts > 0)  # (a bool array: several times faster than a float one)
    ratio = (pairs >> 8).astype(np.float32) / (pairs & 255).astype(np.float32)
    m = _weighted_median(ratio, counts[pairs])
    return float(_weighted_median(np.abs(ratio - m), counts[pairs]))
