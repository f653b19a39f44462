"""Every dark pixel of a view's ROI and its components, before any is chosen (steps 1-5 of
:func:`tendrilkit.segmentation.segment_view`)."""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from tendrilkit.segmentation.faint import drop_unanchored, faint_pixels, reduce_grey
from tendrilkit.segmentation.lines import bridge_line_gaps, light_line_pixels, lines_in_front, vein_pixels

__all__ = ["LabelledForeground", "label_foreground", "grey_image", "foreground_roi", "faint_options"]


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
    line_options : tuple
        ``(line_width_px, bridge_gap_px)`` it was made with (:func:`foreground_roi`).
    """

    foreground: np.ndarray
    roi_offset_xy: np.ndarray
    n_labels: int
    labels: np.ndarray
    channel: str = "blue"
    threshold: str | int = "otsu"
    opening_radius_px: int = 1
    local_options: tuple = (0.1, 5.0, 36, 9, 2, False)
    line_options: tuple = (0, 0)

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
    local_exclude_dark: bool = True,
    line_width_px: int = 11,
    bridge_gap_px: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Steps 1-4 of :func:`segment_view`: every dark pixel of the ROI, before any choice of component.

    Parameters
    ----------
    image_bgr : (H, W, 3) or (H, W) uint8 array
        The full frame.
    roi, keep_out, channel, threshold, opening_radius_px, local_contrast, local_noise_k, background_px,
    local_window_px, local_margin_px, local_exclude_dark, line_width_px, bridge_gap_px
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
    if line_width_px != 0 and line_width_px < 3:
        raise ValueError(f"line_width_px must be 0 (no light lines) or >= 3, got {line_width_px}")
    if bridge_gap_px < 0:
        raise ValueError(f"bridge_gap_px must be >= 0, got {bridge_gap_px}")

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
    reduced = None  # grey's 4x area reduction, made once for the plain faint pixels and the board's level
    dark = fg  # the threshold's pixels (what a light line is in front of)
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
        if local_exclude_dark and faint.any():  # a pale part of an object beside it (a taped stem) is no tendril
            # the plain rule is read at the faint pixels only (drop_unanchored): decided there alone, the same values
            reduced = reduce_grey(grey)
            plain = faint_pixels(grey, local_contrast=local_contrast, local_noise_k=local_noise_k,
                                 background_px=background_px, local_window_px=local_window_px, at=faint,
                                 reduced=reduced)
            faint = drop_unanchored(faint, plain)
        fg = cv2.bitwise_or(fg, faint)
    if line_width_px > 0:  # 4c: a pale line in front of a darker object (lighter than it, darker than the board)
        lines = light_line_pixels(grey, fg, width_px=int(line_width_px), contrast=max(float(local_contrast), 0.05),
                                  reduced=reduced)
        if keep_out is not None and a1 > a0 and b1 > b0 and lines[b0:b1, a0:a1].any():
            # the painted box is a gap through the node, no light line in front of it: its pieces are dropped
            n, lab = cv2.connectedComponents(lines, connectivity=8)
            box = np.zeros(n, bool)
            box[np.unique(lab[b0:b1, a0:a1])] = True
            box[0] = False
            lines[box[lab]] = 0
        veins = vein_pixels(lines, fg, width_px=int(line_width_px))
        if veins.any():  # a leaf's midrib is the leaf's: dark with it (covered), not a line in front of it
            lines = cv2.bitwise_and(lines, cv2.bitwise_not(veins))
            fg = cv2.bitwise_or(fg, veins)
            dark = cv2.bitwise_or(dark, veins)
        fg = lines_in_front(fg, lines, dark)
    if bridge_gap_px > 0:  # 4d: a line broken where it crosses another joined across the gap
        fg = bridge_line_gaps(fg, gap_px=int(bridge_gap_px))
    if (line_width_px > 0 or bridge_gap_px > 0) and keep_out is not None and a1 > a0 and b1 > b0:
        fg[b0:b1, a0:a1] = 0  # nothing joins the stem to the tendril across the keep-out box
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
    local_exclude_dark: bool = True,
    line_width_px: int = 11,
    bridge_gap_px: int = 0,
) -> LabelledForeground:
    """Steps 1-5 of :func:`segment_view`: the ROI's dark pixels (:func:`foreground_roi`) and their components.

    Parameters
    ----------
    image_bgr : (H, W, 3) or (H, W) uint8 array
        The full frame.
    roi, keep_out, channel, threshold, opening_radius_px, local_contrast, local_noise_k, background_px,
    local_window_px, local_margin_px, local_exclude_dark, line_width_px, bridge_gap_px
        As in :func:`segment_view`.

    Returns
    -------
    LabelledForeground
        Nothing dropped: components of every size.
    """
    local = faint_options(local_contrast, local_noise_k, background_px, local_window_px, local_margin_px,
                         local_exclude_dark)
    fg, offset = foreground_roi(image_bgr, roi=roi, keep_out=keep_out, channel=channel, threshold=threshold,
                                opening_radius_px=opening_radius_px, **local, line_width_px=line_width_px,
                                bridge_gap_px=bridge_gap_px)
    n, labels = cv2.connectedComponents(fg, connectivity=8, ltype=cv2.CV_32S)
    return LabelledForeground(foreground=fg, roi_offset_xy=offset, n_labels=int(n), labels=labels, channel=channel,
                              threshold=threshold, opening_radius_px=int(opening_radius_px),
                              local_options=tuple(local.values()),
                              line_options=(int(line_width_px), int(bridge_gap_px)))
