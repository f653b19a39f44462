"""Camera poses from ArUco markers, bundle adjustment, and the authors' stored poses.

Paper: "Experimental Setup" (markers on the panel define the world frame and
give the camera extrinsics); reference notes, stage 1.

The method in four steps:

1. :func:`detect_markers`: ArUco detection (OpenCV's class API) with the
   corners refined from the marker's edges: sub-pixel edge points along each
   side, undistorted, one straight line per side, corners where the lines
   meet; the black border's measured width removes the bias that a non-linear
   camera response puts on every edge (it would scale the whole rig).
2. :func:`marker_pose`: the world marker's pose in each view,
   ``cv2.solvePnP(..., SOLVEPNP_IPPE_SQUARE)`` with the lens distortion. This
   single-marker pose is what the paper uses as the camera pose.
3. :func:`bundle_adjust`: every other marker seen by two or more views is a
   square of unknown pose and side length; the camera poses and these squares
   are refined jointly on all corner observations, the world marker's corners
   held at :func:`marker_object_corners` (which fixes the frame and the scale).
   Markers found to lie on the world marker's board are then held in its
   plane, which pins the world frame's tilt over the board's whole extent.
4. :func:`calibrate` (images) and :func:`calibrate_from_observations`
   (corners) compose them; :func:`calibrate_experiment` and
   :func:`calibrate_to_dir` run them on an experiment file's first processed
   frame, or load the authors' stored poses (``extrinsics: ijcv25``).

:func:`rig_agreement_px` measures a calibration against another (the truth of
a phantom) where it matters: on points of the tendril's working volume.

Why squares and not free 3D corners: a printed ArUco marker is a flat square,
so 7 unknowns (pose and side) instead of 12 describe it exactly; the four
corners then cannot absorb detection noise by bending the square, which both
tightens the camera poses and leaves a residual that says how well the
detections agree. The side is left free because the other markers need not be
printed at the world marker's size.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import cv2
import numpy as np
import pandas as pd
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from tendrilkit.camera import Camera, rotation_from_rvec
from tendrilkit.exceptions import ExperimentError

if TYPE_CHECKING:  # only for type hints: algorithm code never needs params
    from tendrilkit.params import Experiment

RIG_DIR = Path(__file__).resolve().parent / "data" / "ijcv25_rig"

#: Corner refinement methods of :func:`detect_markers`.
REFINE_METHODS = ("edges", "subpix", "contour", "apriltag", "none")


# ----------------------------------------------------------------- world frame
def marker_object_corners(length_mm: float) -> np.ndarray:
    """The world marker's corners (4, 3) mm, OpenCV ArUco order and frame.

    Top-left, top-right, bottom-right, bottom-left: ``(-L/2, L/2, 0), (L/2, L/2, 0),
    (L/2, -L/2, 0), (-L/2, -L/2, 0)``.
    """
    h = float(length_mm) / 2.0
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


# ------------------------------------------------------------------- detection
def _dictionary(name: str):
    if not isinstance(name, str) or not name.startswith("DICT_") or not hasattr(cv2.aruco, name):
        raise ValueError(f"dictionary: expected a cv2.aruco predefined dictionary name such as DICT_ARUCO_ORIGINAL, got {name!r}")
    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, name))


def _grey(image: np.ndarray) -> np.ndarray:
    img = np.asarray(image)
    if img.ndim == 3 and img.shape[2] == 3:
        return cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    if img.ndim == 3 and img.shape[2] == 1:
        return img[:, :, 0]
    if img.ndim == 2:
        return img
    raise ValueError(f"image_bgr: expected a (height, width, 3) BGR or (height, width) grey image, got shape {img.shape}")


def _line_intersection(l1: np.ndarray, l2: np.ndarray) -> np.ndarray:
    """Point where two lines ``(a, b, c)`` (``a x + b y = c``) meet."""
    A = np.array([l1[:2], l2[:2]])
    return np.linalg.solve(A, np.array([l1[2], l2[2]]))


def _crossings(g: np.ndarray, base: np.ndarray, n: np.ndarray, centre: np.ndarray, half: float,
               rising: bool) -> tuple[np.ndarray, np.ndarray]:
    """Sub-pixel edge offsets along ``n`` of profiles through ``base + o n``.

    Each profile spans ``centre +- half`` px (0.25 px steps); the edge is where
    it crosses half-way between its dark and bright ends (the last such
    crossing, dark to bright along ``n`` if ``rising``, else bright to dark),
    interpolated linearly. Returns the offsets (k,) (NaN: no clear edge) and
    the profiles' mid levels (k,).
    """
    offs = np.arange(-half, half + 1e-9, 0.25)
    o = centre[:, None] + offs[None, :]
    pts = base[:, None, :] + o[:, :, None] * n[None, None, :]
    prof = cv2.remap(g, pts[..., 0].astype(np.float32), pts[..., 1].astype(np.float32), cv2.INTER_LINEAR,
                     borderMode=cv2.BORDER_REPLICATE)
    if not rising:
        prof = prof[:, ::-1]
        o = o[:, ::-1]
    k = max(2, len(offs) // 6)
    lo, hi = prof[:, :k].mean(axis=1), prof[:, -k:].mean(axis=1)
    mid = (lo + hi) / 2
    above = prof >= mid[:, None]
    up = ~above[:, :-1] & above[:, 1:]
    has = up.any(axis=1) & ((hi - lo) > 20)
    q = up.shape[1] - 1 - np.argmax(up[:, ::-1], axis=1)
    rows = np.arange(len(base))
    y0, y1 = prof[rows, q], prof[rows, q + 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        edge = o[rows, q] + (mid - y0) / (y1 - y0) * (o[rows, q + 1] - o[rows, q])
    edge[~(has & np.isfinite(edge))] = np.nan
    return edge, mid


def _refine_corners_edges(grey: np.ndarray, corners_xy: np.ndarray, *, cells: int,
                          camera: Camera | None, iterations: int = 3,
                          bias: float | None = None) -> tuple[np.ndarray, float, int] | None:
    """Corners (4, 2) from straight lines fitted to the marker's four sides.

    Along each side, away from the corners, intensity profiles across the edge
    give sub-pixel edge points where the profile crosses half-way between the
    black border and the white surround (unbiased for a symmetric blur of a
    linear image). With a ``camera`` the edge points are undistorted before the
    line fit, so the lines are straight in the pinhole image; the corners are
    distorted back. Returns None when the edges cannot be measured (the caller
    keeps its own corners).

    A camera's non-linear response (gamma), defocus in a non-linear domain or
    ink spread moves every edge of the black square outwards or inwards by the
    same amount ``b`` (a dilation), which scales the marker and so the whole
    rig (1 % of scale is about 10 px at the tendril). ``b`` is measured and
    removed: where the interior cell next to the black border is white, the
    border's inner edge is found too; the border is one cell wide (its width
    in pixels from the homography of the current corners), so
    ``b = (measured width - cell width) / 2``, the median over all such places
    (at least 10, else ``b`` = 0); a given ``bias`` is used instead.
    Returns ``(corners, b, number of places)``.
    """
    g = grey.astype(np.float32)
    c = np.asarray(corners_xy, dtype=float).copy()
    c0 = c.copy()
    h, w = g.shape
    U = marker_object_corners(1.0)[:, :2]  # unit square, marker x right, y up
    for _ in range(iterations):
        side = np.linalg.norm(np.roll(c, -1, axis=0) - c, axis=1)
        if side.min() < 12:
            return None
        cell = side.mean() / cells
        half = float(np.clip(0.45 * cell, 1.5, 5.0))  # profile half-length: stays in one cell
        H = cv2.getPerspectiveTransform(U.astype(np.float32), c.astype(np.float32))
        centre = c.mean(axis=0)
        sides = []
        widths = []
        for i in range(4):
            a, b = c[i], c[(i + 1) % 4]
            L = np.linalg.norm(b - a)
            d = (b - a) / L
            n = np.array([d[1], -d[0]])
            if np.dot((a + b) / 2 - centre, n) < 0:
                n = -n  # outward
            t = np.linspace(0.12, 0.88, max(8, int(0.76 * L)))
            base = a[None, :] + (t * L)[:, None] * d[None, :]
            if base.min() < half + 2 or base[:, 0].max() > w - half - 3 or base[:, 1].max() > h - half - 3:
                return None
            outer, mid = _crossings(g, base, n, np.zeros(len(t)), half, rising=True)
            # cell width across the border at each sample, from the homography
            Pu = U[i][None, :] + t[:, None] * (U[(i + 1) % 4] - U[i])[None, :]
            inward = -(U[i] + U[(i + 1) % 4]) / np.linalg.norm(U[i] + U[(i + 1) % 4])
            p0 = cv2.perspectiveTransform(Pu[None].astype(np.float64), H)[0]
            p1 = cv2.perspectiveTransform((Pu + inward / cells)[None].astype(np.float64), H)[0]
            cell_px = (p0 - p1) @ n
            # inner edge of the border where the neighbouring interior cell is white
            tc = t * cells
            j = np.floor(tc)
            cand = (j >= 1) & (j <= cells - 2) & ((tc - j) > 0.2) & ((tc - j) < 0.8)
            if cand.any():
                probe = base[cand] - 1.5 * cell_px[cand, None] * n[None, :]
                val = cv2.remap(g, probe[:, 0:1].astype(np.float32), probe[:, 1:2].astype(np.float32),
                                cv2.INTER_LINEAR).ravel()
                white = val > mid[cand]
                idx = np.flatnonzero(cand)[white]
                if idx.size:
                    inner, _ = _crossings(g, base[idx], n, -cell_px[idx], half, rising=False)
                    widths.append((outer[idx] - inner) - cell_px[idx])
            sides.append((base, n, outer))
        dil = np.concatenate(widths) / 2 if widths else np.array([])
        dil = dil[np.isfinite(dil)]
        b_used = bias if bias is not None else (float(np.median(dil)) if dil.size >= 10 else 0.0)
        lines = []
        poor = False
        for base, n, outer in sides:
            ok = np.isfinite(outer)
            if ok.sum() < 6:
                return None
            n_samples = len(outer)
            p = base[ok] + (outer[ok] - b_used)[:, None] * n[None, :]
            if camera is not None:
                p = camera.undistort_points(p)
            # total least squares line, one pass of outlier rejection
            for _pass in range(2):
                m = p.mean(axis=0)
                _, _, vt = np.linalg.svd(p - m, full_matrices=False)
                nrm = vt[1]
                r = (p - m) @ nrm
                mad = np.median(np.abs(r - np.median(r))) * 1.4826
                keep = np.abs(r) <= max(3 * mad, 0.3)
                if keep.all() or keep.sum() < 6:
                    break
                p = p[keep]
            r = (p - p.mean(axis=0)) @ nrm
            poor |= len(p) < 0.5 * n_samples or float(np.sqrt(np.mean(r ** 2))) > 0.35
            lines.append(np.array([nrm[0], nrm[1], nrm @ m]))
        new = np.array([_line_intersection(lines[(i - 1) % 4], lines[i]) for i in range(4)])
        if camera is not None:
            new = camera.distort_points(new)
        # OpenCV's corner can be pulled several pixels by something dark touching
        # the marker; the lines are not, but they must stay near the quad
        if not np.all(np.isfinite(new)) or np.abs(new - c0).max() > max(3.0, 0.2 * side.mean()):
            return None
        c = new
    if poor:  # lines through too few or too scattered edge points: keep OpenCV's corners
        return None
    return c, (float(np.median(dil)) if dil.size else np.nan), int(dil.size)


def detect_markers(image_bgr: np.ndarray, dictionary: str, *, refine: str = "edges",
                   camera: Camera | None = None) -> dict[int, np.ndarray]:
    """ArUco markers of one image: ``{marker_id: corners (4, 2) px}``.

    Parameters
    ----------
    image_bgr : (height, width, 3) uint8 array
        The frame (a grey (height, width) image is accepted too).
    dictionary : str
        A ``cv2.aruco`` predefined dictionary name, e.g. ``DICT_ARUCO_ORIGINAL``.
    refine : {"edges", "subpix", "contour", "apriltag", "none"}, keyword-only
        Corner refinement. ``edges`` (default): OpenCV's ``CORNER_REFINE_SUBPIX``
        corners, then straight lines fitted to sub-pixel edge points of each side
        (see Notes); the others are OpenCV's ``CORNER_REFINE_*`` methods alone.
    camera : Camera, optional, keyword-only
        With it, the ``edges`` refinement fits the sides in undistorted
        coordinates (lens distortion bends straight edges).

    Returns
    -------
    dict
        Corners in OpenCV order (top-left, top-right, bottom-right, bottom-left
        of the marker), observed (distorted) pixels, x = column. An id detected
        twice in the image is ambiguous and left out (with a warning).

    Notes
    -----
    On frames rendered through the IJCV25 rig with lens distortion, blur 0.7-2 px
    and noise (benchmarks/bench_calibration.py ``corners``), the mean corner
    error is 0.013-0.022 px (max 0.05) with ``edges``, against 0.2-0.57 px for
    ``subpix``, 0.84-0.92 for ``contour`` and 0.66-0.70 for ``apriltag``
    (OpenCV's corners are biased, mostly outwards or inwards). A corner from
    two lines through ~100 edge points each averages the noise that a local
    corner fit sees, and the dilation correction (see ``_refine_corners_edges``)
    keeps it unbiased under a non-linear response (gamma 2.2: 0.01 px).
    It costs ~60 ms per 1920x1080 frame.
    """
    if refine not in REFINE_METHODS:
        raise ValueError(f"refine: expected one of {', '.join(REFINE_METHODS)}, got {refine!r}")
    dic = _dictionary(dictionary)
    grey = _grey(image_bgr)
    params = cv2.aruco.DetectorParameters()
    method = {"edges": cv2.aruco.CORNER_REFINE_SUBPIX, "subpix": cv2.aruco.CORNER_REFINE_SUBPIX,
              "contour": cv2.aruco.CORNER_REFINE_CONTOUR, "apriltag": cv2.aruco.CORNER_REFINE_APRILTAG,
              "none": cv2.aruco.CORNER_REFINE_NONE}[refine]
    params.cornerRefinementMethod = method
    detector = cv2.aruco.ArucoDetector(dic, params)
    corners, ids, _ = detector.detectMarkers(grey)
    out: dict[int, np.ndarray] = {}
    if ids is None:
        return out
    ids = ids.ravel().astype(int)
    uniq, counts = np.unique(ids, return_counts=True)
    dup = set(uniq[counts > 1].tolist())
    if dup:
        warnings.warn(f"marker id(s) {sorted(dup)} detected more than once in one image; left out", stacklevel=2)
    cells = dic.markerSize + 2
    found = {int(m): np.asarray(c, dtype=float).reshape(4, 2) for m, c in zip(ids, corners) if m not in dup}
    if refine != "edges":
        return dict(sorted(found.items()))
    refined = {m: _refine_corners_edges(grey, c, cells=cells, camera=camera) for m, c in found.items()}
    # a marker with too few white cells along its border takes the image's dilation
    biases = [r[1] for r in refined.values() if r is not None and r[2] >= 10]
    for m, c in found.items():
        r = refined[m]
        if r is not None and r[2] < 10 and biases:
            r = _refine_corners_edges(grey, c, cells=cells, camera=camera, bias=float(np.median(biases)))
        out[m] = c if r is None else r[0]
    return dict(sorted(out.items()))


# ------------------------------------------------------------- single markers
def _pose_candidates(corners_xy: np.ndarray, camera: Camera, length_mm: float) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Distinct poses ``(R, t_mm, rms_px)`` of a square marker, best first.

    Both IPPE_SQUARE solutions, plus SQPnP's: OpenCV's IPPE returns a wrong
    pose (80 px off, or NaN, with success reported) for some near-frontal
    views, e.g. a marker 5 degrees from frontal with its edges along the image
    axes (tests/test_calibration.py, property test). Each is polished by
    Levenberg-Marquardt through the lens distortion.
    """
    obj = marker_object_corners(length_mm)
    img = np.asarray(corners_xy, dtype=float).reshape(4, 1, 2)
    starts = []
    _, rvecs, tvecs, _ = cv2.solvePnPGeneric(obj, img, camera.K, camera.dist, flags=cv2.SOLVEPNP_IPPE_SQUARE)
    starts += list(zip(rvecs, tvecs))
    ok, rv, tv = cv2.solvePnP(obj, img, camera.K, camera.dist, flags=cv2.SOLVEPNP_SQPNP)
    if ok:
        starts.append((rv, tv))
    out: list[tuple[np.ndarray, np.ndarray, float]] = []
    for rv, tv in starts:
        rv, tv = np.asarray(rv, float).reshape(3, 1), np.asarray(tv, float).reshape(3, 1)
        if not (np.all(np.isfinite(rv)) and np.all(np.isfinite(tv))):
            continue
        rv, tv = cv2.solvePnPRefineLM(obj, img, camera.K, camera.dist, rv.copy(), tv.copy())
        R = rotation_from_rvec(rv)
        t = tv.ravel()
        if t[2] <= 0:
            continue
        e = camera.with_pose(R, t).project(obj) - img.reshape(4, 2)
        rms = float(np.sqrt((e ** 2).sum(axis=1).mean()))
        if not np.isfinite(rms):
            continue
        # the same local minimum reached from two starts (0.01 degree, 0.01 %)
        if any(np.linalg.norm(R - R2) < 2e-4 and np.linalg.norm(t - t2) < 1e-4 * np.linalg.norm(t) for R2, t2, _ in out):
            continue
        out.append((R, t, rms))
    if not out:
        raise ValueError("corners_xy: no marker pose fits these corners")
    out.sort(key=lambda x: x[2])
    return out


def marker_pose(corners_xy: np.ndarray, camera: Camera, length_mm: float) -> tuple[np.ndarray, np.ndarray]:
    """Pose ``(R (3, 3), t_mm (3,))`` of a square marker in a camera's frame.

    ``cv2.solvePnP(..., SOLVEPNP_IPPE_SQUARE)`` with the camera's K and lens
    distortion, polished by Levenberg-Marquardt; ``x_cam = R @ x_marker + t_mm``
    with the marker frame of :func:`marker_object_corners`. For the world
    marker this is the camera's world-to-camera pose.

    Parameters
    ----------
    corners_xy : (4, 2) float array
        Observed corners, OpenCV order, pixels.
    camera : Camera
        Intrinsics (its pose is ignored).
    length_mm : float
        Side of the marker's black square, mm.
    """
    c = np.asarray(corners_xy, dtype=float)
    if c.shape != (4, 2) or not np.all(np.isfinite(c)):
        raise ValueError(f"corners_xy: expected 4 finite corners of shape (4, 2), got {c.shape}")
    if not length_mm > 0:
        raise ValueError(f"length_mm: expected a positive side length, got {length_mm}")
    R, t, _ = _pose_candidates(c, camera, length_mm)[0]
    return R, t


# ---------------------------------------------------------- bundle adjustment
def _rodrigues(rvecs: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) of Rodrigues vectors (n, 3)."""
    rv = np.asarray(rvecs, dtype=float).reshape(-1, 3)
    th = np.linalg.norm(rv, axis=1)
    small = th < 1e-12
    k = rv / np.where(small, 1.0, th)[:, None]
    Kx = np.zeros((len(rv), 3, 3))
    Kx[:, 0, 1], Kx[:, 0, 2] = -k[:, 2], k[:, 1]
    Kx[:, 1, 0], Kx[:, 1, 2] = k[:, 2], -k[:, 0]
    Kx[:, 2, 0], Kx[:, 2, 1] = -k[:, 1], k[:, 0]
    s, c = np.sin(th)[:, None, None], np.cos(th)[:, None, None]
    R = np.eye(3)[None] + s * Kx + (1 - c) * (Kx @ Kx)
    R[small] = np.eye(3)
    return R


def _triangulate(cameras: list[Camera], obs_xy: list[np.ndarray | None]) -> np.ndarray:
    """DLT triangulation (n, 3) mm of points seen in several views (undistorted first)."""
    n = next(o for o in obs_xy if o is not None).shape[0]
    out = np.full((n, 3), np.nan)
    und = [None if o is None else cam.undistort_points(o) for cam, o in zip(cameras, obs_xy)]
    for p in range(n):
        rows = []
        for cam, u in zip(cameras, und):
            if u is None or not np.all(np.isfinite(u[p])):
                continue
            P = cam.P
            rows.append(u[p, 0] * P[2] - P[0])
            rows.append(u[p, 1] * P[2] - P[1])
        if len(rows) >= 4:
            _, _, vt = np.linalg.svd(np.array(rows))
            out[p] = vt[-1, :3] / vt[-1, 3]
    return out


def _fit_square(points_world: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Similarity (R, t, side) that best maps the unit marker square onto 4 points."""
    U = marker_object_corners(1.0)
    X = np.asarray(points_world, float)
    mu, mx = U.mean(0), X.mean(0)
    A, B = U - mu, X - mx
    Um, S, Vt = np.linalg.svd(B.T @ A)
    D = np.diag([1, 1, np.sign(np.linalg.det(Um @ Vt))])
    R = Um @ D @ Vt
    s = float(np.trace(np.diag(S) @ D) / (A ** 2).sum())
    return R, mx - s * R @ mu, s


@dataclass(frozen=True, eq=False)
class BundleReport:
    """What :func:`bundle_adjust` did.

    Attributes
    ----------
    table : pandas.DataFrame
        One row per (view, marker, stage): ``view`` (1-based), ``marker_id``,
        ``stage`` (``single``: single-marker camera poses and triangulated
        markers; ``adjusted``: after the adjustment), ``mean_px``, ``max_px``
        (corner reprojection error), ``n_corners``.
    markers_world : dict[int, (4, 3) float array]
        Adjusted corners of every marker used, world mm (the world marker's
        are its fixed corners).
    markers_world_single : dict[int, (4, 3) float array]
        Their starting corners (squares fitted to corners triangulated with
        the initial cameras).
    marker_lengths_mm : dict[int, float]
        Adjusted side length of every marker used.
    on_plane : list[int]
        Markers adjusted as lying in the world marker's plane (``z = 0``).
    rms_before_px, rms_after_px : float
        Root-mean-square corner reprojection error over all observations.
    dropped : list[tuple[int, int]]
        ``(view, marker_id)`` observations dropped as outliers (view 1-based).
    nfev : int
        Residual evaluations of the optimiser.
    converged : bool
        False when the adjustment ended with a corner rms above
        ``outlier_px / 3`` (it failed, e.g. from a start tens of degrees off);
        the initial cameras are then returned, with a warning.
    """

    table: pd.DataFrame
    markers_world: dict[int, np.ndarray]
    markers_world_single: dict[int, np.ndarray]
    marker_lengths_mm: dict[int, float]
    on_plane: list[int]
    rms_before_px: float
    rms_after_px: float
    dropped: list[tuple[int, int]] = field(default_factory=list)
    nfev: int = 0
    converged: bool = True


def _reprojection_rows(cameras: list[Camera], observations: dict[int, dict[int, np.ndarray]],
                       markers_world: dict[int, np.ndarray], stage: str) -> list[dict]:
    rows = []
    for v, obs in sorted(observations.items()):
        for mid, xy in sorted(obs.items()):
            if mid not in markers_world:
                continue
            e = np.linalg.norm(cameras[v].project(markers_world[mid]) - xy, axis=1)
            rows.append({"view": v + 1, "marker_id": int(mid), "stage": stage,
                         "mean_px": float(e.mean()), "max_px": float(e.max()), "n_corners": int(len(e))})
    return rows


def _on_world_plane(corners_world: np.ndarray, tol_deg: float) -> bool:
    """Whether a marker's corners lie in the plane ``z = 0`` up to a tilt of
    ``tol_deg`` of the whole plane about the origin (plus 0.5 mm)."""
    r = np.linalg.norm(corners_world[:, :2], axis=1)
    return bool(np.all(np.abs(corners_world[:, 2]) <= 0.5 + r * np.tan(np.radians(tol_deg))))


def _board_markers(markers_world: dict[int, np.ndarray], world_id: int, tol_deg: float,
                   tol_mm: float) -> set[int]:
    """Markers that share the world marker's flat board, from a free adjustment.

    Candidates lie within ``tol_deg`` of the plane ``z = 0`` (the free
    adjustment's world frame can be tilted by a fraction of a degree); then one
    plane is fitted to the world marker's and the candidates' corners and the
    marker farthest from it is removed until every corner is within ``tol_mm``.
    """
    cand = [m for m, X in markers_world.items() if m != world_id and _on_world_plane(X, tol_deg)]
    W = markers_world[world_id]
    while cand:
        pts = np.vstack([W] + [markers_world[m] for m in cand])
        A = np.column_stack([pts[:, 0], pts[:, 1], np.ones(len(pts))])
        coef = np.linalg.lstsq(A, pts[:, 2], rcond=None)[0]
        off = [np.abs(markers_world[m][:, 2] - np.column_stack([markers_world[m][:, :2], np.ones(4)]) @ coef).max()
               for m in cand]
        worst = int(np.argmax(off))
        if off[worst] <= tol_mm:
            break
        cand.pop(worst)
    return set(cand)


def _solve_rig(obs: dict[int, dict[int, np.ndarray]], cams0: list[Camera], *, world_id: int, length_mm: float,
               min_views: int, loss: str, f_scale_px: float, plane_ids: set[int],
               init: dict[int, np.ndarray] | None) -> dict:
    """One least-squares adjustment; ``plane_ids`` markers are squares in ``z = 0``."""
    n_views = len(cams0)
    seen: dict[int, int] = {}
    for o in obs.values():
        for m in o:
            seen[m] = seen.get(m, 0) + 1
    candidates = sorted(m for m, k in seen.items() if m != world_id and k >= min_views)
    free, plane, p_free, p_plane = [], [], [], []
    for m in candidates:
        if init is not None and m in init:
            X = init[m]
        else:
            X = _triangulate(cams0, [obs[v].get(m) if v in obs else None for v in range(n_views)])
        if not np.all(np.isfinite(X)):
            continue
        R, t, side = _fit_square(X)
        if not side > 0:
            continue
        if m in plane_ids:
            plane.append(m)
            p_plane.append([t[0], t[1], np.arctan2(R[1, 0], R[0, 0]), side])
        else:
            free.append(m)
            p_free.append(np.concatenate([cv2.Rodrigues(R)[0].ravel(), t, [side]]))
    nf, npl = len(free), len(plane)
    slot = {m: i for i, m in enumerate(free)} | {m: nf + i for i, m in enumerate(plane)}
    W = marker_object_corners(length_mm)
    U = marker_object_corners(1.0)
    views, slots, ks, xy = [], [], [], []
    for v in sorted(obs):
        for m, c in sorted(obs[v].items()):
            if m != world_id and m not in slot:
                continue
            for k in range(4):
                views.append(v)
                slots.append(-1 if m == world_id else slot[m])
                ks.append(k)
                xy.append(c[k])
    views_a, slot_a, k_a, xy_a = np.array(views), np.array(slots), np.array(ks), np.array(xy)
    n_cam = 6 * n_views
    off_plane = n_cam + 7 * nf

    def marker_corners(x: np.ndarray) -> np.ndarray:
        """Corners (nf + npl, 4, 3) of the adjusted markers."""
        out = np.empty((nf + npl, 4, 3))
        if nf:
            mp = x[n_cam:off_plane].reshape(nf, 7)
            Rm = _rodrigues(mp[:, :3])
            out[:nf] = np.einsum("mij,kj->mki", Rm, U) * mp[:, None, 6:7] + mp[:, None, 3:6]
        if npl:
            pp = x[off_plane:].reshape(npl, 4)
            c, s_ = np.cos(pp[:, 2]), np.sin(pp[:, 2])
            ux, uy = U[None, :, 0] * pp[:, 3:4], U[None, :, 1] * pp[:, 3:4]
            out[nf:, :, 0] = c[:, None] * ux - s_[:, None] * uy + pp[:, 0:1]
            out[nf:, :, 1] = s_[:, None] * ux + c[:, None] * uy + pp[:, 1:2]
            out[nf:, :, 2] = 0.0
        return out

    def residuals(x: np.ndarray) -> np.ndarray:
        Xm = marker_corners(x)
        P = np.empty((len(xy_a), 3))
        w = slot_a < 0
        P[w] = W[k_a[w]]
        P[~w] = Xm[slot_a[~w], k_a[~w]]
        cp = x[:n_cam].reshape(n_views, 6)
        Rc = _rodrigues(cp[:, :3])
        res = np.zeros_like(xy_a)
        for v in range(n_views):
            sel = views_a == v
            if sel.any():
                res[sel] = cams0[v].with_pose(Rc[v], cp[v, 3:]).project(P[sel]) - xy_a[sel]
        return res.ravel()

    x0 = np.concatenate([np.concatenate([[*c.rvec, *c.t_mm] for c in cams0])]
                        + [np.ravel(p_free)] + [np.ravel(p_plane)])
    sp = lil_matrix((2 * len(xy_a), len(x0)), dtype=int)
    for i, (v, sl) in enumerate(zip(views_a, slot_a)):
        sp[2 * i:2 * i + 2, 6 * v:6 * v + 6] = 1
        if 0 <= sl < nf:
            sp[2 * i:2 * i + 2, n_cam + 7 * sl:n_cam + 7 * sl + 7] = 1
        elif sl >= nf:
            j = off_plane + 4 * (sl - nf)
            sp[2 * i:2 * i + 2, j:j + 4] = 1
    r0 = residuals(x0)
    sol = least_squares(residuals, x0, jac_sparsity=sp, loss=loss, f_scale=f_scale_px, x_scale="jac",
                        method="trf", xtol=1e-10, ftol=1e-10, gtol=1e-10, max_nfev=200)
    cp = sol.x[:n_cam].reshape(n_views, 6)
    Rc = _rodrigues(cp[:, :3])
    cams = [c.with_pose(Rc[v], cp[v, 3:]) for v, c in enumerate(cams0)]
    X0, X1 = marker_corners(x0), marker_corners(sol.x)
    ids = free + plane
    mw0 = {world_id: W.copy()} | {m: X0[slot[m]] for m in ids}
    mw = {world_id: W.copy()} | {m: X1[slot[m]] for m in ids}
    lengths = {world_id: float(length_mm)} | {m: float(np.linalg.norm(X1[slot[m]][1] - X1[slot[m]][0])) for m in ids}
    rms = lambda r: float(np.sqrt((r ** 2).reshape(-1, 2).sum(1).mean()))  # noqa: E731
    return {"cameras": cams, "markers_world": mw, "markers_world0": mw0, "lengths": lengths, "plane": plane,
            "rms0": rms(r0), "rms1": rms(sol.fun), "nfev": int(sol.nfev)}


def bundle_adjust(cameras: list[Camera], observations: dict[int, dict[int, np.ndarray]], *,
                  world_id: int, length_mm: float, on_plane: str | bool | list[int] = "auto",
                  plane_tol_deg: float = 1.5, plane_tol_mm: float = 1.0, min_views: int = 2, loss: str = "soft_l1",
                  f_scale_px: float = 1.0, outlier_px: float = 3.0) -> tuple[list[Camera], BundleReport]:
    """Refine the camera poses jointly with every marker two or more views see.

    Unknowns: each camera's pose (Rodrigues vector, translation) and, for every
    other marker seen in at least ``min_views`` views, a square's pose and side
    length. The world marker's corners stay at ``marker_object_corners(length_mm)``:
    they fix the world frame and, through ``length_mm``, the scale. The residuals
    are the corner reprojection errors through each camera's lens distortion
    (:meth:`Camera.project`); ``scipy.optimize.least_squares`` minimises them
    with a robust ``loss`` (scale ``f_scale_px``) and the sparse Jacobian
    structure (a corner depends on one camera and one marker). A marker whose
    mean error in a view stays above ``outlier_px`` after the first pass is
    dropped from that view and the adjustment rerun.

    Parameters
    ----------
    cameras : list of Camera
        Initial cameras (intrinsics fixed; poses, e.g. single-marker, refined).
    observations : dict
        ``{view_index (0-based): {marker_id: corners (4, 2) px}}``.
    world_id : int
        The world marker's id; it must be seen by at least one view.
    length_mm : float
        The world marker's side.
    on_plane : "auto", bool or list of int, keyword-only
        Markers that lie on the world marker's board (its plane ``z = 0``):
        they are adjusted as squares in that plane (position, in-plane angle,
        side). ``"auto"`` (default): after a free adjustment, the markers whose
        corners lie within ``plane_tol_deg`` (plus 0.5 mm) of the plane and
        within ``plane_tol_mm`` of one plane fitted to them and the world
        marker; ``False``: none; ``True``: all; a list: those ids.

    Returns
    -------
    cameras : list of Camera
        The adjusted cameras, same order.
    report : BundleReport
        Per view and marker the error before and after, marker geometry.

    Notes
    -----
    A free marker ``m`` has corners ``X_mk = R_m (s_m U_k) + t_m`` with ``U_k``
    the corners of the unit square; it is initialised by triangulating its
    corners with the initial cameras and fitting a square (Umeyama).

    Why the plane: the world frame is only as good as the 24 mm world marker's
    own corners; its tilt is the least certain part (depth from the views'
    baselines), and a tilt of 0.1 degree moves a point 15 cm away by 0.26 mm,
    about 1.3 px. Markers on the same flat board pin the plane over its whole
    extent. The in-plane angle and the origin stay the world marker's.
    """
    n_views = len(cameras)
    if not length_mm > 0:
        raise ValueError(f"length_mm: expected a positive side length, got {length_mm}")
    obs = {int(v): {int(m): np.asarray(c, float).reshape(4, 2) for m, c in o.items()} for v, o in observations.items()}
    bad = [v for v in obs if not 0 <= v < n_views]
    if bad:
        raise ValueError(f"observations: view indices must be 0..{n_views - 1}, got {bad}")
    if not any(world_id in o for o in obs.values()):
        raise ValueError(f"world_id: marker {world_id} is not observed in any view")
    if not (on_plane in ("auto", True, False) or isinstance(on_plane, (list, tuple, set))):
        raise ValueError(f"on_plane: expected 'auto', True, False or a list of marker ids, got {on_plane!r}")
    kw = dict(world_id=world_id, length_mm=length_mm, min_views=min_views, loss=loss, f_scale_px=f_scale_px)
    all_ids = {m for o in obs.values() for m in o} - {world_id}
    fixed_plane = all_ids if on_plane is True else set() if on_plane in (False, "auto") else set(on_plane)
    first = _solve_rig(obs, list(cameras), plane_ids=fixed_plane, init=None, **kw)
    rms0, mw0, nfev = first["rms0"], first["markers_world0"], first["nfev"]
    # drop observations that disagree with the adjusted rig
    dropped: list[tuple[int, int]] = []
    rows = _reprojection_rows(first["cameras"], obs, first["markers_world"], "adjusted")
    bad_obs = [(r["view"] - 1, r["marker_id"]) for r in rows if r["mean_px"] > outlier_px and r["marker_id"] != world_id]
    n_other = sum(1 for r in rows if r["marker_id"] != world_id)
    if len(bad_obs) > n_other / 3:  # not a few wrong detections: the adjustment itself failed
        bad_obs = []
    if bad_obs:
        for v, m in bad_obs:
            dropped.append((v + 1, m))
        warnings.warn(f"bundle adjustment: dropped {len(bad_obs)} marker observation(s) off by more than "
                      f"{outlier_px} px: " + ", ".join(f"view {v} marker {m}" for v, m in dropped), stacklevel=2)
    used = {v: {m: c for m, c in o.items() if (v + 1, m) not in dropped} for v, o in obs.items()}
    plane_ids = fixed_plane
    if on_plane == "auto":
        plane_ids = _board_markers(first["markers_world"], world_id, plane_tol_deg, plane_tol_mm)
    result = first
    if bad_obs or plane_ids != fixed_plane:
        result = _solve_rig(used, first["cameras"], plane_ids=plane_ids, init=first["markers_world"], **kw)
        nfev += result["nfev"]
    cams, mw = result["cameras"], result["markers_world"]
    converged = result["rms1"] <= outlier_px / 3
    if not converged:
        warnings.warn(f"bundle adjustment did not converge (corner rms {result['rms1']:.2f} px from "
                      f"{rms0:.2f} px); the initial camera poses are kept", stacklevel=2)
        cams, mw = list(cameras), dict(mw0)
    rows = _reprojection_rows(list(cameras), obs, mw0, "single") + _reprojection_rows(cams, obs, mw, "adjusted")
    table = pd.DataFrame(rows, columns=["view", "marker_id", "stage", "mean_px", "max_px", "n_corners"])
    return cams, BundleReport(table=table, markers_world=mw, markers_world_single=mw0, marker_lengths_mm=result["lengths"],
                              on_plane=sorted(result["plane"]), rms_before_px=rms0,
                              rms_after_px=result["rms1"] if converged else rms0, dropped=dropped,
                              nfev=int(nfev), converged=bool(converged))


_bundle_adjust = bundle_adjust  # calibrate()'s keyword of the same name hides the function


# ----------------------------------------------------------------- calibration
@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """The calibrated rig of one experiment.

    Attributes
    ----------
    cameras : list of Camera
        Final cameras in view order (adjusted if bundle adjustment ran).
    single_cameras : list of Camera
        The single-marker (paper) poses.
    markers : pandas.DataFrame
        Corner reprojection errors, one row per (view, marker, stage):
        ``view`` (1-based), ``marker_id``, ``stage`` (``single`` | ``adjusted``),
        ``mean_px``, ``max_px``, ``n_corners``, and the marker's estimated
        geometry ``x_mm``, ``y_mm``, ``z_mm`` (centre, world) and ``length_mm``
        (NaN for a marker seen by one view only), sorted by stage, view, marker.
    observations : dict
        ``{view_index (0-based): {marker_id: corners (4, 2) px}}`` as detected.
    markers_world : dict[int, (4, 3) float array]
        Corners of every marker in the adjustment, world mm.
    frame : int or None
        The video frame the calibration comes from.
    source : str
        ``markers`` (detection, single marker), ``bundle`` (detection and
        bundle adjustment) or ``ijcv25`` (the authors' stored poses).
    bundle : BundleReport or None
        The adjustment's report (markers on the board plane, dropped
        observations, residuals) when it ran.
    """

    cameras: list[Camera]
    single_cameras: list[Camera]
    markers: pd.DataFrame
    observations: dict[int, dict[int, np.ndarray]]
    markers_world: dict[int, np.ndarray]
    frame: int | None = None
    source: str = "markers"
    bundle: BundleReport | None = None

    def summary(self) -> str:
        """Per view: markers seen, mean corner error single -> adjusted."""
        t = self.markers
        lines = []
        for v in range(1, len(self.cameras) + 1):
            seen = len(self.observations.get(v - 1, {}))
            s = t[(t.view == v) & (t.stage == "single")]
            a = t[(t.view == v) & (t.stage == "adjusted")]
            used = len(a) if len(a) else len(s)
            line = f"view {v}: {seen} marker(s) seen, {used} used; corner error "
            if len(s):
                line += f"mean {_wmean(s):.3f} px (max {s.max_px.max():.3f})"
            if len(a):
                line += f" -> {_wmean(a):.3f} px (max {a.max_px.max():.3f}) after bundle adjustment"
            lines.append(line)
        if self.bundle is not None:
            b = self.bundle
            extra = f"adjusted markers: {', '.join(str(m) for m in sorted(b.markers_world))}"
            if b.on_plane:
                extra += f"; on the world marker's plane: {', '.join(str(m) for m in b.on_plane)}"
            if b.dropped:
                extra += "; dropped: " + ", ".join(f"view {v} marker {m}" for v, m in b.dropped)
            lines.append(extra + f"; rms {b.rms_before_px:.3f} -> {b.rms_after_px:.3f} px")
            if not b.converged:
                lines.append("the bundle adjustment did not converge: the single-marker poses are kept")
        return "\n".join(lines)


def _wmean(rows: pd.DataFrame) -> float:
    return float((rows.mean_px * rows.n_corners).sum() / rows.n_corners.sum())


def _marker_table(rows: pd.DataFrame, markers_world: dict[int, np.ndarray],
                  markers_world_single: dict[int, np.ndarray] | None = None) -> pd.DataFrame:
    """The reprojection rows with each marker's centre and side (per stage)."""
    def geo(X):
        return (*X.mean(0), float(np.mean(np.linalg.norm(np.roll(X, -1, 0) - X, axis=1))))

    by_stage = {"adjusted": {m: geo(X) for m, X in markers_world.items()},
                "single": {m: geo(X) for m, X in (markers_world_single or markers_world).items()}}
    t = rows.copy()
    for j, col in enumerate(("x_mm", "y_mm", "z_mm", "length_mm")):
        t[col] = [by_stage[st][m][j] if m in by_stage[st] else np.nan for st, m in zip(t.stage, t.marker_id)]
    order = {"single": 0, "adjusted": 1}
    t = t.assign(_o=t.stage.map(order)).sort_values(["_o", "view", "marker_id"]).drop(columns="_o")
    return t.reset_index(drop=True)


def calibrate(images: list[np.ndarray], intrinsics: list[Camera], *, dictionary: str, world_id: int,
              length_mm: float, bundle_adjust: bool = True, frame: int = 0,
              refine: str = "edges") -> CalibrationResult:
    """Camera poses from the markers in one frame of every view.

    The world marker's single-marker pose (:func:`marker_pose`) is each camera's
    initial pose, as in the paper; with ``bundle_adjust`` the rig is then
    refined with every marker two or more views see (:func:`bundle_adjust`).

    Parameters
    ----------
    images : list of (height, width, 3) uint8 arrays
        One BGR frame per view, view order.
    intrinsics : list of Camera
        One per view (K, dist, image size; poses ignored).
    dictionary, world_id, length_mm
        The world marker (experiment file's ``marker:``).
    bundle_adjust : bool, keyword-only
        Refine with the other markers (default True).
    frame : int, keyword-only
        The frames' index in the videos, for messages only.

    Raises
    ------
    ExperimentError
        When a view does not show the world marker:
        ``view 2: world marker 815 (DICT_ARUCO_ORIGINAL) not found in frame 0``.
    """
    if len(images) != len(intrinsics):
        raise ValueError(f"images: expected one per camera ({len(intrinsics)}), got {len(images)}")
    if len(images) < 1:
        raise ValueError("images: expected at least one view")
    observations: dict[int, dict[int, np.ndarray]] = {}
    for v, (img, cam) in enumerate(zip(images, intrinsics)):
        observations[v] = detect_markers(img, dictionary, refine=refine, camera=cam)
        if world_id not in observations[v]:
            raise ExperimentError(f"view {v + 1}: world marker {world_id} ({dictionary}) not found in frame {frame}")
    return calibrate_from_observations(observations, intrinsics, world_id=world_id, length_mm=length_mm,
                                       bundle_adjust=bundle_adjust, frame=frame)


def _choose_world_poses(observations, intrinsics, world_id, length_mm) -> list[Camera]:
    """Single-marker camera poses; where IPPE's two solutions are both plausible,
    the combination that makes the other markers' triangulations agree best."""
    cands = [_pose_candidates(observations[v][world_id], cam, length_mm) for v, cam in enumerate(intrinsics)]
    choice = [0] * len(intrinsics)
    # an ambiguous view: the second solution is within a factor 3 of the first
    amb = [v for v, c in enumerate(cands) if len(c) > 1 and c[1][2] < 3 * max(c[0][2], 0.05)]
    shared = [m for m in set().union(*[set(o) for o in observations.values()]) - {world_id}
              if sum(m in o for o in observations.values()) >= 2]
    if amb and shared and len(amb) <= 4:
        best = None
        for bits in range(2 ** len(amb)):
            ch = list(choice)
            for j, v in enumerate(amb):
                ch[v] = (bits >> j) & 1
            cams = [cam.with_pose(*cands[v][ch[v]][:2]) for v, cam in enumerate(intrinsics)]
            err = []
            for m in shared:
                o = [observations[v].get(m) for v in range(len(cams))]
                X = _triangulate(cams, o)
                for v, c in enumerate(cams):
                    if o[v] is not None and np.all(np.isfinite(X)):
                        err.append(np.linalg.norm(c.project(X) - o[v], axis=1))
            score = float(np.median(np.concatenate(err))) if err else np.inf
            if best is None or score < best[0]:
                best = (score, ch)
        choice = best[1]
    return [cam.with_pose(*cands[v][choice[v]][:2]) for v, cam in enumerate(intrinsics)]


def calibrate_from_observations(observations: dict[int, dict[int, np.ndarray]], intrinsics: list[Camera], *,
                                world_id: int, length_mm: float, bundle_adjust: bool = True,
                                frame: int | None = None, dictionary: str = "") -> CalibrationResult:
    """:func:`calibrate` from already detected corners ``{view_index: {id: (4, 2)}}``."""
    for v in range(len(intrinsics)):
        if world_id not in observations.get(v, {}):
            what = f" ({dictionary})" if dictionary else ""
            raise ExperimentError(f"view {v + 1}: world marker {world_id}{what} not found in frame {frame}")
    single = _choose_world_poses(observations, intrinsics, world_id, length_mm)
    W = marker_object_corners(length_mm)
    shared = [m for m in set().union(*[set(o) for o in observations.values()]) - {world_id}
              if sum(m in o for o in observations.values()) >= 2]
    if bundle_adjust and shared:
        cams, rep = _bundle_adjust(single, observations, world_id=world_id, length_mm=length_mm)
        table = _marker_table(rep.table, rep.markers_world, rep.markers_world_single)
        return CalibrationResult(cameras=cams, single_cameras=single, markers=table, observations=observations,
                                 markers_world=rep.markers_world, frame=frame, source="bundle", bundle=rep)
    if bundle_adjust and len(intrinsics) > 1:
        warnings.warn("bundle adjustment skipped: no marker other than the world marker is seen by two views",
                      stacklevel=2)
    rows = pd.DataFrame(_reprojection_rows(single, observations, {world_id: W}, "single"),
                        columns=["view", "marker_id", "stage", "mean_px", "max_px", "n_corners"])
    return CalibrationResult(cameras=single, single_cameras=single, markers=_marker_table(rows, {world_id: W}),
                             observations=observations, markers_world={world_id: W}, frame=frame, source="markers")


def rig_agreement_px(cameras_a: list[Camera], cameras_b: list[Camera], points_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How far apart two rigs put the same world points, per view.

    Parameters
    ----------
    cameras_a, cameras_b : list of Camera
        Two calibrations of the same views (e.g. estimated and true).
    points_world : (n, 3) float array
        World points, mm (e.g. the tendril's working volume); NaN rows ignored.

    Returns
    -------
    max_px, mean_px : (n_views,) float arrays
        Largest and mean distance between the two projections of the points.
    """
    if len(cameras_a) != len(cameras_b):
        raise ValueError(f"cameras_b: expected {len(cameras_a)} cameras like cameras_a, got {len(cameras_b)}")
    X = np.asarray(points_world, float).reshape(-1, 3)
    X = X[np.all(np.isfinite(X), axis=1)]
    if len(X) == 0:
        raise ValueError("points_world: expected at least one finite point")
    d = np.array([np.linalg.norm(a.project(X) - b.project(X), axis=1) for a, b in zip(cameras_a, cameras_b)])
    return d.max(axis=1), d.mean(axis=1)


# ------------------------------------------------- the authors' stored poses
def cameras_from_ijcv25(files: list[Path], intrinsics: list[Camera], *, row: int = 0,
                        frame: int | None = None) -> list[Camera]:
    """Cameras whose poses are the authors' stored marker poses (one file per view).

    ``row`` selects the stored video frame (0: the first row of each file);
    with ``frame``, the row whose stored frame index equals it, if any.
    """
    from tendrilkit.io import read_ijcv25_extrinsics

    out = []
    for f, cam in zip(files, intrinsics):
        ext = read_ijcv25_extrinsics(f)
        r = min(row, len(ext["frame"]) - 1)
        if frame is not None and np.any(ext["frame"] == frame):
            r = int(np.flatnonzero(ext["frame"] == frame)[0])
        out.append(cam.with_pose(ext["R"][r], ext["t_mm"][r]))
    return out


def ijcv25_rig() -> list[Camera]:
    """The real three-camera rig of the paper (intrinsics and first stored poses)."""
    from tendrilkit.io import read_ijcv25_intrinsics

    meta = read_ijcv25_intrinsics(RIG_DIR / "intrinsics.yaml")
    w, h = meta["image_size"]
    intr = [
        Camera(K=np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1.0]]), width=w, height=h)
        for c in meta["cameras"]
    ]
    files = [RIG_DIR / f"CamExtrPara_Corners{i + 1}.csv" for i in range(len(intr))]
    return cameras_from_ijcv25(files, intr)


# ------------------------------------------------------------ experiment files
def _experiment_intrinsics(exp: "Experiment") -> list[Camera]:
    from tendrilkit.io import FrameSource

    cams = []
    for c, video in zip(exp.cameras, exp.videos):
        with FrameSource(video) as src:
            w, h = src.width, src.height
        K = np.array([[c.fx, 0.0, c.cx], [0.0, c.fy, c.cy], [0.0, 0.0, 1.0]])
        cams.append(Camera(K=K, dist=np.asarray(c.dist, float), width=w, height=h))
    return cams


def calibrate_experiment(exp: "Experiment") -> CalibrationResult:
    """The rig of an experiment: from its ``extrinsics`` files, else from markers.

    With ``extrinsics: {format: ijcv25}`` the stored poses of the row whose frame
    is ``frames.start`` (else the first row) are used, and the table holds the
    stored corners' reprojection errors. Otherwise the first processed frame of
    every view is read and :func:`calibrate` runs with the experiment's
    ``marker`` and ``calibration.bundle_adjust``.

    The result is then checked (:func:`check_calibration`): every view's
    marker corners must reproject within ``calibration.max_corner_rms_px``
    (unless ``null``) and no two cameras may sit at the same place.

    Raises
    ------
    ExperimentError
        A video cannot be read, a view does not show the world marker, or the
        calibration failed its checks.
    """
    result = _calibrate_experiment(exp)
    check_calibration(result, max_corner_rms_px=exp.calibration.max_corner_rms_px)
    return result


#: Two cameras closer than this fraction of their distance to the world marker cannot triangulate.
MIN_BASELINE_FRACTION = 0.02


def corner_rms_px(result: CalibrationResult) -> dict[int, float]:
    """Per view (1-based), the corner reprojection error of the final rig, pixels: the root mean
    square, over the markers, of each marker's mean corner error.

    Over every marker the view sees (the ``adjusted`` rows of
    :attr:`CalibrationResult.markers` when the bundle adjustment ran, else the
    ``single`` rows), dropped observations included.
    """
    t = result.markers
    stage = "adjusted" if (t.stage == "adjusted").any() else "single"
    t = t[t.stage == stage]
    out = {}
    for v, g in t.groupby("view"):
        # mean_px is a mean of distances: rms >= mean; the mean of the squares is bounded by max_px^2
        n = g.n_corners.to_numpy(float)
        out[int(v)] = float(np.sqrt((np.asarray(g.mean_px, float) ** 2 * n).sum() / n.sum()))
    return out


def check_calibration(result: CalibrationResult, *, max_corner_rms_px: float | None = 1.5) -> None:
    """Refuse a calibration that cannot be right.

    - A view whose marker corners reproject further than ``max_corner_rms_px``
      (:func:`corner_rms_px`): wrong intrinsics, intrinsics of another image
      size, a moved camera... (``None``: not checked; a warning is given).
    - Two cameras at the same place (closer than :data:`MIN_BASELINE_FRACTION`
      of their distance to the world marker): the same video given for two
      views; nothing can be triangulated.

    Raises
    ------
    ExperimentError
        ``calibration failed: view 1: marker corners reproject 6.27 px rms ...``
    """
    cams = result.cameras
    C = np.array([c.center_world for c in cams])
    depth = np.linalg.norm(C, axis=1)
    for i in range(len(cams)):
        for j in range(i):
            base = float(np.linalg.norm(C[i] - C[j]))
            if not base >= MIN_BASELINE_FRACTION * max(float(min(depth[i], depth[j])), 1e-9):
                raise ExperimentError(
                    f"calibration failed: views {j + 1} and {i + 1} are {base:.1f} mm apart at {depth[i]:.0f} mm from "
                    f"the world marker (at least {100 * MIN_BASELINE_FRACTION:g} % of it needed to triangulate); "
                    f"the same video given for two views?")
    rms = corner_rms_px(result)
    bad = {v: r for v, r in rms.items() if max_corner_rms_px is not None and not r <= max_corner_rms_px}
    if bad:
        v, r = max(bad.items(), key=lambda kv: kv[1])
        others = ", ".join(f"view {w}: {x:.2f} px" for w, x in sorted(bad.items()) if w != v)
        raise ExperimentError(
            f"calibration failed: view {v}: marker corners reproject {r:.2f} px off (rms over markers; limit "
            f"calibration.max_corner_rms_px = {max_corner_rms_px:g} px{'; also ' + others if others else ''}); "
            f"check view {v}'s intrinsics (fx, fy, cx, cy, dist) and image size, or pass --accept-calibration")
    if max_corner_rms_px is None and rms:
        v, r = max(rms.items(), key=lambda kv: kv[1])
        if r > 1.5:
            warnings.warn(f"calibration accepted although view {v}'s marker corners reproject {r:.2f} px rms",
                          stacklevel=2)


def _calibrate_experiment(exp: "Experiment") -> CalibrationResult:
    from tendrilkit.exceptions import FrameReadError
    from tendrilkit.io import FrameSource, read_ijcv25_extrinsics

    intr = _experiment_intrinsics(exp)
    start = exp.frames.start
    L = exp.marker.length_mm
    if exp.extrinsics is not None:
        files = list(exp.extrinsics.files)
        cams = cameras_from_ijcv25(files, intr, frame=start)
        obs: dict[int, dict[int, np.ndarray]] = {}
        frame_used = None
        for v, (f, cam) in enumerate(zip(files, cams)):
            ext = read_ijcv25_extrinsics(f)
            hit = np.flatnonzero(ext["frame"] == start)
            r = int(hit[0]) if hit.size else 0
            frame_used = int(ext["frame"][r])
            obs[v] = {int(ext["marker_id"][r]): ext["corners_xy"][r]}
        mw = {mid: marker_object_corners(L) for o in obs.values() for mid in o}
        rows = pd.DataFrame(_reprojection_rows(cams, obs, mw, "single"),
                            columns=["view", "marker_id", "stage", "mean_px", "max_px", "n_corners"])
        return CalibrationResult(cameras=cams, single_cameras=cams, markers=_marker_table(rows, mw),
                                 observations=obs, markers_world=mw, frame=frame_used, source="ijcv25")
    images = []
    for v, video in enumerate(exp.videos):
        with FrameSource(video) as src:
            try:
                images.append(src.read(start))
            except FrameReadError as e:
                raise ExperimentError(f"view {v + 1}: cannot read the first processed frame {start} for calibration ({e})") from None
    return calibrate(images, intr, dictionary=exp.marker.dictionary, world_id=exp.marker.id,
                     length_mm=L, bundle_adjust=exp.calibration.bundle_adjust, frame=start)


def calibrate_to_dir(experiment_path: str | Path, out_dir: str | Path, *, overrides: dict | None = None) -> str:
    """``python -m tendrilkit calibrate``: write ``cameras.json`` and the marker table.

    Writes ``out_dir/cameras.json`` (EXPERIMENT_FORMAT.md) and
    ``out_dir/calibration_markers.csv`` (:attr:`CalibrationResult.markers`);
    returns a short summary, one line per view. ``overrides`` replace keys
    of the experiment's sections, e.g. ``{"calibration": {"max_corner_rms_px":
    None}}`` (the command line's ``--accept-calibration``).
    """
    from tendrilkit.inputs import check_inputs
    from tendrilkit.io import check_writable_dir, open_views, write_cameras, write_csv
    from tendrilkit.params import load_experiment

    exp = load_experiment(experiment_path)
    if overrides:
        exp = exp.model_copy(update={k: getattr(exp, k).model_copy(update=v) for k, v in overrides.items()})
    out = check_writable_dir(out_dir)
    sources = open_views(list(exp.videos))
    try:
        check_inputs(exp, sources, marks_on_frame=False)  # the marks' geometry only: calibrating does not use them
    finally:
        for s in sources:
            s.close()
    res = calibrate_experiment(exp)
    write_cameras(res.cameras, out / "cameras.json")
    write_csv(res.markers, out / "calibration_markers.csv")
    how = {"ijcv25": "the authors' stored poses (ijcv25)",
           "bundle": "the world marker and bundle adjustment over the markers two or more views see",
           "markers": "the world marker alone"}[res.source]
    head = (f"{exp.name}: {len(res.cameras)} views calibrated from {how}, frame {res.frame} "
            f"(marker {exp.marker.id}, {exp.marker.dictionary}, {exp.marker.length_mm:g} mm)")
    tail = f"wrote {out / 'cameras.json'} and {out / 'calibration_markers.csv'}"
    return "\n".join([head, res.summary(), tail])
