"""Rendering random phantom scenes (:mod:`tendrilkit.phantom.scenes`).

A frame of a scene is drawn like a site phantom's
(:func:`tendrilkit.phantom.render.render_view`): the static board scene (board,
taped stem, leaves, markers) lit by a gradient with vignetting, then, per
frame, the tendril's soft shadow on the board, the objects behind the
tendril, the tendril (a tube of tapering radius, 4 x 4 supersampled, with a
lighter core), the objects in front of it, a global gain (drift and
flicker), optical blur, a short line blur (camera shake), sensor noise, and
JPEG re-encoding (a documented stand-in for H.264 artefacts: blocking and
ringing at low quality). The videos are then written as mp4v like the site
phantoms, so a frame is compressed twice, as a phone's H.264 recording
re-encoded by a user would be.

Public API: :func:`render_scene_view`; the files are written by
:func:`tendrilkit.io.write_scene_experiment`.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from tendrilkit.phantom.design import read_only
from tendrilkit.phantom.projection import _project_safe
from tendrilkit.phantom.render import (_INK, _PAPER, _STEM, _blend, _box_of, _light_map, _marker_bits, _render_static,
                                      _tube_cover, check_frame_view)
from tendrilkit.phantom.scene import _quiet_scale
from tendrilkit.phantom.scenes.make import ScenePhantom
from tendrilkit.phantom.scenes.markers import card_corners_mm


def _poly_cover(cam, poly_mm: np.ndarray, *, ss: int = 4) -> tuple[tuple[int, int, int, int], np.ndarray] | None:
    """Anti-aliased coverage of a planar polygon in space (k, 3) mm: box and (h, w) in [0, 1]."""
    xy = _project_safe(cam, poly_mm)
    if not np.all(np.isfinite(xy)):
        return None
    x0 = int(max(0, math.floor(xy[:, 0].min()) - 2))
    y0 = int(max(0, math.floor(xy[:, 1].min()) - 2))
    x1 = int(min(cam.width, math.ceil(xy[:, 0].max()) + 3))
    y1 = int(min(cam.height, math.ceil(xy[:, 1].max()) + 3))
    if x1 <= x0 or y1 <= y0:
        return None
    big = np.zeros(((y1 - y0) * ss, (x1 - x0) * ss), np.uint8)
    pts = np.round(((xy - [x0, y0] + 0.5) * ss - 0.5) * 16).astype(np.int32)
    cv2.fillPoly(big, [pts], 255, cv2.LINE_8, 4)
    cover = cv2.resize(big, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA).astype(np.float32) / 255.0
    return (x0, y0, x1, y1), cover


def _object_layers(ph: ScenePhantom, view: int) -> tuple[list, list]:
    """Coverage layers (box, cover, colour) of the objects behind and in front of the tendril in ``view``."""
    cam = ph.cameras[view]
    behind, front = [], []
    for tb in ph.tubes:
        res = _tube_cover(cam, tb["pts"], tb["radius"])
        if res is not None:
            layer = front if view in tb["front_views"] else behind
            layer.append((res[0], res[1], np.array(tb["colour"])))
            if "core_bgr" in tb:  # a lighter core, like the tendril's (shoots of issue 11's second round)
                core = _tube_cover(cam, tb["pts"], 0.4 * np.asarray(tb["radius"]), box=res[0])[1]
                layer.append((res[0], 0.6 * core, np.array(tb["core_bgr"])))
    for pl in ph.plates:
        res = _poly_cover(cam, pl["poly"])
        if res is not None:
            (front if view in pl["front_views"] else behind).append((res[0], res[1], np.array(pl["colour"])))
    return behind, front


def _smooth_field(rng: np.random.Generator, shape: tuple[int, int], cell_px: int) -> np.ndarray:
    """Zero-mean, unit-scale random field (H, W) float32 varying over about ``cell_px`` pixels."""
    H, W = shape
    low = rng.standard_normal((H // cell_px + 3, W // cell_px + 3)).astype(np.float32)
    big = cv2.resize(low, ((W // cell_px + 3) * cell_px, (H // cell_px + 3) * cell_px), interpolation=cv2.INTER_CUBIC)
    return big[cell_px:cell_px + H, cell_px:cell_px + W]


def _texture(albedo: np.ndarray, rng: np.random.Generator) -> None:
    """Paper and leaf texture in place: slow +-1.5 % shading of the board, +-6 % mottling of green parts."""
    H, W = albedo.shape[:2]
    slow = _smooth_field(rng, (H, W), 240)
    fine = _smooth_field(rng, (H, W), 16)
    green = np.clip((albedo[..., 1] - albedo[..., 2] - 20.0) / 30.0, 0.0, 1.0)
    albedo *= (1.0 + 0.015 * slow + 0.004 * fine + 0.06 * green * fine)[..., None]


def _render_card(albedo: np.ndarray, cam, card: dict, *, ss: int = 4) -> None:
    """Draw a marker card (:func:`tendrilkit.phantom.scenes.markers.place_card`) into ``albedo`` in place.

    Every pixel of the card's box is sampled ``ss x ss`` times; each sample's
    ray (undistorted) meets the card's plane at local coordinates that pick
    the paper, a black or a white cell, exactly as the board's markers.
    """
    qs = _quiet_scale()
    box = _box_of(cam, card_corners_mm(card, qs), 3)
    if box is None:
        return
    x0, y0, x1, y1 = box
    off = (np.arange(ss) + 0.5) / ss - 0.5
    xs = (np.arange(x0, x1)[:, None] + off[None, :]).ravel()
    ys = (np.arange(y0, y1)[:, None] + off[None, :]).ravel()
    XX, YY = np.meshgrid(xs, ys)
    und = cam.undistort_points(np.stack([XX.ravel(), YY.ravel()], axis=1))
    rays = (np.hstack([und, np.ones((len(und), 1))]) @ np.linalg.inv(cam.K).T) @ cam.R
    c0 = cam.center_world
    centre, e1, e2 = (np.asarray(card[k], float) for k in ("centre_mm", "e1", "e2"))
    n = np.cross(e1, e2)
    lam = ((centre - c0) @ n) / (rays @ n)
    P = c0[None] + lam[:, None] * rays - centre[None]
    u, w = P @ e1, P @ e2
    half = 0.5 * card["length_mm"]
    paper = (np.abs(u) <= half * qs) & (np.abs(w) <= half * qs) & (lam > 0)
    cell = card["length_mm"] / 7.0
    col = np.floor((u + half) / cell).astype(int)
    row = np.floor((half - w) / cell).astype(int)
    inmk = (col >= 0) & (col < 7) & (row >= 0) & (row < 7)
    bits = _marker_bits(card["id"])
    white = np.where(inmk, bits[np.clip(row, 0, 6), np.clip(col, 0, 6)], True)
    # a tilted card gets less of the light from above than the board (Lambertian, light from the cameras' side)
    shade = 0.7 + 0.3 * float(abs(n[2]))
    colour = shade * np.where(white[:, None], _PAPER, _INK)
    h, wd = y1 - y0, x1 - x0
    paper = paper.reshape(h, ss, wd, ss).transpose(0, 2, 1, 3).reshape(h, wd, ss * ss)
    colour = colour.reshape(h, ss, wd, ss, 3).transpose(0, 2, 1, 3, 4).reshape(h, wd, ss * ss, 3)
    cover = paper.mean(axis=-1)
    colsum = (colour * paper[..., None]).sum(axis=2) / paper.shape[-1]
    sub = albedo[y0:y1, x0:x1]
    sub *= (1.0 - cover)[..., None].astype(np.float32)
    sub += colsum.astype(np.float32)


def scene_layers(ph: ScenePhantom, view: int) -> dict:
    """The static layers of one view of a scene, rendered on first use and kept with the scene.

    Returns
    -------
    dict
        ``light`` (H, W) float32; ``lit`` (H, W, 3) float32 (board, stems,
        textures and the objects behind the tendril, lit); ``front`` list of
        (box, coverage, colour) of the objects in front of it; ``noise``
        (H + 32, W + 32, 3) int8. Arrays read-only; kept in the scene's private
        ``_layers`` (freed with it).
    """
    key = ("scene", view)
    if key not in ph._layers:
        cam = ph.cameras[view]
        albedo = _render_static(ph, view)
        for bt in ph.board_tubes:  # side shoots of the stem, on the board
            res = _tube_cover(cam, bt["pts"], bt["radius"])
            if res is not None:
                _blend(albedo, res[0], res[1], _STEM)
        for card in ph.cards:  # markers on cards standing on the board
            _render_card(albedo, cam, card)
        _texture(albedo, np.random.default_rng([ph.seed, 1125, view]))
        behind, front = _object_layers(ph, view)
        for box, cover, colour in behind:
            _blend(albedo, box, cover, colour)
        light = _light_map(cam, ph.scene.light, view)
        rng = np.random.default_rng([ph.seed, 1121, view])
        noise = np.clip(np.round(rng.standard_normal((cam.height + 32, cam.width + 32, 3), dtype=np.float32)
                                 * np.float32(ph.imaging["noise_sigma"])), -127, 127).astype(np.int8)
        front = [(box, read_only(cover), read_only(colour)) for box, cover, colour in front]
        ph._layers[key] = {"light": read_only(light), "lit": read_only(albedo * light[..., None]), "front": front,
                           "noise": read_only(noise)}
    return ph._layers[key]


def render_scene_view(ph: ScenePhantom, frame: int, view_index: int) -> np.ndarray:
    """One frame of one view of a scene, BGR uint8 (height, width, 3), after JPEG re-encoding if asked.

    Parameters
    ----------
    ph : ScenePhantom
    frame : int
        0-based frame.
    view_index : int
        0-based view.
    """
    check_frame_view(ph, frame, view_index)
    st = scene_layers(ph, view_index)
    cam = ph.cameras[view_index]
    im = ph.imaging
    img = st["lit"].copy()
    curve = ph.curves_mm[frame]
    sh = im["shadow"]
    if sh is not None:  # soft shadow: the tube projected along the light onto the board
        ldir = np.asarray(sh["light_dir"])
        spts = curve - (curve[:, 2] / ldir[2])[:, None] * ldir[None]
        spts[:, 2] = 0.0
        pad = int(3 * sh["softness_px"]) + 2
        res = _tube_cover(cam, spts, 1.2 * ph.radius_mm, pad_px=pad)
        if res is not None:
            (x0, y0, x1, y1), cover = res
            cover = cv2.GaussianBlur(cover, (0, 0), sh["softness_px"])
            img[y0:y1, x0:x1] *= (1.0 - sh["strength"] * cover)[..., None]
    res = _tube_cover(cam, curve, ph.radius_mm, pad_px=4)
    if res is not None:
        (x0, y0, x1, y1), cover = res
        core = _tube_cover(cam, curve, 0.4 * ph.radius_mm, box=(x0, y0, x1, y1))[1]
        tube, hi = np.asarray(im["tendril_bgr"], np.float32), np.asarray(im["core_bgr"], np.float32)
        colour = tube[None, None, :] + (0.6 * core)[..., None] * (hi - tube)[None, None, :]
        colour *= st["light"][y0:y1, x0:x1, None]
        sub = img[y0:y1, x0:x1]
        sub += cover[..., None] * (colour - sub)
    for (x0, y0, x1, y1), cover, colour in st["front"]:
        sub = img[y0:y1, x0:x1]
        sub += cover[..., None] * (colour[None, None, :].astype(np.float32) * st["light"][y0:y1, x0:x1, None] - sub)
    img *= np.float32(im["gain"][frame])
    if im["blur_sigma_px"] > 0:
        img = cv2.GaussianBlur(img, (0, 0), im["blur_sigma_px"])
    if im["motion_blur_px"] is not None:
        ln, ang = float(im["motion_blur_px"][frame]), math.radians(float(im["motion_blur_deg"][frame]))
        k = int(math.ceil(ln)) | 1
        ker = np.zeros((k, k), np.float32)
        c = (k - 1) / 2
        for t in np.linspace(-ln / 2, ln / 2, 4 * k):
            ker[int(round(c + t * math.sin(ang))), int(round(c + t * math.cos(ang)))] += 1.0
        img = cv2.filter2D(img, -1, ker / ker.sum())
    out = cv2.convertScaleAbs(img)
    rng = np.random.default_rng([ph.seed, 1123, frame, view_index])
    oy, ox = rng.integers(0, 32, size=2)
    out = cv2.add(out, st["noise"][oy:oy + cam.height, ox:ox + cam.width], dtype=cv2.CV_8U)
    if im["jpeg_quality"] is not None:
        ok, buf = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(im["jpeg_quality"][frame])])
        out = cv2.imdecode(buf, cv2.IMREAD_COLOR)
    return out
