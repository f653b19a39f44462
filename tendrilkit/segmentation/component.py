"""The tendril's component in one view (step 6 of :func:`segment_view`)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

from tendrilkit.exceptions import TendrilLostError
from tendrilkit.segmentation.foreground import LabelledForeground, _box, faint_options, label_foreground

__all__ = ["TendrilMask", "segment_view"]


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
    local_exclude_dark: bool = True,
    line_width_px: int = 11,
    bridge_gap_px: int = 0,
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
        beside a darker leaf or stem is measured against its own depth; faint
        regions found mostly by this alone lose its pixels (a pale part of
        the object: the stem under translucent tape;
        :func:`tendrilkit.segmentation.faint.drop_unanchored`).
    line_width_px : int
        Step 4c, light lines (:func:`tendrilkit.segmentation.lines.light_line_pixels`):
        pixels of a line up to this wide, lighter than the dark pixels on both
        sides of it and darker than the board by ``local_contrast`` (at least
        0.05) are added (a pale tendril in front of a leaf or a shoot), in
        front of it (a one-pixel rim of the object cleared around them,
        :func:`tendrilkit.segmentation.lines.lines_in_front`; pieces running
        into the keep-out box, a gap painted through the node, left out); 0: none.
    bridge_gap_px : int
        Step 4d (:func:`tendrilkit.segmentation.lines.bridge_line_gaps`):
        skeleton ends up to this far apart that face each other (the line
        goes on straight across another it crosses) are joined at the line's
        width; 0: none. The keep-out box is painted background again after
        steps 4c-4d.
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
    local = faint_options(local_contrast, local_noise_k, background_px, local_window_px, local_margin_px,
                          local_exclude_dark)
    labelled = label_foreground(image_bgr, roi=roi, keep_out=keep_out, channel=channel, threshold=threshold,
                                opening_radius_px=opening_radius_px, **local, line_width_px=line_width_px,
                                bridge_gap_px=bridge_gap_px)
    if min_component_px < 0:
        raise ValueError(f"min_component_px must be >= 0, got {min_component_px}")
    offset, n, labels = labelled.roi_offset_xy, labelled.n_labels, labelled.labels
    x, y, w, h = _box(roi, "roi")
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
