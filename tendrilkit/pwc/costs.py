"""Cost of a segment: the normalised cost of one straight line over every interval of samples.

The *cost* of the segmentation (:mod:`tendrilkit.pwc` notes, "cost" and
"penalty"): ``l2`` least squares by prefix sums, ``l1`` the paper's absolute
error of the least-squares line; signals centred and scaled so that penalties
are dimensionless.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["line_costs"]


_SIGMA_FLOOR_RAD = 1e-2


@njit(cache=True, error_model="numpy")
def _line_costs(x, y, w, min_size, l1):
    """``C[i, j]`` of :func:`line_costs` on the normalised signal (``l1``: the absolute error's).

    Least squares: the sums of every interval ``i .. j`` grown together, one sample ``j`` at a time over
    all the intervals that end there (each interval's sums take the same terms in the same order as
    one interval at a time, :func:`_line_costs_one_by_one`: the same bits), so that the loops over
    ``i`` vectorise (numpy's error model: a division by a zero weight gives NaN, not an exception, and
    is not taken).
    """
    if l1:
        return _line_costs_one_by_one(x, y, w, min_size, l1)
    n = x.shape[0]
    C = np.full((n + 1, n + 1), np.inf)
    Sw = np.zeros(n)
    Sx = np.zeros(n)
    Sy = np.zeros(n)
    Sxx = np.zeros(n)
    Sxy = np.zeros(n)
    Syy = np.zeros(n)
    row = np.empty(n)
    for j in range(n):
        wj = w[j]
        tx = wj * x[j]
        ty = wj * y[j]
        txx = tx * x[j]
        txy = tx * y[j]
        tyy = ty * y[j]
        for i in range(j + 1):
            Sw[i] += wj
            Sx[i] += tx
            Sy[i] += ty
            Sxx[i] += txx
            Sxy[i] += txy
            Syy[i] += tyy
        m = j - min_size + 2  # the intervals i .. j of at least min_size samples: i < m
        for i in range(m):
            sw = Sw[i]
            mx = Sx[i] / sw
            my = Sy[i] / sw
            cxx = Sxx[i] - Sx[i] * mx
            cxy = Sxy[i] - Sx[i] * my
            cyy = Syy[i] - Sy[i] * my
            slope = 0.0 if cxx <= 1e-12 * sw else cxy / cxx
            v = cyy - slope * cxy
            v = v if v > 0.0 else 0.0
            row[i] = 0.0 if sw <= 1e-300 else v
        for i in range(m):
            C[i, j + 1] = row[i]
    return C


@njit(cache=True)
def _line_costs_one_by_one(x, y, w, min_size, l1):
    """:func:`_line_costs` one interval start at a time (the absolute error's costs; the reference of the
    least squares' bits)."""
    n = x.shape[0]
    C = np.full((n + 1, n + 1), np.inf)
    for i in range(n):
        Sw = 0.0
        Sx = 0.0
        Sy = 0.0
        Sxx = 0.0
        Sxy = 0.0
        Syy = 0.0
        for j in range(i, n):
            wj = w[j]
            Sw += wj
            Sx += wj * x[j]
            Sy += wj * y[j]
            Sxx += wj * x[j] * x[j]
            Sxy += wj * x[j] * y[j]
            Syy += wj * y[j] * y[j]
            if j - i + 1 < min_size:
                continue
            if Sw <= 1e-300:
                C[i, j + 1] = 0.0
                continue
            mx = Sx / Sw
            my = Sy / Sw
            cxx = Sxx - Sx * mx
            cxy = Sxy - Sx * my
            cyy = Syy - Sy * my
            if cxx <= 1e-12 * Sw:
                slope = 0.0
            else:
                slope = cxy / cxx
            if not l1:
                v = cyy - slope * cxy
                C[i, j + 1] = v if v > 0.0 else 0.0
            else:
                acc = 0.0
                for m in range(i, j + 1):
                    acc += w[m] * abs(y[m] - my - slope * (x[m] - mx))
                C[i, j + 1] = acc
    return C


def _normalise(s: np.ndarray, y: np.ndarray, w: np.ndarray, score: str):
    L = float(s[-1] - s[0])
    x = (s - s[0]) / L - 0.5
    sw = float(w.sum())
    if not sw > 0:
        return x, np.zeros_like(y), np.ones_like(w) / w.size, 1.0
    mean = float(w @ y) / sw
    if score == "l2":
        spread = np.sqrt(float(w @ (y - mean) ** 2) / sw)
    else:
        spread = float(w @ np.abs(y - mean)) / sw
    scale = float(np.hypot(spread, _SIGMA_FLOOR_RAD / L))
    return x, (y - mean) / scale, w / sw, scale


def line_costs(
    s_mm: np.ndarray,
    y: np.ndarray,
    *,
    weights: np.ndarray | None = None,
    score: str = "l2",
    min_size: int = 3,
) -> np.ndarray:
    """Normalised cost of one line over every interval of samples.

    Parameters
    ----------
    s_mm : (n,) float array
        Increasing arc lengths, mm.
    y : (n,) float array
        The signal (curvature or torsion, 1/mm).
    weights : (n,) float array, optional
        Non-negative sample weights (default 1).
    score : {"l2", "l1"}, keyword-only
        Least squares, or the paper's absolute error of the least-squares line.
    min_size : int, keyword-only
        Fewest samples in a segment (a line through 2 samples fits exactly).

    Returns
    -------
    (n + 1, n + 1) float array
        ``C[i, j]``: cost of samples ``i .. j-1`` (``inf`` for fewer than
        ``min_size``), dimensionless (module notes): the costs of a
        segmentation add up to its fraction of unexplained variance.

    Examples
    --------
    >>> import numpy as np
    >>> s = np.linspace(0.0, 100.0, 101)
    >>> y = np.interp(s, [0, 40, 100], [0.02, 0.08, 0.03])
    >>> line_costs(s, y).shape
    (102, 102)
    """
    s, y, w = _check_signal(s_mm, y, weights)
    if score not in ("l2", "l1"):
        raise ValueError(f"score must be 'l2' or 'l1', got {score!r}")
    if min_size < 2:
        raise ValueError(f"min_size must be >= 2, got {min_size}")
    x, yn, wn, _ = _normalise(s, y, w, score)
    return _line_costs(x, yn, wn, int(min_size), score == "l1")


def _check_signal(s_mm, y, weights):
    s = np.asarray(s_mm, dtype=float)
    y = np.asarray(y, dtype=float)
    if s.ndim != 1 or s.size < 2:
        raise ValueError(f"s_mm must have shape (n,) with n >= 2, got {s.shape}")
    if y.shape != s.shape:
        raise ValueError(f"y must have shape {s.shape}, got {y.shape}")
    if np.any(np.diff(s) <= 0):
        raise ValueError("s_mm must be strictly increasing")
    if not (np.all(np.isfinite(s)) and np.all(np.isfinite(y))):
        raise ValueError("s_mm and y must be finite")
    w = np.ones_like(s) if weights is None else np.asarray(weights, dtype=float)
    if w.shape != s.shape or np.any(w < 0) or not np.all(np.isfinite(w)):
        raise ValueError(f"weights must be finite, non-negative, shape {s.shape}")
    return s, y, w
