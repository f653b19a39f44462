"""Calibration boards: their description, detection, and synthetic board videos.

A board is given on the command line as

- ``charuco:SQUARES_X,SQUARES_Y,SQUARE_MM,MARKER_MM,DICT`` (OpenCV's ChArUco
  board: squares along x and y, the side of a chessboard square and of an
  ArUco marker in mm, a ``cv2.aruco`` dictionary name), or
- ``checkerboard:COLS,ROWS,SQUARE_MM`` (a plain chessboard: COLS x ROWS
  *inner* corners, as OpenCV counts them; a board of 10 x 7 squares has
  9 x 6 inner corners).

:func:`parse_board` reads that text; :func:`detect_board` finds the board's
corners in one image (``cv2.aruco.CharucoDetector`` or
``cv2.findChessboardCornersSB``); :func:`render_board_frames` draws the board
through a pinhole camera with lens distortion at seeded, varied poses (exact
ground truth for the tests of :mod:`tendrilkit.intrinsics`).

Board frame: origin at the pattern's top-left corner, x to the right, y
down the printed page, z into the page; millimetres. The corners' object
points are ``(n, 3)`` with z = 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from tendrilkit.camera import Camera, rotation_from_rvec

__all__ = ["Board", "parse_board", "detect_board", "render_board_frames", "board_poses"]


@dataclass(frozen=True)
class Board:
    """A calibration board.

    Attributes
    ----------
    kind : {"charuco", "checkerboard"}
    nx, ny : int
        ChArUco: squares along x and y. Checkerboard: inner corners along x and y.
    square_mm : float
        Side of a chessboard square, mm.
    marker_mm : float
        Side of an ArUco marker (ChArUco only; 0 for a checkerboard), mm.
    dictionary : str
        ``cv2.aruco`` dictionary name (ChArUco only).
    """

    kind: str
    nx: int
    ny: int
    square_mm: float
    marker_mm: float = 0.0
    dictionary: str = ""

    @property
    def text(self) -> str:
        """The board as written on the command line."""
        if self.kind == "charuco":
            return f"charuco:{self.nx},{self.ny},{self.square_mm:g},{self.marker_mm:g},{self.dictionary}"
        return f"checkerboard:{self.nx},{self.ny},{self.square_mm:g}"

    def opencv_board(self):
        """The ``cv2.aruco.CharucoBoard`` (ChArUco only)."""
        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.nx, self.ny), float(self.square_mm), float(self.marker_mm), d)

    def object_points(self) -> np.ndarray:
        """Every corner of the board, (n, 3) float mm, indexed by corner id."""
        if self.kind == "charuco":
            return np.asarray(self.opencv_board().getChessboardCorners(), float).reshape(-1, 3)
        j, i = np.mgrid[0:self.ny, 0:self.nx]
        P = np.zeros((self.nx * self.ny, 3))
        P[:, 0] = (i.ravel() + 1) * self.square_mm
        P[:, 1] = (j.ravel() + 1) * self.square_mm
        return P

    @property
    def size_mm(self) -> tuple[float, float]:
        """Width and height of the pattern (squares only, no white margin), mm."""
        if self.kind == "charuco":
            return self.nx * self.square_mm, self.ny * self.square_mm
        return (self.nx + 1) * self.square_mm, (self.ny + 1) * self.square_mm

    @property
    def n_corners(self) -> int:
        return (self.nx - 1) * (self.ny - 1) if self.kind == "charuco" else self.nx * self.ny


def parse_board(text: str) -> Board:
    """Read ``charuco:SX,SY,SQUARE_MM,MARKER_MM,DICT`` or ``checkerboard:COLS,ROWS,SQUARE_MM``.

    Raises
    ------
    ValueError
        One line naming the part that is wrong and what was expected.
    """
    expect = ("expected charuco:SQUARES_X,SQUARES_Y,SQUARE_MM,MARKER_MM,DICT "
              "(e.g. charuco:7,5,30,22,DICT_5X5_100) or checkerboard:COLS,ROWS,SQUARE_MM (inner corners, "
              "e.g. checkerboard:9,6,25)")
    kind, _, rest = str(text).partition(":")
    parts = [p.strip() for p in rest.split(",")]
    kind = kind.strip().lower()
    try:
        if kind == "charuco" and len(parts) == 5:
            nx, ny, sq, mk, dic = int(parts[0]), int(parts[1]), float(parts[2]), float(parts[3]), parts[4].upper()
            if not dic.startswith("DICT_"):
                dic = "DICT_" + dic
            if not hasattr(cv2.aruco, dic):
                raise ValueError(f"--board: unknown ArUco dictionary {parts[4]!r}; expected a cv2.aruco name such as DICT_5X5_100")
            if nx < 3 or ny < 3:
                raise ValueError(f"--board: a ChArUco board needs at least 3 x 3 squares, got {nx} x {ny}")
            if not 0 < mk < sq:
                raise ValueError(f"--board: expected 0 < MARKER_MM ({mk:g}) < SQUARE_MM ({sq:g})")
            n_markers = (nx * ny) // 2
            size = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, dic)).bytesList.shape[0]
            if n_markers > size:
                raise ValueError(f"--board: {nx} x {ny} squares need {n_markers} markers but {dic} has {size}")
            return Board("charuco", nx, ny, sq, mk, dic)
        if kind == "checkerboard" and len(parts) == 3:
            nx, ny, sq = int(parts[0]), int(parts[1]), float(parts[2])
            if nx < 3 or ny < 3:
                raise ValueError(f"--board: a checkerboard needs at least 3 x 3 inner corners, got {nx} x {ny}")
            if not sq > 0:
                raise ValueError(f"--board: expected SQUARE_MM > 0, got {sq:g}")
            return Board("checkerboard", nx, ny, sq)
    except ValueError as e:
        if str(e).startswith("--board"):
            raise
        raise ValueError(f"--board: {text!r}: {expect}") from None
    raise ValueError(f"--board: {text!r}: {expect}")


# ------------------------------------------------------------------ detection
def _grey(image: np.ndarray) -> np.ndarray:
    img = np.asarray(image)
    if img.ndim == 3:
        return cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    return img


def detect_board(image_bgr: np.ndarray, board: Board, *, min_corners: int = 6) -> tuple[np.ndarray, np.ndarray] | None:
    """The board's corners in one image.

    Parameters
    ----------
    image_bgr : (h, w, 3) uint8 array (or (h, w) grey)
    board : Board
    min_corners : int, keyword-only
        Fewer detected corners count as no detection.

    Returns
    -------
    (ids, corners_xy) or None
        ``ids`` (n,) int: indices into :meth:`Board.object_points`;
        ``corners_xy`` (n, 2) float: observed (distorted) pixels, x = column.
        A checkerboard is found whole or not at all (its 180-degree symmetry
        makes the ids ambiguous, which does not matter for intrinsics).
    """
    grey = _grey(image_bgr)
    if board.kind == "charuco":
        det = cv2.aruco.CharucoDetector(board.opencv_board())
        cc, ci, _, _ = det.detectBoard(grey)
        if ci is None or len(ci) < min_corners:
            return None
        ids = np.asarray(ci, int).ravel()
        xy = np.asarray(cc, float).reshape(-1, 2)
        return ids, xy
    flags = cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_ACCURACY
    ok, corners = cv2.findChessboardCornersSB(grey, (board.nx, board.ny), flags=flags)
    if not ok or corners is None:
        return None
    xy = np.asarray(corners, float).reshape(-1, 2)
    return np.arange(len(xy)), xy


# ------------------------------------------------------------------ rendering
def _texture(board: Board, px_per_mm: float) -> tuple[np.ndarray, float]:
    """The printed page (grey uint8) with a white margin of one square; and the margin, mm."""
    margin_mm = board.square_mm
    w_mm, h_mm = board.size_mm
    W, H = int(round(w_mm * px_per_mm)), int(round(h_mm * px_per_mm))
    if board.kind == "charuco":
        pat = board.opencv_board().generateImage((W, H), marginSize=0, borderBits=1)
    else:
        sq = board.square_mm * px_per_mm
        yy, xx = np.mgrid[0:H, 0:W]
        pat = np.where(((np.floor((xx + 0.5) / sq) + np.floor((yy + 0.5) / sq)) % 2) == 0, 0, 255).astype(np.uint8)
    m = int(round(margin_mm * px_per_mm))
    page = cv2.copyMakeBorder(pat, m, m, m, m, cv2.BORDER_CONSTANT, value=255)
    return page, m / px_per_mm


def board_poses(board: Board, camera: Camera, n: int, *, seed: int = 0, cells: str = "all",
                max_tilt_deg: float = 40.0, fill: tuple[float, float] = (0.3, 0.55)) -> list[tuple[np.ndarray, np.ndarray]]:
    """Seeded board poses ``(R, t_mm)`` (board to camera) with the whole board in the image.

    Parameters
    ----------
    board : Board
    camera : Camera
        Intrinsics and image size (its pose is ignored).
    n : int
        Number of poses.
    seed : int, keyword-only
    cells : {"all", "centre-right"}, keyword-only
        ``all``: the board's centre cycles through the 3 x 3 cells of the
        image (and the middle), so detections cover it; ``centre-right``: the
        board stays in the middle and right thirds (a poorly spread video).
    max_tilt_deg : float, keyword-only
        Largest tilt of the board about its x and y axes, degrees.
    fill : (float, float), keyword-only
        Range of the board's width as a fraction of the image width.
    """
    rng = np.random.default_rng([int(seed), 11])
    W, H = camera.width, camera.height
    if cells == "all":
        targets = [(1, 1)] + [(i, j) for j in range(3) for i in range(3)]
    elif cells == "centre-right":
        targets = [(i, j) for j in range(3) for i in (1, 2)]
    else:
        raise ValueError(f"cells: expected 'all' or 'centre-right', got {cells!r}")
    w_mm, h_mm = board.size_mm
    centre_b = np.array([w_mm / 2, h_mm / 2, 0.0])
    corners_b = np.array([[0, 0, 0], [w_mm, 0, 0], [w_mm, h_mm, 0], [0, h_mm, 0]], float)
    out = []
    k = 0
    tries = 0
    while len(out) < n:
        tries += 1
        if tries > 200 * n:
            raise ValueError(f"no board pose fits the {W}x{H} image (board {w_mm:g} x {h_mm:g} mm)")
        i, j = targets[k % len(targets)]
        frac = rng.uniform(*fill)
        half_x = 0.5 * frac + 0.05
        half_y = 0.5 * frac * (h_mm / w_mm) * (W / H) + 0.05
        lo_x, hi_x = half_x, 1 - half_x
        if cells == "centre-right":  # the board's left edge stays right of the image's left third
            lo_x = min(max(lo_x, 0.36 + half_x), hi_x)
        lo_y, hi_y = min(half_y, 0.5), max(1 - half_y, 0.5)
        tx = lo_x + (hi_x - lo_x) * (i / 2) + rng.uniform(-0.03, 0.03)
        ty = lo_y + (hi_y - lo_y) * (j / 2) + rng.uniform(-0.03, 0.03)
        a = np.radians(rng.uniform(-max_tilt_deg, max_tilt_deg, size=2))
        gz = np.radians(rng.uniform(-25, 25))
        R = rotation_from_rvec(np.array([a[0], 0, 0])) @ rotation_from_rvec(np.array([0, a[1], 0])) \
            @ rotation_from_rvec(np.array([0, 0, gz]))
        f = camera.K[0, 0]
        z = f * w_mm / (frac * W)
        u = np.array([tx * W, ty * H])
        ray = np.linalg.inv(camera.K) @ np.array([u[0], u[1], 1.0])
        c_cam = ray * z
        t = c_cam - R @ centre_b
        pts = (R @ corners_b.T).T + t
        if np.any(pts[:, 2] <= 0.2 * z):
            continue
        xy = camera.with_pose(R, t).project(corners_b)
        m = 0.02 * W
        if np.all(np.isfinite(xy)) and xy[:, 0].min() > m and xy[:, 1].min() > m and xy[:, 0].max() < W - m \
                and xy[:, 1].max() < H - m:
            out.append((R, t))
            k += 1
    return out


def _undistorted_rays(camera: Camera, ss: int, *, grid_px: int = 8) -> np.ndarray:
    """Normalised undistorted coordinates (H*ss, W*ss, 2) float32 of the sub-pixel samples.

    Exact (iterative) undistortion on a grid every ``grid_px`` pixels, then
    bicubic spline interpolation: the map is smooth (error far below 0.001 px).
    """
    W, H = camera.width, camera.height
    gx = np.arange(-grid_px, W + 2 * grid_px, grid_px, dtype=np.float64)
    gy = np.arange(-grid_px, H + 2 * grid_px, grid_px, dtype=np.float64)
    GX, GY = np.meshgrid(gx, gy)
    pts = np.stack([GX.ravel(), GY.ravel()], axis=1).reshape(-1, 1, 2)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 60, 1e-12)
    und = cv2.undistortPoints(pts, camera.K, camera.dist, R=None, P=None, criteria=crit).reshape(len(gy), len(gx), 2)
    off = (np.arange(ss) + 0.5) / ss - 0.5
    xs = (np.arange(W)[:, None] + off[None, :]).ravel()
    ys = (np.arange(H)[:, None] + off[None, :]).ravel()
    from scipy.interpolate import RectBivariateSpline  # exact coordinates (cv2.remap quantises them to 1/32)

    out = np.empty((len(ys), len(xs), 2), np.float32)
    for c in range(2):
        out[..., c] = RectBivariateSpline(gy, gx, und[..., c], kx=3, ky=3)(ys, xs)
    return out


def render_board_frames(board: Board, camera: Camera, poses: list[tuple[np.ndarray, np.ndarray]], *,
                        seed: int = 0, blur_sigma_px: float = 0.8, noise_sigma: float = 2.0,
                        ss: int = 2):
    """Yield the board seen by ``camera`` at each pose, BGR uint8 (height, width, 3).

    Parameters
    ----------
    board : Board
    camera : Camera
        True intrinsics and lens distortion (OpenCV model); pose ignored.
    poses : list of (R (3, 3), t_mm (3,))
        Board to camera: ``x_cam = R @ x_board + t_mm`` (board frame of the module docstring).
    seed : int, keyword-only
        Noise and background.
    blur_sigma_px, noise_sigma : float, keyword-only
        Gaussian optical blur (pixels) and sensor noise (grey levels).
    ss : int, keyword-only
        Supersampling per axis (anti-aliasing).

    Notes
    -----
    Every sub-pixel sample's ray (undistorted exactly, iteratively) meets the
    board plane; the page (printed at 20 px/mm, bilinear) is read there; the
    samples are averaged per pixel, blurred and noised. The page has a white
    margin of one square; outside it a grey background with a gradient.
    """
    px_per_mm = 20.0
    page, margin_mm = _texture(board, px_per_mm)
    # low-pass the page at the samples' spacing on it (3-7 page pixels): point samples of sharp
    # edges alias, which biases the corners by tenths of a pixel
    page = cv2.GaussianBlur(page.astype(np.float32), (0, 0), 2.5)
    rays = _undistorted_rays(camera, ss)
    hh, ww = rays.shape[:2]
    rng = np.random.default_rng([int(seed), 23])
    gy, gx = np.mgrid[0:camera.height, 0:camera.width].astype(np.float32)
    dx = np.ascontiguousarray(rays[..., 0], dtype=np.float32)
    dy = np.ascontiguousarray(rays[..., 1], dtype=np.float32)
    for k, (R, t) in enumerate(poses):
        Hm = np.column_stack([R[:, 0], R[:, 1], t])  # board (x, y, 1) -> camera ray
        h = np.linalg.inv(Hm).astype(np.float32)
        den = h[2, 0] * dx + h[2, 1] * dy + h[2, 2]
        behind = den <= 0
        den[behind] = 1.0
        s_ = np.float32(px_per_mm)
        mapx = (h[0, 0] * dx + h[0, 1] * dy + h[0, 2]) / den
        mapx += np.float32(margin_mm)
        mapx *= s_
        mapx -= np.float32(0.5)
        mapy = (h[1, 0] * dx + h[1, 1] * dy + h[1, 2]) / den
        mapy += np.float32(margin_mm)
        mapy *= s_
        mapy -= np.float32(0.5)
        mapx[behind] = -10
        val = cv2.remap(page, mapx, mapy, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=-1.0)
        level = 90.0 + 40.0 * math.sin(0.7 * k + seed)
        bg = level + 25.0 * (gx / camera.width) - 15.0 * (gy / camera.height)
        on = (val >= 0).astype(np.float32)
        inside = cv2.resize(on, (camera.width, camera.height), interpolation=cv2.INTER_AREA)
        sumv = cv2.resize(val * on, (camera.width, camera.height), interpolation=cv2.INTER_AREA)
        # pixels partly on the page: page where covered, background elsewhere
        img = 30.0 + sumv * (190.0 / 255.0) + (1.0 - inside) * (bg - 30.0)  # ink 30, paper 220
        lit = 0.85 + 0.1 * (gx / camera.width)
        img = img * lit
        if blur_sigma_px > 0:
            img = cv2.GaussianBlur(img, (0, 0), blur_sigma_px)
        if noise_sigma > 0:
            img = img + rng.standard_normal(img.shape).astype(np.float32) * noise_sigma
        grey = np.clip(np.round(img), 0, 255).astype(np.uint8)
        yield cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR)
