"""Evidence of the tendril in one view for the multi-view fit (:mod:`tendrilkit.multiview`).

Prototype of the per-view evidence (the trust issue's ``evidence`` module will
replace it): no decision is taken in a view. Every dark pixel of the region of
interest outside the keep-out box is foreground (no component is chosen), its
skeleton is kept whole, and the distance of every pixel to the nearest
skeleton pixel is the field the 3D curve's projection is pulled onto.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from scipy.spatial import cKDTree

from tendrilkit.camera import Camera
from tendrilkit.exceptions import TendrilLostError
from tendrilkit.segmentation import grey_image
from tendrilkit.skeleton import _skeletonize_strips

__all__ = ["ViewEvidence", "view_evidence", "sample_distance"]


@dataclass(frozen=True, eq=False)
class ViewEvidence:
    """The tendril's evidence in one view, on the region of interest's crop.

    Attributes
    ----------
    offset_xy : (2,) int array
        Full-image pixel ``(x, y)`` of the crop's pixel ``[0, 0]``.
    foreground : (h, w) bool array
        Dark pixels of the ROI (keep-out box painted background, opened).
    skeleton : (h, w) bool array
        Skeleton of ``foreground`` (components under ``min_component_px``
        pixels of foreground dropped).
    skeleton_xy : (k, 2) float array
        The skeleton's pixels, full-image ``(x, y)``.
    tree : scipy.spatial.cKDTree
        Of ``skeleton_xy``: the nearest skeleton pixel of any point.
    centre_xy, tangent_xy : (k, 2) float arrays
        Per skeleton pixel, the mean of the skeleton pixels within 3.5 px
        and their principal direction (unit): the skeleton as short line
        pieces, for sub-pixel distances.
    near_foreground : (h, w) bool array
        Foreground dilated by 2 px: a point projecting outside it is on the
        board in that view (the view contradicts it).
    seen : (h, w) bool array
        Pixels where the view can see the tendril: inside the ROI and the
        image, outside the keep-out box.
    camera : Camera
    """

    offset_xy: np.ndarray
    foreground: np.ndarray
    skeleton: np.ndarray
    skeleton_xy: np.ndarray
    tree: cKDTree
    centre_xy: np.ndarray
    tangent_xy: np.ndarray
    near_foreground: np.ndarray
    seen: np.ndarray
    camera: Camera


def _crop(box, W: int, H: int) -> tuple[int, int, int, int]:
    x, y, w, h = (int(round(float(v))) for v in box)
    return max(x, 0), max(y, 0), min(x + w, W), min(y + h, H)


def view_evidence(image_bgr: np.ndarray, camera: Camera, *, roi, keep_out, channel: str = "blue",
                  threshold: str | int = "otsu", opening_radius_px: int = 1,
                  min_component_px: int = 50) -> ViewEvidence:
    """Foreground, skeleton and distance field of one view's ROI.

    Parameters
    ----------
    image_bgr : (H, W, 3) uint8 array
        The full frame.
    camera : Camera
        The view's calibrated camera (kept with the evidence).
    roi, keep_out : [x, y, w, h]
        The experiment file's marks, full-image pixels (``keep_out`` may be None).
    channel, threshold, opening_radius_px, min_component_px
        As in :func:`tendrilkit.segmentation.segment_view`.

    Returns
    -------
    ViewEvidence

    Raises
    ------
    TendrilLostError
        No foreground component of ``min_component_px`` pixels in the ROI.
    """
    img = np.asarray(image_bgr)
    H, W = img.shape[:2]
    x0, y0, x1, y1 = _crop(roi, W, H)
    if x1 - x0 < 2 or y1 - y0 < 2:
        raise ValueError(f"roi {list(roi)} does not overlap the {W}x{H} image")
    grey = grey_image(img[y0:y1, x0:x1], channel=channel)
    if threshold == "otsu":
        _, fg = cv2.threshold(grey, 0, 255, cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU)
    else:
        _, fg = cv2.threshold(grey, int(threshold) - 1, 255, cv2.THRESH_BINARY_INV)
    seen = np.ones(fg.shape, bool)
    if keep_out is not None:
        kx0, ky0, kx1, ky1 = _crop(keep_out, W, H)
        a0, b0, a1, b1 = kx0 - x0, ky0 - y0, kx1 - x0, ky1 - y0
        if a1 > max(a0, 0) and b1 > max(b0, 0):
            fg[max(b0, 0):b1, max(a0, 0):a1] = 0
            seen[max(b0, 0):b1, max(a0, 0):a1] = False
    if opening_radius_px > 0:
        r = int(opening_radius_px)
        fg = cv2.morphologyEx(fg, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1)))
    n, labels, stats, _ = cv2.connectedComponentsWithStats(fg, connectivity=8)
    small = np.nonzero(stats[:, cv2.CC_STAT_AREA] < max(min_component_px, 1))[0]
    small = small[small > 0]
    if len(small):
        fg[np.isin(labels, small)] = 0
    if not fg.any():
        raise TendrilLostError(f"no component of at least {min_component_px} px in the roi {list(roi)}")
    skel = _skeletonize_strips(fg).astype(bool)
    rc = np.argwhere(skel)
    if len(rc) < 3:
        raise TendrilLostError(f"the foreground of the roi {list(roi)} thins to {len(rc)} skeleton pixel(s)")
    xy = np.column_stack([rc[:, 1] + x0, rc[:, 0] + y0]).astype(float)
    tree = cKDTree(xy)
    centre, tangent = _local_lines(xy, tree)
    return ViewEvidence(offset_xy=np.array([x0, y0]), foreground=fg > 0, skeleton=skel, skeleton_xy=xy,
                        tree=tree, centre_xy=centre, tangent_xy=tangent,
                        near_foreground=cv2.dilate(fg, np.ones((5, 5), np.uint8)) > 0, seen=seen, camera=camera)


def _local_lines(xy: np.ndarray, tree: cKDTree, radius_px: float = 3.5, k: int = 9):
    """Per skeleton pixel, the centre (k, 2) and unit tangent (k, 2) of its neighbours within ``radius_px``."""
    dd, idx = tree.query(xy, k=min(k, len(xy)), distance_upper_bound=radius_px)
    ok = np.isfinite(dd)
    nb = xy[np.where(ok, idx, 0)]
    w = ok.astype(float)
    n = w.sum(axis=1, keepdims=True)
    c = (nb * w[..., None]).sum(axis=1) / n
    r = (nb - c[:, None, :]) * w[..., None]
    sxx, syy, sxy = (r[..., 0] ** 2).sum(1), (r[..., 1] ** 2).sum(1), (r[..., 0] * r[..., 1]).sum(1)
    ang = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    return c, np.column_stack([np.cos(ang), np.sin(ang)])


def sample_distance(ev: ViewEvidence, points_xy: np.ndarray, *, outside_px: float = 50.0, index: bool = False):
    """Distance to the skeleton at full-image pixels, with its gradient.

    Parameters
    ----------
    ev : ViewEvidence
    points_xy : (n, 2) float array
        Full-image pixels (NaN allowed).
    outside_px : float
        Distances are capped at this; also the value outside the ROI.

    Returns
    -------
    d : (n,) float array
        Distance to the nearest skeleton pixel, pixels.
    grad : (n, 2) float array
        ``(dd/dx, dd/dy)`` (unit vector away from that pixel; zero on it or beyond the cap).
    seen : (n,) bool array
        The view sees that place (inside the ROI, outside the keep-out box).
    nearest : (n,) int array
        With ``index``: the row of ``skeleton_xy`` nearest each point (-1: none within ``outside_px``).
    background : (n,) bool array
        With ``index``: seen, and on the board (outside ``near_foreground``).
    """
    p = np.asarray(points_xy, float)
    x = p[:, 0] - ev.offset_xy[0]
    y = p[:, 1] - ev.offset_xy[1]
    h, w = ev.seen.shape
    ok = np.isfinite(x) & np.isfinite(y) & (x >= -0.5) & (y >= -0.5) & (x < w - 0.5) & (y < h - 0.5)
    d = np.full(len(p), float(outside_px))
    g = np.zeros((len(p), 2))
    seen = np.zeros(len(p), bool)
    nearest = np.full(len(p), -1)
    background = np.zeros(len(p), bool)
    if ok.any():
        dd, idx = ev.tree.query(p[ok], distance_upper_bound=outside_px)
        near = np.isfinite(dd)
        # distance to the local line piece of the nearest skeleton pixel, beyond its ends to the piece
        j = idx[near]
        diff = p[ok][near] - ev.centre_xy[j]
        t = ev.tangent_xy[j]
        nrm = np.column_stack([-t[:, 1], t[:, 0]])
        dn = np.einsum("ka,ka->k", diff, nrm)
        dt = np.einsum("ka,ka->k", diff, t)
        ex = np.maximum(np.abs(dt) - 1.0, 0.0)
        dl = np.hypot(dn, ex)
        gl = (dn[:, None] * nrm + (ex * np.sign(dt))[:, None] * t) / np.maximum(dl, 1e-9)[:, None]
        gl[dl < 1e-9] = nrm[dl < 1e-9]
        gg = np.zeros((ok.sum(), 2))
        gg[near] = gl
        dv = np.full(ok.sum(), float(outside_px))
        dv[near] = dl
        d[ok] = dv
        g[ok] = gg
        yi, xi = np.rint(y[ok]).astype(int), np.rint(x[ok]).astype(int)
        seen[ok] = ev.seen[yi, xi]
        nearest[ok] = np.where(near, idx, -1)
        background[ok] = seen[ok] & ~ev.near_foreground[yi, xi]
    return (d, g, seen, nearest, background) if index else (d, g, seen)
