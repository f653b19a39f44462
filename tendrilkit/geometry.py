"""Curve geometry shared by every stage: arc length, resampling, nearest points, rigid fits, quarters.

One home for the numerics that several stages need on polylines (ordered
points, ``(n, d)`` arrays, base first), whatever their frame and unit
(``_xy`` pixels or ``_mm`` world millimetres; the functions keep the unit of
their input):

- :func:`arc_length`: cumulative arc length of a polyline;
- :func:`resample_polyline`: uniform resampling in arc length, by count
  and/or by step, linear or PCHIP;
- :func:`point_at_index`, :func:`point_at_arc_length`: points of a polyline
  at fractional vertex indices or at given (or normalised) arc lengths;
- :func:`whittaker_smooth`: the second-order Whittaker smoother of samples
  along a curve (coordinates, depths), optionally weighted;
- :func:`nearest_on_polyline`, :func:`point_to_polyline_distance`: the
  nearest point of a polyline (exact point-to-segment search, compiled,
  optionally in a window of segments around a starting index);
- :func:`rigid_fit`: the least-squares rotation and translation between two
  point sets (Kabsch);
- :func:`section_masks`: the paper's base and tip quarters of the arc length
  (Tables 1-3);
- :func:`marker_corners`: the corners of a square marker in its plane.

Projections with their Jacobians are :class:`tendrilkit.camera.Camera`
methods. Errors are generic: ``ValueError`` for malformed input,
:class:`~tendrilkit.exceptions.DegenerateCurveError` (a frame error) for a
curve with no length.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from tendrilkit.exceptions import DegenerateCurveError

__all__ = [
    "check_points",
    "arc_length",
    "resample_polyline",
    "point_at_index",
    "point_at_arc_length",
    "NearestOnPolyline",
    "nearest_on_polyline",
    "point_to_polyline_distance",
    "rigid_fit",
    "section_masks",
    "marker_corners",
    "pchip_interpolate",
    "whittaker_smooth",
]


def check_points(points: np.ndarray, *, dim: int | None = None, name: str = "points", min_rows: int = 0,
                 finite: bool = True) -> np.ndarray:
    """``points`` as a float array (n, d), checked at a public boundary.

    Parameters
    ----------
    points : array_like
        The points.
    dim : int, optional, keyword-only
        Required number of columns ``d`` (default: any).
    name : str, keyword-only
        The argument's name, for the message.
    min_rows : int, keyword-only
        Fewest rows ``n``.
    finite : bool, keyword-only
        Refuse NaN and inf.

    Returns
    -------
    (n, d) float array

    Raises
    ------
    ValueError
        Naming the argument, what was expected and what came.

    Examples
    --------
    >>> check_points([[0, 1, 2]], dim=3).dtype
    dtype('float64')
    >>> check_points(np.zeros((4, 2)), dim=3, name="points_mm")
    Traceback (most recent call last):
    ...
    ValueError: points_mm must have shape (n, 3), got (4, 2)
    """
    arr = np.asarray(points, dtype=float)
    if arr.ndim != 2 or (dim is not None and arr.shape[1] != dim) or arr.shape[0] < min_rows:
        rows = "n" if min_rows == 0 else f"n >= {min_rows}"
        raise ValueError(f"{name} must have shape ({rows}, {'d' if dim is None else dim}), got {arr.shape}")
    if finite and not np.all(np.isfinite(arr)):
        raise ValueError(f"{name} must be finite, got {int((~np.isfinite(arr)).any(axis=1).sum())} rows with NaN or inf")
    return arr


def _polyline_pair(points: np.ndarray, polyline: np.ndarray, min_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    P = np.ascontiguousarray(points, dtype=float)
    Q = np.ascontiguousarray(polyline, dtype=float)
    if P.ndim != 2 or Q.ndim != 2 or P.shape[1] != Q.shape[1] or len(Q) < min_vertices:
        raise ValueError(f"points and polyline must have shapes (n, d) and (m >= {min_vertices}, d), "
                         f"got {P.shape} and {Q.shape}")
    if not np.all(np.isfinite(Q)):
        raise ValueError("polyline must be finite (no NaN or inf); NaN is allowed in points only")
    return P, Q


# ----------------------------------------------------------------- arc length
def arc_length(points: np.ndarray) -> np.ndarray:
    """Cumulative arc length of a polyline, from its first point.

    Parameters
    ----------
    points : (n, d) float array
        Ordered points (pixels or mm).

    Returns
    -------
    (n,) float array
        ``s[0] = 0``, ``s[i]`` the length of the polyline up to point ``i``
        (same unit as ``points``); a NaN row makes every later value NaN
        (no check: callers validate their curves).

    Examples
    --------
    >>> arc_length(np.array([[0.0, 0.0], [3.0, 4.0], [3.0, 5.0]]))
    array([0., 5., 6.])
    """
    P = np.asarray(points, dtype=float)
    if P.ndim != 2:
        raise ValueError(f"points must have shape (n, d), got {P.shape}")
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])


# ------------------------------------------------------------------ resampling
def _pchip_slopes(u: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Fritsch-Carlson (PCHIP) derivatives at the nodes, shape preserving, per column."""
    h = np.diff(u)[:, None]
    d = np.diff(y, axis=0) / h
    m = np.zeros_like(y)
    if y.shape[0] == 2:
        m[:] = d[0]
        return m
    w1 = 2 * h[1:] + h[:-1]
    w2 = h[1:] + 2 * h[:-1]
    same = (np.sign(d[1:]) * np.sign(d[:-1])) > 0
    with np.errstate(divide="ignore", invalid="ignore"):
        hm = (w1 + w2) / (w1 / d[:-1] + w2 / d[1:])
    m[1:-1] = np.where(same, hm, 0.0)

    def end(h0, h1, d0, d1):
        e = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1)
        e = np.where(np.sign(e) != np.sign(d0), 0.0, e)
        return np.where((np.sign(d0) != np.sign(d1)) & (np.abs(e) > np.abs(3 * d0)), 3 * d0, e)

    m[0] = end(h[0], h[1], d[0], d[1])
    m[-1] = end(h[-1], h[-2], d[-1], d[-2])
    return m


def pchip_interpolate(u: np.ndarray, y: np.ndarray, ui: np.ndarray) -> np.ndarray:
    """Piecewise cubic Hermite interpolation with PCHIP (Fritsch-Carlson) slopes.

    The same interpolant as ``scipy.interpolate.PchipInterpolator(u, y,
    axis=0)(ui)`` to rounding (a test pins it); kept because the site
    phantoms' results depend on its last bits.

    Parameters
    ----------
    u : (m,) float array
        Strictly increasing nodes, m >= 2.
    y : (m, d) float array
        Values at the nodes.
    ui : (q,) float array
        Where to interpolate (within ``[u[0], u[-1]]``).

    Returns
    -------
    (q, d) float array

    Examples
    --------
    >>> pchip_interpolate(np.array([0.0, 1.0, 2.0]), np.array([[0.0], [1.0], [1.0]]), np.array([0.5, 1.5]))
    array([[0.6875],
           [1.    ]])
    """
    if (u.dtype == np.float64 and y.dtype == np.float64 and ui.dtype == np.float64 and u.ndim == 1 and y.ndim == 2
            and ui.ndim == 1 and u.size >= 2 and y.shape[0] == u.size):
        return _pchip_core(np.ascontiguousarray(u), np.ascontiguousarray(y), np.ascontiguousarray(ui))
    m = _pchip_slopes(u, y)
    j = np.clip(np.searchsorted(u, ui, side="right") - 1, 0, u.size - 2)
    h = (u[j + 1] - u[j])[:, None]
    t = ((ui - u[j])[:, None]) / h
    t2, t3 = t * t, t * t * t
    return ((2 * t3 - 3 * t2 + 1) * y[j] + (t3 - 2 * t2 + t) * h * m[j]
            + (-2 * t3 + 3 * t2) * y[j + 1] + (t3 - t2) * h * m[j + 1])


@njit(cache=True, error_model="numpy")
def _pchip_core(u, y, ui):  # pragma: no cover - compiled
    """:func:`pchip_interpolate` compiled (float64; ``y`` (m, d), m >= 2): :func:`_pchip_slopes` and the
    Hermite sum in numpy's order of operations, element by element (the same bits; IEEE division, as
    numpy's, where a slope is 0), in one call instead of about sixty small array operations."""
    mm, dd = y.shape
    h = np.empty(mm - 1)
    d = np.empty((mm - 1, dd))
    for i in range(mm - 1):
        h[i] = u[i + 1] - u[i]
        for c in range(dd):
            d[i, c] = (y[i + 1, c] - y[i, c]) / h[i]
    m = np.zeros((mm, dd))
    if mm == 2:
        for i in range(2):
            for c in range(dd):
                m[i, c] = d[0, c]
    else:
        for i in range(1, mm - 1):
            w1 = 2 * h[i] + h[i - 1]
            w2 = h[i] + 2 * h[i - 1]
            for c in range(dd):
                a, b = d[i - 1, c], d[i, c]
                if np.sign(b) * np.sign(a) > 0:
                    m[i, c] = (w1 + w2) / (w1 / a + w2 / b)
        for end in range(2):
            i, k0, k1 = (0, 0, 1) if end == 0 else (mm - 1, mm - 2, mm - 3)
            h0, h1 = h[k0], h[k1]
            for c in range(dd):
                d0, d1 = d[k0, c], d[k1, c]
                e = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1)
                if np.sign(e) != np.sign(d0):
                    e = 0.0
                if np.sign(d0) != np.sign(d1) and np.abs(e) > np.abs(3 * d0):
                    e = 3 * d0
                m[i, c] = e
    q = ui.shape[0]
    out = np.empty((q, dd))
    for k in range(q):
        j = min(max(np.searchsorted(u, ui[k], side="right") - 1, 0), mm - 2)
        hj = u[j + 1] - u[j]
        t = (ui[k] - u[j]) / hj
        t2 = t * t
        t3 = t * t * t
        a = 2 * t3 - 3 * t2 + 1
        b = t3 - 2 * t2 + t
        c_ = -2 * t3 + 3 * t2
        e = t3 - t2
        for c in range(dd):
            out[k, c] = a * y[j, c] + b * hj * m[j, c] + c_ * y[j + 1, c] + e * hj * m[j + 1, c]
    return out


def resample_polyline(points: np.ndarray, n: int | None = None, *, step: float | None = None,
                      method: str = "linear", min_points: int = 2, repeat_tol: float = 0.0) -> np.ndarray:
    """Resample a polyline at points equally spaced in arc length.

    Parameters
    ----------
    points : (m, d) float array
        Ordered points, finite, m >= 2 (pixels or mm).
    n : int, optional
        Number of output points, >= ``min_points``.
    step : float, optional, keyword-only
        Largest spacing of the output (unit of ``points``): at least
        ``ceil(L / step) + 1`` points. With ``n`` too, the larger count;
        with neither, ``max(m, min_points)`` points.
    method : {"linear", "pchip"}, keyword-only
        ``linear``: on the polyline itself; ``pchip``: through the points by
        piecewise cubic Hermite interpolation in their arc length
        (:func:`pchip_interpolate`, the paper's reference resampler).
    min_points : int, keyword-only
        Fewest distinct points accepted, and fewest output points.
    repeat_tol : float, keyword-only
        Steps no longer than ``repeat_tol`` times the length are dropped
        first (0: exact repeats only).

    Returns
    -------
    (n, d) float array
        The first and last points are the input's.

    Raises
    ------
    ValueError
        Malformed input, or ``n`` / ``step`` out of range.
    DegenerateCurveError
        The polyline has no length, or fewer than ``min_points`` distinct points.

    Examples
    --------
    >>> resample_polyline(np.array([[0.0, 0.0], [4.0, 0.0]]), 3)
    array([[0., 0.],
           [2., 0.],
           [4., 0.]])
    >>> resample_polyline(np.array([[0.0, 0.0], [4.0, 0.0]]), step=1.5).shape
    (4, 2)
    """
    if method not in ("linear", "pchip"):
        raise ValueError(f"method must be 'linear' or 'pchip', got {method!r}")
    pts = check_points(points)
    if n is not None and int(n) < min_points:
        raise ValueError(f"n must be at least {min_points}, got {n}")
    if step is not None and not step > 0:
        raise ValueError(f"step must be > 0, got {step}")
    if pts.shape[0] < 2:
        raise DegenerateCurveError(f"curve has {pts.shape[0]} point(s); at least {max(min_points, 2)} distinct points are needed")
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    total = float(seg.sum())
    if not total > 0:
        raise DegenerateCurveError("curve has zero length (all points coincide)")
    pts = pts[np.concatenate([[True], seg > repeat_tol * total])]
    if pts.shape[0] < min_points:
        raise DegenerateCurveError(f"curve has {pts.shape[0]} distinct points; at least {min_points} are needed")
    s = arc_length(pts)
    count = max(len(np.asarray(points)), min_points) if n is None and step is None else (0 if n is None else int(n))
    if step is not None:
        count = max(count, int(np.ceil(s[-1] / step)) + 1)
    si = np.linspace(0.0, s[-1], count)
    if method == "pchip":
        out = pchip_interpolate(s, pts, si)
    else:
        out = _interp_columns(si, s, pts)
    out[0], out[-1] = pts[0], pts[-1]
    return out


def _interp_columns(si: np.ndarray, s: np.ndarray, pts: np.ndarray) -> np.ndarray:
    return np.stack([np.interp(si, s, pts[:, c]) for c in range(pts.shape[1])], axis=1)


def point_at_arc_length(points: np.ndarray, s_query: np.ndarray, *, normalised: bool = False) -> np.ndarray:
    """Points of a polyline at given arc lengths (linear along the polyline).

    Parameters
    ----------
    points : (m, d) float array
        Ordered points, finite, m >= 2.
    s_query : (q,) float array
        Arc lengths from the first point (unit of ``points``), or with
        ``normalised`` fractions of the length (0: first point, 1: last);
        clipped to the polyline.
    normalised : bool, keyword-only

    Returns
    -------
    (q, d) float array

    Raises
    ------
    DegenerateCurveError
        The polyline has zero length.

    Examples
    --------
    >>> point_at_arc_length(np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 4.0]]), np.array([0.0, 0.25, 0.75]), normalised=True)
    array([[0., 0.],
           [2., 0.],
           [4., 2.]])
    """
    pts = check_points(points, name="points", min_rows=2)
    s = arc_length(pts)
    if not s[-1] > 0:
        raise DegenerateCurveError("curve has zero length (all points coincide)")
    keep = np.concatenate([[True], np.diff(s) > 0])
    s, pts = s[keep], pts[keep]
    if normalised:
        s = s / s[-1]
    return _interp_columns(np.asarray(s_query, dtype=float), s, pts)


def point_at_index(points: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Points of a polyline at fractional vertex indices (linear between vertices).

    Parameters
    ----------
    points : (m, d) float array
        Polyline, m >= 2.
    t : (k,) float array
        Fractional indices, clipped to ``[0, m - 1]``; NaN gives a NaN row.

    Returns
    -------
    (k, d) float array

    Examples
    --------
    >>> point_at_index(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]]), np.array([0.5, 1.25, np.nan]))
    array([[1. , 0. ],
           [2. , 0.5],
           [nan, nan]])
    """
    n = points.shape[0]
    out = np.full((t.shape[0], points.shape[1]), np.nan)
    ok = np.isfinite(t)
    tt = np.clip(t[ok], 0.0, n - 1.0)
    i0 = np.minimum(np.floor(tt).astype(int), n - 2)
    f = (tt - i0)[:, None]
    out[ok] = points[i0] * (1 - f) + points[i0 + 1] * f
    return out


# ------------------------------------------------------------------ smoothing
def whittaker_smooth(y: np.ndarray, *, lam: float, weights: np.ndarray | None = None) -> np.ndarray:
    """Second-order Whittaker smoother: solve :math:`(W + \\lambda D_2^T D_2) z = W y`.

    Parameters
    ----------
    y : (n,) or (n, k) float array
        Equally spaced samples (each column smoothed independently).
    lam : float, keyword-only
        Smoothing weight (dimensionless); see :func:`tendrilkit.frenet.whittaker_lambda`.
    weights : (n,) float array, optional
        Weight of each sample, >= 0 (default 1: :math:`W = I`); a weight of
        0 lets the smoother interpolate that sample from its neighbours.

    Returns
    -------
    array like ``y``

    Notes
    -----
    The pentadiagonal system is solved by a compiled banded Cholesky
    factorisation, :math:`O(n)`: the solution of
    ``scipy.linalg.solveh_banded`` to rounding (a test pins it), kept because
    the site phantoms' results depend on its last bits.

    Examples
    --------
    A straight line passes unchanged; a zero weight is interpolated:

    >>> z = whittaker_smooth(np.array([0.0, 1.0, 9.0, 3.0, 4.0]), lam=1e3, weights=np.array([1.0, 1, 0, 1, 1]))
    >>> np.round(z, 6) + 0.0
    array([0., 1., 2., 3., 4.])
    """
    y = np.asarray(y, dtype=float)
    n = y.shape[0]
    if not lam >= 0:
        raise ValueError(f"lam must be >= 0, got {lam}")
    if not np.all(np.isfinite(y)):
        raise ValueError("y must be finite (no NaN or inf)")
    if lam == 0 or n < 3:
        return y.copy()
    w = np.ones(n) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != (n,) or not np.all(np.isfinite(w)) or np.any(w < 0) or np.count_nonzero(w) < 2:
        raise ValueError(f"weights must be {n} finite numbers >= 0, at least two of them positive")
    main = np.full(n, 6.0)
    main[[0, -1]] = 1.0
    main[[1, -2]] = 5.0
    off1 = np.full(n - 1, -4.0)
    off1[[0, -1]] = -2.0
    off2 = np.ones(n - 2)
    if n == 3:
        main = np.array([1.0, 4.0, 1.0])
        off1 = np.array([-2.0, -2.0])
    rhs = np.ascontiguousarray((y.reshape(n, -1) * w[:, None]) if weights is not None else y.reshape(n, -1))
    return _solve_penta(w + lam * main, lam * off1, lam * off2, rhs).reshape(y.shape)


@njit(cache=True)
def _solve_penta(d0, d1, d2, y):
    """Solve a symmetric positive-definite pentadiagonal system (banded Cholesky), columns of y."""
    n = d0.shape[0]
    L0 = np.empty(n)
    L1 = np.zeros(n)
    L2 = np.zeros(n)
    for i in range(n):
        a2 = d2[i - 2] / L0[i - 2] if i >= 2 else 0.0
        a1 = (d1[i - 1] - (a2 * L1[i - 1] if i >= 2 else 0.0)) / L0[i - 1] if i >= 1 else 0.0
        L2[i] = a2
        L1[i] = a1
        v = d0[i] - a1 * a1 - a2 * a2
        L0[i] = np.sqrt(v)
    # L stored as: row i has L[i,i]=L0[i], L[i,i-1]=L1[i], L[i,i-2]=L2[i]
    out = np.empty_like(y)
    for c in range(y.shape[1]):
        z = np.empty(n)
        for i in range(n):
            v = y[i, c]
            if i >= 1:
                v -= L1[i] * z[i - 1]
            if i >= 2:
                v -= L2[i] * z[i - 2]
            z[i] = v / L0[i]
        x = np.empty(n)
        for i in range(n - 1, -1, -1):
            v = z[i]
            if i + 1 < n:
                v -= L1[i + 1] * x[i + 1]
            if i + 2 < n:
                v -= L2[i + 2] * x[i + 2]
            x[i] = v / L0[i]
        for i in range(n):
            out[i, c] = x[i]
    return out


# -------------------------------------------------------------- nearest point
@njit(cache=True)
def _nearest_kernel(p, Q, t0, window):  # pragma: no cover - compiled
    n, m, dim = p.shape[0], Q.shape[0], p.shape[1]
    t = np.full(n, np.nan)
    near = np.full((n, dim), np.nan)
    dist = np.full(n, np.nan)
    normal = np.full((n, 2), np.nan)
    for i in range(n):
        finite = True
        for c in range(dim):
            if not np.isfinite(p[i, c]):
                finite = False
        if not finite:
            continue
        if window < 0:
            lo, hi = 0, m - 2
        else:
            s0 = int(np.floor(t0[i]))
            lo = max(s0 - window, 0)
            hi = min(s0 + window, m - 2)
            if hi < lo:
                lo = hi = min(max(s0, 0), m - 2)
        best = np.inf
        for s in range(lo, hi + 1):
            L2 = 0.0
            dot = 0.0
            for c in range(dim):
                b = Q[s + 1, c] - Q[s, c]
                L2 += b * b
                dot += (p[i, c] - Q[s, c]) * b
            u = min(max(dot / L2, 0.0), 1.0) if L2 > 0 else 0.0
            d2 = 0.0
            for c in range(dim):
                e = p[i, c] - Q[s, c] - u * (Q[s + 1, c] - Q[s, c])
                d2 += e * e
            if d2 < best:
                best = d2
                t[i] = s + u
                for c in range(dim):
                    near[i, c] = Q[s, c] + u * (Q[s + 1, c] - Q[s, c])
                if dim == 2:
                    L = np.sqrt(max(L2, 1e-12))
                    normal[i, 0] = -(Q[s + 1, 1] - Q[s, 1]) / L
                    normal[i, 1] = (Q[s + 1, 0] - Q[s, 0]) / L
        dist[i] = np.sqrt(best)
    return t, near, dist, normal


class NearestOnPolyline(NamedTuple):
    """Result of :func:`nearest_on_polyline` (``n`` query points, polyline in ``d`` dimensions).

    Attributes
    ----------
    t : (n,) float array
        Fractional vertex index of the nearest point (segment ``floor(t)``).
    point : (n, d) float array
        The nearest point of the polyline.
    distance : (n,) float array
        Distance to it (unit of the input).
    normal : (n, 2) float array
        Unit normal (left of the direction of travel) of the segment it lies
        on; NaN unless ``d == 2``.
    """

    t: np.ndarray
    point: np.ndarray
    distance: np.ndarray
    normal: np.ndarray


def nearest_on_polyline(points: np.ndarray, polyline: np.ndarray, *, start: np.ndarray | None = None,
                        window: int | None = None) -> NearestOnPolyline:
    """The point of a polyline nearest each query point (exact point-to-segment search).

    Parameters
    ----------
    points : (n, d) float array
        Query points; a NaN row gives NaN outputs.
    polyline : (m, d) float array
        Finite polyline, m >= 2.
    start : (n,) float array, optional, keyword-only
        Fractional vertex index to search around (with ``window``).
    window : int, optional, keyword-only
        Search only the segments within ``window`` of ``floor(start)``
        (tracking a point that moves little); default: every segment.

    Returns
    -------
    NearestOnPolyline

    Notes
    -----
    Compiled (numba) brute force over the segments, :math:`O(n m)` (or
    :math:`O(n \\cdot window)`): exact, and faster for the curves of a frame
    (hundreds of points) than densifying the polyline into a k-d tree, which
    is only as exact as its spacing.

    Examples
    --------
    >>> r = nearest_on_polyline(np.array([[5.0, 2.0]]), np.array([[0.0, 0.0], [10.0, 0.0]]))
    >>> r.t, r.point, r.distance, r.normal
    (array([0.5]), array([[5., 0.]]), array([2.]), array([[-0.,  1.]]))
    """
    P, Q = _polyline_pair(points, polyline, 2)
    if window is None:
        t0, w = np.zeros(len(P)), -1
    else:
        if start is None or int(window) < 0:
            raise ValueError(f"window needs start (n,) and must be >= 0, got {window}")
        t0 = np.ascontiguousarray(start, dtype=float)
        if t0.shape != (len(P),) or not np.all(np.isfinite(t0)):
            raise ValueError(f"start must be {len(P)} finite indices, got shape {t0.shape}")
        w = int(window)
    return NearestOnPolyline(*_nearest_kernel(P, Q, t0, w))


def point_to_polyline_distance(points: np.ndarray, polyline: np.ndarray) -> np.ndarray:
    """Distance (n,) of every point (n, d) to a polyline (m, d); NaN points give NaN.

    A polyline of one point is that point.

    Examples
    --------
    >>> point_to_polyline_distance(np.array([[5.0, 2.0]]), np.array([[0.0, 0.0], [10.0, 0.0]]))
    array([2.])
    """
    P, Q = _polyline_pair(points, polyline, 1)
    if len(Q) == 1:
        return np.linalg.norm(P - Q[0], axis=1)
    return nearest_on_polyline(P, Q).distance


# ------------------------------------------------------------------ rigid fit
@njit(cache=True)
def rigid_fit(P, Q):  # pragma: no cover - compiled
    """Rotation and translation minimising :math:`\\sum_i \\lVert R p_i + t - q_i \\rVert^2` (Kabsch's problem).

    Compiled (numba; callable from other compiled code).

    Parameters
    ----------
    P, Q : (n, 3) float arrays
        Corresponding points (same unit), n >= 1.

    Returns
    -------
    R : (3, 3) float array
        Proper rotation (det +1).
    t : (3,) float array

    Notes
    -----
    Horn's closed form by unit quaternions: with centroids :math:`\\bar p,
    \\bar q` and the cross-covariance :math:`S = \\sum (p_i - \\bar p)(q_i -
    \\bar q)^T`, the rotation is the unit quaternion of the largest eigenvalue
    of Horn's symmetric 4x4 matrix of :math:`S` (always a proper rotation: the
    same minimiser as Kabsch's SVD with its determinant correction), found by
    cyclic Jacobi rotations in scalars (LAPACK's SVD of a 3x3 matrix costs more
    in its call than in its arithmetic: 6.6 -> 2.9 us for 200 points);
    :math:`t = \\bar q - R \\bar p`. Where the rotation is not determined
    (points on a line) any minimiser is returned.

    Examples
    --------
    >>> P = np.array([[0.0, 0, 0], [1, 0, 0], [0, 2, 0], [0, 0, 3]])
    >>> R, t = rigid_fit(P, P[:, [1, 0, 2]] * [-1, 1, 1] + 5.0)
    >>> np.round(R, 6) + 0.0, np.round(t, 6) + 0.0
    (array([[ 0., -1.,  0.],
           [ 1.,  0.,  0.],
           [ 0.,  0.,  1.]]), array([5., 5., 5.]))
    """
    if P.ndim != 2 or P.shape[1] != 3 or P.shape != Q.shape or P.shape[0] < 1:
        raise ValueError("P and Q must have the same shape (n >= 1, 3)")
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(Q))):
        raise ValueError("P and Q must be finite (no NaN or inf)")
    return _rigid_fit_core(P, Q)


@njit(cache=True)
def _rigid_fit_core(P, Q):  # pragma: no cover - compiled
    """:func:`rigid_fit` without its checks (``P, Q`` finite, same shape (n >= 1, 3)): for compiled hot paths
    (the piece-wise clothoid's refinement registers every evaluation)."""
    n = P.shape[0]
    mp0 = mp1 = mp2 = mq0 = mq1 = mq2 = 0.0
    for i in range(n):
        mp0 += P[i, 0]
        mp1 += P[i, 1]
        mp2 += P[i, 2]
        mq0 += Q[i, 0]
        mq1 += Q[i, 1]
        mq2 += Q[i, 2]
    mp0 /= n
    mp1 /= n
    mp2 /= n
    mq0 /= n
    mq1 /= n
    mq2 /= n
    sxx = sxy = sxz = syx = syy = syz = szx = szy = szz = 0.0
    for i in range(n):
        px = P[i, 0] - mp0
        py = P[i, 1] - mp1
        pz = P[i, 2] - mp2
        qx = Q[i, 0] - mq0
        qy = Q[i, 1] - mq1
        qz = Q[i, 2] - mq2
        sxx += px * qx
        sxy += px * qy
        sxz += px * qz
        syx += py * qx
        syy += py * qy
        syz += py * qz
        szx += pz * qx
        szy += pz * qy
        szz += pz * qz
    N = np.empty((4, 4))
    N[0, 0] = sxx + syy + szz
    N[0, 1] = N[1, 0] = syz - szy
    N[0, 2] = N[2, 0] = szx - sxz
    N[0, 3] = N[3, 0] = sxy - syx
    N[1, 1] = sxx - syy - szz
    N[1, 2] = N[2, 1] = sxy + syx
    N[1, 3] = N[3, 1] = szx + sxz
    N[2, 2] = -sxx + syy - szz
    N[2, 3] = N[3, 2] = syz + szy
    N[3, 3] = -sxx - syy + szz
    V = np.eye(4)
    scale = 0.0
    for a in range(4):
        for b in range(4):
            scale += N[a, b] * N[a, b]
    for _ in range(30):
        off = 0.0
        for a in range(3):
            for b in range(a + 1, 4):
                off += N[a, b] * N[a, b]
        if off <= 1e-32 * scale:
            break
        for a in range(3):
            for b in range(a + 1, 4):
                nab = N[a, b]
                if nab == 0.0:
                    continue
                # the rotation zeroing N[a, b] (the symmetric Schur form)
                th = (N[b, b] - N[a, a]) / (2.0 * nab)
                t = (1.0 if th >= 0 else -1.0) / (abs(th) + np.sqrt(th * th + 1.0))
                c = 1.0 / np.sqrt(t * t + 1.0)
                sn = t * c
                for k in range(4):
                    nka = N[k, a]
                    nkb = N[k, b]
                    N[k, a] = c * nka - sn * nkb
                    N[k, b] = sn * nka + c * nkb
                for k in range(4):
                    nak = N[a, k]
                    nbk = N[b, k]
                    N[a, k] = c * nak - sn * nbk
                    N[b, k] = sn * nak + c * nbk
                for k in range(4):
                    vka = V[k, a]
                    vkb = V[k, b]
                    V[k, a] = c * vka - sn * vkb
                    V[k, b] = sn * vka + c * vkb
    best = 0
    for a in range(1, 4):
        if N[a, a] > N[best, best]:
            best = a
    w = V[0, best]
    x = V[1, best]
    y = V[2, best]
    z = V[3, best]
    nrm = np.sqrt(w * w + x * x + y * y + z * z)
    w /= nrm
    x /= nrm
    y /= nrm
    z /= nrm
    R = np.empty((3, 3))
    R[0, 0] = w * w + x * x - y * y - z * z
    R[0, 1] = 2.0 * (x * y - w * z)
    R[0, 2] = 2.0 * (x * z + w * y)
    R[1, 0] = 2.0 * (x * y + w * z)
    R[1, 1] = w * w - x * x + y * y - z * z
    R[1, 2] = 2.0 * (y * z - w * x)
    R[2, 0] = 2.0 * (x * z - w * y)
    R[2, 1] = 2.0 * (y * z + w * x)
    R[2, 2] = w * w - x * x - y * y + z * z
    t = np.empty(3)
    t[0] = mq0 - (R[0, 0] * mp0 + R[0, 1] * mp1 + R[0, 2] * mp2)
    t[1] = mq1 - (R[1, 0] * mp0 + R[1, 1] * mp1 + R[1, 2] * mp2)
    t[2] = mq2 - (R[2, 0] * mp0 + R[2, 1] * mp1 + R[2, 2] * mp2)
    return R, t




# ------------------------------------------------------------------- sections
def section_masks(s: np.ndarray, *, fraction: float = 0.25) -> dict[str, np.ndarray]:
    """The paper's sections of a curve by arc length: base quarter, tip quarter, entire.

    Parameters
    ----------
    s : (n,) float array
        Increasing arc length of the curve's points (any origin, any unit).
    fraction : float, keyword-only
        Length fraction of the base and tip sections (paper: one quarter).

    Returns
    -------
    dict of (n,) bool arrays
        ``base``: :math:`s - s_0 \\le f L`; ``tip``: :math:`s - s_0 \\ge
        (1 - f) L`; ``entire``: every point (:math:`L = s_{n-1} - s_0`).

    Examples
    --------
    >>> m = section_masks(np.arange(9.0))
    >>> m["base"].nonzero()[0].tolist(), m["tip"].nonzero()[0].tolist()
    ([0, 1, 2], [6, 7, 8])
    """
    s = np.asarray(s, dtype=float)
    if s.ndim != 1 or s.size < 1:
        raise ValueError(f"s must have shape (n >= 1,), got {s.shape}")
    L = s[-1] - s[0]
    rel = s - s[0]
    return {"base": rel <= fraction * L, "tip": rel >= (1.0 - fraction) * L, "entire": np.ones(s.size, dtype=bool)}


# -------------------------------------------------------------------- markers
def marker_corners(length_mm: float, *, centre_mm: np.ndarray | None = None, angle_deg: float = 0.0,
                   scale: float = 1.0) -> np.ndarray:
    """Corners (4, 3) mm of a square marker in its plane (z = 0), OpenCV ArUco order.

    Top-left, top-right, bottom-right, bottom-left of a square of side
    ``scale * length_mm``, turned by ``angle_deg`` (counter-clockwise) about
    its centre ``centre_mm`` (2,); unturned and centred at the origin:
    ``(-L/2, L/2, 0), (L/2, L/2, 0), (L/2, -L/2, 0), (-L/2, -L/2, 0)``.

    Examples
    --------
    >>> marker_corners(24.0)
    array([[-12.,  12.,   0.],
           [ 12.,  12.,   0.],
           [ 12., -12.,   0.],
           [-12., -12.,   0.]])
    """
    if not (np.isfinite(length_mm) and length_mm > 0):
        raise ValueError(f"length_mm must be a positive number, got {length_mm}")
    h = 0.5 * float(length_mm) * scale
    xy = np.array([[-h, h], [h, h], [h, -h], [-h, -h]])
    if angle_deg != 0.0:
        a = math.radians(angle_deg)
        xy = xy @ np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]]).T
    if centre_mm is not None:
        xy = xy + np.asarray(centre_mm, dtype=float).reshape(1, 2)
    return np.hstack([xy, np.zeros((4, 1))])
