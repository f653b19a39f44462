"""The phantom's cameras and the projections its generator and renderer share.

:func:`phantom_cameras` is the IJCV25 rig with a small lens distortion per
view; the helpers project world points safely (no fold-back of the
distortion polynomial far outside the image) and map pixels back onto the
board plane.
"""

from __future__ import annotations

import numpy as np

from tendrilkit.camera import Camera

def phantom_cameras(seed: int = 0, *, distortion: bool = True) -> list[Camera]:
    """The IJCV25 rig's true poses and intrinsics with a small lens distortion per view.

    ``k1`` in [-0.06, 0.06], ``k2`` in [-0.02, 0.02], tangential ``p1, p2``
    within 5e-4, drawn from ``seed``; ``distortion=False`` gives zeros.
    """
    from tendrilkit.calibration import ijcv25_rig

    rig = ijcv25_rig()
    rng = np.random.default_rng([int(seed), 7])
    out = []
    for cam in rig:
        d = np.array([rng.uniform(-0.06, 0.06), rng.uniform(-0.02, 0.02),
                      rng.uniform(-5e-4, 5e-4), rng.uniform(-5e-4, 5e-4), 0.0])
        d = np.round(d, 5) if distortion else np.zeros(5)
        out.append(Camera(cam.K.copy(), d, cam.R.copy(), cam.t_mm.copy(), cam.width, cam.height))
    return out


def _pixel_to_board(cam: Camera, xy: np.ndarray) -> np.ndarray:
    """Board-plane (z = 0) world coordinates (n, 2) mm of observed pixels (n, 2)."""
    und = cam.undistort_points(xy)
    rays_cam = np.hstack([und, np.ones((len(und), 1))]) @ np.linalg.inv(cam.K).T
    rays = rays_cam @ cam.R  # R^T applied to each row
    c = cam.center_world
    lam = -c[2] / rays[:, 2]
    return c[None, :2] + lam[:, None] * rays[:, :2]


def _project_safe(cam: Camera, pts_mm: np.ndarray, *, pad_px: float = 150.0) -> np.ndarray:
    """Distorted pixels (n, 2) of world points; NaN far outside the image.

    The polynomial distortion model folds back beyond some field angle, which
    would map points far outside the field of view into the image; points
    whose pinhole projection lies more than ``pad_px`` outside are NaN.
    """
    p0 = cam.project(pts_mm, distort=False)
    p = cam.project(pts_mm)
    far = ~cam.in_image(np.nan_to_num(p0, nan=-1e9), margin_px=-pad_px) | (cam.world_to_cam(pts_mm)[:, 2] <= 0)
    p[far] = np.nan
    return p


def _project_poly(cam: Camera, pts_mm: np.ndarray) -> np.ndarray:
    """Pixels (n, 2) of a polygon's vertices: distorted near the image, pinhole far outside."""
    p = _project_safe(cam, pts_mm)
    bad = ~np.all(np.isfinite(p), axis=1)
    p[bad] = cam.project(pts_mm[bad], distort=False)
    return p


def _mm_per_px(cam: Camera, point_mm: np.ndarray) -> float:
    c = cam.world_to_cam(point_mm[None])[0]
    return float(c[2] / cam.K[0, 0])

