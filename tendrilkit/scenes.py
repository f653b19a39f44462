"""Random phantom scenes like real recordings: geometry, clutter and marks.

The site phantoms (:mod:`tendrilkit.phantom`) are a sanitised world: nothing
touches the tendril in any view, the marks are tight, the light is even. A
*scene* is the same world (rig, board, taped stem, leaves, markers, a tendril
integrated from piece-wise linear curvature and torsion laws) with the
difficulties of real recordings switched on by the factors of
:mod:`tendrilkit.scene_factors`, drawn from a seed. Every scene keeps exact
ground truth and three constraints: the tendril is seen whole by at least two
views in every frame, it never intersects itself or a solid object in 3D
(tube-distance checks on the dense centreline, every frame), and the marks
are ones a user could make on frame 0.

Public API: :func:`make_scene` (geometry, clutter, marks and imaging
parameters; no pixels). Rendering and writing are in
:mod:`tendrilkit.scene_render`.
"""

from __future__ import annotations

import dataclasses
import math
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from tendrilkit import phantom as P
from tendrilkit.camera import Camera
from tendrilkit.scene_factors import active_factors, draw_factors

DEFAULT_SCENE_FRAMES = 12
_MAX_ATTEMPTS = 40
_VIEW_MARGIN_PX = 30.0
_SEED_OFFSET = 1_000_003  # the site designs of a scene never use the nominal (seed 0) draw


@dataclass(frozen=True, eq=False)
class ScenePhantom(P.Phantom):
    """A random scene: a :class:`~tendrilkit.phantom.Phantom` with clutter and imaging factors.

    Extra attributes
    ----------------
    scene_name : str
        ``random`` or the preset.
    factors : dict
        :func:`tendrilkit.scene_factors.draw_factors`.
    realised : dict
        What the generator placed for each factor (positions, distances,
        frames of contact, hidden fractions...), written into ``gt_meta.json``.
    radius_mm : (n_pts,) float array
        Tendril radius at each centreline sample (tapering for ``pale`` and
        ``brown``).
    board_tubes : list of dict
        Extra stems lying on the board: ``pts`` (m, 3) mm, ``radius`` (m,) mm.
    tubes : list of dict
        Tubes in space (second tendril): ``pts``, ``radius``, ``colour``.
    plates : list of dict
        Flat leaves in space: ``poly`` (k, 3) mm, ``colour``.
    imaging : dict
        Per-frame gain, colours, noise, blur, shadow and JPEG parameters.
    design_time_s : (n_frames,) float array
        Time of the response curve each frame shows.
    hidden_fraction : (n_frames, n_views) float array
        Fraction of the centreline samples hidden (by objects in front or
        outside the image) per frame and view.
    """

    scene_name: str = "random"
    factors: dict = field(default_factory=dict)
    realised: dict = field(default_factory=dict)
    radius_mm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    board_tubes: list = field(default_factory=list)
    tubes: list = field(default_factory=list)
    plates: list = field(default_factory=list)
    imaging: dict = field(default_factory=dict)
    design_time_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    hidden_fraction: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def name(self) -> str:
        return f"scene-{self.scene_name}-seed{self.seed}"


class _Retry(Exception):
    """This attempt cannot realise a factor; the generator draws another design."""


# ================================================================ cameras
def scene_cameras(seed: int, *, strong: bool) -> list[Camera]:
    """The IJCV25 rig with a per-view lens distortion; ``strong``: |k1| 0.06-0.1."""
    from tendrilkit.calibration import ijcv25_rig

    rng = np.random.default_rng([int(seed), 1117])
    out = []
    for cam in ijcv25_rig():
        k1 = rng.uniform(0.06, 0.1) * (1 if rng.uniform() < 0.5 else -1) if strong else rng.uniform(-0.06, 0.06)
        d = np.round(np.array([k1, rng.uniform(-0.02, 0.02), rng.uniform(-5e-4, 5e-4), rng.uniform(-5e-4, 5e-4),
                               0.0]), 5)
        out.append(Camera(cam.K.copy(), d, cam.R.copy(), cam.t_mm.copy(), cam.width, cam.height))
    return out


# ================================================================ designs
def _coil_design(seed: int, attempt: int, opts: dict, rng: np.random.Generator) -> tuple[P.Design, dict]:
    """A hanging tendril that coils at its distal part (helix of 2-3 turns, radius 4-10 mm)."""
    d = P._draw_design("S2", seed + _SEED_OFFSET, attempt, opts)  # placement and timing of a hook
    L = d.length_mm
    turns = float(rng.uniform(2.0, 3.0))
    pitch = float(rng.uniform(3.0, 6.0))
    r_max = min(10.0, 0.6 * L / (turns * 2 * np.pi))
    if r_max < 4.0:
        turns = 2.0
        r_max = max(4.0, min(10.0, 0.6 * L / (turns * 2 * np.pi)))
    r = float(rng.uniform(4.0, r_max))
    h = pitch / (2 * np.pi)
    k = r / (r * r + h * h)
    t = h / (r * r + h * h) * (1.0 if rng.uniform() < 0.5 else -1.0)
    coil_f = turns * 2 * np.pi * math.hypot(r, h) / L
    ramp = 0.04
    a = max(0.2, 0.98 - 2 * ramp - coil_f)
    b, c, e = a + ramp, a + ramp + coil_f, a + 2 * ramp + coil_f
    c0 = float(d.kappa_init[0])
    kk, kf = P._trapezoid(a, b, min(c, 0.999), min(e, 1.0), c0, k - c0)
    tk, tf = P._trapezoid(a, b, min(c, 0.999), min(e, 1.0), 0.0, t)
    design = dataclasses.replace(d, site="S3", kappa_knots=kk, kappa_init=np.full_like(kf, c0), kappa_final=kf,
                                 tau_knots=tk, tau_init=np.zeros_like(tf), tau_final=tf)
    return design, {"coil_radius_mm": r, "coil_pitch_mm": pitch, "coil_turns": turns,
                    "coil_s_mm": [b * L, min(c, 1.0) * L]}


def _design(factors: dict, seed: int, attempt: int, opts: dict) -> tuple[P.Design, dict]:
    rng = np.random.default_rng([int(seed), int(attempt), 1113])
    shape = factors["shape"]
    if shape in ("coil", "coil_endon", "multi_crossing"):
        return _coil_design(seed, attempt, opts, rng)
    site = {"slight": "S1", "loop": "S3"}.get(shape) or ("S2" if rng.uniform() < 0.5 else "S4")
    return P._draw_design(site, seed + _SEED_OFFSET, attempt, opts), {}


def _rotation_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation (3, 3) taking unit vector ``a`` to unit vector ``b``."""
    v = np.cross(a, b)
    c = float(np.dot(a, b))
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1.0 + c)


def _coil_axis(curve: np.ndarray, s: np.ndarray, s0: float, s1: float) -> tuple[np.ndarray, np.ndarray]:
    """Axis direction (3,) and centre (3,) of the coiled part of ``curve`` between ``s0`` and ``s1`` mm."""
    sel = (s >= s0) & (s <= s1)
    X = curve[sel]
    c = X.mean(axis=0)
    # the axis is the direction of least spread of the chords' normals: the smallest
    # singular vector of the tangents (a helix's tangents make a constant angle with it)
    T = np.gradient(X, axis=0)
    T /= np.linalg.norm(T, axis=1, keepdims=True)
    _, _, vt = np.linalg.svd(T - T.mean(axis=0), full_matrices=False)
    axis = vt[-1]
    return axis / np.linalg.norm(axis), c


# ================================================================= timing
def _times(factors: dict, n: int, design: P.Design, rng: np.random.Generator) -> tuple[float, np.ndarray]:
    """``fps`` of the experiment file and the design time (s) each frame shows."""
    on, st = design.onset_s, design.stable_s
    if factors["sampling"] == "fps30":
        t0 = float(rng.uniform(on + 0.3 * (st - on) if not factors["tip_leaf"] else st, 880.0))
        return 30.0, t0 + np.arange(n) / 30.0
    if factors["sampling"] == "sparse":
        return 1.0 / 15.0, np.linspace(0.6 * on, min(st + 60.0, 900.0), n)
    lo = on + 0.3 * (st - on) if not factors["tip_leaf"] else st  # resting on a leaf: the curl is done
    hi = max(lo, 900.0 - 15.0 * (n - 1))
    t0 = float(rng.uniform(lo, hi)) if hi > lo else max(0.0, 900.0 - 15.0 * (n - 1))
    return 1.0 / 15.0, t0 + 15.0 * np.arange(n)


def _sway(curves: np.ndarray, time_s: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, dict]:
    """Pendulum sway: each frame rotated rigidly about the base, 2-5 mm at the tip."""
    base = curves[0, 0]
    chord = curves[0, -1] - base
    ell = float(np.linalg.norm(chord))
    u = chord / ell
    a = np.cross(u, rng.standard_normal(3))
    a /= np.linalg.norm(a)
    amp = float(rng.uniform(2.0, 5.0))
    period = float(rng.uniform(1.0, 3.0))
    phase = float(rng.uniform(0, 2 * np.pi))
    out = np.empty_like(curves)
    angles = amp / ell * np.sin(2 * np.pi * time_s / period + phase)
    for f, th in enumerate(angles):
        K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
        R = np.eye(3) + math.sin(th) * K + (1 - math.cos(th)) * K @ K
        out[f] = base + (curves[f] - base) @ R.T
    return out, {"tip_amplitude_mm": amp, "period_s": period, "axis": a.tolist(),
                 "angle_deg": np.degrees(angles).tolist()}


# ============================================================ constraints
def _inside_fraction(cam: Camera, pts: np.ndarray, margin: float) -> float:
    xy = P._project_safe(cam, pts)
    return float(np.mean(cam.in_image(np.nan_to_num(xy, nan=-1e9), margin_px=margin)))


def _outer_third(cam: Camera, pts: np.ndarray) -> float:
    xy = P._project_safe(cam, pts)
    c = np.array([(cam.width - 1) / 2, (cam.height - 1) / 2])
    rho = np.linalg.norm(xy - c, axis=1) / np.linalg.norm(c)
    return float(np.mean(rho >= 2.0 / 3.0))


def _check_tendril(curves: np.ndarray, s: np.ndarray, cams: list, radius: np.ndarray, leave_view: int | None
                   ) -> str | None:
    """The first violated constraint of the tendril alone, or None."""
    if float((curves[..., 2] - radius[None]).min()) < 2.0:
        return "tendril within 2 mm of the board"
    sub = slice(None, None, 2)
    for f in range(len(curves)):
        pairs = cKDTree(curves[f, sub]).query_pairs(2 * float(radius.max()) + 0.5, output_type="ndarray")
        if len(pairs) and np.any(np.abs(s[sub][pairs[:, 0]] - s[sub][pairs[:, 1]]) > 4.0):
            return f"frame {f}: the tendril touches itself in 3D"
    for f in range(len(curves)):
        whole = [_inside_fraction(cam, curves[f, ::4], _VIEW_MARGIN_PX) == 1.0 for cam in cams]
        if leave_view is None and not all(whole):
            return f"frame {f}: the tendril leaves a view"
        if leave_view is not None and sum(w for v, w in enumerate(whole) if v != leave_view) < 2:
            return f"frame {f}: the tendril leaves a view other than {leave_view + 1}"
    for cam in cams:
        if not cam.in_image(P._project_safe(cam, curves[0, :1]), margin_px=80.0)[0]:
            return "the base is not well inside every view"
    return None


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
    seg = np.linalg.norm(np.diff(poly, axis=0), axis=1)
    s = np.r_[0.0, np.cumsum(seg)]
    t = np.arange(0.0, s[-1] + 1e-9, step)
    return np.stack([np.interp(t, s, poly[:, k]) for k in range(poly.shape[1])], axis=1)


def _clear_of_markers(scene: P.Scene, xy: np.ndarray, pad: float) -> bool:
    """Board points ``xy`` (k, 2) keep ``pad`` mm from every marker's paper square."""
    qs = P._quiet_scale()
    for m in scene.markers:
        loc = P._local(xy, m.centre_mm, m.angle_deg)
        half = 0.5 * m.length_mm * qs + pad
        if np.any((np.abs(loc[:, 0]) <= half) & (np.abs(loc[:, 1]) <= half)):
            return False
    return True


def _board_point_under(cam: Camera, X: np.ndarray) -> np.ndarray:
    """Board point (2,) mm seen at the same pixel as world point ``X`` (3,)."""
    return P._pixel_to_board(cam, cam.project(X[None]))[0]


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
        outline = P._ellipse_poly(centre, ang, a + 3, b + 3)[:, :2]
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
            board = P._pixel_to_board(cam, xy + off * n)
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
    poly = P._ellipse_poly(centre[:2], angle_deg, a, b, n=64)
    poly[:, 2] = centre[2]
    return poly


def _inside_plate(xy: np.ndarray, centre: np.ndarray, angle_deg: float, a: float, b: float) -> np.ndarray:
    loc = P._local(xy, centre[:2], angle_deg)
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


def _place_tip_leaf(ph: dict, rng) -> dict:
    """A leaf (plate) beyond and below the tip, placed so the tip rests on it in several frames."""
    curves, radius, s = ph["curves"], ph["radius"], ph["s"]
    n, L = len(curves), float(s[-1])
    need = min(2, n)
    for _ in range(12):
        a, b = float(rng.uniform(10.0, 16.0)), float(rng.uniform(6.0, 9.0))
        T = curves[-1, -1] - curves[-1, -5]
        T /= np.linalg.norm(T)
        nrm = T + rng.uniform(0.3, 1.0) * np.array([0.0, 0.0, -1.0])
        nrm /= np.linalg.norm(nrm)
        tip = curves[:, -1].mean(axis=0)
        _, e1, e2 = _plate3d(tip, nrm, a, b, 0.0)
        off = rng.uniform(-0.3, 0.3, size=2) * [a, b]
        # the plane's offset along the normal: the most advanced tendril surface over its footprint
        h = -np.inf
        for c in curves:
            rel = c - tip
            ins = ((rel @ e1 - off[0]) / a) ** 2 + ((rel @ e2 - off[1]) / b) ** 2 <= 1.0
            if ins.any():
                h = max(h, float(np.max(rel[ins] @ nrm + radius[ins])))
        if not np.isfinite(h):
            continue
        centre = tip + off[0] * e1 + off[1] * e2 + (h + 0.02) * nrm
        poly, _, _ = _plate3d(centre, nrm, a, b, 0.0)
        if poly[:, 2].min() < 0.5:
            continue
        near = s >= L - 8.0
        touching = []
        for f, c in enumerate(curves):
            rel = c[near] - centre
            ins = ((rel @ e1) / a) ** 2 + ((rel @ e2) / b) ** 2 <= 1.0
            gap = -(rel @ nrm) - radius[near]
            if np.any(ins & (gap < 0.3)):
                touching.append(f)
        if len(touching) < need:
            continue
        return {"plate": poly, "touching_frames": touching, "centre_mm": centre.tolist(), "normal": nrm.tolist()}
    raise _Retry("tip_leaf: the tip rests on no leaf for several frames")


def _hidden_by_plate(cam: Camera, plate: np.ndarray, pts: np.ndarray) -> np.ndarray:
    poly = P._project_safe(cam, plate)
    if not np.all(np.isfinite(poly)):
        return np.zeros(len(pts), bool)
    xy = P._project_safe(cam, pts)
    contour = poly.astype(np.float32).reshape(-1, 1, 2)
    return np.array([np.isfinite(p).all() and cv2_point_in(contour, p) for p in xy])


def cv2_point_in(contour: np.ndarray, p: np.ndarray) -> bool:
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
            hid = ~cam.in_image(np.nan_to_num(P._project_safe(cam, pts), nan=-1e9))
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


# ================================================================ markers
def _redo_markers(scene: P.Scene, cams: list, curves: np.ndarray, rng) -> tuple[P.Scene, dict]:
    """Two to five markers: the world marker 16-24 mm, some small, one partly outside a view."""
    qs = P._quiet_scale()
    world = P.MarkerSpec(P.WORLD_MARKER_ID, np.zeros(2), float(rng.choice([16.0, 20.0, 24.0])), 0.0)
    others = list(scene.markers[1:])
    keep = int(rng.integers(0, min(3, len(others)) + 1))
    kept = []
    for m in others[:keep]:
        if rng.uniform() < 0.5:  # small in the image
            m = P.MarkerSpec(m.id, m.centre_mm, float(m.length_mm * rng.uniform(0.4, 0.6)), m.angle_deg)
        kept.append(m)
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
        c = P._pixel_to_board(cam, xy[None])[0]
        mk = P.MarkerSpec(int(rng.integers(0, 1024)), c, float(rng.uniform(20.0, 32.0)), float(rng.uniform(-25, 25)))
        if mk.id in {m.id for m in markers}:
            continue
        r = 0.5 * mk.length_mm * qs * math.sqrt(2)
        if any(np.linalg.norm(c - o.centre_mm) < r + 0.5 * o.length_mm * qs * math.sqrt(2) + 3 for o in markers):
            continue
        poly = P._square_poly(mk, qs)
        if any(np.linalg.norm(c - lf["centre"]) < max(lf["a_mm"], lf["b_mm"]) + r for lf in scene.leaves):
            continue
        far = True
        for u, cu in enumerate(cams):
            pxy = P._project_safe(cu, poly)
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
    info["n_markers"] = len(markers)
    return dataclasses.replace(scene, markers=markers), info


# ================================================================== marks
def _careless(views: list, cams: list, scene: P.Scene, rng) -> tuple[list, dict]:
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
            pxy = P._project_safe(cam, mk.corners_mm(P._quiet_scale()))
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


# ================================================================ imaging
_LOOKS = {  # BGR albedo of the tube and of its lighter core
    "default": ((40.0, 122.0, 84.0), (72.0, 170.0, 126.0)),
    "pale": ((150.0, 196.0, 188.0), (178.0, 215.0, 210.0)),
    "brown": ((72.0, 104.0, 130.0), (100.0, 134.0, 160.0)),
}


def _imaging(factors: dict, n: int, seed: int, rng) -> dict:
    look = factors["look"]
    tube, core = _LOOKS[look]
    jit = rng.uniform(-10, 10, size=3) if look != "default" else np.zeros(3)
    im = {"tendril_bgr": (np.array(tube) + jit).tolist(), "core_bgr": (np.array(core) + jit).tolist(),
          "gain": np.ones(n).tolist(), "vignetting": None, "noise_sigma": 2.0, "blur_sigma_px": 0.7,
          "motion_blur_px": None, "motion_blur_deg": None, "shadow": None, "jpeg_quality": None}
    if factors["flicker"]:
        drift = rng.uniform(-0.1, 0.1)
        flick = rng.uniform(0.02, 0.06)
        g = 1.0 + drift * np.linspace(-1, 1, n) + flick * rng.standard_normal(n)
        im["gain"] = np.clip(g, 0.85, 1.15).tolist()
    if factors["vignetting"]:
        im["vignetting"] = float(rng.uniform(0.3, 0.45))
    if factors["noise"]:
        im["noise_sigma"] = float(rng.uniform(4.0, 8.0))
    if factors["motion_blur"]:
        im["motion_blur_px"] = rng.uniform(2.0, 6.0, size=n).round(2).tolist()
        im["motion_blur_deg"] = rng.uniform(0, 180, size=n).round(1).tolist()
    if factors["shadow"]:
        az = rng.uniform(0, 2 * np.pi)
        el = math.radians(rng.uniform(50.0, 70.0))
        im["shadow"] = {"light_dir": [math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), -math.sin(el)],
                        "strength": float(rng.uniform(0.15, 0.3)), "softness_px": float(rng.uniform(3.0, 7.0))}
    if factors["jpeg"]:
        im["jpeg_quality"] = rng.integers(25, 61, size=n).tolist()
    return im


def _radius(factors: dict, s: np.ndarray, rng) -> tuple[np.ndarray, dict]:
    if factors["look"] == "default":
        return np.full(len(s), 0.75), {"diameter_base_mm": 1.5, "diameter_tip_mm": 1.5}
    d0 = float(rng.uniform(1.2, 2.0))
    d1 = float(rng.uniform(0.8, min(1.2, d0)))
    return 0.5 * (d0 + (d1 - d0) * s / s[-1]), {"diameter_base_mm": d0, "diameter_tip_mm": d1}


def _aim_off(cams: list, v: int, curves: np.ndarray, rng) -> tuple[list, dict]:
    """View ``v`` aimed a little off (its principal point moved) so the distal tendril partly leaves it."""
    cam = cams[v]
    xy = cam.project(curves[:, ::4].reshape(-1, 3)).reshape(len(curves), -1, 2)
    d = xy[-1, -1] - xy[-1, 0]
    axis = 0 if abs(d[0]) > abs(d[1]) else 1
    size = (cam.width, cam.height)[axis] - 1
    target = float(rng.uniform(0.08, 0.25))
    if d[axis] > 0:  # the tip goes towards the far edge: move the image content towards it
        shift = size - max(np.quantile(xy[f, :, axis], 1.0 - target) for f in range(len(xy)))
    else:
        shift = -min(np.quantile(xy[f, :, axis], target) for f in range(len(xy)))
    if abs(shift) > 450:
        raise _Retry("leave_view: the tendril is too far from the edges")
    K = cam.K.copy()
    K[axis, 2] += shift
    new = Camera(K, cam.dist.copy(), cam.R.copy(), cam.t_mm.copy(), cam.width, cam.height)
    out = [new if u == v else c for u, c in enumerate(cams)]
    outside = max(1.0 - _inside_fraction(new, curves[f, ::4], 0.0) for f in range(len(curves)))
    world = P.MarkerSpec(P.WORLD_MARKER_ID, np.zeros(2), P.WORLD_MARKER_MM, 0.0).corners_mm(P._quiet_scale())
    if outside < 0.03 or not np.all(new.in_image(P._project_safe(new, world), margin_px=30.0)):
        raise _Retry("leave_view: aiming the view off hides the world marker or keeps the tendril in")
    return out, {"view": v + 1, "principal_point_shift_px": [float(shift) if a == axis else 0.0 for a in (0, 1)],
                 "max_outside_fraction": float(outside)}


# ================================================================= scenes
_CACHE: "OrderedDict[tuple, ScenePhantom]" = OrderedDict()
_CACHE_SIZE = 3


def _shift_search(curves: np.ndarray, cams: list, rng, want) -> np.ndarray | None:
    """A board-plane shift (3,) mm of the tendril (and its node) meeting ``want(shifted_curves)``."""
    cands = [np.zeros(3)] + [np.array([rng.uniform(-50, 50), rng.uniform(-140, 140), 0.0]) for _ in range(60)]
    for d in cands:
        if want(curves + d):
            return d
    return None


def make_scene(seed: int, *, scene: str = "random", n_frames: int = DEFAULT_SCENE_FRAMES) -> ScenePhantom:
    """Generate a random scene: geometry, clutter, marks and imaging parameters (no pixels).

    Parameters
    ----------
    seed : int
        Seeds 0-9999 are for development, 10000 and above are reserved for
        the generalisation benchmark (``benchmarks/bench_generalize.py``).
    scene : str, keyword-only
        ``random`` (every factor drawn from the seed) or a preset of
        :data:`tendrilkit.scene_factors.PRESETS` (one factor or group alone).
    n_frames : int, keyword-only
        Frames of the sequence (default 12).

    Returns
    -------
    ScenePhantom

    Raises
    ------
    tendrilkit.phantom.PhantomError
        Unknown scene, or no design realised every factor within 40 attempts.
    """
    seed, n = int(seed), int(n_frames)
    if n < 1:
        raise P.PhantomError(f"n_frames: expected at least 1, got {n_frames}")
    try:
        factors = draw_factors(seed, scene)
    except ValueError as e:
        raise P.PhantomError(str(e)) from None
    key = (seed, scene, n)
    if key in _CACHE:
        _CACHE.move_to_end(key)
        return _CACHE[key]
    cams = scene_cameras(seed, strong=factors["distortion"])
    reasons = []
    for attempt in range(_MAX_ATTEMPTS):
        try:
            ph = _attempt(seed, scene, n, factors, cams, attempt)
        except (_Retry, P._Reject) as e:
            reasons.append(str(e))
            continue
        _CACHE[key] = ph
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.popitem(last=False)
        return ph
    common = max(set(reasons), key=reasons.count)
    raise P.PhantomError(f"scene {scene}, seed {seed}: no design realised the factors in {_MAX_ATTEMPTS} attempts "
                         f"(most often: {common})")


def _attempt(seed: int, scene_name: str, n: int, factors: dict, cams: list, attempt: int) -> ScenePhantom:
    opts = P._resolve_options({})
    rng = np.random.default_rng([seed, attempt, 1119])
    design, realised = _design(factors, seed, attempt, opts)
    realised = {"shape": {"family": design.site, **realised}}
    fps, t_design = _times(factors, n, design, rng)
    fps = float(f"{fps:.7g}")
    time_s = np.arange(n) / fps
    if factors["shape"] == "coil_endon":
        v = int(rng.integers(3))
        for _ in range(3):  # the coil's centre moves with the rotation: refine
            s, probe, _, _ = P._centrelines(design, np.array([design.stable_s]))
            axis, centre = _coil_axis(probe[0], s, *realised["shape"]["coil_s_mm"])
            u = cams[v].center_world - centre
            u /= np.linalg.norm(u)
            if np.dot(axis, u) < 0:
                axis = -axis
            R = _rotation_between(axis, u)
            design = dataclasses.replace(design, frame0=design.frame0 @ R.T)
        s, probe, _, _ = P._centrelines(design, np.array([design.stable_s]))
        axis, centre = _coil_axis(probe[0], s, *realised["shape"]["coil_s_mm"])
        u = cams[v].center_world - centre
        ang = math.degrees(math.acos(min(1.0, abs(np.dot(axis, u / np.linalg.norm(u))))))
        if ang > 12.0:
            raise _Retry(f"coil_endon: axis {ang:.0f} deg from camera {v + 1}")
        realised["shape"].update({"axis_view": v + 1, "axis_to_camera_deg": ang})
    s, curves, kappa, tau = P._centrelines(design, t_design)
    radius, look = _radius(factors, s, rng)
    realised["look"] = {"name": factors["look"], **look}
    if factors["sway"]:
        curves, realised["sway"] = _sway(curves, time_s, rng)
    leave = None
    if factors["distortion"]:
        def want(c: np.ndarray) -> bool:
            if any(_inside_fraction(cam, c[:, ::6].reshape(-1, 3), _VIEW_MARGIN_PX) < 1.0 for cam in cams):
                return False
            return max(_outer_third(cam, c[0, ::4]) for cam in cams) >= 0.1

        d = _shift_search(curves, cams, rng, want)
        if d is None:
            raise _Retry("distortion: no position of the tendril reaches the outer third of a view")
        curves = curves + d
        design = dataclasses.replace(design, node_mm=design.node_mm + d, base_mm=design.base_mm + d)
        realised["distortion"] = {"k1": [float(c.dist[0]) for c in cams],
                                  "outer_third_fraction": [_outer_third(c, curves[0, ::4]) for c in cams]}
    if factors["leave_view"]:
        leave = int(rng.integers(3))
        cams, realised["leave_view"] = _aim_off(cams, leave, curves, rng)
    bad = _check_tendril(curves, s, cams, radius, leave)
    if bad:
        raise _Retry(bad)
    L = float(s[-1])
    if factors["shape"] == "multi_crossing":
        counts = [len([c for c in P.self_crossings(cam.project(curves[-1, ::4]), s[::4]) if P._visible(c, L)])
                  for cam in cams]
        if sum(c >= 2 for c in counts) < 2:
            raise _Retry("multi_crossing: fewer than two views with two crossings")
        realised["shape"]["crossings_per_view"] = counts
    scene = P._build_scene(design, cams, curves, seed + _SEED_OFFSET, attempt, 2 * float(radius.max()))
    ctx = {"cams": cams, "curves": curves, "s": s, "radius": radius, "scene": scene}
    board_tubes, tubes, plates, extra_leaves = [], [], [], []
    if factors["over_leaf"]:
        r = _place_over_leaf(ctx, rng)
        extra_leaves.append(r.pop("leaf"))
        realised["over_leaf"] = r
    for name in ("over_stem", "alongside"):
        if factors[name]:
            r = _place_board_shoot(ctx, rng, alongside=name == "alongside")
            board_tubes.append({"pts": r.pop("pts"), "radius": r.pop("radius")})
            realised[name] = r
    if factors["tip_leaf"]:
        r = _place_tip_leaf(ctx, rng)
        poly = r.pop("plate")
        fill = np.vstack([poly, 0.5 * (poly + poly.mean(axis=0)), poly.mean(axis=0)[None]])
        plates.append({"poly": poly, "colour": [52.0, 134.0, 70.0], "front_views": _front_views(cams, curves, fill)})
        realised["tip_leaf"] = dict(r, front_views=[v + 1 for v in plates[-1]["front_views"]])
    if factors["second_tendril"]:
        r = _place_second_tendril(ctx, rng)
        pts, rad = r.pop("pts"), r.pop("radius")
        tubes.append({"pts": pts, "radius": rad, "colour": [46.0, 118.0, 88.0],
                      "front_views": _front_views(cams, curves, pts)})
        r["front_views"] = [v + 1 for v in tubes[-1]["front_views"]]
        realised["second_tendril"] = r
    if factors["occluding_leaf"]:
        r = _place_occluding_leaf(ctx, rng)
        plates.append({"poly": r.pop("plate"), "colour": [44.0, 120.0, 58.0], "front_views": [0, 1, 2]})
        realised["occluding_leaf"] = r
    if extra_leaves:
        scene = dataclasses.replace(scene, leaves=list(scene.leaves) + extra_leaves)
    if factors["markers"]:
        scene, realised["markers"] = _redo_markers(scene, cams, curves, rng)
    imaging = _imaging(factors, n, seed, rng)
    if imaging["vignetting"] is not None:
        light = scene.light.copy()
        light[2] = imaging["vignetting"]
        scene = dataclasses.replace(scene, light=light)
    hidden = _front_hidden(cams, curves, radius, tubes, plates)
    if np.any((hidden <= 0.1).sum(axis=1) < 2):
        raise _Retry("the tendril is not seen whole by two views in every frame")
    proj = np.stack([np.stack([cam.project(c) for cam in cams]) for c in curves])
    views, hidden_base = [], []
    sel = np.concatenate([curves[:1], curves[1::max(1, n // 6)]])
    for v, cam in enumerate(cams):
        ko, hb = P._keep_out(cam, sel, s, scene, 2 * float(radius[0]))
        bp = np.round(proj[0, v, 0]).astype(int)
        views.append({"view": v + 1, "roi": P._roi(cam, curves, 2 * float(radius.max())), "keep_out": ko,
                      "base_point": [int(bp[0]), int(bp[1])]})
        hidden_base.append(hb)
    if factors["careless_marks"]:
        views, realised["careless_marks"] = _careless(views, cams, scene, rng)
    coarse = slice(None, None, 4)
    crossings = [[P.self_crossings(proj[f, v][coarse], s[coarse]) for v in range(len(cams))] for f in range(n)]
    opts = dict(opts, diameter_mm=2 * float(radius[0]), noise_sigma=imaging["noise_sigma"],
                blur_sigma_px=imaging["blur_sigma_px"])
    return ScenePhantom(
        site=design.site, seed=seed, n_frames=n, fps=fps, time_s=time_s, cameras=cams, s_mm=s, curves_mm=curves,
        projections_px=proj, kappa=kappa, tau=tau,
        response=P.response_profile(t_design, design.onset_s, design.stable_s, design.wobble),
        design=design, scene=scene, views=views, hidden_base_mm=np.array(hidden_base), crossings=crossings,
        options=opts, scene_name=scene_name, factors=factors, realised=realised, radius_mm=radius,
        board_tubes=board_tubes, tubes=tubes, plates=plates, imaging=imaging, design_time_s=t_design,
        hidden_fraction=hidden)


def scene_meta(ph: ScenePhantom) -> dict:
    """``gt_meta.json`` of a scene: the phantom's keys plus ``scene``, ``factors``, ``active_factors``,
    ``realised``, ``imaging``, ``design_time_s``, ``hidden_fraction`` and ``seen_whole_views``."""
    meta = P._meta(ph)
    meta.update({
        "scene": ph.scene_name, "factors": ph.factors, "active_factors": active_factors(ph.factors),
        "realised": _jsonable(ph.realised), "imaging": _jsonable(ph.imaging),
        "design_time_s": [float(t) for t in ph.design_time_s],
        "hidden_fraction": np.round(ph.hidden_fraction, 4).tolist(),
        "seen_whole_views": [[v + 1 for v in range(ph.hidden_fraction.shape[1]) if ph.hidden_fraction[f, v] <= 0.1]
                             for f in range(ph.n_frames)],
    })
    return meta


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    return x
