"""Pinhole cameras with OpenCV lens distortion.

A :class:`Camera` maps world points (mm, world-marker frame) to pixels:

.. math::

    x_{cam} = R\\,x_{world} + t, \\qquad
    (u, v) = \\mathrm{distort}(x_{cam} / z_{cam}) \\text{ through } K

with OpenCV's distortion model ``dist = (k1, k2, p1, p2, k3)`` (or OpenCV's
longer models of 8, 12 or 14 coefficients: ``k4, k5, k6`` rational,
``s1..s4`` thin prism, ``tauX, tauY`` tilted sensor; projected by OpenCV).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import cv2
import numpy as np
from numba import njit

from tendrilkit.geometry import check_points


@njit(cache=True, error_model="numpy")
def _project_brown(Xc, K, dist, distort):
    """Pixels (n, 2) of camera-frame points (n, 3): pinhole, with OpenCV's 5-coefficient distortion if ``distort``."""
    n = Xc.shape[0]
    out = np.empty((n, 2))
    k1, k2, p1, p2, k3 = dist[0], dist[1], dist[2], dist[3], dist[4]
    for i in range(n):
        z = Xc[i, 2]
        x = Xc[i, 0] / z
        y = Xc[i, 1] / z
        if distort:
            r2 = x * x + y * y
            radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
            xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
            yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
            x, y = xd, yd
        out[i, 0] = K[0, 0] * x + K[0, 1] * y + K[0, 2]
        out[i, 1] = K[1, 1] * y + K[1, 2]
    return out


def _as_points(points: np.ndarray, dim: int, name: str) -> np.ndarray:
    """(n, dim) float array of ``points`` (one point may come as (dim,)); NaN allowed."""
    if type(points) is np.ndarray and points.dtype == np.float64 and points.ndim == 2 and points.shape[1] == dim:
        return points  # what the checks below return for it (the projections' hot path: no call for nothing)
    arr = np.asarray(points, dtype=float)
    if arr.ndim == 1 and arr.shape[0] == dim:
        arr = arr[None, :]
    return check_points(arr, dim=dim, name=name, finite=False)


@dataclass(frozen=True, eq=False)
class Camera:
    """One calibrated view.

    Attributes
    ----------
    K : (3, 3) float array
        Intrinsic matrix, pixels.
    dist : (5,), (8,), (12,) or (14,) float array
        OpenCV distortion ``(k1, k2, p1, p2, k3[, k4, k5, k6[, s1, s2, s3, s4[, tauX, tauY]]])``
        (fewer than 5 are completed with zeros).
    R : (3, 3) float array
        World-to-camera rotation.
    t_mm : (3,) float array
        World-to-camera translation, mm: ``x_cam = R @ x_world + t_mm``.
    width, height : int
        Image size, pixels.
    """

    K: np.ndarray
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    t_mm: np.ndarray = field(default_factory=lambda: np.zeros(3))
    width: int = 1920
    height: int = 1080

    def __post_init__(self) -> None:
        K = np.asarray(self.K, dtype=float).reshape(3, 3)
        d = np.asarray(self.dist, dtype=float).ravel()
        if d.size > 5 and d.size not in (8, 12, 14):
            raise ValueError(f"dist must have at most 5, or 8, 12 or 14 coefficients (OpenCV), got {d.size}")
        dist = np.zeros(max(5, d.size))
        dist[: d.size] = d
        object.__setattr__(self, "K", K)
        object.__setattr__(self, "dist", dist)
        object.__setattr__(self, "R", np.asarray(self.R, dtype=float).reshape(3, 3))
        object.__setattr__(self, "t_mm", np.asarray(self.t_mm, dtype=float).reshape(3))

    # ------------------------------------------------------------------ poses
    @property
    def rvec(self) -> np.ndarray:
        """Rodrigues vector of ``R``, shape (3,)."""
        return cv2.Rodrigues(self.R)[0].ravel()

    @property
    def center_world(self) -> np.ndarray:
        """Optical centre in world mm, shape (3,)."""
        return -self.R.T @ self.t_mm

    @property
    def P(self) -> np.ndarray:
        """Projection matrix ``K [R | t]`` (3, 4) for undistorted pixels."""
        return self.K @ np.hstack([self.R, self.t_mm[:, None]])

    @cached_property
    def has_distortion(self) -> bool:  # read by every projection: computed once
        return bool(np.any(self.dist != 0))

    def with_pose(self, R: np.ndarray, t_mm: np.ndarray) -> "Camera":
        """The same intrinsics with another pose."""
        return Camera(self.K, self.dist, R, t_mm, self.width, self.height)

    # ------------------------------------------------------------- projection
    def world_to_cam(self, points_world: np.ndarray) -> np.ndarray:
        """Camera-frame coordinates (n, 3) mm of world points (n, 3) mm."""
        X = _as_points(points_world, 3, "points_world")
        return X @ self.R.T + self.t_mm

    def project(self, points_world: np.ndarray, *, distort: bool = True) -> np.ndarray:
        """Pixels (n, 2) of world points (n, 3) mm; NaN rows stay NaN.

        With ``distort=False`` the ideal pinhole pixels (undistorted image).
        """
        Xc = self.world_to_cam(points_world)
        if distort and self.has_distortion and self.dist.size > 5:
            z = Xc[:, 2]
            with np.errstate(divide="ignore", invalid="ignore"):
                return self._project_opencv(Xc[:, 0] / z, Xc[:, 1] / z)
        # the pinhole and the 5-coefficient model, point by point (compiled: the same arithmetic in the same order
        # as numpy's whole-array expressions, bit for bit, without their per-call cost on short arrays)
        return _project_brown(Xc, self.K, self.dist, bool(distort and self.has_distortion))

    def project_jacobian(self, points_world: np.ndarray, *, distort: bool = False, step_mm: float = 1e-3,
                         along: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Pixels (n, 2) of world points (n, 3) mm and their Jacobians (n, 2, 3), px per mm.

        With ``distort=False`` (default) the ideal pinhole pixels (undistorted
        image) and the exact Jacobian

        .. math::

            \\frac{\\partial u}{\\partial X} = K_{2 \\times 2}
            \\begin{pmatrix} 1/z & 0 & -x/z \\\\ 0 & 1/z & -y/z \\end{pmatrix} R,
            \\qquad (x, y) = (X_c / z, Y_c / z);

        with ``distort=True`` the observed pixels (:meth:`project`) and the
        forward differences of :meth:`project` with steps of ``step_mm``.
        With ``along`` (n, 3), world directions (pinhole only): the
        derivatives (n, 2) of the pixels along them, px per unit of
        ``along``, instead of the Jacobians.

        Examples
        --------
        >>> cam = Camera(K=np.diag([100.0, 100.0, 1.0]), t_mm=np.array([0.0, 0.0, 10.0]))
        >>> u, J = cam.project_jacobian(np.array([[1.0, 0.0, 0.0]]))
        >>> u, J[0]
        (array([[10.,  0.]]), array([[10.,  0., -1.],
               [ 0., 10.,  0.]]))
        """
        X = _as_points(points_world, 3, "points_world")
        if distort and along is not None:
            raise ValueError("along is for the pinhole projection (distort=False) only")
        if distort:  # the points and their three shifted copies in one projection
            n = len(X)
            S = np.empty((4 * n, 3))
            S[:n] = X
            for a in range(3):
                S[(a + 1) * n:(a + 2) * n] = X
                S[(a + 1) * n:(a + 2) * n, a] += step_mm
            U = self.project(S)
            u = U[:n]
            J = np.empty((n, 2, 3))
            for a in range(3):
                J[:, :, a] = (U[(a + 1) * n:(a + 2) * n] - u) / step_mm
            return u, J
        Xc = X @ self.R.T + self.t_mm
        z = Xc[:, 2]
        x, y = Xc[:, 0] / z, Xc[:, 1] / z
        K = self.K
        u = np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=1)
        if along is not None:
            dXc = _as_points(along, 3, "along") @ self.R.T
            if dXc.shape != X.shape:
                raise ValueError(f"along must have shape {X.shape}, got {dXc.shape}")
            dx = (dXc[:, 0] - x * dXc[:, 2]) / z
            dy = (dXc[:, 1] - y * dXc[:, 2]) / z
            return u, np.stack([K[0, 0] * dx + K[0, 1] * dy, K[1, 1] * dy], axis=1)
        dn = np.zeros((len(X), 2, 3))  # d(x, y)/dXc
        dn[:, 0, 0] = 1 / z
        dn[:, 0, 2] = -x / z
        dn[:, 1, 1] = 1 / z
        dn[:, 1, 2] = -y / z
        J = np.einsum("ab,kbc,cd->kad", K[:2, :2], dn, self.R)
        return u, J

    def _project_opencv(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """OpenCV's projection of normalised coordinates (the 8, 12 and 14 coefficient models)."""
        out = np.full((len(x), 2), np.nan)
        ok = np.isfinite(x) & np.isfinite(y)
        if ok.any():
            pts = np.stack([x[ok], y[ok], np.ones(int(ok.sum()))], axis=1).reshape(-1, 1, 3)
            uv, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), self.K, self.dist)
            out[ok] = uv.reshape(-1, 2)
        return out

    def undistort_points(self, points_xy: np.ndarray) -> np.ndarray:
        """Ideal pinhole pixels (n, 2) of observed (distorted) pixels (n, 2)."""
        xy = _as_points(points_xy, 2, "points_xy")
        if not self.has_distortion or xy.shape[0] == 0:
            return xy.copy()
        out = np.full_like(xy, np.nan)
        ok = np.all(np.isfinite(xy), axis=1)
        if ok.any():
            # OpenCV 5 has no undistortPointsIter; undistortPoints takes the criteria
            und = cv2.undistortPoints(
                xy[ok].reshape(-1, 1, 2), self.K, self.dist, R=None, P=self.K,
                criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-9),
            )
            out[ok] = und.reshape(-1, 2)
        return out

    def distort_points(self, points_xy: np.ndarray) -> np.ndarray:
        """Observed pixels (n, 2) of ideal pinhole pixels (n, 2)."""
        xy = _as_points(points_xy, 2, "points_xy")
        if not self.has_distortion:
            return xy.copy()
        Kinv = np.linalg.inv(self.K)
        rays = np.hstack([xy, np.ones((len(xy), 1))]) @ Kinv.T
        cam = Camera(self.K, self.dist, np.eye(3), np.zeros(3), self.width, self.height)
        return cam.project(rays)

    def ray_directions_cam(self, points_xy: np.ndarray) -> np.ndarray:
        """Unit viewing rays (n, 3) in the camera frame of observed pixels (n, 2)."""
        und = self.undistort_points(points_xy)
        rays = np.hstack([und, np.ones((len(und), 1))]) @ np.linalg.inv(self.K).T
        return rays / np.linalg.norm(rays, axis=1, keepdims=True)

    def in_image(self, points_xy: np.ndarray, *, margin_px: float = 0.0) -> np.ndarray:
        """Boolean (n,) whether pixels lie inside the image."""
        xy = _as_points(points_xy, 2, "points_xy")
        return (
            (xy[:, 0] >= margin_px)
            & (xy[:, 1] >= margin_px)
            & (xy[:, 0] <= self.width - 1 - margin_px)
            & (xy[:, 1] <= self.height - 1 - margin_px)
        )

    # ------------------------------------------------------------ plain text
    def to_dict(self, view: int) -> dict:
        """The ``cameras.json`` entry of this camera (EXPERIMENT_FORMAT.md)."""
        return {
            "view": int(view),
            "K": self.K.tolist(),
            "dist": self.dist.tolist(),
            "R": self.R.tolist(),
            "t_mm": self.t_mm.tolist(),
            "width": int(self.width),
            "height": int(self.height),
        }

    @classmethod
    def from_dict(cls, d: dict) -> "Camera":
        return cls(
            K=np.asarray(d["K"], dtype=float),
            dist=np.asarray(d.get("dist", [0, 0, 0, 0, 0]), dtype=float),
            R=np.asarray(d["R"], dtype=float),
            t_mm=np.asarray(d["t_mm"], dtype=float),
            width=int(d.get("width", 1920)),
            height=int(d.get("height", 1080)),
        )


def rotation_from_rvec(rvec: np.ndarray) -> np.ndarray:
    """3x3 rotation of a Rodrigues vector (3,)."""
    r = np.asarray(rvec, dtype=float)
    if r.size != 3 or not np.all(np.isfinite(r)):
        raise ValueError(f"rvec must be 3 finite numbers, got {r.ravel().tolist()}")
    return cv2.Rodrigues(r.reshape(3, 1))[0]


def look_at(eye_world: np.ndarray, target_world: np.ndarray, up_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World-to-camera ``(R, t)`` of a camera at ``eye`` looking at ``target``.

    The image's y axis (down) is aligned as well as possible with ``-up``.
    """
    eye = np.asarray(eye_world, float)
    z = np.asarray(target_world, float) - eye
    if not np.linalg.norm(z) > 0:  # also NaN
        raise ValueError(f"eye_world and target_world must be distinct finite points, got {eye.tolist()} and {np.asarray(target_world).tolist()}")
    z /= np.linalg.norm(z)
    down = -np.asarray(up_world, float)
    x = np.cross(down, z)
    if not np.linalg.norm(x) > 1e-12 * max(float(np.linalg.norm(down)), 1e-300):
        raise ValueError(f"up_world must be finite and not parallel to the viewing direction, got {np.asarray(up_world).tolist()}")
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ eye
