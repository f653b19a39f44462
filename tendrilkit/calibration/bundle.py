"""Bundle adjustment of the rig: camera poses and marker squares refined on every corner observation."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import cv2
import numpy as np
import pandas as pd
from scipy.optimize import least_squares
from scipy.sparse import lil_matrix

from tendrilkit.calibration import markers as _markers
from tendrilkit.camera import Camera
from tendrilkit.geometry import marker_corners

__all__ = ["BundleReport", "bundle_adjust"]


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
    U = marker_corners(1.0)
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
    sigma_px : float
        The corner noise (px, per coordinate, of a corner of average weight)
        the adjusted residuals show (their sum of squares over the degrees of
        freedom), at least the detector's measured noise
        (:func:`~tendrilkit.calibration.markers.corner_sigma_px`).
    camera_cov : (n_views, 6, 6) float array
        Covariance of each adjusted camera's pose (Rodrigues vector, translation
        mm), ``sigma_px^2 (J^T J)^-1`` (infinite when the markers cannot pin the rig).
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
    sigma_px: float = float("nan")
    camera_cov: np.ndarray | None = None


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
    W = marker_corners(length_mm)
    U = marker_corners(1.0)
    views, slots, ks, xy, wts = [], [], [], [], []
    for v in sorted(obs):
        for m, c in sorted(obs[v].items()):
            if m != world_id and m not in slot:
                continue
            w = _markers.corner_weight(c)  # proportional to 1 / corner_sigma_px(c)
            for k in range(4):
                views.append(v)
                slots.append(-1 if m == world_id else slot[m])
                ks.append(k)
                xy.append(c[k])
                wts.append(w)
    views_a, slot_a, k_a, xy_a = np.array(views), np.array(slots), np.array(ks), np.array(xy)
    # scaled to a root mean square of 1: a weighted residual is in px of a corner of average weight, whose
    # expected noise (corner_sigma_px = 10 CORNER_SIGMA_PX / weight) is then sigma_ref
    rms_w = np.sqrt(np.mean(np.square(wts)))
    wts_a = np.array(wts)[:, None] / rms_w
    sigma_ref = 10.0 * _markers.CORNER_SIGMA_PX / float(rms_w)
    n_cam = 6 * n_views
    off_plane = n_cam + 7 * nf

    def corners_of(x: np.ndarray) -> np.ndarray:
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
        Xm = corners_of(x)
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
        return (res * wts_a).ravel()

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
    X0, X1 = corners_of(x0), corners_of(sol.x)
    ids = free + plane
    mw0 = {world_id: W.copy()} | {m: X0[slot[m]] for m in ids}
    mw = {world_id: W.copy()} | {m: X1[slot[m]] for m in ids}
    lengths = {world_id: float(length_mm)} | {m: float(np.linalg.norm(X1[slot[m]][1] - X1[slot[m]][0])) for m in ids}
    rms = lambda r: float(np.sqrt(((r.reshape(-1, 2) / wts_a) ** 2).sum(1).mean()))  # noqa: E731  (unweighted)
    sigma, cov = _camera_covariance(sol, n_cam, floor_px=sigma_ref)
    return {"cameras": cams, "markers_world": mw, "markers_world0": mw0, "lengths": lengths, "plane": plane,
            "rms0": rms(r0), "rms1": rms(sol.fun), "nfev": int(sol.nfev), "sigma_px": sigma, "camera_cov": cov}


def _camera_covariance(sol, n_cam: int, floor_px: float = 0.0) -> tuple[float, np.ndarray]:
    """The corner noise (px, per coordinate, of a corner of average weight) and the covariance
    (n_views, 6, 6) of each camera's pose (Rodrigues vector, translation mm) it implies.

    ``sigma^2 = sum r^2 / (m - p)`` over the ``m`` weighted residuals and ``p``
    unknowns, at least ``floor_px`` (the detector's measured noise,
    :func:`~tendrilkit.calibration.markers.corner_sigma_px`: with few markers
    the residuals have few degrees of freedom, and a free square absorbs part
    of its corners' error, so they can show a noise several times below the
    real one). The world marker's fixed corners set the gauge, so ``J^T J`` is
    regular unless the markers cannot pin the rig (then the covariance is
    infinite); the covariance is ``sigma^2 (J^T J)^-1``, first order.
    """
    J = sol.jac.toarray() if hasattr(sol.jac, "toarray") else np.asarray(sol.jac)
    m, p = J.shape
    sigma = max(float(floor_px), float(np.sqrt(np.sum(sol.fun ** 2) / max(1, m - p))))
    n_views = n_cam // 6
    JtJ = J.T @ J
    try:
        if np.linalg.cond(JtJ) > 1e14:
            raise np.linalg.LinAlgError
        C = np.linalg.inv(JtJ)[:n_cam, :n_cam] * sigma ** 2
    except np.linalg.LinAlgError:
        return sigma, np.full((n_views, 6, 6), np.inf)
    return sigma, np.stack([C[6 * v:6 * v + 6, 6 * v:6 * v + 6] for v in range(n_views)])


def bundle_adjust(cameras: list[Camera], observations: dict[int, dict[int, np.ndarray]], *,
                  world_id: int, length_mm: float, on_plane: str | bool | list[int] = "auto",
                  plane_tol_deg: float = 1.5, plane_tol_mm: float = 1.0, min_views: int = 2, loss: str = "soft_l1",
                  f_scale_px: float = 1.0, outlier_px: float = 3.0) -> tuple[list[Camera], BundleReport]:
    """Refine the camera poses jointly with every marker two or more views see.

    Unknowns: each camera's pose (Rodrigues vector, translation) and, for every
    other marker seen in at least ``min_views`` views, a square's pose and side
    length. The world marker's corners stay at ``marker_corners(length_mm)``:
    they fix the world frame and, through ``length_mm``, the scale. The residuals
    are the corner reprojection errors through each camera's lens distortion
    (:meth:`Camera.project`); ``scipy.optimize.least_squares`` minimises them
    with a robust ``loss`` (scale ``f_scale_px``) and the sparse Jacobian
    structure (a corner depends on one camera and one marker). Each corner's
    residual is weighted by one over its marker's expected corner error in
    that view (:func:`~tendrilkit.calibration.markers.corner_sigma_px`, from
    the marker's side and foreshortening in the image: a small marker's or a
    glancing card's corners are noisier), the weights scaled to a root mean
    square of 1. The pose covariance (:attr:`BundleReport.camera_cov`) uses
    the same weights and the larger of the residuals' noise and that
    model's. A marker whose
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
                              nfev=int(nfev), converged=bool(converged), sigma_px=result["sigma_px"],
                              camera_cov=result["camera_cov"] if converged else None)

