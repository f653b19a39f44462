"""Point correspondence between the ordered centrelines of the views
(paper: "Mapping Points Between Views"; stage 5 of ``../shared/REFERENCE_NOTES.md``).

Two methods, both returning, for ``k`` points of the reference view's curve,
the matched point in every view as a ``(n_views, k, 2)`` array of *observed*
(distorted) pixels, NaN where a view has no match:

``frechet`` (the paper, :func:`match_frechet`)
    Every other view's curve is mapped into the reference view by the
    homography of the world marker's plane (four corners), all curves are
    resampled to ``k`` points at uniform arc length, and the discrete Fréchet
    coupling (:func:`discrete_frechet`) pairs the reference with each mapped
    curve; each reference point takes the coupled point of least distance.
    The matched point is then taken back *by index* to the view's own
    resampled curve (its own pixels), which is what the method intends (the
    reference implementation passes the homography-mapped, reference-view
    coordinates of views 1 and 3 to triangulation instead). The homography is
    exact only for points on the marker's plane, so the coupling is an
    arc-length-like pairing that ignores parallax: adequate for a flat, short
    tendril, not for a curled one.

``epipolar`` (tendrilkit's default, :func:`match_epipolar`)
    The rig is calibrated, so the match of a reference point lies on its
    epipolar line in every other view.

    1. *Monotone programme, per view pair.* The reference curve is resampled
       to ``k`` points, each other view's curve to ``m = oversample * k``
       points (uniform arc length, undistorted pixels). With the symmetric
       epipolar distance :math:`c_{ij}` between reference point ``i`` and
       point ``j`` of the other view (truncated at ``max_distance_px``), the
       programme finds non-decreasing positions :math:`j_1 \\le j_2 \\le
       \\dots` minimising

       .. math::

          \\sum_i c_{i j_i} + \\beta \\sum_i (j_{i+1} - j_i - r)^2,
          \\qquad r = m / k,

       with steps :math:`0 \\le j_{i+1} - j_i \\le` ``max_step``. The
       quadratic step term makes the position advance uniformly where the
       epipolar cost is flat (an epipolar line running along the curve).
       Reference points at either end may stay unmatched (cost
       ``max_distance_px`` each) and the other curve may start and end anywhere:
       the views see the base and the tip a little differently, and the match
       keeps their common part.
    2. *Depth along the reference ray, all views together.* Each reference
       point's 3D point is :math:`X(d)` at depth ``d`` on its viewing ray.
       Starting from the pairwise matches, Gauss-Newton on ``d`` minimises the
       distance of the projection of :math:`X(d)` to every other view's curve
       (point-to-segment, near the current match, Huber-weighted): the
       sub-pixel intersection of the epipolar line with the local curve
       segment, in every view at once. A view whose curve runs along its
       epipolar line contributes little (its residual barely changes with
       ``d``); another view resolves the depth.
    3. *Tangency.* Where every view is nearly tangent, ``d`` is unobservable.
       The depths are smoothed by a second-order Whittaker smoother weighted
       by each point's information :math:`\\sum_v w_v J_v^2` (``J_v``: pixels
       of residual per mm of depth): well-observed points keep their depth,
       the others are interpolated from their neighbours along the curve.
    4. The matched point in each view is the point of its curve nearest the
       projection of :math:`X(d)`; a view farther than ``max_distance_px`` from
       it, unmatched by the programme, or whose curve ends before the
       projection (that view does not see this part: the keep-out box hides a
       different length of base in every view) gets NaN, in steps 2-3 too.
       Reference points no other view matches are NaN as well: the curve is
       truncated to the part at least two views see.

Both return observed pixels; :func:`tendrilkit.triangulation.triangulate`
undistorts them.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from tendrilkit.camera import Camera
from tendrilkit.exceptions import CorrespondenceError
from tendrilkit.geometry import (
    arc_length,
    check_points,
    marker_corners,
    nearest_on_polyline,
    point_at_index,
    resample_polyline,
    whittaker_smooth,
)

__all__ = [
    "discrete_frechet",
    "marker_homography",
    "match_frechet",
    "fundamental_matrix",
    "epipolar_distance",
    "match_epipolar",
]


# ------------------------------------------------------------ discrete Fréchet
@njit(cache=True)
def _frechet_table(P, Q):  # pragma: no cover - compiled
    p, q = P.shape[0], Q.shape[0]
    ca = np.empty((p, q))
    for i in range(p):
        for j in range(q):
            d = 0.0
            for c in range(P.shape[1]):
                e = P[i, c] - Q[j, c]
                d += e * e
            d = np.sqrt(d)
            if i == 0 and j == 0:
                ca[i, j] = d
            elif i == 0:
                ca[i, j] = max(ca[i, j - 1], d)
            elif j == 0:
                ca[i, j] = max(ca[i - 1, j], d)
            else:
                m = min(ca[i - 1, j - 1], ca[i - 1, j], ca[i, j - 1])
                ca[i, j] = max(m, d)
    return ca


@njit(cache=True)
def _frechet_backtrack(ca):  # pragma: no cover - compiled
    i, j = ca.shape[0] - 1, ca.shape[1] - 1
    path = np.empty((ca.shape[0] + ca.shape[1], 2), dtype=np.int64)
    n = 0
    path[n, 0], path[n, 1] = i, j
    n += 1
    while i > 0 or j > 0:
        if i == 0:
            j -= 1
        elif j == 0:
            i -= 1
        else:
            a, b, c = ca[i - 1, j - 1], ca[i - 1, j], ca[i, j - 1]
            if a <= b and a <= c:
                i -= 1
                j -= 1
            elif b <= c:
                i -= 1
            else:
                j -= 1
        path[n, 0], path[n, 1] = i, j
        n += 1
    return path[:n][::-1].copy()


def discrete_frechet(P: np.ndarray, Q: np.ndarray) -> tuple[float, np.ndarray]:
    """Discrete Fréchet distance of two ordered point sequences, and a coupling.

    Parameters
    ----------
    P : (p, d) float array
    Q : (q, d) float array
        Ordered points (p, q >= 1), same dimension ``d``.

    Returns
    -------
    distance : float
        :math:`\\delta_F(P, Q)`.
    coupling : (m, 2) int array
        Index pairs ``(a_i, b_i)`` from ``(0, 0)`` to ``(p-1, q-1)``, each step
        advancing ``a``, ``b`` or both by one; the largest pair distance along
        it equals ``distance``.

    Notes
    -----
    The table of Eiter & Mannila (1994),

    .. math::

        c_{ij} = \\max\\left(\\lVert P_i - Q_j \\rVert,\\;
        \\min(c_{i-1,j}, c_{i-1,j-1}, c_{i,j-1})\\right),

    is filled iteratively (compiled, :math:`O(pq)`, no recursion); the
    coupling is recovered by walking back through the smallest predecessor
    (diagonal first on ties), whose values never exceed :math:`c_{p-1,q-1}`.

    Examples
    --------
    >>> d, c = discrete_frechet(np.array([[0.0, 0], [1, 0], [2, 0]]), np.array([[0.0, 1], [2, 1]]))
    >>> round(d, 6), c.tolist()
    (1.414214, [[0, 0], [1, 0], [2, 1]])
    """
    P = np.ascontiguousarray(P, dtype=float)
    Q = np.ascontiguousarray(Q, dtype=float)
    if P.ndim != 2 or Q.ndim != 2 or P.shape[1] != Q.shape[1] or len(P) == 0 or len(Q) == 0:
        raise ValueError(f"P and Q must have shapes (p, d) and (q, d) with p, q >= 1, got {P.shape} and {Q.shape}")
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(Q))):
        raise ValueError("P and Q must be finite (no NaN or inf): a NaN distance would be ignored by the table")
    ca = _frechet_table(P, Q)
    return float(ca[-1, -1]), _frechet_backtrack(ca)


# ------------------------------------------------------------ paper's method
def marker_homography(camera_from: Camera, camera_to: Camera, *, corners_world: np.ndarray | None = None,
                      length_mm: float = 24.0) -> np.ndarray:
    """Homography (3, 3) of the world marker's plane, undistorted pixels of one view to another.

    The marker's four corners (world, z = 0; default: a marker of
    ``length_mm`` centred at the origin) are projected by both cameras and
    the homography is fitted to the four pairs, as the paper does with the
    detected corners.
    """
    import cv2

    if corners_world is None:
        corners_world = marker_corners(length_mm)
    a = camera_from.project(corners_world, distort=False).astype(np.float64)
    b = camera_to.project(corners_world, distort=False).astype(np.float64)
    H, _ = cv2.findHomography(a, b, 0)
    if H is None:
        raise CorrespondenceError("marker corners give no homography between the views")
    return H


def _apply_h(H: np.ndarray, xy: np.ndarray) -> np.ndarray:
    p = np.hstack([xy, np.ones((len(xy), 1))]) @ H.T
    return p[:, :2] / p[:, 2:3]


def match_frechet(
    centerlines_xy: list[np.ndarray],
    cameras: list[Camera],
    *,
    reference: int,
    k: int = 200,
    marker_corners_xy: list[np.ndarray] | None = None,
    marker_length_mm: float = 24.0,
) -> np.ndarray:
    """The paper's correspondence: marker homography, resampling, Fréchet coupling.

    Parameters
    ----------
    centerlines_xy : list of (n_v, 2) float arrays
        Ordered centrelines, base to tip, observed pixels, one per view.
    cameras : list of Camera
        One per view (for undistortion and, without ``marker_corners_xy``,
        the marker's projected corners).
    reference : int
        0-based index of the reference view.
    k : int
        Points per curve (paper: 200).
    marker_corners_xy : list of (4, 2) float arrays, optional
        The marker's detected corners (observed pixels) per view; the
        homographies are fitted to them (undistorted). Default: the corners
        projected by the cameras.
    marker_length_mm : float
        Side of the world marker when the corners are projected.

    Returns
    -------
    (n_views, k, 2) float array
        Observed pixels; row ``reference`` is its resampled curve, the other
        rows each view's own resampled points coupled to it.
    """
    curves, cams, ref = _check_inputs(centerlines_xy, cameras, reference, k)
    V = len(curves)
    und = [cams[v].undistort_points(curves[v]) for v in range(V)]
    out = np.full((V, k, 2), np.nan)
    ref_obs = resample_polyline(curves[ref], k)
    ref_und = cams[ref].undistort_points(ref_obs)
    out[ref] = ref_obs
    for v in range(V):
        if v == ref:
            continue
        if marker_corners_xy is not None:
            import cv2

            a = cams[v].undistort_points(np.asarray(marker_corners_xy[v], float))
            b = cams[ref].undistort_points(np.asarray(marker_corners_xy[ref], float))
            H, _ = cv2.findHomography(a, b, 0)
            if H is None:
                raise CorrespondenceError(f"view {v + 1}: marker corners give no homography to the reference view")
        else:
            H = marker_homography(cams[v], cams[ref], length_mm=marker_length_mm)
        # resample in the view's own undistorted pixels, map the same points
        own_und = resample_polyline(und[v], k)
        mapped = _apply_h(H, own_und)
        _, coupling = discrete_frechet(ref_und, mapped)
        d = np.linalg.norm(ref_und[coupling[:, 0]] - mapped[coupling[:, 1]], axis=1)
        best = np.full(k, -1)
        best_d = np.full(k, np.inf)
        for (a_i, b_i), dd in zip(coupling, d):
            if dd < best_d[a_i]:
                best_d[a_i], best[a_i] = dd, b_i
        out[v] = cams[v].distort_points(own_und[best])
    return out


# ------------------------------------------------------------ epipolar method
def _skew(t: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -t[2], t[1]], [t[2], 0.0, -t[0]], [-t[1], t[0], 0.0]])


def fundamental_matrix(camera_from: Camera, camera_to: Camera) -> np.ndarray:
    """Fundamental matrix F (3, 3), undistorted pixels: ``x_to^T F x_from = 0``, ``|F| = 1``."""
    R = camera_to.R @ camera_from.R.T
    t = camera_to.t_mm - R @ camera_from.t_mm
    if not np.linalg.norm(t) > 1e-9 * max(1.0, float(np.linalg.norm(camera_to.t_mm))):
        raise ValueError("camera_from and camera_to share a centre: no epipolar geometry (zero baseline)")
    E = _skew(t) @ R
    F = np.linalg.inv(camera_to.K).T @ E @ np.linalg.inv(camera_from.K)
    return F / np.linalg.norm(F)


def epipolar_distance(F: np.ndarray, x_from: np.ndarray, x_to: np.ndarray) -> np.ndarray:
    """Symmetric epipolar distance (px) of every pair: (n_from, n_to) array.

    The mean of the distance of ``x_to[j]`` to the epipolar line of
    ``x_from[i]`` and of ``x_from[i]`` to the line of ``x_to[j]``
    (undistorted pixels).
    """
    a = np.hstack([x_from, np.ones((len(x_from), 1))])
    b = np.hstack([x_to, np.ones((len(x_to), 1))])
    l_to = a @ F.T  # lines in the 'to' image, (n_from, 3)
    l_from = b @ F  # lines in the 'from' image, (n_to, 3)
    alg = np.abs(l_to @ b.T)
    n1 = np.hypot(l_to[:, 0], l_to[:, 1])[:, None]
    n2 = np.hypot(l_from[:, 0], l_from[:, 1])[None, :]
    return 0.5 * alg * (1.0 / np.maximum(n1, 1e-300) + 1.0 / np.maximum(n2, 1e-300))


@njit(cache=True)
def _monotone_dp(C, skip_cost, beta, r, max_step):  # pragma: no cover - compiled
    """Monotone alignment; returns the position (or -1) of every row."""
    k, m = C.shape
    D = np.empty((k, m))
    back = np.zeros((k, m), dtype=np.int32)  # step taken; -1: started here
    pre = np.empty(k)  # all rows so far unmatched
    post = np.empty(k)  # matching already ended
    post_from = np.full(k, -2, dtype=np.int64)  # -1: post[i-1]; j: ended after (i-1, j)
    pen = np.empty(max_step + 1)
    for s in range(max_step + 1):
        pen[s] = beta * (s - r) * (s - r)
    for j in range(m):
        D[0, j] = C[0, j]
        back[0, j] = -1
    pre[0] = skip_cost
    post[0] = np.inf
    for i in range(1, k):
        pre[i] = pre[i - 1] + skip_cost
        best_end, arg_end = np.inf, -1
        for j in range(m):
            if D[i - 1, j] < best_end:
                best_end, arg_end = D[i - 1, j], j
        if post[i - 1] <= best_end:
            post[i] = post[i - 1] + skip_cost
            post_from[i] = -1
        else:
            post[i] = best_end + skip_cost
            post_from[i] = arg_end
        for j in range(m):
            best = pre[i - 1]
            arg = -1
            lo = j - max_step if j - max_step > 0 else 0
            for jp in range(lo, j + 1):
                v = D[i - 1, jp] + pen[j - jp]
                if v < best:
                    best = v
                    arg = j - jp
            D[i, j] = C[i, j] + best
            back[i, j] = arg
    # end state
    pos = np.full(k, -1, dtype=np.int64)
    best, arg = pre[k - 1], -3  # -3: nothing matched
    if post[k - 1] < best:
        best, arg = post[k - 1], -1
    for j in range(m):
        if D[k - 1, j] < best:
            best, arg = D[k - 1, j], j
    i = k - 1
    if arg == -3:
        return pos
    if arg == -1:  # walk back through the post states
        while i > 0 and post_from[i] == -1:
            i -= 1
        j = post_from[i]
        i -= 1
    else:
        j = arg
    while i >= 0:
        pos[i] = j
        s = back[i, j]
        if s < 0:
            break
        j -= s
        i -= 1
    return pos


def _beyond_ends(t: np.ndarray, dist: np.ndarray, m: int, tol_px: float = 1.0) -> np.ndarray:
    """Projections that fall past either end of a view's curve (its nearest point is an end, > tol_px away).

    That view did not see this part of the tendril (the keep-out box hides a
    different length of base in every view, the tip may be hidden): it says
    nothing about the point, rather than pulling it onto its curve's
    extension.
    """
    return ((t <= 0.0) | (t >= m - 1.0)) & (dist > tol_px)


def _check_inputs(centerlines_xy, cameras, reference, k):
    curves = [check_points(c, dim=2, name=f"centerlines_xy[{v}]") for v, c in enumerate(centerlines_xy)]
    cams = list(cameras)
    if len(curves) < 2:
        raise ValueError(f"centerlines_xy must hold at least 2 views, got {len(curves)}")
    if len(cams) != len(curves):
        raise ValueError(f"cameras must have one entry per view ({len(curves)}), got {len(cams)}")
    if not 0 <= int(reference) < len(curves):
        raise ValueError(f"reference must be a 0-based view index in 0..{len(curves) - 1}, got {reference}")
    if int(k) < 5:
        raise ValueError(f"k must be at least 5, got {k}")
    for v, c in enumerate(curves):
        if c.shape[0] < 2 or not arc_length(c)[-1] > 0:
            raise CorrespondenceError(f"view {v + 1}: the centreline has no length")
    return curves, cams, int(reference)


def match_epipolar(
    centerlines_xy: list[np.ndarray],
    cameras: list[Camera],
    *,
    reference: int,
    k: int = 200,
    oversample: int = 2,
    max_distance_px: float = 8.0,
    beta: float = 0.2,
    max_step_factor: float = 5.0,
    window: int = 12,
    iterations: int = 8,
    depth_smoothing: float = 100.0,
) -> np.ndarray:
    """Match the ordered curves by epipolar geometry (see the module notes).

    Parameters
    ----------
    centerlines_xy : list of (n_v, 2) float arrays
        Ordered centrelines, base to tip, observed (distorted) pixels, one per view.
    cameras : list of Camera
        Calibrated cameras, one per view.
    reference : int
        0-based index of the reference view; its curve is resampled to ``k``
        points.
    k : int
        Matched points.
    oversample : int
        The other views are resampled to ``oversample * k`` points.
    max_distance_px : float
        Epipolar distances are truncated here; it is also the cost of leaving
        a reference point unmatched at either end, and the largest distance
        (px) of a projected point to a view's curve for a match.
    beta : float
        Weight of the step regularity term (px per squared step).
    max_step_factor : float
        Largest step along the other curve, in mean steps ``r``.
    window : int
        Segments searched on each side of the current position for the
        nearest curve point.
    iterations : int
        Gauss-Newton iterations on the depths.
    depth_smoothing : float
        Weight of the second-difference penalty on the depths, relative to
        the information of a typical point (the median): larger smooths
        more; where the depth is unobservable it is interpolated whatever
        the weight.

    Returns
    -------
    (n_views, k, 2) float array
        Observed pixels; row ``reference`` holds its resampled curve (NaN at
        points no other view matches), the other rows the matched points,
        NaN where unmatched.

    Raises
    ------
    CorrespondenceError
        No view matches the reference curve.
    """
    curves, cams, ref = _check_inputs(centerlines_xy, cameras, reference, k)
    V = len(curves)
    k = int(k)
    m = max(int(oversample) * k, 4)
    cam0 = cams[ref]
    ref_obs = resample_polyline(curves[ref], k)
    ref_und = cam0.undistort_points(ref_obs)

    # viewing rays of the reference points: X(d) = C0 + d * a, d = depth (mm, camera z)
    rays_cam = np.hstack([ref_und, np.ones((k, 1))]) @ np.linalg.inv(cam0.K).T
    a = rays_cam @ cam0.R  # world directions (R^T r)
    C0 = cam0.center_world

    others = [v for v in range(V) if v != ref]
    dense_obs = {}
    dense_und = {}
    pos = {}
    r = m / k
    max_step = int(np.ceil(max_step_factor * r))
    for v in others:
        obs = resample_polyline(curves[v], m)
        und = cams[v].undistort_points(obs)
        dense_obs[v], dense_und[v] = obs, und
        F = fundamental_matrix(cam0, cams[v])
        C = np.minimum(epipolar_distance(F, ref_und, und), max_distance_px)
        p = _monotone_dp(np.ascontiguousarray(C), float(max_distance_px), float(beta), float(r), max_step).astype(float)
        p[p < 0] = np.nan
        pos[v] = p

    # initial depth: closest approach of the reference ray and each matched ray
    num = np.zeros(k)
    den = np.zeros(k)
    for v in others:
        ok = np.isfinite(pos[v])
        if not ok.any():
            continue
        q = point_at_index(dense_und[v], pos[v])
        bc = np.hstack([q, np.ones((k, 1))]) @ np.linalg.inv(cams[v].K).T @ cams[v].R  # world dirs
        C1 = cams[v].center_world
        w0 = C0 - C1
        aa = np.einsum("ij,ij->i", a, a)
        bb = np.einsum("ij,ij->i", bc, bc)
        ab = np.einsum("ij,ij->i", a, bc)
        aw = a @ w0
        bw = bc @ w0
        det = aa * bb - ab * ab
        with np.errstate(invalid="ignore", divide="ignore"):
            d_v = (ab * bw - bb * aw) / det
        # weight: sine of the angle between curve and epipolar line (sensitivity)
        _, dp = cams[v].project_jacobian(C0 + d_v[:, None] * a, along=a)
        tq = np.gradient(dense_und[v], axis=0)
        tv = point_at_index(tq, pos[v])
        tv /= np.maximum(np.linalg.norm(tv, axis=1, keepdims=True), 1e-12)
        sens = np.abs(tv[:, 0] * dp[:, 1] - tv[:, 1] * dp[:, 0])
        good = ok & np.isfinite(d_v) & (d_v > 0) & np.isfinite(sens)
        w = np.where(good, sens ** 2 + 1e-6, 0.0)
        num += np.where(good, w * np.nan_to_num(d_v), 0.0)
        den += w
    if not np.any(den > 0):
        raise CorrespondenceError("no view matches the reference curve along its epipolar lines")
    matched = den > 0
    idx = np.flatnonzero(matched)
    d = np.interp(np.arange(k), idx, num[idx] / den[idx])

    # Gauss-Newton on the depths, all views
    t_cur = {v: np.where(np.isfinite(pos[v]), pos[v], np.nan) for v in others}
    for v in others:  # positions outside the programme's match: fill from neighbours for the search
        p = t_cur[v]
        ok = np.isfinite(p)
        t_cur[v] = np.interp(np.arange(k), np.flatnonzero(ok), p[ok]) if ok.any() else p
    delta = 2.0  # Huber threshold, px
    info = np.zeros(k)
    resid = {}
    for it in range(iterations + 1):
        X = C0 + d[:, None] * a
        g = np.zeros(k)
        H = np.zeros(k)
        sens2 = np.zeros(k)
        for v in others:
            if not np.all(np.isfinite(t_cur[v])):
                continue
            p, dp = cams[v].project_jacobian(X, along=a)
            t, near, _, nrm = nearest_on_polyline(p, dense_und[v], start=t_cur[v], window=window)
            t_cur[v] = t
            e = p - near
            rr = np.einsum("ij,ij->i", nrm, p - near)
            J = np.einsum("ij,ij->i", nrm, dp)
            dist = np.hypot(e[:, 0], e[:, 1])
            w = np.where(dist <= delta, 1.0, delta / np.maximum(dist, 1e-12))
            use = np.isfinite(pos[v]) & (dist <= 3 * max_distance_px) & ~_beyond_ends(t, dist, len(dense_und[v]))
            w = np.where(use, w, 0.0)
            g += w * J * rr
            H += w * J * J
            sens2 += np.where(use, np.einsum("ij,ij->i", dp, dp), 0.0)
            resid[v] = dist
        if it == iterations:
            info = H
            break
        mu = 1e-3 * np.maximum(sens2, 1e-9)
        step = -g / (H + mu)
        # keep the step within a few pixels' worth of depth
        lim = 4.0 / np.sqrt(np.maximum(sens2 / max(len(others), 1), 1e-12))
        d = d + np.clip(step, -lim, lim)

    # tangency: smooth the depths with information weights (interpolates unobservable ones)
    ok = matched & np.isfinite(d)
    if ok.sum() >= 3:
        w = np.where(ok, info, 0.0)
        scale = np.median(w[ok]) if np.any(w[ok] > 0) else 1.0  # typical point: weight 1
        d_s = whittaker_smooth(np.where(ok, d, 0.0), lam=depth_smoothing, weights=w / max(scale, 1e-12) + 1e-9 * ok)
        d = np.where(ok, d_s, d)

    # final matches: nearest curve points to the projections
    out = np.full((V, k, 2), np.nan)
    X = C0 + d[:, None] * a
    any_match = np.zeros(k, dtype=bool)
    for v in others:
        if not np.all(np.isfinite(t_cur[v])):
            continue
        p = cams[v].project(X, distort=False)
        t, near, _, _ = nearest_on_polyline(p, dense_und[v], start=t_cur[v], window=window)
        dist = np.hypot(*(p - near).T)
        good = np.isfinite(pos[v]) & (dist <= max_distance_px) & matched & ~_beyond_ends(t, dist, len(dense_und[v]))
        t = np.where(good, t, np.nan)
        out[v] = point_at_index(dense_obs[v], t)
        any_match |= good
    if not any_match.any():
        raise CorrespondenceError("no reference point has a match in another view")
    out[ref] = np.where(any_match[:, None], ref_obs, np.nan)
    return out
