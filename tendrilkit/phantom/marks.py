"""The marks a user makes on frame 0 of a phantom: ROI and keep-out box per view."""

from __future__ import annotations

import math

import cv2
import numpy as np

from tendrilkit.camera import Camera
from tendrilkit.phantom.design import _ROI_MARGIN_PX
from tendrilkit.phantom.projection import _mm_per_px
from tendrilkit.phantom.scene import Scene

def keep_out_box(cam: Camera, curves: np.ndarray, s_mm: np.ndarray, scene: Scene, diameter_mm: float) -> tuple[list[int], float]:
    """Keep-out box (x, y, w, h) over the node where the tendril leaves it, and the hidden length.

    ``curves`` (k, n, 3): frame 0 first, then other times of the sequence; the
    box separates the tendril from the stem in all of them, the hidden length
    (arc length from the base to where the centreline leaves the box) is
    frame 0's.
    """
    curve = curves[0]
    H, W = cam.height, cam.width
    # full-resolution masks near the node
    node_xy = cam.project(scene.node_mm[None])[0]
    half = 80
    x0, y0 = int(node_xy[0]) - half, int(node_xy[1]) - half
    shape = (2 * half, 2 * half)

    def tube(pts, rad):
        m = np.zeros(shape, np.uint8)
        xy = cam.project(pts) - [x0, y0]
        depth = cam.world_to_cam(pts)[:, 2]
        r = np.broadcast_to(rad, (len(pts),)) / depth * cam.K[0, 0]
        for (x, y), rr in zip(xy, r):
            cv2.circle(m, (int(round(x * 16)), int(round(y * 16))), max(1, int(round(rr * 16))), 1, -1, cv2.LINE_8, 4)
        return m

    near = np.linalg.norm(scene.stem_mm[:, :2] - scene.node_mm[None, :2], axis=1) < 30.0
    dark = tube(scene.stem_mm[near], scene.stem_radius_mm[near]) | tube(scene.node_mm[None], scene.node_radius_mm)
    sel = s_mm <= 30.0
    ten = np.zeros(shape, np.uint8)
    for c in curves:
        ten |= tube(c[sel], diameter_mm / 2)
    b = cam.project(curve[:1])[0] - [x0, y0]
    # start: a few pixels around the base, then grow until, outside the box, no
    # tendril pixel is within 2 px of a stem/node pixel (the components separate)
    bx0, by0 = int(math.floor(b[0])) - 2, int(math.floor(b[1])) - 2
    bx1, by1 = int(math.ceil(b[0])) + 2, int(math.ceil(b[1])) + 2
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))  # 2 px gap
    for _ in range(30):
        box = np.zeros(shape, bool)
        box[max(by0, 0):by1 + 1, max(bx0, 0):bx1 + 1] = True
        t_out = ten.astype(bool) & ~box
        d_out = dark.astype(bool) & ~box
        touch = cv2.dilate(t_out.astype(np.uint8), kernel).astype(bool) & d_out
        if not touch.any():
            break
        ys, xs = np.nonzero(touch)
        bx0, by0 = min(bx0, xs.min()), min(by0, ys.min())
        bx1, by1 = max(bx1, xs.max()), max(by1, ys.max())
    xy = cam.project(curve) - [x0, y0]
    inside = ((xy >= [bx0, by0]) & (xy <= [bx1, by1])).all(axis=1)
    first_out = int(np.argmin(inside)) if not inside.all() else len(inside)
    hidden = float(s_mm[first_out - 1]) if first_out > 0 else 0.0
    box = [int(bx0 + x0), int(by0 + y0), int(bx1 - bx0 + 1), int(by1 - by0 + 1)]
    box[0], box[1] = max(box[0], 0), max(box[1], 0)
    box[2], box[3] = min(box[2], W - box[0]), min(box[3], H - box[1])
    return box, hidden


def roi_box(cam: Camera, curves: np.ndarray, diameter_mm: float) -> list[int]:
    """ROI (x, y, w, h) px: the tendril's extent over ``curves`` (k, n, 3) mm, grown by its radius and 40 px."""
    xy = cam.project(curves.reshape(-1, 3))
    r = diameter_mm / 2 / _mm_per_px(cam, curves.reshape(-1, 3).mean(axis=0))
    lo = np.floor(xy.min(axis=0) - r - _ROI_MARGIN_PX).astype(int)
    hi = np.ceil(xy.max(axis=0) + r + _ROI_MARGIN_PX).astype(int)
    lo = np.maximum(lo, 0)
    hi = np.minimum(hi, [cam.width - 1, cam.height - 1])
    return [int(lo[0]), int(lo[1]), int(hi[0] - lo[0] + 1), int(hi[1] - lo[1] + 1)]


#: The last few phantoms made (tests and the writer ask for the same ones repeatedly);

