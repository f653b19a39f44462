"""N-view triangulation and reprojection errors
(paper: "Mapping Points Between Views" and "Accuracy of Stereo Reconstruction",
Table 1; stage 6 of ``../shared/REFERENCE_NOTES.md``).

:func:`triangulate` takes matched points of every view (observed pixels, NaN
for a missing observation), undistorts them, solves the linear (DLT) problem
of every point at once, then refines each point by Gauss-Newton on its
reprojection error:

.. math::

    X^* = \\arg\\min_X \\sum_{v \\in \\mathcal{V}(X)}
        \\lVert \\pi_v(X) - \\hat u_v \\rVert^2

with :math:`\\pi_v` the pinhole projection of view ``v`` (undistorted pixels)
and :math:`\\hat u_v` the undistorted observation. The per-view error returned
is measured in observed pixels (with distortion), which is what a reader sees
on the image.

:func:`reprojection_table` is the paper's Table 1: the reconstruction is
projected into every view and the distance of each projected point to the
extracted 2D skeleton (polyline) is summarised per quarter: base (first
quarter of the 3D arc length), tip (last quarter) and entire.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from tendrilkit.camera import Camera
from tendrilkit.geometry import arc_length, nearest_on_polyline, point_to_polyline_distance, section_masks

__all__ = ["Triangulated", "triangulate", "refine_to_curves", "reprojection_table"]


@dataclass(frozen=True, eq=False)
class Triangulated:
    """Result of :func:`triangulate`.

    Attributes
    ----------
    points_mm : (k, 3) float array
        World points, mm; NaN where fewer than two views observe the point
        or the solution lies behind a camera that observes it.
    reproj_err_px : (n_views, k) float array
        Distance between the projection (with distortion) and the observation,
        observed pixels; NaN where the view has no observation.
    n_views : (k,) int array
        Views used per point.
    """

    points_mm: np.ndarray
    reproj_err_px: np.ndarray
    n_views: np.ndarray


def _check_views(points_xy, cameras) -> tuple[np.ndarray, list[Camera]]:
    x = np.asarray(points_xy, dtype=float)
    if x.ndim != 3 or x.shape[2] != 2:
        raise ValueError(f"points_xy must have shape (n_views, k, 2), got {x.shape}")
    cams = list(cameras)
    if len(cams) != x.shape[0]:
        raise ValueError(f"cameras must have one entry per view ({x.shape[0]}), got {len(cams)}")
    return x, cams


def _newton_steps(H: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Batched Gauss-Newton steps :math:`-H^{-1} g`, (k, 3), of normal matrices (k, 3, 3) and gradients (k, 3).

    A non-finite step (a singular point) is 0; a singular batch raises ``LinAlgError``.
    """
    step = np.linalg.solve(H, -g[..., None])[..., 0]
    return np.where(np.isfinite(step), step, 0.0)


def triangulate(points_xy: np.ndarray, cameras: list[Camera], *, refine: bool = True,
                iterations: int = 5) -> Triangulated:
    """Triangulate matched points seen by two or more views.

    Parameters
    ----------
    points_xy : (n_views, k, 2) float array
        Observed (distorted) pixels, NaN where a view has no observation.
    cameras : list of Camera
        One per view.
    refine : bool, keyword-only
        Gauss-Newton refinement of the reprojection error after the DLT.
    iterations : int
        Gauss-Newton iterations.

    Returns
    -------
    Triangulated

    Notes
    -----
    DLT in normalised camera coordinates: for each view the rows
    :math:`x\\,p_3^T - p_1^T` and :math:`y\\,p_3^T - p_2^T` of
    :math:`[R \\mid t]` (unit-norm rows), solved for every point at once as
    an inhomogeneous least-squares problem (batched 3x3 normal equations);
    a missing view contributes zero rows.
    """
    x, cams = _check_views(points_xy, cameras)
    V, k = x.shape[:2]
    und = np.full_like(x, np.nan)
    for v, cam in enumerate(cams):
        ok = np.all(np.isfinite(x[v]), axis=1)
        if ok.any():
            und[v, ok] = cam.undistort_points(x[v, ok])
    valid = np.all(np.isfinite(und), axis=2)  # (V, k)
    n_views = valid.sum(axis=0)
    A = np.zeros((k, 2 * V, 4))
    for v, cam in enumerate(cams):
        Rt = np.hstack([cam.R, cam.t_mm[:, None]])
        Kinv = np.linalg.inv(cam.K)
        n = np.hstack([np.nan_to_num(und[v]), np.ones((k, 1))]) @ Kinv.T  # normalised coords
        r0 = n[:, 0:1] * Rt[2] - Rt[0]
        r1 = n[:, 1:2] * Rt[2] - Rt[1]
        r0 /= np.linalg.norm(r0, axis=1, keepdims=True)
        r1 /= np.linalg.norm(r1, axis=1, keepdims=True)
        m = valid[v][:, None]
        A[:, 2 * v] = np.where(m, r0, 0.0)
        A[:, 2 * v + 1] = np.where(m, r1, 0.0)
    ok = n_views >= 2
    X = np.full((k, 3), np.nan)
    if ok.any():
        # inhomogeneous least squares A[:, :3] X = -A[:, 3] (points at a finite distance),
        # batched 3x3 normal equations: ~10x faster than a batched SVD of the (2V, 4) systems
        Ao = A[ok]
        M = np.einsum("kri,krj->kij", Ao[..., :3], Ao[..., :3])
        b = -np.einsum("kri,kr->ki", Ao[..., :3], Ao[..., 3])
        with np.errstate(divide="ignore", invalid="ignore"):
            try:
                X[ok] = np.linalg.solve(M, b[..., None])[..., 0]
            except np.linalg.LinAlgError:  # a singular system (parallel rays): per point, SVD
                _, _, Vt = np.linalg.svd(Ao)
                h = Vt[:, -1, :]
                X[ok] = h[:, :3] / h[:, 3:4]
        # parallel rays (views sharing a centre, a point at infinity) leave the depth undetermined:
        # NaN, not an arbitrary point on the ray
        ev = np.linalg.eigvalsh(M)
        X[np.flatnonzero(ok)[~(ev[:, 0] > 1e-12 * ev[:, -1])]] = np.nan
        ok = ok & np.all(np.isfinite(X), axis=1)
    if refine and ok.any():
        Xo = X[ok]
        uo = und[:, ok]
        vo = valid[:, ok]
        for _ in range(iterations):
            H = np.zeros((len(Xo), 3, 3))
            g = np.zeros((len(Xo), 3))
            for v, cam in enumerate(cams):
                u, J = cam.project_jacobian(Xo)
                r = np.where(vo[v][:, None], u - np.nan_to_num(uo[v]), 0.0)
                Jm = np.where(vo[v][:, None, None], J, 0.0)
                H += np.einsum("kai,kaj->kij", Jm, Jm)
                g += np.einsum("kai,ka->ki", Jm, r)
            H += 1e-9 * np.trace(H, axis1=1, axis2=2)[:, None, None] * np.eye(3)
            try:
                step = _newton_steps(H, g)
            except np.linalg.LinAlgError:
                break
            Xo = Xo + step
            if np.max(np.abs(step)) < 1e-9:
                break
        X[ok] = Xo
    # cheirality: a point behind a camera that observes it is no solution
    for v, cam in enumerate(cams):
        m = valid[v] & np.all(np.isfinite(X), axis=1)
        if m.any():
            z = X[m] @ cam.R[2] + cam.t_mm[2]
            bad = np.flatnonzero(m)[z <= 0]
            X[bad] = np.nan
    ok = np.all(np.isfinite(X), axis=1)
    err = np.full((V, k), np.nan)
    for v, cam in enumerate(cams):
        m = valid[v] & ok
        if m.any():
            err[v, m] = np.linalg.norm(cam.project(X[m]) - x[v, m], axis=1)
    return Triangulated(points_mm=X, reproj_err_px=err, n_views=n_views)


def refine_to_curves(points_mm: np.ndarray, curves_xy: list[np.ndarray | None], cameras: list[Camera], *,
                     iterations: int = 6, huber_px: float = 2.0, max_px: float = 20.0) -> np.ndarray:
    """Move each 3D point to minimise its projections' distances to every view's curve.

    Parameters
    ----------
    points_mm : (k, 3) float array
        Triangulated points (NaN rows stay NaN).
    curves_xy : list of (n_v, 2) float arrays or None
        Each view's extracted, ordered 2D centreline, observed pixels (None:
        the view is left out).
    cameras : list of Camera
    iterations : int
        Gauss-Newton iterations.
    huber_px : float
        Residuals above this are down-weighted (Huber).
    max_px : float
        A view whose curve is farther than this from a point's projection is
        ignored for that point.

    Returns
    -------
    (k, 3) float array

    Notes
    -----
    Point-to-point triangulation spreads the error of the matches *along*
    the curves over every view; the paper's accuracy measure (Table 1) is the
    distance of the projections to the skeletons, across them. This step
    minimises that measure directly:

    .. math::

        X^* = \\arg\\min_X \\sum_v \\rho\\left(n_v^T (\\pi_v(X) - c_v(X))\\right)

    with :math:`c_v(X)` the point of view ``v``'s curve nearest the projection
    and :math:`n_v` the curve's normal there (point-to-line Gauss-Newton).
    Sliding along the 3D curve changes no residual; a small damping keeps the
    points where triangulation put them in that direction (the curve is
    resampled by arc length afterwards).
    """
    X = np.array(points_mm, dtype=float)
    if X.ndim != 2 or X.shape[1] != 3:
        raise ValueError(f"points_mm must have shape (k, 3), got {X.shape}")
    ok = np.all(np.isfinite(X), axis=1)
    for v, c in enumerate(curves_xy):
        if c is not None and not np.all(np.isfinite(np.asarray(c, float))):
            raise ValueError(f"curves_xy[{v}] must be finite (no NaN or inf)")
    views = [(cam, cam.undistort_points(np.asarray(c, float))) for c, cam in zip(curves_xy, cameras)
             if c is not None and len(c) >= 2]
    if len(views) < 2 or not ok.any():
        return X
    Xo = X[ok]
    t = [nearest_on_polyline(cam.project(Xo, distort=False), Q).t for cam, Q in views]
    for _ in range(iterations):
        H = np.zeros((len(Xo), 3, 3))
        g = np.zeros((len(Xo), 3))
        for n_v, (cam, Q) in enumerate(views):
            u, J = cam.project_jacobian(Xo)
            tt, near, _, nrm = nearest_on_polyline(u, Q, start=t[n_v], window=8)
            t[n_v] = tt
            dist = np.hypot(*(u - near).T)
            r = np.einsum("ka,ka->k", nrm, u - near)
            Jn = np.einsum("ka,kai->ki", nrm, J)
            w = np.where(dist <= huber_px, 1.0, huber_px / np.maximum(dist, 1e-12))
            w = np.where(dist <= max_px, w, 0.0)
            H += w[:, None, None] * np.einsum("ki,kj->kij", Jn, Jn)
            g += (w * r)[:, None] * Jn
        H += (0.05 * np.trace(H, axis1=1, axis2=2) / 3 + 1e-12)[:, None, None] * np.eye(3)
        step = _newton_steps(H, g)
        Xo = Xo + step
        if np.max(np.abs(step)) < 1e-6:
            break
    X[ok] = Xo
    return X


def reprojection_table(points_mm: np.ndarray, skeletons_xy: list[np.ndarray | None], cameras: list[Camera], *,
                       measured: np.ndarray | None = None) -> pd.DataFrame:
    """The paper's Table 1: distance of the projected reconstruction to each view's skeleton.

    Parameters
    ----------
    points_mm : (k, 3) float array
        Reconstructed centreline, base to tip, mm (finite).
    skeletons_xy : list of (n_v, 2) float arrays or None
        The extracted, ordered 2D skeleton of each view, observed pixels
        (None: the view is skipped).
    cameras : list of Camera
    measured : (k,) bool array, optional
        Points to include (default all): e.g. not the part of the curve that
        no view sees (an extension to the base marks). The sections are
        still quarters of the whole curve's length.

    Returns
    -------
    pandas.DataFrame
        Columns ``view`` (1-based), ``section`` (``base`` | ``tip`` |
        ``entire``), ``mean_px``, ``std_px``, ``max_px``, ``n_points``; the
        base and tip sections are the first and last quarters of the 3D arc
        length. Sorted by view, then base, tip, entire.
    """
    X = np.asarray(points_mm, dtype=float)
    if X.ndim != 2 or X.shape[1] != 3:
        raise ValueError(f"points_mm must have shape (k, 3), got {X.shape}")
    if len(skeletons_xy) != len(cameras):
        raise ValueError(f"skeletons_xy must have one entry per camera ({len(cameras)}), got {len(skeletons_xy)}")
    sec = section_masks(arc_length(X))
    keep = np.ones(len(X), dtype=bool) if measured is None else np.asarray(measured, dtype=bool)
    if keep.shape != (len(X),):
        raise ValueError(f"measured must have shape ({len(X)},), got {keep.shape}")
    rows = []
    for v, (sk, cam) in enumerate(zip(skeletons_xy, cameras)):
        if sk is None:
            continue
        d = _distance_to_curve_px(cam.project(X), np.asarray(sk, float))
        for name in ("base", "tip", "entire"):
            dd = d[sec[name] & keep & np.isfinite(d)]
            rows.append({
                "view": v + 1,
                "section": name,
                "mean_px": float(dd.mean()) if dd.size else np.nan,
                "std_px": float(dd.std()) if dd.size else np.nan,
                "max_px": float(dd.max()) if dd.size else np.nan,
                "n_points": int(dd.size),
            })
    return pd.DataFrame(rows, columns=["view", "section", "mean_px", "std_px", "max_px", "n_points"])


#: Segments searched on each side of the nearest vertex by :func:`_distance_to_curve_px` (points needing more:
#: every segment).
_NEAR_SEGMENTS = 16


def _distance_to_curve_px(xy: np.ndarray, curve_xy: np.ndarray) -> np.ndarray:
    """Distance (n,) of every point (n, 2) to a polyline (m, 2), px: :func:`~tendrilkit.geometry.point_to_polyline_distance`'s
    figures (the same numbers), searching only the segments that can hold the nearest point.

    The nearest vertex, at distance ``U``, bounds the distance from above;
    the nearest point lies on a segment, within half its length ``L / 2``
    of one of its ends, so that end is within ``U + L_max / 2`` of the
    point. The segments next to the vertices within that reach are searched
    (:func:`~tendrilkit.geometry.nearest_on_polyline` with a window about the
    nearest vertex) when they lie within :data:`_NEAR_SEGMENTS` of it, and
    every segment otherwise (another pass of the curve nearby, at a
    crossing). The minimum over segments that include the nearest one is the
    same number: exact, and 10-40 times faster for a dense 2D skeleton.
    NaN points give NaN.
    """
    from scipy.spatial import cKDTree

    P = np.ascontiguousarray(xy, dtype=float)
    Q = np.ascontiguousarray(curve_xy, dtype=float)
    if len(Q) < 4 * _NEAR_SEGMENTS or not np.all(np.isfinite(Q)):
        return point_to_polyline_distance(P, Q)
    out = np.full(len(P), np.nan)
    idx = np.flatnonzero(np.all(np.isfinite(P), axis=1))
    if len(idx) == 0:
        return out
    tree = cKDTree(Q)
    U, j0 = tree.query(P[idx])
    reach = U + 0.5 * float(np.max(np.hypot(*np.diff(Q, axis=0).T))) + 1e-6
    balls = tree.query_ball_point(P[idx], reach)
    sizes = np.fromiter((len(b) for b in balls), int, len(balls))
    flat = np.fromiter((c for b in balls for c in b), int, int(sizes.sum()))
    span = np.maximum.reduceat(np.abs(flat - np.repeat(j0, sizes)), np.cumsum(sizes) - sizes) + 1
    near = span <= _NEAR_SEGMENTS
    if near.any():
        out[idx[near]] = nearest_on_polyline(P[idx[near]], Q, start=j0[near].astype(float),
                                             window=_NEAR_SEGMENTS).distance
    if not near.all():
        out[idx[~near]] = point_to_polyline_distance(P[idx[~near]], Q)
    return out

