"""Markers of the random phantom scenes as people tape them (:mod:`tendrilkit.phantom.scenes`).

- ``markers``: two to five markers in all, the world marker 16-24 mm, some
  small in the images, one across an image edge of one view
  (:func:`_redo_markers`);
- ``glancing_marker``: a marker printed on a card that stands on the board,
  tilted 58-78 degrees from it, so at least one view sees it at a glancing
  angle (60 degrees or more between its normal and the line of sight)
  (:func:`place_card`). It is not on the world marker's board plane: the
  bundle adjustment must find that out.

Both keep every marker clear of the tendril's projection (40 px) in every
view; a placement that fails raises :class:`~tendrilkit.phantom.scenes.clutter._Retry`.

:func:`world_marker_cover`: once every object of a scene is placed, what
lies over the world marker's paper in a view (the calibration needs it in
every view: a user does not tape it under the stem) in the frames that
calibrate (:data:`CALIBRATION_FRAMES`; the tendril may pass over it later).

No marker gets an id whose corners a detector cannot order
(:func:`tendrilkit.calibration.markers.ambiguous_marker_ids`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from scipy.spatial import cKDTree

from tendrilkit.calibration.markers import ambiguous_marker_ids
from tendrilkit.camera import Camera
from tendrilkit.params import Calibration
from tendrilkit.phantom.design import DICTIONARY, WORLD_MARKER_ID
from tendrilkit.phantom.projection import _pixel_to_board, _project_safe
from tendrilkit.phantom.scene import MarkerSpec, Scene, _poly_mask, _quiet_scale, _rect_poly, _square_poly, _tube_mask
from tendrilkit.phantom.scenes.clutter import _Retry

#: Video frames the calibration reads (``calibration.average_frames``' default; a scene's experiment file
#: keeps it): the world marker must be clear of the tendril in these frames, not later ones.
CALIBRATION_FRAMES = int(Calibration.model_fields["average_frames"].default)


def _redo_markers(scene: Scene, cams: list, curves: np.ndarray, rng) -> tuple[Scene, dict]:
    """Two to five markers: the world marker 16-24 mm, some small, one partly outside a view."""
    qs = _quiet_scale()
    world = MarkerSpec(WORLD_MARKER_ID, np.zeros(2), float(rng.choice([16.0, 20.0, 24.0])), 0.0)
    others = list(scene.markers[1:])
    keep = int(rng.integers(0, min(3, len(others)) + 1))
    kept = []
    for m in others[:keep]:
        if rng.uniform() < 0.5:  # small in the image
            m = MarkerSpec(m.id, m.centre_mm, float(m.length_mm * rng.uniform(0.4, 0.6)), m.angle_deg)
        kept.append(m)
    if others and not kept:  # at least one other marker, so a small one: with the one outside, two to five
        kept = [others[0]]
    if kept and not any(m.length_mm < 16 for m in kept):
        m = kept[0]
        kept[0] = MarkerSpec(m.id, m.centre_mm, float(min(0.5 * m.length_mm, 14.0)), m.angle_deg)
    markers = [world] + kept
    info = {"world_length_mm": world.length_mm, "n_markers": None, "small": [m.id for m in kept if m.length_mm < 16],
            "partly_outside": None}
    # one marker across an image edge of one view, clear of the tendril and the other markers
    for _ in range(40):
        v = int(rng.integers(3))
        cam = cams[v]
        edge = int(rng.integers(4))
        t = rng.uniform(0.15, 0.85)
        xy = np.array([[t * cam.width, 0.0], [cam.width - 1.0, t * cam.height], [t * cam.width, cam.height - 1.0],
                       [0.0, t * cam.height]])[edge]
        c = _pixel_to_board(cam, xy[None])[0]
        mk = MarkerSpec(int(rng.integers(0, 1024)), c, float(rng.uniform(20.0, 32.0)), float(rng.uniform(-25, 25)))
        if mk.id in {m.id for m in markers} | ambiguous_marker_ids(DICTIONARY):
            continue
        r = 0.5 * mk.length_mm * qs * math.sqrt(2)
        if any(np.linalg.norm(c - o.centre_mm) < r + 0.5 * o.length_mm * qs * math.sqrt(2) + 3 for o in markers):
            continue
        poly = _square_poly(mk, qs)
        if any(np.linalg.norm(c - lf["centre"]) < max(lf["a_mm"], lf["b_mm"]) + r for lf in scene.leaves):
            continue
        far = True
        for u, cu in enumerate(cams):
            pxy = _project_safe(cu, poly)
            if not np.any(np.isfinite(pxy)):
                continue
            txy = cu.project(curves[:, ::8].reshape(-1, 3))
            d, _ = cKDTree(txy).query(np.nan_to_num(pxy, nan=-1e6))
            far &= bool(np.min(d) > 40.0)
        if not far:
            continue
        markers.append(mk)
        info["partly_outside"] = {"id": mk.id, "view": v + 1}
        break
    if info["partly_outside"] is None:
        raise _Retry("markers: no room for a marker across an image edge")
    info["n_markers"] = len(markers)
    return dataclasses.replace(scene, markers=markers), info


def card_corners_mm(card: dict, scale: float = 1.0) -> np.ndarray:
    """Corners (4, 3) mm of a card's marker (``scale`` x side), OpenCV order (top-left first, clockwise).

    The card's frame is ``centre_mm`` with in-plane axes ``e1`` (marker x,
    right) and ``e2`` (marker y, up), its normal ``e1 x e2`` facing the cameras.
    """
    h = 0.5 * card["length_mm"] * scale
    c, e1, e2 = (np.asarray(card[k], float) for k in ("centre_mm", "e1", "e2"))
    return np.array([c - h * e1 + h * e2, c + h * e1 + h * e2, c + h * e1 - h * e2, c - h * e1 - h * e2])


def incidence_deg(cam: Camera, card: dict) -> float:
    """Angle (deg) between a card's normal and the line of sight from its centre to ``cam``."""
    n = np.cross(card["e1"], card["e2"])
    u = cam.center_world - np.asarray(card["centre_mm"])
    return math.degrees(math.acos(float(np.clip(np.dot(n, u) / np.linalg.norm(u), -1.0, 1.0))))


def _poly_distance_px(cam: Camera, poly_mm: np.ndarray, xy: np.ndarray) -> float:
    """Smallest distance (px, negative inside) from pixels ``xy`` (m, 2) to a projected polygon."""
    import cv2

    p = _project_safe(cam, poly_mm)
    if not np.all(np.isfinite(p)) or len(xy) == 0:
        return np.inf
    contour = p.astype(np.float32).reshape(-1, 1, 2)
    return -max(float(cv2.pointPolygonTest(contour, (float(x), float(y)), True)) for x, y in xy)


def place_card(scene: Scene, cams: list, curves: np.ndarray, avoid_mm: list, rng) -> dict:
    """A marker on a card standing on the board, seen at a glancing angle by at least one view.

    Parameters
    ----------
    scene : Scene
        Its markers' ids are not reused and their papers stay clear of the card in every view.
    cams : list of Camera
    curves : (n_frames, n, 3) float array
        The tendril, mm: the card stays 40 px from its projection in every view.
    avoid_mm : list of (m, 3) float arrays
        Other objects in space (shoots) the card must not hide or touch (40 px).
    rng : numpy.random.Generator

    Returns
    -------
    dict
        ``id``, ``length_mm``, ``centre_mm``, ``e1``, ``e2`` (the card,
        :func:`card_corners_mm`), ``tilt_deg`` (from the board),
        ``incidence_deg`` per view, ``corners_mm`` (4, 3).
    """
    qs = _quiet_scale()
    used = {m.id for m in scene.markers} | ambiguous_marker_ids(DICTIONARY)
    tendril = curves[:, ::8].reshape(-1, 3)
    centre_xy = np.mean([c.center_world[:2] for c in cams], axis=0)
    for _ in range(60):
        v = int(rng.integers(3))
        cam = cams[v]
        xy = np.array([rng.uniform(0.12, 0.88) * cam.width, rng.uniform(0.12, 0.88) * cam.height])
        b = _pixel_to_board(cam, xy[None])[0]
        length = float(rng.uniform(20.0, 30.0))
        tilt = math.radians(float(rng.uniform(58.0, 78.0)))
        mid = int(rng.integers(0, 1024))
        if mid in used:
            continue
        toward = centre_xy - b  # the card faces the rig (seen from the front by every view)
        az = math.atan2(toward[1], toward[0]) + float(rng.uniform(-0.6, 0.6))
        h = -np.array([math.cos(az), math.sin(az), 0.0])  # the card leans back, away from the rig
        e1 = np.array([-h[1], h[0], 0.0])
        if np.cross(e1, math.cos(tilt) * h + math.sin(tilt) * np.array([0.0, 0.0, 1.0]))[2] < 0:
            e1 = -e1
        e2 = math.cos(tilt) * h + math.sin(tilt) * np.array([0.0, 0.0, 1.0])
        centre = np.r_[b, 0.0] + 0.5 * length * qs * e2
        card = {"id": mid, "length_mm": length, "centre_mm": centre, "e1": e1, "e2": e2}
        paper = card_corners_mm(card, qs)
        inc = [incidence_deg(c, card) for c in cams]
        if max(inc) < 60.0 or max(inc) > 84.0:
            continue
        ok = True
        for c in cams:
            pxy = _project_safe(c, paper)
            if not np.all(np.isfinite(pxy)) or not np.all(c.in_image(pxy, margin_px=20.0)):
                ok = False
                break
            txy = c.project(tendril)
            d, _ = cKDTree(txy).query(pxy)
            if np.min(d) < 40.0 or _poly_distance_px(c, paper, txy) < 40.0:
                ok = False
                break
            for obj in avoid_mm:
                if _poly_distance_px(c, paper, c.project(obj[::4])) < 40.0:
                    ok = False
            for mk in scene.markers:
                if _poly_distance_px(c, paper, _project_safe(c, _square_poly(mk, qs))) < 10.0:
                    ok = False
            if not ok:
                break
        if not ok:
            continue
        card.update({"tilt_deg": math.degrees(tilt), "incidence_deg": inc,
                     "corners_mm": card_corners_mm(card), "view": v + 1})
        return card
    raise _Retry("glancing_marker: no room for a tilted card clear of the tendril and the markers")


def world_marker_cover(scene: Scene, cams: list, curves: np.ndarray, radius: np.ndarray, *, board_tubes: list = (),
                       tubes: list = (), plates: list = (), cards: list = (),
                       calibration_frames: int = CALIBRATION_FRAMES) -> str | None:
    """What covers the world marker's paper in a view, or None when it is clear in every view.

    The world marker defines the world frame: the calibration must find it
    in every view. Every object the renderer draws over the board's markers
    is tested, on the half-resolution masks of
    :func:`tendrilkit.phantom.scene.build_scene`, against the marker's paper
    square (its quiet zone included): the taped stem and its node, the tape
    strips, side shoots on the board, objects in space (second tendril,
    shoots, petioles, leaves), marker cards, and the tendril swept over the
    frames that calibrate. Leaves lying on the board are not: the marker's paper is drawn
    over them, and so is every other marker's (placed clear of it).

    Parameters
    ----------
    scene : Scene
        The world marker (id :data:`~tendrilkit.phantom.design.WORLD_MARKER_ID`) among its markers.
    cams : list of Camera
        The views the calibration reads.
    curves : (n_frames, n, 3) float array
        The tendril, mm.
    radius : (n,) float array
        The tendril's radius per sample, mm.
    board_tubes, tubes, plates, cards : lists, keyword-only
        As :class:`~tendrilkit.phantom.scenes.make.ScenePhantom` holds them.
    calibration_frames : int, keyword-only
        The tendril is tested in its first ``calibration_frames`` frames
        (default :data:`CALIBRATION_FRAMES`): the others do not calibrate.

    Returns
    -------
    str or None
        E.g. ``"the stem in views 1, 2, 3"``: the objects over it and the views.
    """
    world = next(m for m in scene.markers if m.id == WORLD_MARKER_ID)
    paper = _square_poly(world, _quiet_scale())
    hits: dict[str, list[int]] = {}
    for v, cam in enumerate(cams):
        wm = _poly_mask(cam, paper)
        if not wm.any():
            continue
        objects = [("the stem", lambda: _tube_mask(cam, scene.stem_mm, scene.stem_radius_mm)),
                   ("the node", lambda: _tube_mask(cam, scene.node_mm[None], scene.node_radius_mm))]
        objects += [("a tape strip", lambda t=t: _poly_mask(cam, _rect_poly(*t))) for t in scene.tapes]
        objects += [("a side shoot on the board", lambda b=b: _tube_mask(cam, b["pts"], b["radius"]))
                    for b in board_tubes]
        objects += [("an object in space", lambda b=b: _tube_mask(cam, b["pts"], b["radius"])) for b in tubes]
        objects += [("a leaf in space", lambda p=p: _poly_mask(cam, p["poly"])) for p in plates]
        objects += [("a marker card", lambda c=c: _poly_mask(cam, card_corners_mm(c, _quiet_scale()))) for c in cards]
        objects += [("the tendril", lambda: _swept_mask(cam, curves[:calibration_frames], radius))]
        for name, mask in objects:
            if v + 1 not in hits.get(name, []) and np.any(mask() & wm):
                hits.setdefault(name, []).append(v + 1)
    if not hits:
        return None
    return "; ".join(f"{name} in view{'s' if len(vs) > 1 else ''} {', '.join(map(str, vs))}"
                     for name, vs in hits.items())


def _swept_mask(cam: Camera, curves: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """Half-resolution mask of the tendril's tube over every frame (every second sample)."""
    m = _tube_mask(cam, curves[0, ::2], radius[::2])
    for c in curves[1:]:
        m |= _tube_mask(cam, c[::2], radius[::2])
    return m
