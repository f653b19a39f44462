"""Seeded synthetic calibration scenes with exact ground truth (for tests and benchmarks).

A flat board with the world marker and five other ArUco markers, rendered
through a camera by ray/board intersection (:func:`render_board`), and marker
corners around the working volume, on and off the board, observed with
Gaussian noise (:func:`synthetic_markers`, :func:`observe_markers`). The rig
is the paper's with a lens distortion (:func:`distorted_rig`).
"""

from __future__ import annotations

import cv2
import numpy as np

from tendrilkit.calibration.ijcv25 import ijcv25_rig
from tendrilkit.camera import Camera, rotation_from_rvec
from tendrilkit.geometry import marker_corners

__all__ = ["BOARD", "BOARD_MARKERS", "DICT", "DIST", "L", "WORLD_ID", "board_scene", "distorted_rig", "observe_markers",
           "render_board", "rot_err_deg", "synthetic_markers", "working_volume"]

DICT = "DICT_ARUCO_ORIGINAL"
WORLD_ID = 815
L = 24.0
DIST = np.array([-0.09, 0.06, 0.0008, -0.0005, 0.0])

TEX_MM = L / 280.0  # texel size: the world marker is 280 texels (7 cells x 40)
BOARD = (-60.0, 200.0, -200.0, 150.0)  # x_min, x_max, y_min, y_max on the board, mm
#: other markers on the board: id -> (centre x, centre y, side), mm
BOARD_MARKERS = {
    7: (70.0, -130.0, 30.0),
    23: (165.0, -110.0, 30.0),
    42: (160.0, 80.0, 30.0),
    101: (20.0, 100.0, 30.0),
    250: (-30.0, -80.0, 24.0),
}


def board_texture(markers: dict[int, tuple[float, float, float]]) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """Board texture (grey float) and the exact world corners (4, 3) of each marker."""
    x0, x1, y0, y1 = BOARD
    w, h = int(round((x1 - x0) / TEX_MM)), int(round((y1 - y0) / TEX_MM))
    tex = np.full((h, w), 225.0, np.float32)
    dic = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, DICT))
    corners = {}
    for mid, (cx, cy, side) in markers.items():
        n = int(round(side / TEX_MM / 7)) * 7
        col = int(round((cx - x0) / TEX_MM - n / 2))
        row = int(round((y1 - cy) / TEX_MM - n / 2))
        img = cv2.aruco.generateImageMarker(dic, mid, n)
        tex[row:row + n, col:col + n] = np.where(img > 127, 225.0, 25.0)
        # texel i covers [x0 + i*TEX_MM, x0 + (i+1)*TEX_MM)
        left, top = x0 + col * TEX_MM, y1 - row * TEX_MM
        s = n * TEX_MM
        corners[mid] = np.array([[left, top, 0], [left + s, top, 0], [left + s, top - s, 0], [left, top - s, 0]])
    return tex, corners


def board_scene(markers: dict | None = None) -> tuple[np.ndarray, dict[int, np.ndarray]]:
    """The board texture and the exact world corners (4, 3) mm of the world marker and ``markers``
    (default :data:`BOARD_MARKERS`: id -> (centre x, centre y, side) mm)."""
    m = {WORLD_ID: (0.0, 0.0, L), **(BOARD_MARKERS if markers is None else markers)}
    return board_texture(m)


def render_board(camera: Camera, tex: np.ndarray, *, rng: np.random.Generator, blur_px: float = 0.7,
           noise: float = 2.0, ss: int = 2, corners: dict[int, np.ndarray] | None = None) -> np.ndarray:
    """BGR frame of the board through ``camera`` (ray/board intersection + remap).

    With ``corners`` (the markers' world corners) only windows around the
    markers are ray-traced (2 x 2 sub-samples per pixel); the rest of the
    board is blank (225) anyway.
    """
    x0, x1, y0, y1 = BOARD
    W, H = camera.width, camera.height
    if corners is None:
        windows = [(0, 0, W, H)]
    else:
        windows = []
        for X in corners.values():
            c = X.mean(0)
            xy = camera.project(c + 1.6 * (X - c))  # the marker and a margin around it
            lo = np.clip(np.floor(xy.min(0)) - 8, 0, [W, H]).astype(int)
            hi = np.clip(np.ceil(xy.max(0)) + 8, 0, [W, H]).astype(int)
            windows.append((lo[0], lo[1], hi[0], hi[1]))
    img = np.full((H, W), 225.0, np.float32)
    off = (np.arange(ss) + 0.5) / ss - 0.5
    C = camera.center_world
    for wx0, wy0, wx1, wy1 in windows:
        if wx1 <= wx0 or wy1 <= wy0:
            continue
        gx, gy = np.meshgrid(np.arange(wx0, wx1), np.arange(wy0, wy1))
        acc = np.zeros(gx.shape, np.float32)
        for dy in off:
            for dx in off:
                xy = np.stack([gx + dx, gy + dy], -1).reshape(-1, 1, 2).astype(np.float64)
                nrm = cv2.undistortPoints(xy, camera.K, camera.dist).reshape(-1, 2)
                rays = np.hstack([nrm, np.ones((len(nrm), 1))]) @ camera.R  # world directions (R^T r)
                s_ = -C[2] / rays[:, 2]
                mu = ((C[0] + s_ * rays[:, 0] - x0) / TEX_MM - 0.5).reshape(gx.shape).astype(np.float32)
                mv = ((y1 - (C[1] + s_ * rays[:, 1])) / TEX_MM - 0.5).reshape(gx.shape).astype(np.float32)
                acc += cv2.remap(tex, mu, mv, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=225.0)
        img[wy0:wy1, wx0:wx1] = acc / (ss * ss)
    if blur_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), blur_px)
    img = img + rng.normal(0, noise, img.shape)
    g = np.clip(np.round(img), 0, 255).astype(np.uint8)
    return cv2.merge([g, g, g])


def distorted_rig() -> list[Camera]:
    """The paper's rig (:func:`~tendrilkit.calibration.ijcv25.ijcv25_rig`) with the lens distortion :data:`DIST`."""
    return [Camera(c.K, DIST, c.R, c.t_mm, c.width, c.height) for c in ijcv25_rig()]


def working_volume(n: int = 400, seed: int = 0) -> np.ndarray:
    """Points 100-150 mm from the marker where the tendril hangs (below it, in front of the board)."""
    rng = np.random.default_rng(seed)
    P = np.column_stack([rng.uniform(40, 160, 4 * n), rng.uniform(-80, 40, 4 * n), rng.uniform(5, 60, 4 * n)])
    d = np.linalg.norm(P, axis=1)
    return P[(d >= 100) & (d <= 150)][:n]


def rot_err_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """Angle (degrees) of the rotation between two rotation matrices (3, 3)."""
    c = (np.trace(Ra.T @ Rb) - 1) / 2
    return float(np.degrees(np.arccos(np.clip(c, -1, 1))))


def synthetic_markers(rng: np.random.Generator) -> dict[int, np.ndarray]:
    """World corners of markers around the working volume, on and off the board."""
    out = {WORLD_ID: marker_corners(L)}
    for mid, (cx, cy, s) in BOARD_MARKERS.items():
        out[mid] = marker_corners(s) + [cx, cy, 0.0]
    # two on stands, tilted towards the cameras
    for mid, c, rv in ((301, (120.0, -60.0, 40.0), (0.3, 0.2, 0.1)), (302, (60.0, 60.0, 30.0), (-0.2, 0.3, 0.0))):
        out[mid] = marker_corners(20.0) @ rotation_from_rvec(np.array(rv)).T + c
    out[303] = marker_corners(30.0) + [120.0, -20.0, 4.0]  # parallel to the board, 4 mm above it
    return out


def observe_markers(cams: list[Camera], markers: dict[int, np.ndarray], rng: np.random.Generator,
                    sigma_px: float) -> dict[int, dict[int, np.ndarray]]:
    """``{view_index: {marker_id: corners (4, 2) px}}``: exact projections plus Gaussian noise ``sigma_px``."""
    obs = {}
    for v, cam in enumerate(cams):
        obs[v] = {m: cam.project(X) + rng.normal(0, sigma_px, (4, 2)) for m, X in markers.items()}
    return obs
