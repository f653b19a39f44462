"""Tangents of skeleton branches: principal-axis directions, end tangents outside a junction zone, turns."""

from __future__ import annotations

import numpy as np


def _direction(pts: np.ndarray) -> np.ndarray:
    """Unit direction of the line fitted to ``pts`` (principal axis), oriented first -> last."""
    d = pts[-1] - pts[0]
    if len(pts) >= 3:
        c = pts - pts.mean(axis=0)
        _, _, vt = np.linalg.svd(c, full_matrices=False)
        a = vt[0]
        if a @ d < 0:
            a = -a
        d = a
    nrm = np.hypot(*d)
    return d / nrm if nrm > 0 else np.array([1.0, 0.0])


def _arc(pts: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])


def _end_tangent(pts: np.ndarray, centre: np.ndarray, radius: float, window: float) -> np.ndarray:
    """Direction away from the node at ``pts[0]``, fitted outside ``radius``."""
    if radius > 0:
        out = np.nonzero(np.hypot(*(pts - centre).T) >= radius)[0]
        start = int(out[0]) if len(out) else max(len(pts) - 2, 0)
    else:
        start = 0
    s = _arc(pts[start:])
    sel = pts[start:][s <= window]
    if len(sel) < 2:
        sel = pts[max(len(pts) - 2, 0):] if len(pts) >= 2 else np.vstack([centre, pts])
        if len(pts) >= 2 and start >= len(pts) - 1:
            sel = pts
    return _direction(sel)


def _signed_angle_deg(d_in: np.ndarray, d_out: np.ndarray) -> float:
    return float(np.degrees(np.arctan2(d_in[0] * d_out[1] - d_in[1] * d_out[0], d_in @ d_out)))
