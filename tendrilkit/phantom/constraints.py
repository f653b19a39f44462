"""The geometric constraints a phantom's tendril must meet, and its self-crossings in a view."""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from tendrilkit.camera import Camera
from tendrilkit.phantom.design import _MARGIN_PX, _WORKING_MM, _Z_MIN_MM
from tendrilkit.phantom.projection import _mm_per_px, _project_safe

def self_crossings(xy: np.ndarray, s_mm: np.ndarray, *, min_ds_mm: float = 3.0) -> list[tuple[float, float, float, float, float]]:
    """Self-intersections of a 2D polyline.

    Parameters
    ----------
    xy : (n, 2) float array
        Polyline vertices, pixels.
    s_mm : (n,) float array
        Arc length of each vertex (any unit; compared with ``min_ds_mm``).
    min_ds_mm : float
        Segments closer than this along the curve are not compared.

    Returns
    -------
    list of ``(s_a, s_b, x, y, angle_deg)``, ``s_a < s_b``: where the curve at
    ``s_a`` crosses the curve at ``s_b``, the crossing point (pixels) and the
    angle between the two branches (0-90 degrees).

    Examples
    --------
    A Z drawn back over itself crosses once, at right angles:

    >>> xy = np.array([[0, 0], [10, 10], [10, 0], [0, 10]], float)
    >>> s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(xy, axis=0), axis=1))]
    >>> [round(v, 2) for v in self_crossings(xy, s)[0]]
    [7.07, 31.21, 5.0, 5.0, 90.0]
    """
    xy = np.asarray(xy, dtype=float)
    p, q = xy[:-1], xy[1:]
    d = q - p
    sm = 0.5 * (s_mm[:-1] + s_mm[1:])
    seg_len = np.linalg.norm(d, axis=1)
    if len(p) < 3 or not np.all(np.isfinite(seg_len)):
        return []
    # two segments can only meet if their midpoints are within the longest segment's length
    pairs = cKDTree(0.5 * (p + q)).query_pairs(float(seg_len.max()) + 1e-9, output_type="ndarray")
    if len(pairs) == 0:
        return []
    i, j = pairs.min(axis=1), pairs.max(axis=1)
    keep = (j - i >= 2) & ((sm[j] - sm[i]) > min_ds_mm)
    i, j = i[keep], j[keep]
    order = np.lexsort((j, i))
    i, j = i[order], j[order]
    if i.size == 0:
        return []
    di, dj = d[i], d[j]
    den = di[:, 0] * dj[:, 1] - di[:, 1] * dj[:, 0]
    w = p[j] - p[i]
    with np.errstate(divide="ignore", invalid="ignore"):
        ta = (w[:, 0] * dj[:, 1] - w[:, 1] * dj[:, 0]) / den
        tb = (w[:, 0] * di[:, 1] - w[:, 1] * di[:, 0]) / den
    hit = (np.abs(den) > 1e-12) & (ta >= 0) & (ta < 1) & (tb >= 0) & (tb < 1)
    out = []
    for k in np.flatnonzero(hit):
        a, b = i[k], j[k]
        pt = p[a] + ta[k] * di[k]
        cosang = abs(np.dot(di[k], dj[k])) / (np.linalg.norm(di[k]) * np.linalg.norm(dj[k]))
        sa = s_mm[a] + ta[k] * (s_mm[a + 1] - s_mm[a])
        sb = s_mm[b] + tb[k] * (s_mm[b + 1] - s_mm[b])
        out.append((float(sa), float(sb), float(pt[0]), float(pt[1]), float(np.degrees(np.arccos(min(1.0, cosang))))))
    return out


def _visible(crossing: tuple, length_mm: float) -> bool:
    """A crossing a user would see: not at the ends and not grazing (>= 20 degrees)."""
    sa, sb, _, _, ang = crossing
    return ang >= 20.0 and sa >= 3.0 and sb <= length_mm - 3.0


def check_constraints(curves: np.ndarray, s_mm: np.ndarray, cams: list[Camera], site: str, *,
                      time_s: np.ndarray, stable_s: float, diameter_mm: float = 1.5) -> list[str]:
    """The geometric constraints a phantom's tendril must meet; returns the violations.

    Parameters
    ----------
    curves : (n_frames, n_pts, 3) float array
        Centrelines, world mm.
    s_mm : (n_pts,) float array
    cams : list of Camera
    site : str
    time_s : (n_frames,) float array
    stable_s : float
    diameter_mm : float

    Returns
    -------
    list of str
        Empty when every constraint holds: z >= 3 mm; inside every image with
        a 60 px margin; centroid of the sequence 100-150 mm from the world
        marker; no 3D self-contact (points more than 4 mm apart along the
        tendril stay ``diameter_mm + 0.5`` mm apart); S1, S2, S4: no crossing
        and no near-touch in any view; S3: at least one visible crossing
        (:func:`self_crossings`, >= 20 degrees, away from the ends) in at
        least two views in every frame after ``stable_s``.
    """
    bad = []
    zmin = float(curves[..., 2].min())
    if zmin < _Z_MIN_MM:
        bad.append(f"tendril behind z = {_Z_MIN_MM} mm (min z {zmin:.2f})")
    for v, cam in enumerate(cams):
        xy = _project_safe(cam, curves.reshape(-1, 3))
        if not np.all(cam.in_image(xy, margin_px=_MARGIN_PX)):
            bad.append(f"tendril leaves view {v + 1} (margin {_MARGIN_PX} px)")
    dist = float(np.linalg.norm(curves.reshape(-1, 3).mean(axis=0)))
    if not _WORKING_MM[0] <= dist <= _WORKING_MM[1]:
        bad.append(f"centroid {dist:.0f} mm from the world marker, expected {_WORKING_MM[0]:.0f}-{_WORKING_MM[1]:.0f}")
    if bad:
        return bad
    sub = slice(None, None, 2)
    ss = s_mm[sub]
    for f in range(len(curves)):
        tree = cKDTree(curves[f, sub])
        pairs = tree.query_pairs(diameter_mm + 0.5, output_type="ndarray")
        if len(pairs) and np.any(np.abs(ss[pairs[:, 0]] - ss[pairs[:, 1]]) > 4.0):
            bad.append(f"frame {f}: the tendril touches itself in 3D")
            break
    L = float(s_mm[-1])
    coarse = slice(None, None, 4)
    for f in range(len(curves)):
        views_with = 0
        for v, cam in enumerate(cams):
            xy = cam.project(curves[f, coarse])
            cr = [c for c in self_crossings(xy, s_mm[coarse]) if _visible(c, L)]
            if site != "S3":
                if self_crossings(xy, s_mm[coarse]):
                    bad.append(f"frame {f}: the tendril crosses itself in view {v + 1}")
                    return bad
                # near-touch: parts far apart along the tendril closer than a tube width + 4 px
                w_px = diameter_mm / _mm_per_px(cam, curves[f].mean(axis=0))
                tree = cKDTree(xy)
                pairs = tree.query_pairs(w_px + 4.0, output_type="ndarray")
                if len(pairs) and np.any(np.abs(s_mm[coarse][pairs[:, 0]] - s_mm[coarse][pairs[:, 1]]) > 8.0):
                    bad.append(f"frame {f}: the tendril nearly touches itself in view {v + 1}")
                    return bad
            elif cr:
                views_with += 1
        if site == "S3" and time_s[f] >= stable_s and views_with < 2:
            bad.append(f"frame {f}: a visible crossing in {views_with} view(s), expected at least 2")
            return bad
    return bad


