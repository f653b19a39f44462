"""Per-view mask of the tendril (paper: "Pre-processing"; stage 2 of
``../shared/REFERENCE_NOTES.md``).

:func:`segment_view` works on the region of interest (ROI) only:

1. a grey image in which the tendril is dark: the blue channel (a green/brown
   tendril on a white board is dark in blue, the reference's default) or, with
   ``channel="hsv"``, :math:`g = \\min(V, 255 - S)` (dark *or* saturated pixels
   are low, the white board is high);
2. a threshold: Otsu's on the ROI, or a fixed grey level (pixels darker than
   it are tendril);
3. the keep-out box (between the tendril and the stem) painted background, so
   the stem cannot join the tendril's component;
4. a morphological opening with a disk (removes speckle and one-pixel bridges);
4b. faint pixels added (:func:`faint_pixels`): darker than their local
   background by a relative contrast, farther than ``local_margin_px`` from
   the pixels of steps 2-4 (a pale tendril that the threshold, pulled by a dark
   stem or leaf in the ROI, leaves with the board; dark tendrils keep their
   thresholded outline), keep-out box painted background, not opened; with
   ``local_exclude_dark``, a faint pixel's structure depth is taken beside
   the thresholded pixels, not over them (a pale tendril passing a leaf or
   the stem is kept there);
5. connected components (8-connected); components under ``min_component_px``
   are dropped;
6. the tendril's component: on the first frame the component at, or nearest
   to, the base point (when several are about as near, as the stem and the
   tendril on both sides of the keep-out box are, the thinnest of them); on
   later frames the component whose centroid is nearest the previous frame's
   centroid (the paper's tracking).

No dialog or click anywhere: the ROI, keep-out box and base point come from the
experiment file.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from tendrilkit.exceptions import TendrilLostError

__all__ = ["TendrilMask", "LabelledForeground", "segment_view", "label_foreground", "grey_image", "foreground_roi",
           "faint_pixels", "faint_options"]


@dataclass(frozen=True, eq=False)
class LabelledForeground:
    """Every dark pixel of a view's ROI and its 8-connected components, before any is chosen.

    Steps 1-5 of :func:`segment_view` without dropping the small components
    (:func:`label_foreground`); the segmentation keeps it
    (:attr:`TendrilMask.foreground`) so that what else reads the same image
    with the same options (:func:`tendrilkit.evidence.view_evidence`, for the
    verification) need not threshold and label it again.

    Attributes
    ----------
    foreground : (h, w) uint8 array
        255 on dark pixels of the ROI crop, 0 elsewhere (:func:`foreground_roi`).
    roi_offset_xy : (2,) int array
        Full-image pixel ``(x, y)`` of the crop's pixel ``[0, 0]``.
    n_labels : int
        Labels in ``labels``, background included (``labels.max() + 1``).
    labels : (h, w) int32 array
        Component of every pixel (1, 2, ...), 0 on the background.
    channel, threshold, opening_radius_px
        The options it was made with (:func:`foreground_roi`).
    local_options : tuple
        ``(local_contrast, local_noise_k, background_px, local_window_px,
        local_margin_px, local_exclude_dark)``
        it was made with (:func:`foreground_roi`).
    """

    foreground: np.ndarray
    roi_offset_xy: np.ndarray
    n_labels: int
    labels: np.ndarray
    channel: str = "blue"
    threshold: str | int = "otsu"
    opening_radius_px: int = 1
    local_options: tuple = (0.1, 5.0, 36, 9, 2, False)

    @cached_property
    def pixels(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(rows, cols, labels)``: every foreground pixel's row, column and label, (m,) int arrays, raster order.

        Computed once, when first read (the segmentation's component areas and
        centroids and the evidence's small components read it; read only):
        ``cv2.findNonZero`` takes 0.4 ms where ``np.nonzero`` takes 1.7 ms on
        a 1 Mpx crop, and the foreground is a small part of the crop.
        """
        nz = cv2.findNonZero(self.foreground)
        if nz is None:
            out = (np.zeros(0, np.int32), np.zeros(0, np.int32), np.zeros(0, np.int32))
        else:
            nz = nz.reshape(-1, 2)
            out = (nz[:, 1], nz[:, 0], self.labels[nz[:, 1], nz[:, 0]])
        for a in out:
            a.flags.writeable = False
        return out

    @cached_property
    def areas(self) -> np.ndarray:
        """(n_labels,) int array: pixels of every component (0 for the background's label 0); read only."""
        out = np.bincount(self.pixels[2], minlength=self.n_labels)
        out[0] = 0
        out.flags.writeable = False
        return out


@dataclass(frozen=True, eq=False)
class TendrilMask:
    """The tendril's pixels in one view and frame.

    Attributes
    ----------
    mask_roi : (h, w) bool array
        The tendril's component in the ROI crop (``h, w`` the ROI's height and
        width, clipped to the image).
    roi_offset_xy : (2,) int array
        Full-image pixel position ``(x, y)`` of the crop's pixel ``[0, 0]``.
    centroid_xy : (2,) float array
        Centroid of the component, full-image pixels.
    area_px : int
        Number of pixels of the component.
    n_components : int
        Components left in the ROI after dropping the small ones (1 when the
        tendril is alone; more means the choice of component mattered).
    foreground : LabelledForeground or None
        Every dark pixel of the ROI and its components, the tendril's among
        them (read only: it is shared with what reuses it).
    """

    mask_roi: np.ndarray
    roi_offset_xy: np.ndarray
    centroid_xy: np.ndarray
    area_px: int
    n_components: int
    foreground: LabelledForeground | None = None


def _box(box, name: str) -> tuple[int, int, int, int]:
    try:
        x, y, w, h = (int(round(float(v))) for v in box)
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be 4 numbers [x, y, w, h], got {box!r}") from None
    if w <= 0 or h <= 0:
        raise ValueError(f"{name} must have positive width and height, got {[x, y, w, h]}")
    return x, y, w, h


def grey_image(image_bgr: np.ndarray, *, channel: str = "blue") -> np.ndarray:
    """The uint8 grey image in which the tendril is dark.

    Parameters
    ----------
    image_bgr : (h, w, 3) uint8 array
        A BGR image (or crop), as OpenCV reads it. A (h, w) image is taken as
        already grey.
    channel : {"blue", "hsv"}
        ``blue``: the blue channel; ``hsv``: :math:`\\min(V, 255 - S)`.

    Returns
    -------
    (h, w) uint8 array
    """
    if image_bgr.ndim == 2:
        return np.ascontiguousarray(image_bgr, dtype=np.uint8)
    if channel == "blue":
        return np.ascontiguousarray(image_bgr[:, :, 0])
    if channel == "hsv":
        hsv = cv2.cvtColor(image_bgr, cv2.COLOR_BGR2HSV)
        return np.minimum(hsv[:, :, 2], 255 - hsv[:, :, 1])
    raise ValueError(f"channel must be 'blue' or 'hsv', got {channel!r}")


_BAND_ROWS = 64  # rows per band of faint_pixels' float work


def faint_pixels(
    grey: np.ndarray,
    *,
    local_contrast: float = 0.1,
    local_noise_k: float = 5.0,
    background_px: int = 36,
    local_window_px: int = 9,
    exclude: np.ndarray | None = None,
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
    :func:`segment_view` 4.9 -> 6.6 ms, ``bench_evidence.py masks``, load 10).

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
    step = 4
    size = (max(w // step, 1), max(h // step, 1))
    small = cv2.resize(grey, size, interpolation=cv2.INTER_AREA)
    if exclude is not None and exclude.any():  # the board's level only: the other objects' pixels filled in from it
        valid = cv2.compare(exclude, 0, cv2.CMP_EQ)
        share = cv2.resize(valid.astype(np.float32) / 255, size, interpolation=cv2.INTER_AREA)
        total = cv2.resize(cv2.bitwise_and(grey, valid).astype(np.float32), size, interpolation=cv2.INTER_AREA)
        hole = cv2.compare(share, 0.5, cv2.CMP_LT)
        small = np.clip(np.round(total / np.maximum(share, np.float32(0.5))), 0, 255).astype(np.uint8)
        small = _fill_from_board(small, hole)
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
    for y0 in range(0, h, _BAND_ROWS):
        y1 = min(y0 + _BAND_ROWS, h)
        e0, e1 = max(y0 - r, 0), min(y1 + r, h)
        bx, _, bw, _ = cv2.boundingRect(candidate[y0:y1])
        if bw == 0:
            continue
        bx, _, bw, _ = cv2.boundingRect(candidate[e0:e1])
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
    return out


def _fill_from_board(small: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """``small`` (uint8) with its ``hole`` pixels (uint8, nonzero) filled by the brightest board pixel next to them.

    Grown in from the hole's rim one pixel a step (3 x 3 dilation of the
    board's levels): the board is the brightest thing in a view, so a pale
    tendril beside a leaf never lends its level to the leaf's hole (as an
    interpolation from every side would); what is left after as many steps as
    the image's longer side (no board at all) is 255.
    """
    if not hole.any():
        return small
    out = small.copy()
    out[hole > 0] = 0
    todo = hole > 0
    kernel = np.ones((3, 3), np.uint8)
    for _ in range(max(small.shape)):
        if not todo.any():
            break
        grown = cv2.dilate(out, kernel)
        reach = todo & (cv2.dilate((~todo).view(np.uint8), kernel) > 0)
        if not reach.any():
            break
        out[reach] = grown[reach]
        todo &= ~reach
    out[todo] = 255
    return out


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
    pairs = np.flatnonzero(counts)
    ratio = (pairs >> 8).astype(np.float32) / (pairs & 255).astype(np.float32)
    m = _weighted_median(ratio, counts[pairs])
    return float(_weighted_median(np.abs(ratio - m), counts[pairs]))


def foreground_roi(
    image_bgr: np.ndarray,
    *,
    roi,
    keep_out,
    channel: str = "blue",
    threshold: str | int = "otsu",
    opening_radius_px: int = 1,
    local_contrast: float = 0.1,
    local_noise_k: float = 5.0,
    background_px: int = 36,
    local_window_px: int = 9,
    local_margin_px: int = 2,
    local_exclude_dark: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """Steps 1-4 of :func:`segment_view`: every dark pixel of the ROI, before any choice of component.

    Parameters
    ----------
    image_bgr : (H, W, 3) or (H, W) uint8 array
        The full frame.
    roi, keep_out, channel, threshold, opening_radius_px
        As in :func:`segment_view`.

    Returns
    -------
    fg : (h, w) uint8 array
        255 on foreground, 0 elsewhere, in the ROI crop clipped to the image
        (keep-out box painted background, opening applied).
    offset_xy : (2,) int array
        Full-image pixel ``(x, y)`` of ``fg[0, 0]``.

    Raises
    ------
    ValueError
        Malformed image, box, threshold or radius.
    """
    img = np.asarray(image_bgr)
    if img.dtype != np.uint8 or img.ndim not in (2, 3) or (img.ndim == 3 and img.shape[2] != 3):
        raise ValueError(f"image_bgr must be a (H, W, 3) or (H, W) uint8 array, got {img.shape} {img.dtype}")
    H, W = img.shape[:2]
    x, y, w, h = _box(roi, "roi")
    x0, y0 = max(x, 0), max(y, 0)
    x1, y1 = min(x + w, W), min(y + h, H)
    if x1 - x0 < 2 or y1 - y0 < 2:
        raise ValueError(f"roi {[x, y, w, h]} does not overlap the {W}x{H} image")
    if threshold != "otsu" and not (isinstance(threshold, (int, np.integer)) and 0 <= threshold <= 255):
        raise ValueError(f"threshold must be 'otsu' or an integer 0-255, got {threshold!r}")
    if opening_radius_px < 0:
        raise ValueError(f"opening_radius_px must be >= 0, got {opening_radius_px}")

    if not 0 <= local_contrast < 1:
        raise ValueError(f"local_contrast must be in [0, 1), got {local_contrast}")
    if not local_noise_k >= 0:
        raise ValueError(f"local_noise_k must be >= 0, got {local_noise_k}")
    if background_px < 4:
        raise ValueError(f"background_px must be >= 4, got {background_px}")
    if local_window_px < 1:
        raise ValueError(f"local_window_px must be >= 1, got {local_window_px}")
    if local_margin_px < 0:
        raise ValueError(f"local_margin_px must be >= 0, got {local_margin_px}")

    grey = grey_image(img[y0:y1, x0:x1], channel=channel)
    if threshold == "otsu":
        _, fg = cv2.threshold(grey, 0, 255, cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU)
    else:
        # tendril: grey < threshold
        _, fg = cv2.threshold(grey, int(threshold) - 1, 255, cv2.THRESH_BINARY_INV)

    a0 = a1 = b0 = b1 = 0
    if keep_out is not None:
        kx, ky, kw, kh = _box(keep_out, "keep_out")
        a0, b0 = max(kx - x0, 0), max(ky - y0, 0)
        a1, b1 = min(kx + kw - x0, fg.shape[1]), min(ky + kh - y0, fg.shape[0])
        if a1 > a0 and b1 > b0:
            fg[b0:b1, a0:a1] = 0

    if opening_radius_px > 0:
        r = int(opening_radius_px)
        kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
        fg = cv2.morphologyEx(fg, cv2.MORPH_OPEN, kernel)
    if local_contrast > 0:  # not opened: a pale tendril's faint pixels are as narrow as its half-depth core
        near = fg
        if local_margin_px > 0:  # the rim of what the threshold found stays its own (dark tendrils unchanged)
            r = int(local_margin_px)
            near = cv2.dilate(fg, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))
        faint = faint_pixels(grey, local_contrast=local_contrast, local_noise_k=local_noise_k,
                             background_px=background_px, local_window_px=local_window_px,
                             exclude=near if local_exclude_dark else None)
        if keep_out is not None and a1 > a0 and b1 > b0:
            faint[b0:b1, a0:a1] = 0
        if local_margin_px > 0:
            faint = cv2.bitwise_and(faint, cv2.compare(near, 0, cv2.CMP_EQ))
        fg = cv2.bitwise_or(fg, faint)
    return fg, np.array([x0, y0])


def faint_options(local_contrast: float, local_noise_k: float, background_px: int, local_window_px: int,
                  local_margin_px: int, local_exclude_dark: bool) -> dict:
    """The faint-pixel options (:func:`faint_pixels`) as keywords, typed, in the order of
    :attr:`LabelledForeground.local_options`."""
    return {"local_contrast": float(local_contrast), "local_noise_k": float(local_noise_k),
            "background_px": int(background_px), "local_window_px": int(local_window_px),
            "local_margin_px": int(local_margin_px), "local_exclude_dark": bool(local_exclude_dark)}


def label_foreground(
    image_bgr: np.ndarray,
    *,
    roi,
    keep_out,
    channel: str = "blue",
    threshold: str | int = "otsu",
    opening_radius_px: int = 1,
    local_contrast: float = 0.1,
    local_noise_k: float = 5.0,
    background_px: int = 36,
    local_window_px: int = 9,
    local_margin_px: int = 2,
    local_exclude_dark: bool = False,
) -> LabelledForeground:
    """Steps 1-5 of :func:`segment_view`: the ROI's dark pixels (:func:`foreground_roi`) and their components.

    Parameters
    ----------
    image_bgr : (H, W, 3) or (H, W) uint8 array
        The full frame.
    roi, keep_out, channel, threshold, opening_radius_px
        As in :func:`segment_view`.

    Returns
    -------
    LabelledForeground
        Nothing dropped: components of every size.
    """
    local = faint_options(local_contrast, local_noise_k, background_px, local_window_px, local_margin_px,
                         local_exclude_dark)
    fg, offset = foreground_roi(image_bgr, roi=roi, keep_out=keep_out, channel=channel, threshold=threshold,
                                opening_radius_px=opening_radius_px, **local)
    n, labels = cv2.connectedComponents(fg, connectivity=8, ltype=cv2.CV_32S)
    return LabelledForeground(foreground=fg, roi_offset_xy=offset, n_labels=int(n), labels=labels, channel=channel,
                              threshold=threshold, opening_radius_px=int(opening_radius_px),
                              local_options=tuple(local.values()))


def segment_view(
    image_bgr: np.ndarray,
    *,
    roi,
    keep_out,
    base_point_xy,
    prev_centroid_xy=None,
    channel: str = "blue",
    threshold: str | int = "otsu",
    opening_radius_px: int = 1,
    local_contrast: float = 0.1,
    local_noise_k: float = 5.0,
    background_px: int = 36,
    local_window_px: int = 9,
    local_margin_px: int = 2,
    local_exclude_dark: bool = False,
    min_component_px: int = 50,
) -> TendrilMask:
    """Segment the tendril in one view of one frame.

    Parameters
    ----------
    image_bgr : (H, W, 3) uint8 array
        The full frame, BGR (a (H, W) grey image is accepted too).
    roi : [x, y, w, h]
        Region of interest, full-image pixels; clipped to the image.
    keep_out : [x, y, w, h] or None
        Box painted background (the junction between tendril and stem).
    base_point_xy : (2,) sequence of float
        Where the tendril leaves the stem, full-image pixels; picks the
        component on the first frame.
    prev_centroid_xy : (2,) sequence of float, optional
        The previous frame's centroid; when given, the component whose
        centroid is nearest it is taken (the paper's tracking).
    channel : {"blue", "hsv"}
        See :func:`grey_image`.
    threshold : "otsu" or int
        Otsu's threshold on the ROI, or a fixed grey level 0-255 (darker
        pixels are tendril).
    opening_radius_px : int
        Radius of the disk of the morphological opening; 0: no opening.
    local_contrast, local_noise_k, background_px, local_window_px
        Faint pixels (step 4b, :func:`faint_pixels`); ``local_contrast`` 0: none.
    local_margin_px : int
        Faint pixels within this many pixels of the thresholded ones are dropped.
    local_exclude_dark : bool
        Take a faint pixel's structure depth :math:`d_{max}` over the pixels
        outside the thresholded ones grown by ``local_margin_px`` (the
        ``exclude`` of :func:`faint_pixels`), not over all: a pale tendril
        beside a darker leaf or stem is measured against its own depth.
    min_component_px : int
        Components with fewer pixels are dropped.

    Returns
    -------
    TendrilMask

    Raises
    ------
    TendrilLostError
        No component of at least ``min_component_px`` pixels in the ROI.
    ValueError
        Malformed arguments (shape, box, threshold).
    """
    labelled = label_foreground(image_bgr, roi=roi, keep_out=keep_out, channel=channel, threshold=threshold,
                                opening_radius_px=opening_radius_px, local_contrast=local_contrast,
                                local_noise_k=local_noise_k, background_px=background_px,
                                local_window_px=local_window_px, local_margin_px=local_margin_px,
                                local_exclude_dark=local_exclude_dark)
    if min_component_px < 0:
        raise ValueError(f"min_component_px must be >= 0, got {min_component_px}")
    fg, offset, n, labels = labelled.foreground, labelled.roi_offset_xy, labelled.n_labels, labelled.labels
    x, y, w, h = _box(roi, "roi")
    x0, y0 = int(offset[0]), int(offset[1])
    if keep_out is not None:
        kx, ky, kw, kh = _box(keep_out, "keep_out")

    # labels without cv2's statistics (those cost 4 ms on a 700 x 700 crop,
    # the labels 0.5 ms); areas and centroids from the foreground pixels only
    rows, cols, lab = labelled.pixels
    if len(rows) == 0:
        raise TendrilLostError(f"no component (no foreground pixel at all) in the roi {[x, y, w, h]}")
    areas = labelled.areas
    keep = np.nonzero(areas >= max(min_component_px, 1))[0]
    if len(keep) == 0:
        raise TendrilLostError(
            f"no component of at least {min_component_px} px in the roi {[x, y, w, h]}"
        )
    with np.errstate(invalid="ignore", divide="ignore"):
        centroids = np.column_stack(
            [np.bincount(lab, weights=cols, minlength=n) / areas, np.bincount(lab, weights=rows, minlength=n) / areas]
        )

    if prev_centroid_xy is not None:
        p = np.asarray(prev_centroid_xy, dtype=float).reshape(2) - offset
        best = int(keep[np.argmin(np.hypot(*(centroids[keep] - p).T))])
    elif len(keep) == 1:
        best = int(keep[0])
    else:
        p = np.asarray(base_point_xy, dtype=float).reshape(2) - offset
        reach = 3.0 if keep_out is None else max(3.0, 0.5 * float(np.hypot(kw, kh)) + 2.0)
        best = _pick_at_base(labels, rows, cols, lab, areas, keep, p, reach)

    mask = labels == best
    return TendrilMask(
        mask_roi=mask,
        roi_offset_xy=offset,
        centroid_xy=centroids[best] + offset,
        area_px=int(areas[best]),
        n_components=len(keep),
        foreground=labelled,
    )


def _pick_at_base(labels, rows, cols, lab, areas, keep, p_xy, reach: float) -> int:
    """The tendril's component on the first frame.

    Candidates: the component nearest the base point and every other one
    whose nearest pixel is less than ``reach`` farther (the keep-out box sits
    between the tendril and the stem, so both are about equally near a base
    point marked in the box). Among them, the thinnest: twice the area over
    the perimeter, a tube's width (the tendril is thinner than the stem and
    the node it leaves).
    """
    ok = np.isin(lab, keep)
    d = np.hypot(cols[ok] - p_xy[0], rows[ok] - p_xy[1])
    lk = lab[ok]
    near = np.full(labels.max() + 1, np.inf)
    np.minimum.at(near, lk, d)
    cand = np.nonzero(near <= near.min() + reach)[0]
    if len(cand) == 1:
        return int(cand[0])
    widths = []
    for k in cand:
        rr, cc = rows[lab == k], cols[lab == k]
        r0, c0 = rr.min(), cc.min()
        sub = np.zeros((rr.max() - r0 + 3, cc.max() - c0 + 3), np.uint8)
        sub[rr - r0 + 1, cc - c0 + 1] = 1
        contours, _ = cv2.findContours(sub, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
        perimeter = sum(cv2.arcLength(c, True) for c in contours)
        widths.append(2.0 * areas[k] / max(perimeter, 1.0))
    return int(cand[int(np.argmin(widths))])
