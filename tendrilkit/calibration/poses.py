"""Single-marker poses (the paper's camera poses): IPPE_SQUARE and SQPnP, polished, and the choice between
IPPE's two solutions when both are plausible."""

from __future__ import annotations

import cv2
import numpy as np

from tendrilkit.calibration.bundle import _triangulate
from tendrilkit.camera import Camera, rotation_from_rvec
from tendrilkit.geometry import marker_corners

__all__ = ["marker_pose"]


def _pose_candidates(corners_xy: np.ndarray, camera: Camera, length_mm: float) -> list[tuple[np.ndarray, np.ndarray, float]]:
    """Distinct poses ``(R, t_mm, rms_px)`` of a square marker, best first.

    Both IPPE_SQUARE solutions, plus SQPnP's: OpenCV's IPPE returns a wrong
    pose (80 px off, or NaN, with success reported) for some near-frontal
    views, e.g. a marker 5 degrees from frontal with its edges along the image
    axes (tests/test_calibration.py, property test). Each is polished by
    Levenberg-Marquardt through the lens distortion.
    """
    obj = marker_corners(length_mm)
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
    with the marker frame of :func:`tendrilkit.geometry.marker_corners`. For the world
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
