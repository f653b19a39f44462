"""Centreline geometry along a walk: bridges through junction zones, ends
extended to the mask, smoothing and resampling; comparison with a true centreline."""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

from tendrilkit.skeleton.tangents import _arc, _direction

__all__ = ["compare_centerlines"]


def _bridge(pieces: list, nodes_seq: list, node_xy: np.ndarray, radius: np.ndarray, window: float) -> np.ndarray:
    """Concatenate the oriented branch paths, replacing junction zones by Hermite bridges."""
    keep_parts = []
    flags = []
    for k, p in enumerate(pieces):
        a, b = nodes_seq[k], nodes_seq[k + 1]
        keep = np.ones(len(p), bool)
        if radius[a] > 0:
            inside = np.hypot(*(p - node_xy[a]).T) < radius[a]
            # only the run touching the start of the piece
            run = np.argmin(inside) if not inside.all() else len(p)
            keep[:run] = False
        if radius[b] > 0:
            inside = np.hypot(*(p[::-1] - node_xy[b]).T) < radius[b]
            run = np.argmin(inside) if not inside.all() else len(p)
            keep[len(p) - run :] = False
        if k > 0:
            keep_parts.append(p[1:])
            flags.append(keep[1:])
        else:
            keep_parts.append(p)
            flags.append(keep)
    pts = np.vstack(keep_parts)
    keep = np.concatenate(flags)
    if keep.all():
        return pts
    if not keep.any():
        return pts  # nothing outside the zones: keep the skeleton as it is
    out = []
    n = len(pts)
    # the runs [i, j) of kept and of dropped points, in order
    edges = (np.flatnonzero(keep[1:] != keep[:-1]) + 1).tolist()
    for i, j in zip([0] + edges, edges + [n]):
        if keep[i]:
            out.append(pts[i:j])
            continue
        # gap [i, j): bridge from pts[i-1] to pts[j]
        if j == n:
            # the walk ends in a crossing (a tip stub shorter than prune_px
            # was pruned, or the tip touches the tendril): drop the bent
            # skeleton, the tip is extended along its tangent instead
            break
        if i == 0:
            out.append(pts[i:j])
            continue
        p0, p1 = pts[i - 1], pts[j]
        tl = _run_tangent(pts, keep, i - 1, -1, window)
        tr = _run_tangent(pts, keep, j, +1, window)
        d = float(np.hypot(*(p1 - p0)))
        m = max(int(np.ceil(d)), 1)
        t = np.linspace(0, 1, m + 1)[1:-1, None]
        h00 = 2 * t**3 - 3 * t**2 + 1
        h10 = t**3 - 2 * t**2 + t
        h01 = -2 * t**3 + 3 * t**2
        h11 = t**3 - t**2
        bridge = h00 * p0 + h10 * d * tl + h01 * p1 + h11 * d * tr
        out.append(bridge)
    return np.vstack(out)


def _run_tangent(pts: np.ndarray, keep: np.ndarray, i: int, step: int, window: float) -> np.ndarray:
    """Tangent (direction of travel) at ``pts[i]`` from the kept run on the side ``step``."""
    j = i
    run = [pts[i]]
    length = 0.0
    while 0 <= j + step < len(pts) and keep[j + step] and length < window:
        length += float(np.hypot(*(pts[j + step] - pts[j])))
        j += step
        run.append(pts[j])
    run = np.array(run)
    if len(run) < 2:
        return np.zeros(2)
    d = _direction(run)  # oriented from pts[i] outward along `step`
    return -d if step < 0 else d


def _extend_ends(path: np.ndarray, crop: np.ndarray, half: float, window: float, tip_inset: float, *, tip_reach: float) -> np.ndarray:
    """Extend both ends along their tangents to the mask boundary (tip: minus ``tip_inset`` half-widths).

    The base goes at most ``4 half + 4`` px, the tip at most ``tip_reach``
    (more when the walk ends in a crossing: through it, and through a pruned
    stub of the tip beyond it).
    """
    h, w = crop.shape

    def reach(p: np.ndarray, d: np.ndarray, limit: float) -> float:
        step = 0.5
        s = 0.0
        while s < limit:
            q = p + (s + step) * d
            c, r = int(round(q[0])), int(round(q[1]))
            if not (0 <= r < h and 0 <= c < w) or crop[r, c] == 0:
                break
            s += step
        return s

    def line(p: np.ndarray, d: np.ndarray, length: float) -> np.ndarray:
        n = int(np.floor(length))
        if n < 1:
            return np.empty((0, 2))
        return p + np.arange(1, n + 1)[:, None] * d

    s = _arc(path)
    if len(path) < 2:
        return path
    d0 = _direction(path[s <= window][::-1]) if np.sum(s <= window) >= 2 else path[0] - path[1]
    ext0 = line(path[0], d0, reach(path[0], d0, 4.0 * half + 4.0) + 0.5)
    parts = [ext0[::-1], path]
    sel = path[s >= s[-1] - window]
    d1 = _direction(sel) if len(sel) >= 2 else path[-1] - path[-2]
    length = reach(path[-1], d1, tip_reach) + 0.5 - tip_inset * half
    parts.append(line(path[-1], d1, length))
    return np.vstack(parts)


def _smooth_resample(path: np.ndarray, sigma: float, spacing: float = 1.0) -> np.ndarray:
    """Resample every ``spacing`` px of arc length and smooth (Gaussian, odd reflection at the ends)."""
    keep = np.ones(len(path), bool)
    keep[1:] = np.hypot(*np.diff(path, axis=0).T) > 1e-9
    path = path[keep]
    if len(path) < 2:
        return path
    s = _arc(path)
    n = max(int(round(s[-1] / spacing)), 1) + 1
    si = np.linspace(0, s[-1], n)
    p = np.column_stack([np.interp(si, s, path[:, 0]), np.interp(si, s, path[:, 1])])
    if sigma > 0 and len(p) > 3:
        k = min(int(np.ceil(4 * sigma)), len(p) - 1)
        head = 2 * p[0] - p[1 : k + 1][::-1]
        tail = 2 * p[-1] - p[-k - 1 : -1][::-1]
        q = np.vstack([head, p, tail])
        q = gaussian_filter1d(q, sigma, axis=0, mode="nearest")
        p = q[k : k + len(p)]
        # the pixel staircase is longer than the curve: resample the smoothed path again
        s = _arc(p)
        n = max(int(round(s[-1] / spacing)), 1) + 1
        si = np.linspace(0, s[-1], n)
        p = np.column_stack([np.interp(si, s, p[:, 0]), np.interp(si, s, p[:, 1])])
    return p


def compare_centerlines(points_xy: np.ndarray, truth_xy: np.ndarray) -> dict:
    """Accuracy and order of an ordered centreline against a true one (both base to tip).

    Parameters
    ----------
    points_xy : (n, 2) float array
        The measured centreline, ordered base to tip.
    truth_xy : (m, 2) float array
        The true centreline (e.g. the ground-truth projection), base to tip.

    Returns
    -------
    dict
        ``mean_px``, ``max_px``: distance of every measured point to the true
        polyline; ``arc_corr``: correlation between a point's index and the arc
        position of its nearest true point (1 for a right order; a crossing
        makes a few points' nearest true point lie on the other pass, which
        barely moves it); ``fraction_max_px``: the largest distance between
        the measured and the true point at the same fraction of arc length
        (101 fractions); ``base_px``, ``tip_px``: distances between the ends.

    Examples
    --------
    >>> import numpy as np
    >>> truth = np.column_stack([np.linspace(0, 100, 101), np.zeros(101)])
    >>> m = compare_centerlines(truth + (0, 0.5), truth)
    >>> m["mean_px"], round(m["arc_corr"], 6), m["tip_px"]
    (0.5, 1.0, 0.5)
    """
    from scipy.spatial import cKDTree

    p = np.asarray(points_xy, float)
    t = np.asarray(truth_xy, float)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < 2 or t.ndim != 2 or t.shape[1] != 2 or len(t) < 2:
        raise ValueError(f"points_xy and truth_xy must have shape (n >= 2, 2), got {p.shape} and {t.shape}")
    st = _arc(t)
    dense_s = np.arange(0.0, st[-1] + 0.25, 0.25)
    dense = np.column_stack([np.interp(dense_s, st, t[:, 0]), np.interp(dense_s, st, t[:, 1])])
    d, idx = cKDTree(dense).query(p)
    arc_corr = float(np.corrcoef(np.arange(len(p)), dense_s[idx])[0, 1]) if np.ptp(idx) > 0 else 0.0
    f = np.linspace(0, 1, 101)
    sp = _arc(p)

    def at(pts, s):
        return np.column_stack([np.interp(f * s[-1], s, pts[:, 0]), np.interp(f * s[-1], s, pts[:, 1])])

    frac = np.hypot(*(at(p, sp) - at(t, st)).T)
    return {
        "mean_px": float(d.mean()),
        "max_px": float(d.max()),
        "arc_corr": arc_corr,
        "fraction_max_px": float(frac.max()),
        "base_px": float(np.hypot(*(p[0] - t[0]))),
        "tip_px": float(np.hypot(*(p[-1] - t[-1]))),
    }
