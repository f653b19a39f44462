"""Clutter and marks of the random phantom scenes: objects near the tendril, careless marks.

Placed by :func:`tendrilkit.phantom.scenes.make_scene` after the tendril and the
site phantom's scene: leaves and side shoots on the board under or along the
tendril, a leaf the tip rests on, a second tendril, a leaf, a side shoot of
the stem and a leaf's petiole in space (in front of or behind the tendril in
each view), and marks as a hurried user draws them (markers are in
:mod:`tendrilkit.phantom.scenes.markers`). Every object in space keeps a
surface gap from the tendril's tube in every frame
(:func:`tube_clearance_mm`); a placement that fails raises :class:`_Retry`
and the generator draws another design.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from tendrilkit.phantom.projection import _pixel_to_board, _project_safe
from tendrilkit.phantom.scene import Scene, _ellipse_poly, _local, _quiet_scale
from tendrilkit.camera import Camera
from tendrilkit.geometry import arc_length


class _Retry(Exception):
    """This attempt cannot realise a factor; the generator draws another design."""


def tube_clearance_mm(curves: np.ndarray, radius: np.ndarray, pts: np.ndarray, pts_radius: np.ndarray) -> float:
    """Smallest surface gap (mm) between a tube along ``pts`` and the tendril's tube in any frame.

    Parameters
    ----------
    curves : (n_frames, n, 3) float array
        Tendril centrelines, mm.
    radius : (n,) float array
        Tendril radius per sample, mm.
    pts : (m, 3) float array
        The object's centreline (or surface samples with ``pts_radius`` 0), mm.
    pts_radius : (m,) float array
    """
    tree = cKDTree(pts)
    gap = np.inf
    for c in curves:
        d, i = tree.query(c)
        gap = min(gap, float(np.min(d - radius - pts_radius[i])))
    return gap


# ================================================================ objects
def _dense(poly: np.ndarray, step: float = 0.5) -> np.ndarray:
    s = arc_length(poly)
    t = np.arange(0.0, s[-1] + 1e-9, step)
    return np.stack([np.interp(t, s, poly[:, k]) for k in range(poly.shape[1])], axis=1)


def _clear_of_markers(scene: Scene, xy: np.ndarray, pad: float) -> bool:
    """Board points ``xy`` (k, 2) keep ``pad`` mm from every marker's paper square."""
    qs = _quiet_scale()
    for m in scene.markers:
        loc = _local(xy, m.centre_mm, m.angle_deg)
        half = 0.5 * m.length_mm * qs + pad
        if np.any((np.abs(loc[:, 0]) <= half) & (np.abs(loc[:, 1]) <= half)):
            return False
    return True


def _board_point_under(cam: Camera, X: np.ndarray) -> np.ndarray:
    """Board point (2,) mm seen at the same pixel as world point ``X`` (3,)."""
    return _pixel_to_board(cam, cam.project(X[None]))[0]


def _place_over_leaf(ph: dict, rng) -> dict:
    cams, curves, s = ph["cams"], ph["curves"], ph["s"]
    L = s[-1]
    for _ in range(15):
        X = curves[-1, int(np.searchsorted(s, rng.uniform(0.3, 0.8) * L))]
        v = int(rng.integers(3))
        centre = _board_point_under(cams[v], X)
        a, b = float(rng.uniform(18.0, 30.0)), float(rng.uniform(9.0, 15.0))
        ang = float(rng.uniform(0, 180))
        d = np.array([math.cos(math.radians(ang)), math.sin(math.radians(ang))])
        outline = _ellipse_poly(centre, ang, a + 3, b + 3)[:, :2]
        if not _clear_of_markers(ph["scene"], np.vstack([outline, centre[None]]), 3.0):
            continue
        leaf = {"centre": centre, "angle_deg": ang, "a_mm": a, "b_mm": b,
                "petiole": np.stack([centre + d * (a + 14.0), centre + d * 0.7 * a])}
        return {"leaf": leaf, "view": v + 1, "centre_mm": centre.tolist()}
    raise _Retry("over_leaf: no room for a leaf under the tendril")


def _place_board_shoot(ph: dict, rng, alongside: bool) -> dict:
    cams, curves, s, radius = ph["cams"], ph["curves"], ph["s"], ph["radius"]
    L = s[-1]
    r = float(rng.uniform(1.2, 1.6))
    for _ in range(20):
        v = int(rng.integers(3))
        cam = cams[v]
        if alongside:
            # along the proximal part (before any curl), smoothed: a shoot does not follow a coil
            s0 = rng.uniform(0.08, 0.2) * L
            sel = (s >= s0) & (s <= s0 + rng.uniform(0.25, 0.45) * L)
            xy = cam.project(curves[-1, sel][::8])
            u = np.linspace(-1, 1, len(xy))
            xy = np.stack([np.polyval(np.polyfit(u, xy[:, k], 2), u) for k in (0, 1)], axis=1)
            t = np.gradient(xy, axis=0)
            n = np.stack([-t[:, 1], t[:, 0]], axis=1) / np.linalg.norm(t, axis=1, keepdims=True)
            off = float(rng.uniform(14.0, 26.0)) * (1 if rng.uniform() < 0.5 else -1)
            board = _pixel_to_board(cam, xy + off * n)
        else:
            X = curves[-1, int(np.searchsorted(s, rng.uniform(0.3, 0.8) * L))]
            c = _board_point_under(cam, X)
            k = int(np.searchsorted(s, s[np.argmin(np.linalg.norm(curves[-1] - X, axis=1))]))
            tan = curves[-1, min(k + 4, len(s) - 1), :2] - curves[-1, max(k - 4, 0), :2]
            ang = math.atan2(tan[1], tan[0]) + math.pi / 2 + rng.uniform(-0.5, 0.5)
            d = np.array([math.cos(ang), math.sin(ang)])
            half = float(rng.uniform(30.0, 50.0))
            board = np.stack([c - half * d, c + half * d])
        pts = _dense(np.hstack([board, np.full((len(board), 1), r)]))
        rad = np.full(len(pts), r)
        if not _clear_of_markers(ph["scene"], pts[:, :2], 2.0):
            continue
        if tube_clearance_mm(curves, radius, pts, rad) < 0.5:
            continue
        info = {"pts": pts, "radius": rad, "view": v + 1}
        if alongside:
            xy_t = cam.project(curves[-1, ::4])
            d2, _ = cKDTree(xy_t).query(cam.project(pts))
            med = float(np.median(d2))
            if not 8.0 <= med <= 35.0 or np.mean((d2 >= 8.0) & (d2 <= 35.0)) < 0.6:
                continue
            info["median_distance_px"] = med
            info["length_mm"] = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
        return info
    raise _Retry(("alongside" if alongside else "over_stem") + ": no room for a side shoot")


def _plate(centre: np.ndarray, angle_deg: float, a: float, b: float) -> np.ndarray:
    poly = _ellipse_poly(centre[:2], angle_deg, a, b, n=64)
    poly[:, 2] = centre[2]
    return poly


def _inside_plate(xy: np.ndarray, centre: np.ndarray, angle_deg: float, a: float, b: float) -> np.ndarray:
    loc = _local(xy, centre[:2], angle_deg)
    return (loc[:, 0] / a) ** 2 + (loc[:, 1] / b) ** 2 <= 1.0


def _plate3d(centre: np.ndarray, normal: np.ndarray, a: float, b: float, spin: float, n: int = 64
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An ellipse (n, 3) in the plane through ``centre`` with ``normal``; and its in-plane axes."""
    e1 = np.cross(normal, [0.0, 0.0, 1.0] if abs(normal[2]) < 0.9 else [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    e1, e2 = math.cos(spin) * e1 + math.sin(spin) * e2, -math.sin(spin) * e1 + math.cos(spin) * e2
    th = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return centre + a * np.cos(th)[:, None] * e1 + b * np.sin(th)[:, None] * e2, e1, e2


def _pierces(curves: np.ndarray, radius: np.ndarray, centre: np.ndarray, nrm: np.ndarray, e1: np.ndarray,
             e2: np.ndarray, a: float, b: float) -> bool:
    """True when the tendril's tube crosses a thin elliptic plate (beyond it along ``nrm``) in some frame."""
    for c in curves:
        rel = c - centre
        ins = ((rel @ e1) / a) ** 2 + ((rel @ e2) / b) ** 2 <= 1.0
        if np.any(ins & (rel @ nrm + radius > 0.0)):
            return True
    return False


def _place_tip_leaf(ph: dict, rng) -> dict:
    """A leaf (plate) beyond and below the tip, placed so the tip rests on it in several frames.

    The leaf's normal leans from the tip's tangent downwards. In the later
    rounds of :func:`~tendrilkit.phantom.scenes.make.make_scene` (``rest_frames``
    given), when no such leaf works, the normal leans from the tip's outward
    side instead (away from the distal quarter's centre): at the end of a
    coil, the turn before the tip lies ahead of it along its tangent and
    would hold a leaf there off the tip, while nothing of the tendril lies
    beyond its outer side.
    """
    curves, radius, s = ph["curves"], ph["radius"], ph["s"]
    rest = ph.get("rest_frames")  # relaxed: the leaf is placed where the tip rests after the curl
    down = np.array([0.0, 0.0, -1.0])
    T = curves[-1, -1] - curves[-1, -5]
    T /= np.linalg.norm(T)

    def attempts(towards, lean_lo, lean_hi):  # 12 leaves of random size, normal `towards` leaning down
        for _ in range(12):
            a, b = float(rng.uniform(10.0, 16.0)), float(rng.uniform(6.0, 9.0))
            r = _tip_leaf(curves, radius, s, rest, towards + rng.uniform(lean_lo, lean_hi) * down, a, b, rng)
            if r is not None:
                return r
        return None

    r = attempts(T, 0.3, 1.0)
    if r is not None:
        return r
    if rest is not None:
        distal = curves[rest[-1], s >= 0.75 * s[-1]]
        out = curves[rest[-1], -1] - distal.mean(axis=0)
        out -= np.dot(out, T) * T
        if np.linalg.norm(out) > 1e-6:
            r = attempts(out / np.linalg.norm(out), 0.0, 0.6)
            if r is not None:
                return r
    raise _Retry("tip_leaf: the tip rests on no leaf for several frames")


def _tip_leaf(curves: np.ndarray, radius: np.ndarray, s: np.ndarray, rest, nrm: np.ndarray, a: float, b: float,
              rng) -> dict | None:
    """An elliptic leaf (semi-axes ``a``, ``b`` mm) of normal ``nrm`` just beyond the tip, or None when
    it would pierce the tendril, reach below the board or touch the tip in fewer than two frames."""
    n, L = len(curves), float(s[-1])
    need = min(2, n)
    nrm = nrm / np.linalg.norm(nrm)
    if rest is not None:  # the tip slides along the leaf between the resting frames: the normal across its path
        dv = curves[rest[-1], -1] - curves[rest[0], -1]
        if np.linalg.norm(dv) > 1e-6:
            dv /= np.linalg.norm(dv)
            nrm = nrm - np.dot(nrm, dv) * dv
            nrm /= np.linalg.norm(nrm)
    tip = (curves if rest is None else curves[rest])[:, -1].mean(axis=0)
    _, e1, e2 = _plate3d(tip, nrm, a, b, 0.0)
    off = rng.uniform(-0.3, 0.3, size=2) * [a, b]
    # the plane's offset along the normal: the most advanced tendril surface over its footprint
    h = -np.inf
    for c in (curves if rest is None else curves[rest]):
        rel = c - tip
        ins = ((rel @ e1 - off[0]) / a) ** 2 + ((rel @ e2 - off[1]) / b) ** 2 <= 1.0
        if ins.any():
            h = max(h, float(np.max(rel[ins] @ nrm + radius[ins])))
    if not np.isfinite(h):
        return None
    centre = tip + off[0] * e1 + off[1] * e2 + (h + 0.02) * nrm
    poly, _, _ = _plate3d(centre, nrm, a, b, 0.0)
    if rest is not None and _pierces(curves, radius, centre, nrm, e1, e2, a, b):
        return None
    if poly[:, 2].min() < 0.5:
        return None
    near = s >= L - 8.0
    touching = []
    for f, c in enumerate(curves):
        rel = c[near] - centre
        ins = ((rel @ e1) / a) ** 2 + ((rel @ e2) / b) ** 2 <= 1.0
        gap = -(rel @ nrm) - radius[near]
        if np.any(ins & (gap < 0.5)):  # within 0.5 mm (2-3 px): touching in the images
            touching.append(f)
    if len(touching) < need:
        return None
    return {"plate": poly, "touching_frames": touching, "centre_mm": centre.tolist(), "normal": nrm.tolist()}


def _hidden_by_plate(cam: Camera, plate: np.ndarray, pts: np.ndarray) -> np.ndarray:
    poly = _project_safe(cam, plate)
    if not np.all(np.isfinite(poly)):
        return np.zeros(len(pts), bool)
    xy = _project_safe(cam, pts)
    contour = poly.astype(np.float32).reshape(-1, 1, 2)
    return np.array([np.isfinite(p).all() and _point_in(contour, p) for p in xy])


def _point_in(contour: np.ndarray, p: np.ndarray) -> bool:
    import cv2

    return cv2.pointPolygonTest(contour, (float(p[0]), float(p[1])), False) >= 0


def _place_occluding_leaf(ph: dict, rng) -> dict:
    cams, curves, s, radius = ph["cams"], ph["curves"], ph["s"], ph["radius"]
    L, n = s[-1], len(curves)
    for _ in range(15):
        v = int(rng.integers(3))
        cam = cams[v]
        f = n // 2
        X = curves[f, int(np.searchsorted(s, rng.uniform(0.45, 0.9) * L))]
        w = cam.center_world - X
        w /= np.linalg.norm(w)
        dz = float(rng.uniform(10.0, 20.0))
        c = X + dz / w[2] * w
        a, b = float(rng.uniform(7.0, 11.0)), float(rng.uniform(4.0, 6.5))
        ang = float(rng.uniform(0, 180))
        plate = _plate(c, ang, a, b)
        ok = True
        for k in range(n):
            ins = _inside_plate(curves[k, :, :2], c, ang, a, b)
            if ins.any() and np.max(curves[k, ins, 2] + radius[ins]) > c[2] - 1.0:
                ok = False
        if not ok:
            continue
        hid = np.array([[_hidden_by_plate(cams[u], plate, curves[k, ::8]).mean() for u in range(3)] for k in range(n)])
        others = [u for u in range(3) if u != v]
        if hid[:, others].max() > 0.1 or hid[:, v].max() < 0.03:
            continue
        return {"plate": plate, "view": v + 1, "centre_mm": c.tolist(), "hidden_fraction": hid[:, v].tolist()}
    raise _Retry("occluding_leaf: no leaf position hides the tendril in one view only")


def _place_second_tendril(ph: dict, rng) -> dict:
    cams, curves, s, radius = ph["cams"], ph["curves"], ph["s"], ph["radius"]
    L, n = s[-1], len(curves)
    r2 = float(rng.uniform(0.5, 0.75))
    for _ in range(20):
        v = int(rng.integers(3))
        cam = cams[v]
        f = n - 1
        k = int(np.searchsorted(s, rng.uniform(0.3, 0.85) * L))
        X = curves[f, k]
        w = cam.center_world - X
        w /= np.linalg.norm(w)
        front = bool(rng.uniform() < 0.5)
        d = float(rng.uniform(6.0, 14.0))
        if not front:
            d = -min(d, (X[2] - r2 - 3.0) / w[2])
            if d > -3.0:
                front, d = True, -d if d < 0 else 6.0
        q = X + d * w
        tan = curves[f, min(k + 4, len(s) - 1)] - curves[f, max(k - 4, 0)]
        tan -= np.dot(tan, w) * w
        tan /= np.linalg.norm(tan)
        across = np.cross(w, tan)
        ang = rng.uniform(-0.7, 0.7)  # 50-130 degrees to the tendril in that view
        u = math.cos(ang) * across + math.sin(ang) * tan
        nrm = np.cross(w, u)
        t = np.arange(-float(rng.uniform(25, 45)), float(rng.uniform(30, 55)), 0.5)
        kap = float(rng.uniform(-0.008, 0.008))
        pts = q[None] + t[:, None] * u[None] + 0.5 * kap * (t ** 2)[:, None] * nrm[None]
        rad = r2 * (1.0 - 0.3 * (t - t[0]) / (t[-1] - t[0]))
        if np.min(pts[:, 2] - rad) < 1.0:
            continue
        if tube_clearance_mm(curves, radius, pts, rad) < 1.0:
            continue
        return {"pts": pts, "radius": rad, "view": v + 1, "in_front": front, "depth_offset_mm": abs(d),
                "crossing_mm": X.tolist()}
    raise _Retry("second_tendril: no path crosses the tendril in a view without touching it")


def _front_hidden(cams: list, curves: np.ndarray, radius: np.ndarray, tubes: list, plates: list) -> np.ndarray:
    """Fraction (n_frames, n_views) of centreline samples hidden by objects in front or outside the image."""
    out = np.zeros((len(curves), len(cams)))
    for f in range(len(curves)):
        pts = curves[f, ::4]
        for v, cam in enumerate(cams):
            hid = ~cam.in_image(np.nan_to_num(_project_safe(cam, pts), nan=-1e9))
            for p in plates:
                if p.get("front_views") and v in p["front_views"]:
                    hid |= _hidden_by_plate(cam, p["poly"], pts)
            xy = cam.project(pts)
            depth = cam.world_to_cam(pts)[:, 2]
            for tb in tubes:
                if v not in tb["front_views"]:
                    continue
                txy = cam.project(tb["pts"])
                tr = tb["radius"] / cam.world_to_cam(tb["pts"])[:, 2] * cam.K[0, 0]
                d, i = cKDTree(txy).query(xy)
                hid |= (d < tr[i]) & (cam.world_to_cam(tb["pts"][i])[:, 2] < depth)
            out[f, v] = float(hid.mean())
    return out


def _front_views(cams: list, curves: np.ndarray, pts: np.ndarray) -> list[int]:
    """Views in which an object along ``pts`` is in front of the tendril where they overlap."""
    out = []
    for v, cam in enumerate(cams):
        xy_o = cam.project(pts)
        z_o = cam.world_to_cam(pts)[:, 2]
        votes = 0
        for c in curves:
            d, i = cKDTree(cam.project(c[::2])).query(xy_o)
            near = d < 15.0
            if near.any():
                votes += int(np.sum(z_o[near] < cam.world_to_cam(c[::2][i[near]])[:, 2]))
                votes -= int(np.sum(z_o[near] >= cam.world_to_cam(c[::2][i[near]])[:, 2]))
        if votes > 0:
            out.append(v)
    return out


# ================================================================== marks
def _careless(views: list, cams: list, scene: Scene, rng) -> tuple[list, dict]:
    """Marks as a hurried user draws them: generous ROI, sloppy keep-out box, base point off."""
    out, info = [], []
    for m, cam in zip(views, cams):
        x, y, w, h = m["roi"]
        g = rng.uniform(20.0, 160.0, size=4).astype(int)
        x0, y0 = max(0, x - g[0]), max(0, y - g[1])
        x1, y1 = min(cam.width - 1, x + w + g[2]), min(cam.height - 1, y + h + g[3])
        # take in part of the nearest marker (its border) when one is close
        best = None
        for mk in scene.markers:
            pxy = _project_safe(cam, mk.corners_mm(_quiet_scale()))
            if not np.all(np.isfinite(pxy)):
                continue
            cx, cy = pxy.mean(axis=0)
            d = max(x0 - cx, cx - x1, 0) + max(y0 - cy, cy - y1, 0)
            if best is None or d < best[0]:
                best = (d, pxy)
        took_marker = False
        if best is not None and best[0] < 250 and rng.uniform() < 0.7:
            lo, hi = best[1].min(axis=0), best[1].max(axis=0)
            x0, y0 = int(min(x0, max(0, lo[0] + 0.6 * (hi[0] - lo[0])))), int(min(y0, max(0, lo[1] + 0.6 * (hi[1] - lo[1]))))
            x1, y1 = int(max(x1, min(cam.width - 1, hi[0] - 0.6 * (hi[0] - lo[0])))), int(max(y1, min(cam.height - 1, hi[1] - 0.6 * (hi[1] - lo[1]))))
            took_marker = True
        kx, ky, kw, kh = m["keep_out"]
        sx, sy = rng.uniform(0.7, 1.6, size=2)
        dx, dy = rng.integers(-6, 7, size=2)
        nw, nh = max(3, int(round(kw * sx))), max(3, int(round(kh * sy)))
        nx = int(kx + (kw - nw) // 2 + dx)
        ny = int(ky + (kh - nh) // 2 + dy)
        ang = rng.uniform(0, 2 * np.pi)
        off = rng.uniform(2.0, 5.0)
        bp = [int(round(m["base_point"][0] + off * math.cos(ang))), int(round(m["base_point"][1] + off * math.sin(ang)))]
        out.append({"view": m["view"], "roi": [int(x0), int(y0), int(x1 - x0 + 1), int(y1 - y0 + 1)],
                    "keep_out": [max(0, nx), max(0, ny), nw, nh], "base_point": bp})
        info.append({"view": m["view"], "roi_growth_px": [int(v) for v in g], "roi_takes_marker": took_marker,
                     "keep_out_scale": [float(sx), float(sy)], "keep_out_offset_px": [int(dx), int(dy)],
                     "base_point_offset_px": float(off)})
    return out, {"views": info}


# ======================================================= shoots in space
#: Colours (BGR) of the tubes that cross the tendril's projection.
SHOOT_BGR = [38.0, 92.0, 52.0]  # a side shoot of the stem (the stem's colour)
PETIOLE_BGR = [58.0, 136.0, 76.0]  # a leaf's petiole, lighter
PETIOLE_LEAF_BGR = [48.0, 128.0, 62.0]


def _shoot_path(a: np.ndarray, q: np.ndarray, e: np.ndarray, bow: np.ndarray, step: float = 0.5) -> np.ndarray:
    """A smooth curve (m, 3) from ``a`` through ``q`` to ``e``, bowed by ``bow`` (3,) mm between ``a`` and ``q``.

    A cubic spline through ``a``, the bowed midpoint of ``a`` and ``q``, ``q``
    and ``e`` (chord-length parameter), sampled every ``step`` mm.
    """
    from scipy.interpolate import CubicSpline

    knots = np.stack([a, 0.5 * (a + q) + bow, q, e])
    u = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))]
    t = np.linspace(0.0, u[-1], 600)
    return _dense(CubicSpline(u, knots, bc_type="natural")(t), step)


def _hides_a_marker(cams: list, scene: Scene, pts: np.ndarray, pad_px: float = 6.0) -> bool:
    """True when points ``pts`` (m, 3) project onto (or within ``pad_px`` of) a marker's paper in a view."""
    for cam in cams:
        xy = _project_safe(cam, pts)
        xy = xy[np.all(np.isfinite(xy), axis=1)]
        for mk in scene.markers:
            poly = _project_safe(cam, mk.corners_mm(_quiet_scale()))
            if len(xy) == 0 or not np.all(np.isfinite(poly)):
                continue
            contour = poly.astype(np.float32).reshape(-1, 1, 2)
            if any(_signed_distance_px(contour, p) >= -pad_px for p in xy[::2]):
                return True
    return False


def _signed_distance_px(contour: np.ndarray, p: np.ndarray) -> float:
    """Signed distance (px, positive inside) of point ``p`` (2,) to a polygon ``contour``."""
    import cv2

    return float(cv2.pointPolygonTest(contour, (float(p[0]), float(p[1])), True))


def _crossing_2d(cam: Camera, curve: np.ndarray, radius: np.ndarray, pts: np.ndarray, rad: np.ndarray
                 ) -> tuple[float, float]:
    """Gap (px, negative = overlap) between the projections of the tendril and a tube, and their angle (deg)."""
    xy_t = cam.project(curve[::2])
    xy_o = cam.project(pts)
    d, i = cKDTree(xy_t).query(xy_o)
    j = int(np.argmin(d))
    f = cam.K[0, 0]
    r_t = radius[::2][i[j]] / cam.world_to_cam(curve[::2][i[j]][None])[0, 2] * f
    r_o = rad[j] / cam.world_to_cam(pts[j][None])[0, 2] * f
    to = xy_o[min(j + 3, len(xy_o) - 1)] - xy_o[max(j - 3, 0)]
    k = i[j]
    tt = xy_t[min(k + 3, len(xy_t) - 1)] - xy_t[max(k - 3, 0)]
    c = abs(float(np.dot(to, tt))) / max(1e-9, float(np.linalg.norm(to) * np.linalg.norm(tt)))
    return float(d[j] - r_t - r_o), math.degrees(math.acos(min(1.0, c)))


def _place_crossing_shoot(ph: dict, rng, *, kind: str) -> dict:
    """A shoot from the stem, in space, crossing the tendril's projection in one view.

    ``kind``: ``behind_stem`` (a side shoot of the stem, 2.4-3.4 mm thick,
    passing between one camera and the tendril: the tendril passes behind it
    in that view) or ``petiole`` (a leaf's petiole, 0.9-1.4 mm, in front of
    or behind the tendril, ending in a leaf blade). Both start on the stem,
    keep at least 1 mm (surface to surface) from the tendril's tube in every
    frame, and hide no marker in any view.
    """
    cams, curves, s, radius, scene = ph["cams"], ph["curves"], ph["s"], ph["radius"], ph["scene"]
    L, n = float(s[-1]), len(curves)
    stem, node = scene.stem_mm, scene.node_mm
    for _ in range(30):
        v = int(rng.integers(3))
        cam = cams[v]
        f = int(rng.integers(n))
        k = int(np.searchsorted(s, rng.uniform(0.3, 0.85) * L))
        X = curves[f, k]
        w = cam.center_world - X
        w /= np.linalg.norm(w)
        if kind == "behind_stem":
            r, front = float(rng.uniform(1.2, 1.7)), True
        else:
            r, front = float(rng.uniform(0.45, 0.7)), bool(rng.uniform() < 0.5)
        d = float(rng.uniform(5.0, 12.0))
        if not front:
            d = -min(d, (X[2] - r - 3.0) / w[2])
            if d > -3.0:
                continue
        q = X + d * w
        dist = np.linalg.norm(stem[:, :2] - q[None, :2], axis=1)
        ok = (dist > 25.0) & (dist < 80.0) & (np.linalg.norm(stem[:, :2] - node[None, :2], axis=1) > 35.0)
        if not ok.any():
            continue
        a = stem[int(rng.choice(np.flatnonzero(ok)))].copy()
        u = q - a
        u /= np.linalg.norm(u)
        e = q + float(rng.uniform(15.0, 35.0)) * u
        e[2] = max(r + 1.0, e[2] - float(rng.uniform(0.0, 8.0)))
        side = np.cross(u, rng.standard_normal(3))
        side /= np.linalg.norm(side)
        side *= np.sign(side[2]) if side[2] != 0 else 1.0  # arching up, not into the board
        pts = _shoot_path(a, q, e, float(rng.uniform(0.08, 0.2)) * float(np.linalg.norm(q - a)) * side)
        t = np.linspace(0.0, 1.0, len(pts))
        rad = r * (1.0 - 0.35 * t)
        if np.min(pts[4:, 2] - rad[4:]) < 0.2:
            continue
        if tube_clearance_mm(curves, radius, pts, rad) < 1.0:
            continue
        gap, ang = _crossing_2d(cam, curves[f], radius, pts, rad)
        if gap > -1.0 or ang < 35.0:
            continue
        if _hides_a_marker(cams, scene, pts) or depth_order_mixed(cams, curves, radius, pts, rad):
            continue
        info = {"pts": pts, "radius": rad, "view": v + 1, "frame": f, "in_front": front, "depth_offset_mm": abs(d),
                "crossing_mm": X.tolist(), "crossing_angle_deg": ang, "stem_point_mm": a.tolist()}
        if kind == "petiole":
            la, lb = float(rng.uniform(10.0, 16.0)), float(rng.uniform(6.0, 9.0))
            nrm = np.array([0.0, 0.0, 1.0]) + 0.6 * rng.standard_normal(3)
            nrm /= np.linalg.norm(nrm)
            tip_dir = pts[-1] - pts[-8]
            tip_dir /= np.linalg.norm(tip_dir)
            c = pts[-1] + la * tip_dir
            poly, e1, _ = _plate3d(c, nrm, la, lb, 0.0)
            # turn the blade so its long axis continues the petiole
            spin = math.atan2(float(np.dot(np.cross(e1, tip_dir), nrm)), float(np.dot(e1, tip_dir)))
            poly, _, _ = _plate3d(c, nrm, la, lb, spin)
            fill = np.vstack([poly, 0.5 * (poly + c), c[None]])
            if poly[:, 2].min() < 0.5 or tube_clearance_mm(curves, radius, fill, np.zeros(len(fill))) < 1.0:
                continue
            if _hides_a_marker(cams, scene, fill):
                continue
            info["leaf"] = poly
        return info
    raise _Retry(f"{kind}: no shoot from the stem crosses the tendril in a view without touching it")


def hidden_s_ranges(cam: Camera, curve: np.ndarray, s: np.ndarray, radius: np.ndarray, pts: np.ndarray,
                    rad: np.ndarray) -> list[list[float]]:
    """Arc-length ranges (mm) of ``curve`` hidden in ``cam`` by a tube ``pts`` in front of it.

    A centreline sample is hidden when its pixel lies inside the tube's
    projected width and the tube is nearer to the camera there.
    """
    xy = cam.project(curve)
    depth = cam.world_to_cam(curve)[:, 2]
    txy = cam.project(pts)
    tz = cam.world_to_cam(pts)[:, 2]
    tr = rad / tz * cam.K[0, 0]
    dd, i = cKDTree(txy).query(xy)
    hid = (dd < tr[i]) & (tz[i] < depth)
    out, k = [], 0
    while k < len(hid):
        if hid[k]:
            j = k
            while j + 1 < len(hid) and hid[j + 1]:
                j += 1
            out.append([round(float(s[k]), 2), round(float(s[j]), 2)])
            k = j + 1
        else:
            k += 1
    return out


def depth_order_mixed(cams: list, curves: np.ndarray, radius: np.ndarray, pts: np.ndarray, rad: np.ndarray) -> bool:
    """True when a tube is in front of the tendril at one overlap and behind it at another, in some view.

    The renderer draws an object either in front of the tendril or behind it
    in a view (:func:`_front_views`); such an object would be drawn wrongly.
    """
    for cam in cams:
        txy = cam.project(pts)
        tz = cam.world_to_cam(pts)[:, 2]
        tr = rad / tz * cam.K[0, 0]
        signs = set()
        for c in curves:
            xy = cam.project(c[::2])
            z = cam.world_to_cam(c[::2])[:, 2]
            cr = radius[::2] / z * cam.K[0, 0]
            d, i = cKDTree(txy).query(xy)
            over = d < tr[i] + cr + 1.0
            signs |= set(np.sign(tz[i[over]] - z[over]).astype(int).tolist())
        if len(signs) > 1:
            return True
    return False
