"""What one view's image says about where the tendril is, before any decision.

A reconstruction method (the epipolar chain, the paper's Fréchet matching, a
3D curve fitted to all views at once) and the verification of its result
(:mod:`tendrilkit.verify`) both need the same per-view evidence, and neither
should depend on which connected component the segmentation picked or how a
skeleton was walked. :func:`view_evidence` computes it once per view and
frame, on the region of interest (ROI) only:

* ``foreground``: every dark pixel of the ROI (the same channel, threshold,
  faint pixels darker than their local background, light lines and joins across crossings when asked
  (``line_width_px``, ``bridge_gap_px``), keep-out box and opening as :func:`tendrilkit.segmentation.segment_view`,
  by the same function, :func:`tendrilkit.segmentation.label_foreground`,
  or the segmentation's own when given),
  components smaller than ``min_component_px`` dropped; no component is
  chosen;
* ``labels``: the 8-connected components of ``foreground`` (0: background);
* ``distance_px``: for every ROI pixel, the Euclidean distance in pixels to
  the nearest foreground pixel (0 on the tendril), float32 (OpenCV's 5 x 5
  chamfer distance: within 2 % of the exact one), computed when first read;
* ``skeleton_xy``: the one-pixel skeleton of ``foreground``, full-image pixel
  positions (optional);
* ``probability``: a soft tendril probability, a logistic function of how
  much darker than the threshold a pixel is (optional).

:func:`sample_distance` reads ``distance_px`` at sub-pixel positions
(bilinear): the data term of a curve fitted to the images, and the precision
measure of the verification. Until something reads the whole ``distance_px``,
it transforms only the box around the positions (the same values: see its
Notes), a third of the ROI for a curve on the tendril.

Example
-------
>>> import numpy as np
>>> img = np.full((40, 60, 3), 255, np.uint8)
>>> img[20:23, 5:55] = 20                                 # a dark horizontal bar
>>> ev = view_evidence(img, roi=[0, 0, 60, 40], keep_out=None, base_point_xy=[5, 21],
...                    opening_radius_px=0, min_component_px=10)
>>> sample_distance(ev, np.array([[30.0, 21.0], [30.0, 30.0]])).round(1).tolist()
[0.0, 8.0]
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np

from tendrilkit.segmentation import LabelledForeground, faint_options, grey_image, label_foreground
from tendrilkit.segmentation.foreground import _box
from tendrilkit.skeleton.thinning import thin_strips

__all__ = ["ViewEvidence", "view_evidence", "sample_distance", "roi_contains"]


@dataclass(frozen=True, eq=False)
class ViewEvidence:
    """The tendril's evidence in one view of one frame (ROI crop).

    Attributes
    ----------
    foreground : (h, w) bool array
        Dark pixels of the ROI crop (keep-out box painted background, opening
        applied, components under ``min_component_px`` dropped).
    labels : (h, w) int32 array
        Component label of every foreground pixel (1, 2, ...), 0 elsewhere.
    distance_px : (h, w) float32 array
        Distance of every crop pixel to the nearest foreground pixel, px
        (0 on the foreground; the crop's diagonal if there is none);
        computed when first read, read only.
    roi_offset_xy : (2,) int array
        Full-image pixel ``(x, y)`` of the crop's pixel ``[0, 0]``.
    base_point_xy : (2,) float array
        The base mark, full-image pixels.
    keep_out : (4,) int array or None
        The keep-out box ``[x, y, w, h]``, full-image pixels.
    skeleton_xy : (m, 2) float array or None
        Skeleton pixels of ``foreground``, full-image ``(x, y)``, sorted by
        row then column; None when not asked for.
    width_px : float
        Typical width of the dark structures: foreground area over skeleton
        length (NaN without skeleton or foreground).
    probability : (h, w) float32 array or None
        Soft tendril probability in [0, 1] (0.5 at the threshold), when asked.
    """

    foreground: np.ndarray
    labels: np.ndarray
    roi_offset_xy: np.ndarray
    base_point_xy: np.ndarray
    keep_out: np.ndarray | None = None
    skeleton_xy: np.ndarray | None = None
    width_px: float = float("nan")
    probability: np.ndarray | None = None

    @property
    def shape(self) -> tuple[int, int]:
        """``(h, w)`` of the ROI crop."""
        return self.foreground.shape

    @cached_property
    def distance_px(self) -> np.ndarray:
        """(h, w) float32: every crop pixel's distance to the nearest foreground pixel, px (see the class)."""
        fg = self.foreground.view(np.uint8)
        if fg.any():
            # the 5x5 chamfer mask: within 2 % of the exact Euclidean distance, 2-3 times faster than the exact one
            out = cv2.distanceTransform(cv2.compare(fg, 0, cv2.CMP_EQ), cv2.DIST_L2, 5)
        else:
            out = np.full(fg.shape, float(np.hypot(*fg.shape)), np.float32)
        out.flags.writeable = False
        return out

    @cached_property
    def _distance_boxes(self) -> list:
        """The boxes of the crop :func:`sample_distance` transformed so far: ``(r0, r1, c0, c1, D)`` (crop rows
        ``r0:r1``, columns ``c0:c1``, their float32 distance transform), read again by later calls."""
        return []

    @cached_property
    def inside_px(self) -> np.ndarray:
        """(h, w) float32: every foreground pixel's distance to the nearest board pixel, px (0 on the board).

        How deep inside a dark region a pixel lies: about half the local
        width on a line's middle. Computed once, when first read (the checks
        and the multi-view method both read it; read only), on the
        foreground's bounding box grown by one pixel: a foreground pixel's
        nearest background pixel is never farther than that box's rim, and the
        chamfer distance of a pixel inside the box only takes paths inside it
        (the values are those of the whole crop's transform, bit for bit).
        """
        fg = self.foreground.view(np.uint8)
        out = np.zeros(fg.shape, np.float32)
        x, y, w, h = cv2.boundingRect(fg)
        if w:  # on the foreground's box grown by a pixel (background, or the crop's edge): the same distances
            y0, y1, x0, x1 = max(y - 1, 0), min(y + h + 1, fg.shape[0]), max(x - 1, 0), min(x + w + 1, fg.shape[1])
            out[y0:y1, x0:x1] = cv2.distanceTransform(np.ascontiguousarray(fg[y0:y1, x0:x1]), cv2.DIST_L2, 5)
        out.flags.writeable = False
        return out

    def in_keep_out(self, xy: np.ndarray) -> np.ndarray:
        """(n,) bool: which full-image points ``xy`` (n, 2) lie in the keep-out box."""
        xy = np.asarray(xy, float).reshape(-1, 2)
        if self.keep_out is None:
            return np.zeros(len(xy), bool)
        x, y, w, h = self.keep_out
        return (xy[:, 0] >= x) & (xy[:, 0] < x + w) & (xy[:, 1] >= y) & (xy[:, 1] < y + h)


def view_evidence(
    image_bgr: np.ndarray,
    *,
    roi,
    keep_out,
    base_point_xy,
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
    skeleton: bool = True,
    probability: bool = False,
    probability_scale: float = 10.0,
    foreground: LabelledForeground | None = None,
) -> ViewEvidence:
    """The evidence of one view (see the module's docstring).

    Parameters
    ----------
    image_bgr : (H, W, 3) or (H, W) uint8 array
        The full frame, BGR.
    roi, keep_out : [x, y, w, h]
        The view's marks, full-image pixels (``keep_out`` may be None).
    base_point_xy : (2,) sequence of float
        The base mark, full-image pixels (kept for the checks).
    channel, threshold, opening_radius_px, local_contrast, local_noise_k, background_px, local_window_px,
    local_margin_px, local_exclude_dark, line_width_px, bridge_gap_px, min_component_px
        As in :func:`tendrilkit.segmentation.segment_view` (the experiment's
        ``segmentation:`` section).
    skeleton : bool
        Compute ``skeleton_xy`` and ``width_px`` (about 2 ms on a 1080p
        phantom view's ROI, by :func:`tendrilkit.skeleton.thinning.thin_strips`).
    probability : bool
        Compute ``probability``: :math:`1 / (1 + e^{(g - t) / c})` with ``g``
        the grey level, ``t`` the threshold (Otsu's or the fixed one) and
        ``c = probability_scale`` grey levels.
    probability_scale : float
        Grey levels over which the probability goes from 0.27 to 0.73.
    foreground : LabelledForeground, optional
        The labelled dark pixels of this image, ROI and keep-out box, made with
        the same ``channel``, ``threshold``, ``opening_radius_px`` and local options
        (:attr:`tendrilkit.segmentation.TendrilMask.foreground`): reused
        instead of thresholding and labelling the ROI again (the same result).

    Returns
    -------
    ViewEvidence

    Raises
    ------
    ValueError
        Malformed image, box or option.
    """
    if min_component_px < 0:
        raise ValueError(f"min_component_px must be >= 0, got {min_component_px}")
    if not probability_scale > 0:
        raise ValueError(f"probability_scale must be > 0, got {probability_scale}")
    local = faint_options(local_contrast, local_noise_k, background_px, local_window_px, local_margin_px,
                         local_exclude_dark)
    if foreground is None:
        foreground = label_foreground(image_bgr, roi=roi, keep_out=keep_out, channel=channel, threshold=threshold,
                                      opening_radius_px=opening_radius_px, **local, line_width_px=line_width_px,
                                      bridge_gap_px=bridge_gap_px)
    elif ((foreground.channel, foreground.threshold, foreground.opening_radius_px, tuple(foreground.local_options),
           tuple(foreground.line_options))
          != (channel, threshold, opening_radius_px, tuple(local.values()), (int(line_width_px), int(bridge_gap_px)))):
        raise ValueError("foreground was made with other segmentation options than channel, threshold, "
                         "opening_radius_px, the local_* and background_px, line_width_px and bridge_gap_px options")
    fg, offset, n, labels = foreground.foreground, foreground.roi_offset_xy, foreground.n_labels, foreground.labels
    mask = None
    if n > 1 and min_component_px > 1:
        small = foreground.areas < min_component_px  # the areas from the foreground's pixels, not the whole crop
        small[0] = False
        if small.any():
            remap = (np.cumsum(~small) - 1).astype(np.int32)  # background stays 0; kept labels renumbered 1, 2, ...
            remap[small] = 0
            rows, cols, lab = foreground.pixels  # relabel the foreground's pixels only (the rest stays 0)
            labels = np.zeros(labels.shape, np.int32)
            labels[rows, cols] = remap[lab]
            mask = labels > 0
    if mask is None:
        mask = fg > 0

    skel_xy, width = None, float("nan")
    if skeleton:
        skel_xy, width = _skeleton(mask, offset)

    prob = None
    if probability:
        img = np.asarray(image_bgr)
        h, w = mask.shape
        grey = grey_image(img[offset[1]:offset[1] + h, offset[0]:offset[0] + w], channel=channel).astype(np.float32)
        if threshold == "otsu":
            t, _ = cv2.threshold(grey.astype(np.uint8), 0, 255, cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU)
            t += 0.5  # grey <= t is foreground
        else:
            t = float(threshold) - 0.5
        prob = (1.0 / (1.0 + np.exp((grey - np.float32(t)) / np.float32(probability_scale)))).astype(np.float32)
        if keep_out is not None:
            kx, ky, kw, kh = _box(keep_out, "keep_out")
            prob[max(ky - offset[1], 0):max(ky + kh - offset[1], 0), max(kx - offset[0], 0):max(kx + kw - offset[0], 0)] = 0

    ko = None if keep_out is None else np.array(_box(keep_out, "keep_out"), int)
    return ViewEvidence(foreground=mask, labels=labels, roi_offset_xy=np.asarray(offset, int),
                        base_point_xy=np.asarray(base_point_xy, float).reshape(2), keep_out=ko,
                        skeleton_xy=skel_xy, width_px=width, probability=prob)


def _skeleton(mask: np.ndarray, offset: np.ndarray) -> tuple[np.ndarray, float]:
    """Skeleton pixels (m, 2) full-image xy of a mask, and area / skeleton length (px)."""
    m8 = mask.view(np.uint8)
    area = cv2.countNonZero(m8)  # the mask's area and box without listing its pixels (cv2.findNonZero)
    if area == 0:
        return np.zeros((0, 2)), float("nan")
    x0, y0, w, h = cv2.boundingRect(m8)  # a uint8 image: the box of its nonzero pixels
    sub = mask[y0:y0 + h, x0:x0 + w]
    # cv2.findNonZero: the pixels in np.nonzero's (raster) order, several times faster on a large sparse array
    sk = cv2.findNonZero(thin_strips(sub).view(np.uint8))
    sk = np.zeros((0, 2), np.int32) if sk is None else sk.reshape(-1, 2)
    xy = (sk + [x0 + offset[0], y0 + offset[1]]).astype(float)
    width = float(area) / max(len(xy), 1)
    return xy, width


def roi_contains(ev: ViewEvidence, xy: np.ndarray) -> np.ndarray:
    """(n,) bool: which full-image points ``xy`` (n, 2) lie inside the ROI crop."""
    xy = np.asarray(xy, float).reshape(-1, 2)
    h, w = ev.shape
    u = xy[:, 0] - ev.roi_offset_xy[0]
    v = xy[:, 1] - ev.roi_offset_xy[1]
    return (u >= 0) & (u <= w - 1) & (v >= 0) & (v <= h - 1)


def sample_distance(ev: ViewEvidence, xy: np.ndarray) -> np.ndarray:
    """Distance to the nearest foreground pixel at sub-pixel positions, px.

    Parameters
    ----------
    ev : ViewEvidence
    xy : (n, 2) float array
        Full-image positions ``(x, y)`` (x = column), e.g. a 3D curve
        projected into the view.

    Returns
    -------
    (n,) float array
        Bilinear interpolation of ``ev.distance_px``. A point outside the
        ROI crop gets the value at the nearest crop pixel plus its distance
        to the crop (continuous, and growing away from the ROI: a curve
        leaving the ROI is off the tendril). NaN where ``xy`` is NaN.

    Notes
    -----
    Plain numpy gather: about 10 µs for 200 points, 60 µs for 10 000, once
    ``distance_px`` is there. Before, only the box of the pixels read, grown
    by :data:`LOCAL_MARGIN_PX`, is transformed (:func:`_local_distance`): a
    foreground pixel outside that box is more than the margin away (the
    chamfer distance is at least the chessboard one), and the chamfer distance
    between two pixels of a box takes only paths inside it, so every value up
    to the margin is the whole ROI's, bit for bit; a larger one, or boxes
    over half the ROI, makes the whole ``distance_px``. The positions are
    boxed in runs of :data:`LOCAL_RUN` (a curve's positions come along it).
    """
    xy = np.asarray(xy, dtype=float).reshape(-1, 2)
    h, w = ev.shape
    u = xy[:, 0] - ev.roi_offset_xy[0]
    v = xy[:, 1] - ev.roi_offset_xy[1]
    uc = np.clip(u, 0.0, w - 1.0)
    vc = np.clip(v, 0.0, h - 1.0)
    bad = ~(np.isfinite(u) & np.isfinite(v))
    uc[bad] = 0.0
    vc[bad] = 0.0
    i0 = np.minimum(vc.astype(np.intp), max(h - 2, 0))
    j0 = np.minimum(uc.astype(np.intp), max(w - 2, 0))
    i1 = np.minimum(i0 + 1, h - 1)
    j1 = np.minimum(j0 + 1, w - 1)
    fv = vc - i0
    fu = uc - j0
    corners = None if "distance_px" in ev.__dict__ else _local_distance(ev, [i0, i0, i1, i1], [j0, j1, j0, j1], ~bad)
    if corners is None:
        D = ev.distance_px
        corners = D[i0, j0], D[i0, j1], D[i1, j0], D[i1, j1]
    d00, d01, d10, d11 = corners
    d = (d00 * (1 - fu) * (1 - fv) + d01 * fu * (1 - fv) + d10 * (1 - fu) * fv + d11 * fu * fv).astype(float)
    d += np.hypot(u - uc, v - vc)
    d[bad] = np.nan
    return d


#: Margin of the boxes :func:`sample_distance` transforms around the pixels it reads, px.
LOCAL_MARGIN_PX = 16
#: Consecutive positions per box: a curve's positions come in order along it, and the boxes of its short runs
#: cover much less of the ROI than the box of the whole curve.
LOCAL_RUN = 256


def _local_distance(ev: ViewEvidence, rows: list, cols: list, use: np.ndarray) -> list | None:
    """``ev.distance_px[rows[k], cols[k]]`` for every k, from boxes around the pixels read (see :func:`sample_distance`).

    ``rows``, ``cols``: lists of (n,) int arrays of crop pixels, one per
    corner of the bilinear interpolation; ``use``: (n,) bool, the positions
    whose values count (the others get 0). A position is first read from the
    boxes an earlier call transformed (:attr:`ViewEvidence._distance_boxes`:
    the checks read the same curve's surroundings several times) when each
    of its pixels' values is at most that pixel's distance to the box's
    sides inside the crop (the margin argument of :func:`sample_distance`,
    per pixel: the same values, bit for bit). The others are taken in runs of
    :data:`LOCAL_RUN`, each run's pixels from the transform of their own box
    grown by :data:`LOCAL_MARGIN_PX` (kept for later calls). None when the
    new boxes would not pay (over half the ROI together) or a value exceeds
    the margin: then the whole transform is needed.
    """
    h, w = ev.shape
    n = len(use)
    out = [np.zeros(n, np.float32) for _ in rows]
    todo = use.copy()
    kept = ev._distance_boxes
    if kept:
        # a position's pixels' rows and columns span (the bilinear corners: a pixel and its next)
        rmin, rmax = np.minimum.reduce(rows), np.maximum.reduce(rows)
        cmin, cmax = np.minimum.reduce(cols), np.maximum.reduce(cols)
    for r0, r1, c0, c1, D in kept:
        k = np.flatnonzero(todo)
        if len(k) == 0:
            break
        inside = (rmin[k] >= r0) & (rmax[k] < r1) & (cmin[k] >= c0) & (cmax[k] < c1)
        k = k[inside]
        # the margin of all of a position's pixels: their least chessboard distance to the box's sides that are
        # not the crop's
        margin = np.full(len(k), np.inf)
        if r0 > 0:
            margin = np.minimum(margin, rmin[k] - r0)
        if r1 < h:
            margin = np.minimum(margin, r1 - 1 - rmax[k])
        if c0 > 0:
            margin = np.minimum(margin, cmin[k] - c0)
        if c1 < w:
            margin = np.minimum(margin, c1 - 1 - cmax[k])
        vals = [D[a[k] - r0, b[k] - c0] for a, b in zip(rows, cols)]
        done = np.all([v <= margin for v in vals], axis=0) if len(k) else np.zeros(0, bool)
        for o, v in zip(out, vals):
            o[k[done]] = v[done]
        todo[k[done]] = False
    boxes = []
    for s in range(0, n, LOCAL_RUN):
        u = todo[s:s + LOCAL_RUN]
        if not u.any():
            continue
        r = np.concatenate([a[s:s + LOCAL_RUN][u] for a in rows])
        c = np.concatenate([a[s:s + LOCAL_RUN][u] for a in cols])
        m = LOCAL_MARGIN_PX
        boxes.append((s, max(int(r.min()) - m, 0), min(int(r.max()) + m + 1, h), max(int(c.min()) - m, 0),
                      min(int(c.max()) + m + 1, w)))
    if sum((r1 - r0) * (c1 - c0) for _, r0, r1, c0, c1 in boxes) > 0.5 * h * w:
        return None
    for s, r0, r1, c0, c1 in boxes:
        sub = np.ascontiguousarray(ev.foreground[r0:r1, c0:c1]).view(np.uint8)
        if not sub.any():
            return None
        D = cv2.distanceTransform(cv2.compare(sub, 0, cv2.CMP_EQ), cv2.DIST_L2, 5)
        kept.append((r0, r1, c0, c1, D))
        u = todo[s:s + LOCAL_RUN]
        for v, a, b in zip(out, rows, cols):
            vals = D[a[s:s + LOCAL_RUN][u] - r0, b[s:s + LOCAL_RUN][u] - c0]
            if vals.max() > LOCAL_MARGIN_PX:
                return None
            v[s:s + LOCAL_RUN][u] = vals
    return out
