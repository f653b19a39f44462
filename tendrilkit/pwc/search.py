"""Search for the optimal segmentation: one penalty, or every penalty at once (the penalty path).

The *search* of the segmentation (:mod:`tendrilkit.pwc` notes): the exact
:math:`O(n^2)` prefix programme, and the pass over segment counts whose lower
convex envelope gives every segmentation optimal for some penalty.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from tendrilkit.exceptions import DegenerateCurveError

__all__ = ["PenaltyPath", "segment_penalty", "penalty_path"]


@njit(cache=True)
def _dp_penalty(C, pen):
    n = C.shape[0] - 1
    F = np.full(n + 1, np.inf)
    arg = np.zeros(n + 1, dtype=np.int64)
    F[0] = 0.0
    for j in range(1, n + 1):
        best = np.inf
        bi = 0
        for i in range(j):
            c = C[i, j]
            if c < np.inf and F[i] < np.inf:
                v = F[i] + c + pen
                if v < best:
                    best = v
                    bi = i
        F[j] = best
        arg[j] = bi
    return F, arg


@njit(cache=True)
def _dp_counts(C, kmax):
    n = C.shape[0] - 1
    G = np.full((kmax + 1, n + 1), np.inf)
    back = np.zeros((kmax + 1, n + 1), dtype=np.int64)
    G[0, 0] = 0.0
    # m: the shortest interval j - i with a finite cost (for line_costs, the minimum segment
    # size). G[k, j] is inf for j < k m and only i in [(k - 1) m, j - m] can give a finite
    # value, so the loops skip the rest: the same optimum and back-pointers
    m = n + 1
    for i in range(n):
        for j in range(i + 1, min(i + m, n + 1)):
            if C[i, j] < np.inf:
                m = j - i
                break
    for k in range(1, kmax + 1):
        for j in range(1, n + 1):
            best = np.inf
            bi = 0
            if j < k * m:
                G[k, j] = best
                back[k, j] = bi
                continue
            for i in range((k - 1) * m, j - m + 1):
                g = G[k - 1, i]
                c = C[i, j]
                if g < np.inf and c < np.inf:
                    v = g + c
                    if v < best:
                        best = v
                        bi = i
            G[k, j] = best
            back[k, j] = bi
    return G, back


@njit(cache=True)
def _path_core(C, kmax):
    """:func:`penalty_path` after its checks, compiled: :func:`_dp_counts`, the lower convex hull of
    :math:`(k, G_k(n))`, its decreasing part, the penalty intervals and every hull count's segmentation
    (back-tracked), the same arithmetic as in Python (a float times an int as a float). Returns
    ``G[:, n]`` (a copy), the counts, their costs, the intervals' ends and the segmentations end to end
    (``flat[ends[i]:ends[i + 1]]``).
    """
    G, back = _dp_counts(C, kmax)
    n = C.shape[0] - 1
    g = G[:, n].copy()
    hull = np.empty(kmax, dtype=np.int64)
    h = 0
    for k in range(1, kmax + 1):
        if not np.isfinite(g[k]):
            continue
        while h >= 2:
            k1, k2 = hull[h - 2], hull[h - 1]
            # drop k2 if it lies on or above the segment k1 -> k
            if (g[k2] - g[k1]) * (k - k1) >= (g[k] - g[k1]) * (k2 - k1):
                h -= 1
            else:
                break
        hull[h] = k
        h += 1
    # keep only the part with decreasing cost (optimal for some penalty >= 0)
    while h >= 2 and g[hull[h - 1]] >= g[hull[h - 2]]:
        h -= 1
    counts = hull[:h].copy()
    costs = np.empty(h)
    for i in range(h):
        costs[i] = g[counts[i]]
    lo = np.zeros(h)
    hi = np.full(h, np.inf)
    for i in range(h - 1):
        slope = (costs[i] - costs[i + 1]) / (counts[i + 1] - counts[i])
        lo[i] = slope
        hi[i + 1] = slope
    ends = np.zeros(h + 1, dtype=np.int64)
    for i in range(h):
        ends[i + 1] = ends[i] + counts[i] + 1
    flat = np.empty(ends[h], dtype=np.int64)
    for i in range(h):
        k = counts[i]
        j = n
        flat[ends[i + 1] - 1] = n
        for kk in range(k, 0, -1):
            j = back[kk, j]
            flat[ends[i] + kk - 1] = j
    return g, counts, costs, lo, hi, flat, ends


def _backtrack(arg: np.ndarray, n: int) -> np.ndarray:
    cuts = [n]
    j = n
    while j > 0:
        j = int(arg[j])
        cuts.append(j)
    return np.array(cuts[::-1], dtype=np.int64)


def segment_penalty(C: np.ndarray, penalty: float) -> tuple[np.ndarray, float]:
    """Exact optimal segmentation for one penalty, :math:`O(n^2)`.

    Parameters
    ----------
    C : (n + 1, n + 1) float array
        Interval costs from :func:`line_costs`.
    penalty : float
        Cost of each segment (dimensionless, module notes), >= 0.

    Returns
    -------
    bounds : (K + 1,) int array
        Segment ``k`` holds samples ``bounds[k] .. bounds[k+1]-1``.
    cost : float
        :math:`\\sum_k C + K \\epsilon` at the optimum.

    Examples
    --------
    A tent-shaped curvature is two lines meeting at 40 mm:

    >>> import numpy as np
    >>> from tendrilkit.pwc import line_costs
    >>> s = np.linspace(0.0, 100.0, 101)
    >>> y = np.interp(s, [0, 40, 100], [0.02, 0.08, 0.03])
    >>> bounds, cost = segment_penalty(line_costs(s, y), 0.01)
    >>> bounds.tolist(), round(cost, 4)
    ([0, 40, 101], 0.02)
    """
    if not penalty >= 0:
        raise ValueError(f"penalty must be >= 0, got {penalty}")
    C = np.ascontiguousarray(C, dtype=float)
    if C.ndim != 2 or C.shape[0] < 2 or C.shape[0] != C.shape[1]:
        raise ValueError(f"C must be a square cost table (n + 1, n + 1) with n >= 1, got {C.shape}")
    n = C.shape[0] - 1
    F, arg = _dp_penalty(C, float(penalty))
    if not np.isfinite(F[n]):
        raise DegenerateCurveError(f"no segmentation of {n} samples with the minimum segment size")
    return _backtrack(arg, n), float(F[n])


@dataclass(frozen=True, eq=False)
class PenaltyPath:
    """Every segmentation that is optimal for some penalty.

    Attributes
    ----------
    counts : (m,) int array
        Segment counts on the lower envelope, increasing.
    costs : (m,) float array
        Their optimal costs without penalty :math:`G_K` (dimensionless).
    penalty_lo, penalty_hi : (m,) float arrays
        The segmentation with ``counts[i]`` segments is optimal for every
        penalty in ``[penalty_lo[i], penalty_hi[i]]`` (``inf`` for 1 segment).
    bounds : tuple of (K + 1,) int arrays
        The segmentations (sample boundaries).
    all_costs : (kmax + 1,) float array
        :math:`G_K` for every ``K`` (``inf`` if impossible), the curve the
        envelope is taken of.
    """

    counts: np.ndarray
    costs: np.ndarray
    penalty_lo: np.ndarray
    penalty_hi: np.ndarray
    bounds: tuple
    all_costs: np.ndarray

    def at(self, penalty: float) -> np.ndarray:
        """The optimal segmentation (sample boundaries) for ``penalty``."""
        return self.bounds[self.index(penalty)]

    def index(self, penalty: float) -> int:
        """Index in the path of the segmentation optimal for ``penalty``."""
        if not penalty >= 0:
            raise ValueError(f"penalty must be >= 0, got {penalty}")
        v = self.costs + self.counts * float(penalty)
        return int(np.argmin(v))  # first minimum: the fewest segments on a tie


def penalty_path(C: np.ndarray, *, kmax: int | None = None) -> PenaltyPath:
    """All optimal segmentations over every penalty, from one pass over counts.

    :math:`G_k(j) = \\min_i G_{k-1}(i) + C_{ij}`; for a penalty
    :math:`\\epsilon` the optimum has :math:`\\arg\\min_k G_k(n) + k\\epsilon`
    segments, so the segmentations on the lower convex envelope of
    :math:`k \\mapsto G_k(n)` are all the optima, each over an interval of
    penalties. :math:`O(k_{max} n^2)`.

    Parameters
    ----------
    C : (n + 1, n + 1) float array
        Interval costs from :func:`line_costs`.
    kmax : int, optional
        Largest segment count considered (default: all possible). With a
        smaller ``kmax`` the path is exact for penalties above the returned
        ``penalty_lo[-1]``.

    Examples
    --------
    >>> import numpy as np
    >>> from tendrilkit.pwc import line_costs
    >>> s = np.linspace(0.0, 100.0, 101)
    >>> y = np.interp(s, [0, 40, 100], [0.02, 0.08, 0.03])
    >>> path = penalty_path(line_costs(s, y), kmax=4)
    >>> path.counts.tolist(), path.at(0.01).tolist()
    ([1, 2], [0, 40, 101])
    """
    C = np.ascontiguousarray(C, dtype=float)
    n = C.shape[0] - 1
    # the largest feasible count: n // min_size, min_size read off the costs
    min_size = 1
    while min_size <= n and not np.isfinite(C[0, min_size]):
        min_size += 1
    if min_size > n:
        raise DegenerateCurveError(f"no segment of {n} samples is long enough")
    kcap = n // min_size
    kmax = kcap if kmax is None else max(1, min(int(kmax), kcap))
    g, counts, costs, lo, hi, flat, ends = _path_core(C, kmax)
    bounds = [flat[ends[i]:ends[i + 1]].copy() for i in range(counts.size)]
    return PenaltyPath(counts=counts, costs=costs, penalty_lo=lo, penalty_hi=hi,
                       bounds=tuple(bounds), all_costs=g)
