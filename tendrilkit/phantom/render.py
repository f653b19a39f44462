"""Drawing a phantom's frames: the static scene once per view, then the tendril per frame.

:func:`render_view` draws one frame of one view (BGR uint8, before video
compression): the board, leaves, markers, taped stem and node, lit by a
gradient with vignetting, then the tendril (a 4 x 4 supersampled tube with a
lighter core), optical blur and sensor noise. :func:`render_tube_views` is a
bare tube without a scene, for fast tests of the reconstruction.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from tendrilkit.camera import Camera
from tendrilkit.phantom.design import DICTIONARY, SITES, WORLD_MARKER_ID, WORLD_MARKER_MM, read_only
from tendrilkit.phantom.make import Phantom
from tendrilkit.phantom.projection import _mm_per_px, _pixel_to_board, _project_poly, _project_safe
from tendrilkit.phantom.scene import _ellipse_poly, _local, _quiet_scale, _rect_poly

# colours (BGR albedo, 0-255) of the rendered scene
_BOARD = np.array([222.0, 228.0, 231.0])
_PAPER = np.array([240.0, 242.0, 243.0])
_INK = np.array([28.0, 26.0, 26.0])
_STEM = np.array([38.0, 92.0, 52.0])
_NODE = np.array([34.0, 84.0, 50.0])
_TAPE = np.array([205.0, 226.0, 236.0])
_LEAF = np.array([48.0, 128.0, 62.0])
_VEIN = np.array([90.0, 165.0, 112.0])
_TENDRIL = np.array([40.0, 122.0, 84.0])
_TENDRIL_CORE = np.array([72.0, 170.0, 126.0])

def _light_map(cam: Camera, light: np.ndarray, view: int) -> np.ndarray:
    """Lighting gradient times vignetting, (H, W) float32 around 0.9."""
    H, W = cam.height, cam.width
    gx, gy, vig, level, cx, cy = light
    # each view sees the gradient from its own side
    gx, gy = gx * (1.0 - 0.4 * view), gy * (1.0 + 0.3 * view)
    u = (np.arange(W, dtype=np.float32) / W - 0.5) * 2
    v = (np.arange(H, dtype=np.float32) / H - 0.5) * 2
    grad = 1.0 + gx * u[None, :] + gy * v[:, None]
    r2 = ((u[None, :] - 2 * cx) ** 2 * (W / math.hypot(W, H)) ** 2 + (v[:, None] - 2 * cy) ** 2 * (H / math.hypot(W, H)) ** 2)
    return (level * grad * (1.0 - vig * r2)).astype(np.float32)


def _box_of(cam: Camera, pts_mm: np.ndarray, pad_px: float) -> tuple[int, int, int, int] | None:
    xy = _project_poly(cam, pts_mm)
    xy = xy[np.all(np.isfinite(xy), axis=1)]
    if len(xy) == 0:
        return None
    x0 = int(max(0, math.floor(xy[:, 0].min() - pad_px)))
    y0 = int(max(0, math.floor(xy[:, 1].min() - pad_px)))
    x1 = int(min(cam.width, math.ceil(xy[:, 0].max() + pad_px) + 1))
    y1 = int(min(cam.height, math.ceil(xy[:, 1].max() + pad_px) + 1))
    if x1 <= x0 or y1 <= y0:
        return None
    return x0, y0, x1, y1


def _board_samples(cam: Camera, box: tuple[int, int, int, int], ss: int, *, grid_px: int = 4) -> np.ndarray:
    """Board coordinates (h, w, ss*ss, 2) mm of ``ss x ss`` samples in every pixel of ``box``.

    The exact mapping (undistortion, ray-plane intersection) is evaluated on a
    grid every ``grid_px`` pixels and interpolated bilinearly: the mapping is
    smooth, so the interpolation error is below 1e-6 mm.
    """
    x0, y0, x1, y1 = box
    gx = np.arange(x0 - 1.0, x1 + grid_px, grid_px)
    gy = np.arange(y0 - 1.0, y1 + grid_px, grid_px)
    GX, GY = np.meshgrid(gx, gy)
    G = _pixel_to_board(cam, np.stack([GX.ravel(), GY.ravel()], axis=1)).reshape(len(gy), len(gx), 2)
    off = (np.arange(ss) + 0.5) / ss - 0.5
    xs = (np.arange(x0, x1)[:, None] + off[None, :]).ravel()
    ys = (np.arange(y0, y1)[:, None] + off[None, :]).ravel()
    fx = (xs - gx[0]) / grid_px
    fy = (ys - gy[0]) / grid_px
    ix = np.minimum(np.floor(fx).astype(int), len(gx) - 2)
    iy = np.minimum(np.floor(fy).astype(int), len(gy) - 2)
    ax = (fx - ix)[None, :, None]
    ay = (fy - iy)[:, None, None]
    g00 = G[iy][:, ix]
    g01 = G[iy][:, ix + 1]
    g10 = G[iy + 1][:, ix]
    g11 = G[iy + 1][:, ix + 1]
    xy = (g00 * (1 - ax) + g01 * ax) * (1 - ay) + (g10 * (1 - ax) + g11 * ax) * ay
    h, w = y1 - y0, x1 - x0
    return xy.reshape(h, ss, w, ss, 2).transpose(0, 2, 1, 3, 4).reshape(h, w, ss * ss, 2)


def _blend(img: np.ndarray, box: tuple[int, int, int, int], cover: np.ndarray, colour: np.ndarray) -> None:
    x0, y0, x1, y1 = box
    sub = img[y0:y1, x0:x1]
    c = cover[..., None].astype(np.float32)
    sub *= 1.0 - c
    sub += c * np.asarray(colour, np.float32)


def _marker_bits(marker_id: int) -> np.ndarray:
    dic = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, DICTIONARY))
    return cv2.aruco.generateImageMarker(dic, int(marker_id), 7, borderBits=1) > 127


def _tube_cover(cam: Camera, pts_mm: np.ndarray, radius_mm: np.ndarray | float, *, ss: int = 4,
                pad_px: int = 6, box: tuple[int, int, int, int] | None = None
                ) -> tuple[tuple[int, int, int, int], np.ndarray] | None:
    """Anti-aliased coverage of a tube: the union of its discs, drawn ``ss`` x supersampled.

    Returns the pixel box ``(x0, y0, x1, y1)`` (``box`` if given) and the
    coverage (h, w) in [0, 1].
    """
    xy = _project_safe(cam, pts_mm)
    depth = cam.world_to_cam(pts_mm)[:, 2]
    r_px = np.broadcast_to(np.asarray(radius_mm, float), (len(pts_mm),)) / depth * cam.K[0, 0]
    ok = np.all(np.isfinite(xy), axis=1) & cam.in_image(np.nan_to_num(xy, nan=-1e9), margin_px=-60.0)
    if not ok.any():
        return None
    xy, r_px = xy[ok], r_px[ok]
    if box is not None:
        x0, y0, x1, y1 = box
    else:
        x0 = int(max(0, math.floor((xy[:, 0] - r_px).min()) - pad_px))
        y0 = int(max(0, math.floor((xy[:, 1] - r_px).min()) - pad_px))
        x1 = int(min(cam.width, math.ceil((xy[:, 0] + r_px).max()) + pad_px + 1))
        y1 = int(min(cam.height, math.ceil((xy[:, 1] + r_px).max()) + pad_px + 1))
    if x1 <= x0 or y1 <= y0:
        return None
    big = np.zeros(((y1 - y0) * ss, (x1 - x0) * ss), np.uint8)
    shift = 4
    # pixel centre (x, y) -> supersampled coordinate (x - x0 + 0.5) * ss - 0.5
    cx = np.round(((xy[:, 0] - x0 + 0.5) * ss - 0.5) * (1 << shift)).astype(np.int64)
    cy = np.round(((xy[:, 1] - y0 + 0.5) * ss - 0.5) * (1 << shift)).astype(np.int64)
    rr = np.round(r_px * ss * (1 << shift)).astype(np.int64)
    for a, b, r in zip(cx.tolist(), cy.tolist(), rr.tolist()):
        cv2.circle(big, (a, b), max(r, 1), 255, -1, cv2.LINE_8, shift)
    cover = cv2.resize(big, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA).astype(np.float32) / 255.0
    return (x0, y0, x1, y1), cover


def _render_static(ph: Phantom, view: int) -> np.ndarray:
    """Albedo of the static scene (H, W, 3) float32, before lighting."""
    cam, sc = ph.cameras[view], ph.scene
    img = np.empty((cam.height, cam.width, 3), np.float32)
    img[:] = _BOARD.astype(np.float32)
    qs = _quiet_scale()
    # leaves and their petioles (flat on the board), soft edges from the signed distance
    for leaf in sc.leaves:
        c, ang, a, b = leaf["centre"], leaf["angle_deg"], leaf["a_mm"], leaf["b_mm"]
        pet = leaf["petiole"]
        pts = np.vstack([_ellipse_poly(c, ang, a, b), np.hstack([pet, np.zeros((2, 1))])])
        box = _box_of(cam, pts, 4)
        if box is None:
            continue
        xy = _board_samples(cam, box, 1)[:, :, 0]
        mmpp = _mm_per_px(cam, np.r_[c, 0.0])
        loc = _local(xy, c, ang)
        rho = np.sqrt((loc[..., 0] / a) ** 2 + (loc[..., 1] / b) ** 2)
        grad = np.sqrt((loc[..., 0] / a**2) ** 2 + (loc[..., 1] / b**2) ** 2) / np.maximum(rho, 1e-9)
        d = (rho - 1.0) / np.maximum(grad, 1e-9)
        # petiole: a 1.6 mm strip from the stem to the leaf
        p0, p1 = pet
        seg = p1 - p0
        tt = np.clip(((xy - p0) @ seg) / (seg @ seg), 0, 1)
        dp = np.linalg.norm(xy - (p0 + tt[..., None] * seg), axis=-1) - 0.8
        _blend(img, box, np.clip(0.5 - np.minimum(d, dp) / mmpp, 0, 1), _LEAF)
        # midrib
        mid = np.abs(loc[..., 1]) - 0.35
        inside = np.abs(loc[..., 0]) < 0.9 * a
        _blend(img, box, np.clip(0.5 - mid / mmpp, 0, 1) * inside * np.clip(0.5 - d / mmpp, 0, 1), _VEIN)
    # markers: white paper square (quiet zone) and the exact cells, 4 x 4 samples per pixel
    for mk in sc.markers:
        box = _box_of(cam, mk.corners_mm(qs), 3)
        if box is None:
            continue
        xy = _board_samples(cam, box, 4)
        loc = _local(xy, mk.centre_mm, mk.angle_deg)
        half = 0.5 * mk.length_mm
        paper = (np.abs(loc[..., 0]) <= half * qs) & (np.abs(loc[..., 1]) <= half * qs)
        cell = mk.length_mm / 7.0
        col = np.floor((loc[..., 0] + half) / cell).astype(int)
        row = np.floor((half - loc[..., 1]) / cell).astype(int)
        inmk = (col >= 0) & (col < 7) & (row >= 0) & (row < 7)
        bits = _marker_bits(mk.id)
        white = np.where(inmk, bits[np.clip(row, 0, 6), np.clip(col, 0, 6)], True)
        colour = np.where(white[..., None], _PAPER, _INK)  # (h, w, 16, 3)
        cover = paper.mean(axis=-1)
        colsum = (colour * paper[..., None]).sum(axis=2) / paper.shape[-1]
        x0, y0, x1, y1 = box
        sub = img[y0:y1, x0:x1]
        sub *= (1.0 - cover)[..., None].astype(np.float32)
        sub += colsum.astype(np.float32)
    # the stem (a tube lying on the board) and the node
    res = _tube_cover(cam, sc.stem_mm, sc.stem_radius_mm)
    if res is not None:
        _blend(img, res[0], res[1], _STEM)
    res = _tube_cover(cam, sc.node_mm[None], sc.node_radius_mm)
    if res is not None:
        _blend(img, res[0], res[1], _NODE)
    # tape strips over the stem (semi-transparent)
    for c, ang, ln, wd in sc.tapes:
        box = _box_of(cam, _rect_poly(c, ang, ln, wd), 4)
        if box is None:
            continue
        xy = _board_samples(cam, box, 1)[:, :, 0]
        loc = _local(xy, c, ang)
        d = np.maximum(np.abs(loc[..., 0]) - 0.5 * ln, np.abs(loc[..., 1]) - 0.5 * wd)
        mmpp = _mm_per_px(cam, np.r_[c, 0.0])
        _blend(img, box, 0.72 * np.clip(0.5 - d / mmpp, 0, 1), _TAPE)
    return img


def static_layers(ph: Phantom, view: int) -> dict[str, np.ndarray]:
    """The static layers of one view (0-based), rendered on first use and kept with the phantom.

    Returns
    -------
    dict of read-only arrays
        ``light`` (H, W) float32 lighting gradient times vignetting; ``lit``
        (H, W, 3) float32 lit albedo of the static scene; ``blurred`` the same
        after the optical blur; ``noise`` (H + 32, W + 32, 3) int8 sensor noise
        (frames take shifted windows of it).

    Notes
    -----
    Kept in the phantom's private ``_layers`` (about 40 MB a view), so they
    live exactly as long as the phantom: nothing global, nothing to clear.
    """
    key = ("site", view)
    if key not in ph._layers:
        cam = ph.cameras[view]
        light = _light_map(cam, ph.scene.light, view)
        lit = _render_static(ph, view) * light[..., None]
        sigma = float(ph.options["blur_sigma_px"])
        blurred = cv2.GaussianBlur(lit, (0, 0), sigma) if sigma > 0 else lit.copy()
        rng = np.random.default_rng([ph.seed, SITES.index(ph.site), view, 31])
        # whole grey levels in int8 (7 MB a view); frames take shifted windows of it
        noise = np.clip(np.round(rng.standard_normal((cam.height + 32, cam.width + 32, 3), dtype=np.float32)
                                 * np.float32(ph.options["noise_sigma"])), -127, 127).astype(np.int8)
        ph._layers[key] = {"light": read_only(light), "lit": read_only(lit), "blurred": read_only(blurred),
                           "noise": read_only(noise)}
    return ph._layers[key]


def render_tube_views(X_mm: np.ndarray, *, width_px: int = 9, margin_px: int = 40, name: str = "tube",
                      fps: float = 1.0, cameras: list | None = None):
    """A bare tube along ``X_mm`` drawn into every view, with an experiment whose marks fit it.

    No scene, noise or distortion: a fast, exact input for tests and benchmarks
    of the reconstruction (the full phantom is :func:`make_phantom`).

    Parameters
    ----------
    X_mm : (n, 3) float array
        Centreline, world mm, base first (densely sampled: it is drawn as a polyline).
    width_px : int
        Line width of the tube, pixels.
    margin_px : int
        The ROI is the tube's bounding box grown by this much.
    name, fps
        Of the experiment.
    cameras : list of Camera, optional
        Default: the IJCV25 rig (:func:`tendrilkit.calibration.ijcv25_rig`).

    Returns
    -------
    images : list of (1080, 1920, 3) uint8 arrays
    cameras : list of Camera
    experiment : tendrilkit.params.Experiment
        Videos ``v1.mp4``... (not written), base point at the projected first point.
    """
    from tendrilkit.calibration import ijcv25_rig
    from tendrilkit.params import parse_experiment

    cams = ijcv25_rig() if cameras is None else cameras
    images, views = [], []
    for v, c in enumerate(cams):
        img = np.full((c.height, c.width, 3), 235, np.uint8)
        p = c.project(np.asarray(X_mm, float))
        cv2.polylines(img, [np.round(p * 16).astype(np.int32)], False, (40, 40, 40), width_px, cv2.LINE_AA, 4)
        images.append(img)
        lo, hi = (p.min(0) - margin_px).astype(int), (p.max(0) + margin_px).astype(int)
        views.append({"view": v + 1, "roi": [int(lo[0]), int(lo[1]), int(hi[0] - lo[0]), int(hi[1] - lo[1])],
                      "base_point": [float(p[0, 0]), float(p[0, 1])]})
    exp = parse_experiment({
        "name": name, "videos": [f"v{i + 1}.mp4" for i in range(len(cams))], "fps": fps, "reference_view": 2,
        "cameras": [{"view": i + 1, "fx": float(c.K[0, 0]), "fy": float(c.K[1, 1]), "cx": float(c.K[0, 2]),
                     "cy": float(c.K[1, 2]), "dist": c.dist.tolist()} for i, c in enumerate(cams)],
        "marker": {"dictionary": DICTIONARY, "id": WORLD_MARKER_ID, "length_mm": WORLD_MARKER_MM},
        "views": views,
    })
    return images, cams, exp


def check_frame_view(ph, frame: int, view_index: int) -> None:
    """ValueError unless ``frame`` and ``view_index`` (0-based) exist in phantom ``ph`` (a site or scene phantom)."""
    if not 0 <= frame < ph.n_frames:
        raise ValueError(f"frame: expected 0..{ph.n_frames - 1}, got {frame}")
    if not 0 <= view_index < len(ph.cameras):
        raise ValueError(f"view_index: expected 0..{len(ph.cameras) - 1}, got {view_index}")


def render_view(phantom: Phantom, frame: int, view_index: int, *, noise: bool = True) -> np.ndarray:
    """One frame of one view, BGR uint8 (height, width, 3), before compression.

    Parameters
    ----------
    phantom : Phantom
    frame : int
        0-based frame.
    view_index : int
        0-based view.
    noise : bool, keyword-only
        Add the sensor noise (deterministic per frame and view).

    Notes
    -----
    The static scene of each view is rendered once and kept with the
    phantom (:func:`static_layers`). The tendril is the union of discs of its projected centreline
    (4 x 4 supersampled), so where it crosses itself in a view it is one
    merged blob; then optical blur, noise and rounding.
    """
    check_frame_view(phantom, frame, view_index)
    st = static_layers(phantom, view_index)
    cam = phantom.cameras[view_index]
    img = st["blurred"].copy()
    sigma = float(phantom.options["blur_sigma_px"])
    reach = int(math.ceil(4 * sigma)) + 1 if sigma > 0 else 0  # OpenCV's kernel radius is about 4 sigma
    res = _tube_cover(cam, phantom.curves_mm[frame], 0.5 * phantom.diameter_mm, pad_px=2 * reach + 2)
    if res is not None:
        (x0, y0, x1, y1), cover = res
        # a lighter core: the tube's rounded surface catches the light along its middle
        core = _tube_cover(cam, phantom.curves_mm[frame], 0.2 * phantom.diameter_mm, box=(x0, y0, x1, y1))[1]
        colour = (_TENDRIL.astype(np.float32)[None, None, :]
                  + (0.6 * core)[..., None] * (_TENDRIL_CORE - _TENDRIL).astype(np.float32)[None, None, :])
        colour *= st["light"][y0:y1, x0:x1, None]
        sub = st["lit"][y0:y1, x0:x1].copy()
        colour -= sub
        colour *= cover[..., None]
        sub += colour  # lit + cover (tendril - lit)
        if sigma > 0:
            sub = cv2.GaussianBlur(sub, (0, 0), sigma)
        # keep the inner part, whose blur saw no border of the box
        ix0, iy0 = (reach if x0 > 0 else 0), (reach if y0 > 0 else 0)
        ix1 = sub.shape[1] - reach if x1 < cam.width else sub.shape[1]
        iy1 = sub.shape[0] - reach if y1 < cam.height else sub.shape[0]
        img[y0 + iy0:y0 + iy1, x0 + ix0:x0 + ix1] = sub[iy0:iy1, ix0:ix1]
    out = cv2.convertScaleAbs(img)  # rounds and saturates
    if noise and phantom.options["noise_sigma"] > 0:
        rng = np.random.default_rng([phantom.seed, SITES.index(phantom.site), frame, view_index, 37])
        oy, ox = rng.integers(0, 32, size=2)
        out = cv2.add(out, st["noise"][oy:oy + cam.height, ox:ox + cam.width], dtype=cv2.CV_8U)
    return out



