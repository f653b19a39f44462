"""Continuous piece-wise linear laws of curvature or torsion: joins, overshoot merges, knot refit.

Continuity (:mod:`tendrilkit.pwc` notes, :func:`join_segments`) and the law
itself (:class:`PiecewiseLinearLaw`: a clothoid per piece), with the exact
mean of a law over each integration step.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from tendrilkit.pwc.costs import _check_signal

__all__ = ["PiecewiseLinearLaw", "join_segments"]


@dataclass(frozen=True, eq=False)
class PiecewiseLinearLaw:
    """A continuous piece-wise linear law along arc length (a clothoid per piece).

    Attributes
    ----------
    knots_mm : (K + 1,) float array
        Increasing arc lengths, first = 0 (base), last = the curve's length.
    values : (K + 1,) float array
        The law's values at the knots, 1/mm.
    kind : str
        ``"kappa"`` or ``"tau"``.
    """

    knots_mm: np.ndarray
    values: np.ndarray
    kind: str = ""

    @property
    def n_segments(self) -> int:
        return int(self.knots_mm.size - 1)

    def __call__(self, s_mm: np.ndarray) -> np.ndarray:
        return np.interp(s_mm, self.knots_mm, self.values)

    def step_means(self, s_mm: np.ndarray) -> np.ndarray:
        """Exact mean of the law over each step ``[s_i, s_{i+1}]``, shape (n - 1,)."""
        return _pwl_step_means(np.ascontiguousarray(s_mm, dtype=float), np.ascontiguousarray(self.knots_mm, dtype=float),
                               np.ascontiguousarray(self.values, dtype=float))

    def segments(self) -> list[tuple[float, float, float, float]]:
        """``(s0_mm, s1_mm, value at s0, value at s1)`` per segment."""
        k, v = self.knots_mm, self.values
        return [(float(k[i]), float(k[i + 1]), float(v[i]), float(v[i + 1])) for i in range(k.size - 1)]


class _Lines:
    """Weighted least-squares line of any interval ``[a, c)`` in O(1) (prefix sums, centred s)."""

    def __init__(self, s, y, w):
        self.s0 = float(s.mean())
        x = s - self.s0
        self.span2 = float((s[-1] - s[0]) ** 2)
        z = np.zeros(1)
        self.W = np.concatenate([z, np.cumsum(w)])
        self.X = np.concatenate([z, np.cumsum(w * x)])
        self.Y = np.concatenate([z, np.cumsum(w * y)])
        self.XX = np.concatenate([z, np.cumsum(w * x * x)])
        self.XY = np.concatenate([z, np.cumsum(w * x * y)])

    def __call__(self, a: int, c: int) -> tuple[float, float]:
        """(slope, intercept) in the original arc length."""
        sw = self.W[c] - self.W[a]
        if sw <= 0:
            return 0.0, 0.0
        sx, sy = self.X[c] - self.X[a], self.Y[c] - self.Y[a]
        mx, my = sx / sw, sy / sw
        cxx = (self.XX[c] - self.XX[a]) - sx * mx
        if cxx <= 1e-12 * sw * self.span2:
            return 0.0, float(my)
        slope = ((self.XY[c] - self.XY[a]) - sx * my) / cxx
        return float(slope), float(my - slope * mx - slope * self.s0)


def join_segments(
    s_mm: np.ndarray,
    y: np.ndarray,
    bounds: np.ndarray,
    *,
    weights: np.ndarray | None = None,
    kind: str = "",
) -> PiecewiseLinearLaw:
    """Make a segmentation continuous: joins, overshoot merges, knot refit.

    Parameters
    ----------
    s_mm, y : (n,) float arrays
        Arc length (mm) and signal (1/mm).
    bounds : (K + 1,) int array
        Sample boundaries of the segments (from :func:`segment_penalty`).
    weights : (n,) float array, optional
        Sample weights (torsion: curvature squared).
    kind : str
        Label stored on the law.

    Returns
    -------
    PiecewiseLinearLaw
        The best continuous piece-wise linear fit (weighted least squares)
        whose knots are the joins that survive.

    Examples
    --------
    >>> import numpy as np
    >>> s = np.linspace(0.0, 100.0, 101)
    >>> y = np.interp(s, [0, 40, 100], [0.02, 0.08, 0.03])
    >>> law = join_segments(s, y, np.array([0, 40, 101]), kind="kappa")
    >>> law.knots_mm.round(3).tolist(), law.values.round(4).tolist()
    ([0.0, 40.0, 100.0], [0.02, 0.08, 0.03])
    >>> law(np.array([20.0, 70.0])).round(4).tolist()
    [0.05, 0.055]
    """
    s, y, w = _check_signal(s_mm, y, weights)
    return _Joiner(s, y, w).join(bounds, kind)


class _Joiner:
    """One signal prepared for :func:`join_segments` of many segmentations.

    The automatic selection and the grid search join several segmentations of
    the same signal; the checks, the prefix sums and the square-root weights
    are made once here (``s``, ``y``, ``w``: checked (n,) arrays).
    """

    def __init__(self, s, y, w):
        self.s, self.y, self.w = s, y, w
        self.h_min = float(np.min(np.diff(s)))
        self.line = _Lines(s, y, w)
        self.sq = np.sqrt(w)
        self.w_sum = float(w.sum())  # numpy's sum (pairwise), as _refit_values takes it

    def join(self, bounds, kind=""):
        """The continuous law of the segmentation ``bounds`` (:func:`join_segments`)."""
        s = self.s
        b = np.array([int(v) for v in np.asarray(bounds)], dtype=np.int64)
        if b[0] != 0 or b[-1] != s.size or np.any(b[1:] <= b[:-1]):
            raise ValueError(f"bounds must increase from 0 to {s.size}, got {b.tolist()}")
        line = self.line
        kn, values = _join_core(s, self.y, self.sq, line.W, line.X, line.Y, line.XX, line.XY, line.s0, line.span2,
                                self.h_min, self.w_sum, b)
        return PiecewiseLinearLaw(knots_mm=kn, values=values, kind=kind)


@njit(cache=True)
def _join_core(s, y, sq, W, X, Y, XX, XY, s0, span2, h_min, w_sum, bounds):
    """:meth:`_Joiner.join` compiled: each segment's line (:class:`_Lines`' arithmetic on its prefix
    sums ``W .. XY``, ``s0``, ``span2``), the joins at the lines' intersections, a segment merged into
    the next where its join overshoots, and the values refitted at the joins (:func:`_refit_values`,
    ``w_sum``: the weights' sum as numpy makes it): the same bits as those steps in Python, in one call
    (a join is made for every distinct law of the penalty paths). Returns ``(knots, values)``.
    """
    b = bounds.copy()
    nb = b.shape[0]
    n = s.shape[0]
    slope = np.empty(nb)
    icpt = np.empty(nb)
    knots = np.empty(nb)
    while True:
        for k in range(nb - 1):
            a, c = b[k], b[k + 1]
            sw = W[c] - W[a]
            if sw <= 0:
                slope[k], icpt[k] = 0.0, 0.0
                continue
            sx, sy = X[c] - X[a], Y[c] - Y[a]
            mx, my = sx / sw, sy / sw
            cxx = (XX[c] - XX[a]) - sx * mx
            if cxx <= 1e-12 * sw * span2:
                slope[k], icpt[k] = 0.0, my
                continue
            sl = ((XY[c] - XY[a]) - sx * my) / cxx
            slope[k], icpt[k] = sl, my - sl * mx - sl * s0
        knots[0] = s[0]
        nk = 1
        bad = -1
        for i in range(nb - 2):
            a1, c1, a2, c2 = slope[i], icpt[i], slope[i + 1], icpt[i + 1]
            lo, hi = s[b[i]], s[b[i + 2] - 1]
            if a1 == a2:
                bad = i
                break
            x = (c2 - c1) / (a1 - a2)
            if not (lo < x < hi) or x <= knots[nk - 1] + 0.5 * h_min or x >= s[n - 1] - 0.5 * h_min:
                bad = i
                break
            knots[nk] = x
            nk += 1
        if bad < 0:
            break
        for k in range(bad + 1, nb - 1):  # del b[bad + 1]
            b[k] = b[k + 1]
        nb -= 1
    knots[nk] = s[n - 1]
    kn = knots[:nk + 1].copy()
    m = kn.shape[0]
    ridge = 1e-6 * np.sqrt(w_sum / m) if m > 2 else 0.0
    return kn, _refit_core(s, y, kn, sq, ridge)


def _refit_values(s, y, w, knots, sq=None):
    """The values at ``knots`` of the weighted least-squares continuous law (:func:`_refit_core`)."""
    sq = np.sqrt(w) if sq is None else sq
    m = knots.size
    ridge = 1e-6 * np.sqrt(w.sum() / m) if m > 2 else 0.0  # numpy's sum (pairwise), as before
    return _refit_core(s, y, np.ascontiguousarray(knots, dtype=float), sq, float(ridge))


@njit(cache=True)
def _refit_core(s, y, knots, sq, ridge):
    """:func:`_refit_values` compiled: the rows of the linear interpolation at the knots (the law at ``s``
    is those rows times the values) weighted by ``sq`` (the square-root weights), a whisper of ridge
    (``ridge``) on the second differences (it keeps knots with no weight defined),
    and LAPACK's least squares as ``numpy.linalg.lstsq`` calls it (the same cut-off): the same values
    as those steps in numpy, without their calls' overhead (a join is made for every candidate law).
    """
    n, m = s.shape[0], knots.shape[0]
    nd = m - 2 if m > 2 else 0
    lhs = np.zeros((n + nd, m))
    rhs = np.zeros(n + nd)
    for i in range(n):
        j = min(max(np.searchsorted(knots, s[i], side="right") - 1, 0), m - 2)
        t = min(max((s[i] - knots[j]) / (knots[j + 1] - knots[j]), 0.0), 1.0)
        lhs[i, j] = (1.0 - t) * sq[i]
        lhs[i, j + 1] = t * sq[i]
        rhs[i] = y[i] * sq[i]
    for k in range(nd):
        lhs[n + k, k] = ridge
        lhs[n + k, k + 1] = -2.0 * ridge
        lhs[n + k, k + 2] = ridge
    return np.linalg.lstsq(lhs, rhs, rcond=np.finfo(np.float64).eps * max(n + nd, m))[0]


@njit(cache=True)
def _pwl_step_means(s, knots, values):
    """Exact mean of a continuous piece-wise linear law over each step of ``s``."""
    m = knots.shape[0]
    Ik = np.zeros(m)
    for j in range(m - 1):
        Ik[j + 1] = Ik[j] + 0.5 * (knots[j + 1] - knots[j]) * (values[j] + values[j + 1])
    n = s.shape[0]
    I = np.empty(n)
    j = 0
    for i in range(n):
        x = s[i]
        while j < m - 2 and x > knots[j + 1]:
            j += 1
        x = min(max(x, knots[0]), knots[m - 1])
        d = knots[j + 1] - knots[j]
        v = values[j] + (values[j + 1] - values[j]) * (x - knots[j]) / d if d > 0 else values[j]
        I[i] = Ik[j] + 0.5 * (x - knots[j]) * (values[j] + v)
    out = np.empty(n - 1)
    for i in range(n - 1):
        out[i] = (I[i + 1] - I[i]) / (s[i + 1] - s[i])
    return out


def _insert_knot(law, x):
    k = np.array(sorted(law.knots_mm.tolist() + [float(x)]))  # a few knots: Python's sort, the same order
    return PiecewiseLinearLaw(k, law(k), law.kind)


def _merge_knots(a, b, min_gap):
    """Union of two knot sets (same ends); knots of ``b`` closer than ``min_gap`` to one of ``a`` dropped."""
    # a few knots each: Python floats, a third of the time of the array steps (the same
    # differences, minima and order: the same bits)
    al = a.tolist()
    extra = [x for x in b[1:-1].tolist() if min(abs(y - x) for y in al) >= min_gap]
    return np.array(sorted(al + extra)) if extra else a
