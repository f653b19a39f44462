"""The static scene around a phantom's tendril: board markers, the taped stem, its node and leaves.

:func:`build_scene` lays the scene out around the tendril's swept region so
that nothing touches it in any view (collision masks at half resolution),
drawing from the seed; a layout that does not fit raises :class:`Reject`
and the generator draws the next design.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from tendrilkit.calibration.markers import ambiguous_marker_ids
from tendrilkit.camera import Camera
from tendrilkit.geometry import arc_length, marker_corners
from tendrilkit.phantom.design import (_CLEAR_PX, _NODE_RADIUS_MM, _STEM_RADIUS_MM, DICTIONARY, SITES,
                                       WORLD_MARKER_ID, WORLD_MARKER_MM, Design)
from tendrilkit.phantom.projection import _mm_per_px, _project_poly, _project_safe

@dataclass(frozen=True, eq=False)
class MarkerSpec:
    """An ArUco marker on the board: ``id``, centre (2,) mm, side mm, angle deg."""

    id: int
    centre_mm: np.ndarray
    length_mm: float
    angle_deg: float

    def corners_mm(self, scale: float = 1.0) -> np.ndarray:
        """Corners (4, 3) mm on the board (z = 0), OpenCV order, ``scale`` x side."""
        return marker_corners(self.length_mm, centre_mm=self.centre_mm, angle_deg=self.angle_deg, scale=scale)


@dataclass(frozen=True, eq=False)
class Scene:
    """The static scene: board-plane elements in world mm.

    Attributes
    ----------
    stem_mm : (m, 3) float array
        Stem centreline (lying on the board, z = radius).
    stem_radius_mm : (m,) float array
    node_mm : (3,) float array
        Centre of the node that carries the tendril.
    node_radius_mm : float
    tapes : list of (centre (2,), angle_deg, length_mm, width_mm)
    leaves : list of dict (centre (2,), angle_deg, a_mm, b_mm, petiole (2, 2))
    markers : list of MarkerSpec (the world marker first)
    light : (6,) float array
        Lighting gradient and vignetting coefficients.
    """

    stem_mm: np.ndarray
    stem_radius_mm: np.ndarray
    node_mm: np.ndarray
    node_radius_mm: float
    tapes: list
    leaves: list
    markers: list
    light: np.ndarray


def _stem_path(node: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The stem on the board: from beyond the left image edge to the node, then a short apex.

    Headings are angles from world +x (down) towards +y (right). Far from the
    node the stem runs to the right (90 deg); near the node it rises to
    ``90 + beta`` so that the hanging tendril leaves it at a wide angle (a
    narrow one would make the keep-out box hide more of the tendril); the
    apex continues upwards, away from the tendril.
    """
    beta = rng.uniform(25.0, 35.0)
    far = 90.0 + rng.uniform(-6.0, 4.0)
    step = 1.0
    back = np.arange(0.0, 340.0 + step, step)  # arc length back from the node
    heading = far + (90.0 + beta - far) * np.clip(1.0 - back / 70.0, 0.0, 1.0) ** 2
    hb = np.radians(heading + 180.0)  # walking backwards
    bx = node[0] + np.r_[0.0, np.cumsum(np.cos(hb[1:]) * step)]
    by = node[1] + np.r_[0.0, np.cumsum(np.sin(hb[1:]) * step)]
    left = np.stack([bx, by, np.full_like(bx, _STEM_RADIUS_MM)], axis=1)[::-1]
    ang = np.radians(np.linspace(90.0 + beta + 10.0, 90.0 + beta + 45.0, 30))
    astep = 16.0 / (len(ang) - 1)
    ax = node[0] + np.r_[0.0, np.cumsum(np.cos(ang[1:]) * astep)]
    ay = node[1] + np.r_[0.0, np.cumsum(np.sin(ang[1:]) * astep)]
    apex = np.stack([ax, ay, np.full_like(ax, _STEM_RADIUS_MM)], axis=1)[1:]
    path = np.vstack([left, apex])
    rad = np.full(len(path), _STEM_RADIUS_MM)
    rad[len(left):] = _STEM_RADIUS_MM * np.linspace(1.0, 0.45, len(apex))
    path[:, 2] = rad  # lying on the board
    return path, rad

_HALF = 0.5  # scale of the collision masks


def _mask_shape(cam: Camera) -> tuple[int, int]:
    return int(round(cam.height * _HALF)), int(round(cam.width * _HALF))


def _poly_mask(cam: Camera, poly_mm: np.ndarray, *, dilate_px: float = 0.0) -> np.ndarray:
    m = np.zeros(_mask_shape(cam), np.uint8)
    xy = _project_poly(cam, poly_mm) * _HALF
    if not np.all(np.isfinite(xy)):
        return m
    poly = [np.round(xy * 16).astype(np.int32)]
    cv2.fillPoly(m, poly, 1, lineType=cv2.LINE_8, shift=4)
    if dilate_px > 0:  # a dilation by a disc: the outline drawn with round caps and joins
        k = int(math.ceil(dilate_px * _HALF))
        cv2.polylines(m, poly, True, 1, thickness=2 * k + 1, lineType=cv2.LINE_8, shift=4)
    return m


def _tube_mask(cam: Camera, pts_mm: np.ndarray, radius_mm: float | np.ndarray, *, dilate_px: float = 0.0) -> np.ndarray:
    m = np.zeros(_mask_shape(cam), np.uint8)
    xy = _project_safe(cam, pts_mm) * _HALF
    rad = np.broadcast_to(np.asarray(radius_mm, float), (len(pts_mm),))
    depth = cam.world_to_cam(pts_mm)[:, 2]
    r_px = rad / depth * cam.K[0, 0] * _HALF + dilate_px * _HALF
    ok = np.all(np.isfinite(xy), axis=1)
    for (x, y), r in zip(xy[ok], r_px[ok]):
        cv2.circle(m, (int(round(x * 4)), int(round(y * 4))), max(1, int(round(r * 4))), 1, -1, cv2.LINE_8, 2)
    return m


def _ellipse_poly(centre: np.ndarray, angle_deg: float, a: float, b: float, n: int = 48) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    local = np.stack([a * np.cos(t), b * np.sin(t)], axis=1)
    ang = math.radians(angle_deg)
    R = np.array([[math.cos(ang), -math.sin(ang)], [math.sin(ang), math.cos(ang)]])
    xy = local @ R.T + centre[None, :]
    return np.hstack([xy, np.zeros((n, 1))])


def _local(xy: np.ndarray, centre: np.ndarray, angle_deg: float) -> np.ndarray:
    """Board points (..., 2) mm in the frame of an object at ``centre`` (2,) turned by ``angle_deg``."""
    a = math.radians(angle_deg)
    d = xy - centre
    return np.stack([d[..., 0] * math.cos(a) + d[..., 1] * math.sin(a),
                     -d[..., 0] * math.sin(a) + d[..., 1] * math.cos(a)], axis=-1)


def _square_poly(marker: MarkerSpec, scale: float) -> np.ndarray:
    c = marker.corners_mm(scale)
    out = []
    for k in range(4):
        a, b = c[k], c[(k + 1) % 4]
        for t in np.linspace(0, 1, 8, endpoint=False):
            out.append(a + t * (b - a))
    return np.array(out)


def _quiet_scale(marker_cells: int = 7) -> float:
    return (marker_cells + 2.0) / marker_cells  # one white cell around the marker


def build_scene(design: Design, cams: list[Camera], curves: np.ndarray, seed: int, attempt: int,
                diameter_mm: float, *, world_frames: int | None = None) -> Scene:
    """Stem, tape, leaves and markers around the tendril's swept region ``curves`` (k, n, 3).

    Collisions are tested on half-resolution masks of every view: each element
    (dilated by ``_CLEAR_PX``) against the tendril swept over ``curves``
    (widened by ``_CLEAR_PX``) and against the elements placed before it.
    ``world_frames`` (keyword-only): the world marker is tested against the
    tendril of the first ``world_frames`` frames only (the frames that
    calibrate: the tendril may pass over it later); None (the site phantoms):
    every frame. No marker gets an id of :func:`tendrilkit.calibration.markers.ambiguous_marker_ids`.
    Raises :class:`Reject` when the stem is in the way or there is no room.
    """
    rng = np.random.default_rng([int(seed), SITES.index(design.site), int(attempt), 23])
    node = design.node_mm
    stem, stem_r = _stem_path(node, rng)
    # swept tendril region per view (dilated by the clearance); the distal part
    # (beyond 20 mm) separately: it must not come back to the stem near the node
    sub = curves[:, ::4]
    s_sub = np.linspace(0.0, design.length_mm, curves.shape[1])[::4]
    swept, distal, swept_world = [], [], []  # swept_world: the frames that calibrate only (all without world_frames)
    for cam in cams:
        m = np.zeros(_mask_shape(cam), np.uint8)
        md = np.zeros_like(m)
        mw = None
        for i, c in enumerate(sub):
            if i == world_frames:
                mw = m.copy()
            xy = _project_safe(cam, c) * _HALF
            w = diameter_mm / _mm_per_px(cam, c.mean(axis=0)) * _HALF
            th = max(1, int(round(w + 2 * _CLEAR_PX * _HALF)))
            cv2.polylines(m, [np.round(xy * 16).astype(np.int32)], False, 1, thickness=th, lineType=cv2.LINE_8, shift=4)
            cv2.polylines(md, [np.round(xy[s_sub > 20.0] * 16).astype(np.int32)], False, 1, thickness=th,
                          lineType=cv2.LINE_8, shift=4)
        swept.append(m)
        distal.append(md)
        swept_world.append(m if mw is None else mw)
    static = [np.zeros_like(s) for s in swept]

    def clear_of(masks: list[np.ndarray], others: list[np.ndarray] | None, tendril: list | None = None) -> bool:
        for v, m in enumerate(masks):
            if np.any(m & (swept if tendril is None else tendril)[v]):
                return False
            if others is not None and np.any(m & others[v]):
                return False
        return True

    # stem (except near the node) must be clear of the tendril
    far = np.linalg.norm(stem[:, :2] - node[None, :2], axis=1) > 6.0 * _STEM_RADIUS_MM
    stem_masks = [_tube_mask(cam, stem[far], stem_r[far]) for cam in cams]
    if not clear_of(stem_masks, None):
        raise Reject("the stem is in the tendril's way")
    full_stem = [_tube_mask(cam, stem, stem_r, dilate_px=6.0) for cam in cams]
    node_mask = [_tube_mask(cam, node[None], _NODE_RADIUS_MM) for cam in cams]
    if any(np.any((f | n) & d) for f, n, d in zip(full_stem, node_mask, distal)):
        raise Reject("the tendril comes back to the stem near the node")
    static = [s | f for s, f in zip(static, full_stem)]

    # tape strips across the stem, left of the node
    tapes = []
    k_node = int(np.argmin(np.linalg.norm(stem[:, :2] - node[None, :2], axis=1)))
    back = arc_length(stem[k_node::-1, :2])
    for dist in (rng.uniform(22.0, 32.0), rng.uniform(48.0, 62.0)):
        k = k_node - int(np.argmin(np.abs(back - dist)))
        k = min(max(k, 1), len(stem) - 2)
        tangent = stem[k + 1, :2] - stem[k - 1, :2]
        ang = math.degrees(math.atan2(tangent[1], tangent[0])) + 90.0 + rng.uniform(-8, 8)
        tapes.append((stem[k, :2].copy(), ang, float(rng.uniform(22.0, 28.0)), float(rng.uniform(9.0, 12.0))))
    tape_masks = []
    for c, ang, ln, wd in tapes:
        poly = _rect_poly(c, ang, ln, wd)
        tape_masks.append([_poly_mask(cam, poly, dilate_px=4.0) for cam in cams])
    for tm in tape_masks:
        if not clear_of(tm, None):
            raise Reject("a tape strip is in the tendril's way")
        static = [s | t for s, t in zip(static, tm)]

    # leaves on petioles from the stem, away from the tendril
    leaves = []
    n_leaves = int(rng.integers(2, 4))
    tries = 0
    while len(leaves) < n_leaves and tries < 300:
        tries += 1
        # the first 200 candidates must show their centre in every view, later ones some part in one
        visible_centre = tries <= 200
        k = int(rng.integers(5, len(stem) - 60))
        anchor = stem[k, :2]
        if np.linalg.norm(anchor - node[:2]) < 20.0:
            continue
        side = -1.0 if rng.uniform() < 0.5 else 1.0
        ang = math.radians(180.0 if side < 0 else 0.0) + rng.uniform(-0.6, 0.6)
        direction = np.array([math.cos(ang), math.sin(ang)])
        a = float(rng.uniform(28.0, 42.0))
        b = float(rng.uniform(15.0, 22.0))
        pet = float(rng.uniform(10.0, 25.0))
        centre = anchor + direction * (pet + a)
        poly = _ellipse_poly(centre, math.degrees(ang), a, b)
        pet_poly = _rect_poly(anchor + direction * pet / 2, math.degrees(ang), pet, 1.6)
        if visible_centre and not all(cam.in_image(_project_safe(cam, np.r_[centre, 0.0][None]))[0] for cam in cams):
            continue
        masks = [(_poly_mask(cam, poly, dilate_px=_CLEAR_PX) | _poly_mask(cam, pet_poly, dilate_px=_CLEAR_PX)) for cam in cams]
        if not any(m.any() for m in masks) or not clear_of(masks, None):
            continue
        # leaves do not overlap each other (on the board)
        if any(np.linalg.norm(centre - o["centre"]) < 0.9 * (max(a, b) + max(o["a_mm"], o["b_mm"])) for o in leaves):
            continue
        leaves.append({"centre": centre, "angle_deg": math.degrees(ang), "a_mm": a, "b_mm": b,
                       "petiole": np.stack([anchor, anchor + direction * (pet + 0.3 * a)])})
        static = [s | m for s, m in zip(static, masks)]
    if len(leaves) < 2:
        raise Reject("no room for two leaves")

    # markers: the world marker, then 3-5 others spread around the working volume
    world = MarkerSpec(WORLD_MARKER_ID, np.zeros(2), WORLD_MARKER_MM, 0.0)
    markers = [world]
    qs = _quiet_scale()

    def marker_ok(mk: MarkerSpec, check_static: bool, tendril: list | None = None) -> list[np.ndarray] | None:
        poly = _square_poly(mk, qs)
        masks = []
        for cam in cams:
            if not np.all(cam.in_image(_project_safe(cam, poly), margin_px=30.0)):
                return None
            masks.append(_poly_mask(cam, poly, dilate_px=_CLEAR_PX))
        if not clear_of(masks, static if check_static else None, tendril):
            return None
        return masks

    wm = marker_ok(world, False, swept_world)
    if wm is None:
        raise Reject("the world marker is hidden by the tendril")
    static = [s | m for s, m in zip(static, wm)]
    n_markers = int(rng.integers(3, 6))
    used = {WORLD_MARKER_ID} | ambiguous_marker_ids(DICTIONARY)  # drawn all the same: the draws stay the seed's
    cands = []
    for _ in range(120):
        mid = int(rng.integers(0, 1024))
        size = float(rng.uniform(20.0, 40.0))
        centre = np.array([rng.uniform(-10.0, 175.0), rng.uniform(-230.0, 210.0)])
        angle = float(rng.uniform(-25.0, 25.0))
        cands.append((mid, centre, size, angle))
    for _ in range(n_markers):
        best, best_d, best_masks = None, -1.0, None
        for mid, centre, size, angle in cands:
            if mid in used:
                continue
            mk = MarkerSpec(mid, centre, size, angle)
            r = 0.5 * size * qs * math.sqrt(2)
            d = min(np.linalg.norm(centre - o.centre_mm) - r - 0.5 * o.length_mm * qs * math.sqrt(2) for o in markers)
            if d < 4.0 or d <= best_d:
                continue
            masks = marker_ok(mk, True)
            if masks is None:
                continue
            best, best_d, best_masks = mk, d, masks
        if best is None:
            break
        markers.append(best)
        used.add(best.id)
        static = [s | m for s, m in zip(static, best_masks)]
    if len(markers) < 4:
        raise Reject("no room for three other markers")
    light = np.array([rng.uniform(-0.08, 0.08), rng.uniform(-0.08, 0.08), rng.uniform(0.08, 0.16),
                      rng.uniform(0.9, 0.97), rng.uniform(-0.05, 0.05), rng.uniform(-0.05, 0.05)])
    return Scene(stem_mm=stem, stem_radius_mm=stem_r, node_mm=node.copy(), node_radius_mm=_NODE_RADIUS_MM,
                 tapes=tapes, leaves=leaves, markers=markers, light=light)


def _rect_poly(centre: np.ndarray, angle_deg: float, length: float, width: float) -> np.ndarray:
    a = math.radians(angle_deg)
    d = np.array([math.cos(a), math.sin(a)])
    n = np.array([-d[1], d[0]])
    pts = [centre + sx * 0.5 * length * d + sy * 0.5 * width * n for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    xy = np.array(pts)
    return np.hstack([xy, np.zeros((4, 1))])


class Reject(Exception):
    """A design violates a constraint (the generator draws another)."""


