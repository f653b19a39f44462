"""Piece-wise clothoid fit: segmentation of curvature and torsion, continuity, rebuild.

Paper: "Automatic Piece-Wise Fitting of Curvature & Torsion", "Three-dimensional
Reconstruction" and "Sensitivity of Fitting Parameters" (Fan et al., IJCV
2025); stages 8-9 of ``../shared/REFERENCE_NOTES.md``.

A segmentation is a cost x a search x a penalty:

cost
    :func:`line_costs` gives the cost of one straight line over every interval
    of samples ``[i, j)``, computed once per signal. ``score="l2"``: the
    weighted least-squares residual (prefix sums, :math:`O(n^2)`);
    ``score="l1"``: the paper's score, the same least-squares line scored by
    its sum of absolute residuals (the reference fits lines by least squares
    and scores them by absolute error; an exact least-absolute-deviation line
    per interval would cost a linear programme each), :math:`O(n^3)` compiled.
search
    :func:`segment_penalty` is the exact :math:`O(n^2)` prefix programme
    :math:`F_j = \\min_i F_i + C_{ij} + \\epsilon`; it has the same optimum as
    the paper's interval programme
    :math:`J(a, b) = \\min\\{\\epsilon + E(a, b), \\min_m J(a, m) + J(m, b)\\}`
    (:math:`O(n^3)`). :func:`penalty_path` runs one pass over segment counts
    (:math:`G_k(j)`, the best cost of ``j`` samples in ``k`` segments) and
    returns every segmentation that is optimal for some penalty: the lower
    convex envelope of :math:`G_k(n) + k \\epsilon`, with the exact penalty
    interval of each.
penalty
    Dimensionless. The signal :math:`y` (curvature or torsion, 1/mm) is
    centred and divided by its weighted standard deviation
    :math:`\\sigma` (or, for ``l1``, its mean absolute deviation), arc length by
    the curve length, and a segmentation's cost is divided by the total weight.
    The cost of a segmentation is then the *fraction of the signal's
    variance left unexplained* (``l2``), and the penalty :math:`\\epsilon` is the
    fraction of the variance a new segment must explain to be worth adding.
    Values do not depend on the unit of length, on the number of samples (for
    uniform sampling) or on the size of the signal: 0.01 means "a segment
    must explain 1 % of the variance". To keep an almost constant signal from
    being split on its noise, :math:`\\sigma^2` is floored at
    :math:`(10^{-2} \\text{ rad} / L)^2`.

Torsion samples are weighted by :math:`\\kappa^2` (torsion turns the shape in
proportion to the curvature, and is undefined where the curvature is zero, see
:mod:`tendrilkit.frenet`).

Continuity (:func:`join_segments`): adjacent lines are joined at their
intersection; a join that falls outside the span of its two segments (or
before the previous join; parallel lines never meet) *overshoots*, and the two
segments are merged, as the paper does. The values at the resulting knots are
then refitted by continuous piece-wise linear least squares, so the law is the
best continuous fit with those knots (the reference keeps the joined
polyline, which is not).

Rebuild (:func:`rebuild_curve`): the Frenet frame is integrated with exact
rotations per step (:func:`tendrilkit.frenet.integrate_frenet`) using the
laws' exact mean over each step, positions by the trapezoidal rule, then
registered rigidly onto the data (SVD, :func:`register_rigid`).

Selection of the penalties (:func:`fit_piecewise_clothoid`):

``selection="auto"`` (default)
    The candidates are the distinct continuous laws of the two penalty paths
    (every segmentation optimal for some penalty, up to ``max_segments``
    each). Starting from one segment each, a forward search moves to the next
    segmentation of either path while the criterion improves; each candidate
    is refined on the 3D points (below), warm-started from the current fit.
    The criterion is the Bayesian information criterion of the registered 3D
    residuals, :math:`3n \\ln(SSE / 3n) + p \\ln(3n)` with :math:`p = 2
    K_\\kappa + 2 K_\\tau + 6` (a value and a position per knot, the rigid
    registration), among fits that reach ``target_r2`` (below the target, the
    higher R^2 wins). BIC adds a segment only when it explains the shape
    beyond the noise; the paper's target-R^2 rule alone (``criterion="r2"``:
    the fewest segments reaching ``target_r2``) stops at few segments on
    precise data (0.999 is about 1 mm rms on a 150 mm tendril) and at many on
    noisy data. tendrilkit's addition (``insertions=True``): each step may
    also add one knot to either law where a score test on the 3D residuals
    asks for it (the hinge whose Jacobian column best explains them), since
    curvature and torsion estimated from noisy points place knots poorly near
    the ends and where torsion is weak.
``selection="fixed"``
    The given ``penalty_kappa``, ``penalty_tau`` (dimensionless, above).
:func:`grid_search_penalties`
    The paper's procedure: a grid over both penalties refined around the best
    cell until :math:`R^2 >` target (and SSE below a bound).

Refinement (``refine=True``, tendrilkit's addition): the knot values and the
inner knot positions of both laws are fitted by Levenberg-Marquardt to the
registered 3D points (analytic Jacobian, compiled). A curvature bias of
:math:`10^{-3}` /mm moves the tip of a 150 mm tendril by about 10 mm, so laws
fitted in curvature space alone (the paper; ``refine=False``) are far less
accurate than the points they came from. With 0.15 mm noise on 120-200 mm
piece-wise clothoids the refined fit lies about 0.05 mm from the true curve
(curvature space alone: about 1 mm).

Scores (Tables 2-3): R^2 of the rebuilt, registered points against the data
about the data's mean, :math:`1 - SSE / \\sum |c_i - \\bar c|^2`, and SSE in
mm^2, for the entire curve, the base quarter and the tip quarter of its
length (each quarter about its own mean).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numba import njit

from tendrilkit.exceptions import DegenerateCurveError
from tendrilkit.frenet import FrenetFrames, _integrate, _orthonormal_frame, auto_smoothing_length_mm, frenet_frames

__all__ = [
    "PiecewiseLinearLaw",
    "PenaltyPath",
    "PWCFit",
    "line_costs",
    "segment_penalty",
    "penalty_path",
    "join_segments",
    "register_rigid",
    "rebuild_curve",
    "fit_scores",
    "fit_piecewise_clothoid",
    "GridLevel",
    "GridSearch",
    "grid_search_penalties",
    "penalty_table",
]

_SIGMA_FLOOR_RAD = 1e-2
#: Refined and inserted knots stay at least this many sample spacings apart.
KNOT_GAP_SAMPLES = 9


# ---------------------------------------------------------------- costs


@njit(cache=True)
def _line_costs(x, y, w, min_size, l1):
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


# ---------------------------------------------------------------- search


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
    for k in range(1, kmax + 1):
        for j in range(1, n + 1):
            best = np.inf
            bi = 0
            for i in range(j):
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
    """
    C = np.ascontiguousarray(C, dtype=float)
    n = C.shape[0] - 1
    finite = np.isfinite(np.diag(C, 1)) if n > 0 else np.array([])
    # the largest feasible count: n // min_size, min_size read off the costs
    min_size = 1
    while min_size <= n and not np.isfinite(C[0, min_size]):
        min_size += 1
    if min_size > n:
        raise DegenerateCurveError(f"no segment of {n} samples is long enough")
    del finite
    kcap = n // min_size
    kmax = kcap if kmax is None else max(1, min(int(kmax), kcap))
    G, back = _dp_counts(C, kmax)
    g = G[:, n]
    ks = [k for k in range(1, kmax + 1) if np.isfinite(g[k])]
    # lower convex hull of (k, g_k), scanning k upwards
    hull: list[int] = []
    for k in ks:
        while len(hull) >= 2:
            k1, k2 = hull[-2], hull[-1]
            # drop k2 if it lies on or above the segment k1 -> k
            if (g[k2] - g[k1]) * (k - k1) >= (g[k] - g[k1]) * (k2 - k1):
                hull.pop()
            else:
                break
        hull.append(k)
    # keep only the part with decreasing cost (optimal for some penalty >= 0)
    while len(hull) >= 2 and g[hull[-1]] >= g[hull[-2]]:
        hull.pop()
    counts = np.array(hull, dtype=np.int64)
    costs = g[counts]
    lo = np.zeros(counts.size)
    hi = np.full(counts.size, np.inf)
    for i in range(counts.size - 1):
        slope = (costs[i] - costs[i + 1]) / (counts[i + 1] - counts[i])
        lo[i] = slope
        hi[i + 1] = slope
    bounds = []
    for k in counts:
        cuts = [n]
        j = n
        for kk in range(int(k), 0, -1):
            j = int(back[kk, j])
            cuts.append(j)
        bounds.append(np.array(cuts[::-1], dtype=np.int64))
    return PenaltyPath(counts=counts, costs=costs, penalty_lo=lo, penalty_hi=hi,
                       bounds=tuple(bounds), all_costs=g.copy())


# ---------------------------------------------------------------- continuity


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


def _hat_matrix(s: np.ndarray, knots: np.ndarray) -> np.ndarray:
    """(n, K+1) matrix A with law(s) = A @ values (linear interpolation)."""
    n, m = s.size, knots.size
    A = np.zeros((n, m))
    j = np.clip(np.searchsorted(knots, s, side="right") - 1, 0, m - 2)
    t = (s - knots[j]) / (knots[j + 1] - knots[j])
    t = np.clip(t, 0.0, 1.0)
    rows = np.arange(n)
    A[rows, j] = 1.0 - t
    A[rows, j + 1] += t
    return A


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
    """
    s, y, w = _check_signal(s_mm, y, weights)
    b = [int(v) for v in np.asarray(bounds)]
    if b[0] != 0 or b[-1] != s.size or any(b2 <= b1 for b1, b2 in zip(b[:-1], b[1:])):
        raise ValueError(f"bounds must increase from 0 to {s.size}, got {b}")
    h_min = float(np.min(np.diff(s)))
    line = _Lines(s, y, w)
    while True:
        lines = [line(a, c) for a, c in zip(b[:-1], b[1:])]
        knots = [float(s[0])]
        bad = None
        for i in range(len(lines) - 1):
            (a1, c1), (a2, c2) = lines[i], lines[i + 1]
            lo, hi = s[b[i]], s[b[i + 2] - 1]
            if a1 == a2:
                bad = i
                break
            x = (c2 - c1) / (a1 - a2)
            if not (lo < x < hi) or x <= knots[-1] + 0.5 * h_min or x >= s[-1] - 0.5 * h_min:
                bad = i
                break
            knots.append(float(x))
        if bad is None:
            break
        del b[bad + 1]
    knots.append(float(s[-1]))
    kn = np.array(knots)
    values = _refit_values(s, y, w, kn)
    return PiecewiseLinearLaw(knots_mm=kn, values=values, kind=kind)


def _refit_values(s, y, w, knots):
    A = _hat_matrix(s, knots)
    sq = np.sqrt(w)
    Aw = A * sq[:, None]
    # a whisper of ridge on the second differences keeps knots with no weight defined
    m = knots.size
    if m > 2:
        D = np.diff(np.eye(m), 2, axis=0) * (1e-6 * np.sqrt(w.sum() / m))
    else:
        D = np.zeros((0, m))
    lhs = np.vstack([Aw, D])
    rhs = np.concatenate([y * sq, np.zeros(D.shape[0])])
    sol, *_ = np.linalg.lstsq(lhs, rhs, rcond=None)
    return sol


# ---------------------------------------------------------------- rebuild and scores


@njit(cache=True)
def _kabsch(P, Q):
    """R, t minimising sum |R p + t - q|^2."""
    n = P.shape[0]
    mp = np.zeros(3)
    mq = np.zeros(3)
    for i in range(n):
        for c in range(3):
            mp[c] += P[i, c]
            mq[c] += Q[i, c]
    mp /= n
    mq /= n
    H = np.zeros((3, 3))
    for i in range(n):
        for a in range(3):
            pa = P[i, a] - mp[a]
            for c in range(3):
                H[a, c] += pa * (Q[i, c] - mq[c])
    U, S, Vt = np.linalg.svd(H)
    d = np.linalg.det(Vt.T @ U.T)
    D = np.eye(3)
    if d < 0:
        D[2, 2] = -1.0
    R = Vt.T @ D @ U.T
    t = mq - R @ mp
    return R, t


@njit(cache=True)
def _registered_sse(s, k_step, t_step, F0, p0, data):
    P, T, N, B = _integrate(s, k_step, t_step, F0, p0, False)
    if not np.all(np.isfinite(P)):
        return np.inf
    R, t = _kabsch(P, data)
    sse = 0.0
    for i in range(P.shape[0]):
        for c in range(3):
            v = R[c, 0] * P[i, 0] + R[c, 1] * P[i, 1] + R[c, 2] * P[i, 2] + t[c] - data[i, c]
            sse += v * v
    return sse


def register_rigid(P: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rigid transform taking ``P`` onto ``Q`` in least squares (SVD, no scaling).

    Parameters
    ----------
    P, Q : (n, 3) float arrays
        Corresponding points, mm.

    Returns
    -------
    R : (3, 3) float array
        Proper rotation (det +1).
    t : (3,) float array
        Translation, mm: ``Q ~ P @ R.T + t``.
    """
    P = np.ascontiguousarray(P, dtype=float)
    Q = np.ascontiguousarray(Q, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape != Q.shape:
        raise ValueError(f"P and Q must have the same shape (n, 3), got {P.shape} and {Q.shape}")
    if P.shape[0] < 3:
        raise ValueError(f"P must have at least 3 points, got {P.shape[0]}")
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(Q))):
        raise ValueError("P and Q must be finite (no NaN or inf)")
    return _kabsch(P, Q)


def rebuild_curve(
    s_mm: np.ndarray,
    kappa_law: PiecewiseLinearLaw,
    tau_law: PiecewiseLinearLaw,
    data_mm: np.ndarray,
    *,
    frame0: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    positions: str = "trapezoid",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate the laws from the data's base and register onto the data.

    Parameters
    ----------
    s_mm : (n,) float array
        Arc lengths of the data points, mm.
    kappa_law, tau_law : PiecewiseLinearLaw
    data_mm : (n, 3) float array
        The points to register onto, mm.
    frame0 : (T0, N0, B0), optional
        Initial frame (default: the identity; registration fixes the pose).
    positions : {"trapezoid", "exact"}

    Returns
    -------
    points_mm : (n, 3) float array
        Rebuilt and registered points, mm.
    R : (3, 3) float array
    t : (3,) float array
        The registration: ``points = P_integrated @ R.T + t``.
    """
    s = np.asarray(s_mm, dtype=float)
    data = np.ascontiguousarray(data_mm, dtype=float)
    F0 = np.eye(3) if frame0 is None else _orthonormal_frame(*frame0)
    P, _, _, _ = _integrate(s, kappa_law.step_means(s), tau_law.step_means(s), F0, data[0].copy(), positions == "exact")
    R, t = _kabsch(P, data)
    return P @ R.T + t, R, t


@dataclass(frozen=True, eq=False)
class FitScores:
    """R^2 (about the data's mean) and SSE (mm^2): entire, base quarter, tip quarter."""

    r2_entire: float
    r2_base: float
    r2_tip: float
    sse_entire_mm2: float
    sse_base_mm2: float
    sse_tip_mm2: float
    rmse_mm: float
    max_error_mm: float


def fit_scores(fitted_mm: np.ndarray, data_mm: np.ndarray, s_mm: np.ndarray) -> FitScores:
    """Scores of a fitted curve against the data (Tables 2-3).

    The base quarter holds the points with :math:`s \\le L/4`, the tip quarter
    those with :math:`s \\ge 3L/4`; each quarter's R^2 is about its own mean.
    """
    f = np.asarray(fitted_mm, dtype=float)
    d = np.asarray(data_mm, dtype=float)
    s = np.asarray(s_mm, dtype=float)
    if f.ndim != 2 or f.shape != d.shape or s.shape != (len(d),) or len(d) < 2:
        raise ValueError(f"fitted_mm, data_mm and s_mm must have shapes (n, 3), (n, 3), (n,) with n >= 2, "
                         f"got {f.shape}, {d.shape}, {s.shape}")
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(d)) and np.all(np.isfinite(s))):
        raise ValueError("fitted_mm, data_mm and s_mm must be finite (no NaN or inf)")
    L = s[-1] - s[0]
    err = np.sum((f - d) ** 2, axis=1)

    def r2sse(mask):
        sse = float(err[mask].sum())
        sst = float(np.sum((d[mask] - d[mask].mean(axis=0)) ** 2))
        return (1.0 - sse / sst if sst > 0 else float("nan")), sse

    everything = np.ones(s.size, bool)
    r2e, ssee = r2sse(everything)
    r2b, sseb = r2sse(s - s[0] <= 0.25 * L)
    r2t, sset = r2sse(s - s[0] >= 0.75 * L)
    return FitScores(r2e, r2b, r2t, ssee, sseb, sset, float(np.sqrt(err.mean())), float(np.sqrt(err.max())))


# ---------------------------------------------------------------- refinement


@njit(cache=True)
def _lm_jacobian(s, P, T, B, R, X, Mk, Mt):
    # Mk, Mt: (n-1, p) derivatives of the step means per parameter
    """(3n, p + 6) Jacobian of the registered points (values, then rotation, translation).

    One pass over the points, every parameter's two running sums updated per
    step (rows of the Jacobian written contiguously).
    """
    n = P.shape[0]
    nk = Mk.shape[1]
    p = nk + Mt.shape[1]
    J = np.zeros((3 * n, p + 6))
    A = np.zeros((p, 3))
    C = np.zeros((p, 3))
    for j in range(1, n):
        i = j - 1
        h = s[j] - s[i]
        bx = 0.5 * (B[i, 0] + B[j, 0])
        by = 0.5 * (B[i, 1] + B[j, 1])
        bz = 0.5 * (B[i, 2] + B[j, 2])
        tx = 0.5 * (T[i, 0] + T[j, 0])
        ty = 0.5 * (T[i, 1] + T[j, 1])
        tz = 0.5 * (T[i, 2] + T[j, 2])
        mx = 0.5 * (P[i, 0] + P[j, 0])
        my = 0.5 * (P[i, 1] + P[j, 1])
        mz = 0.5 * (P[i, 2] + P[j, 2])
        px = P[j, 0]
        py = P[j, 1]
        pz = P[j, 2]
        r0 = 3 * j
        for q in range(p):
            if q < nk:
                c = h * Mk[i, q]
                ax = c * bx
                ay = c * by
                az = c * bz
            else:
                c = h * Mt[i, q - nk]
                ax = c * tx
                ay = c * ty
                az = c * tz
            A[q, 0] += ax
            A[q, 1] += ay
            A[q, 2] += az
            C[q, 0] += ay * mz - az * my
            C[q, 1] += az * mx - ax * mz
            C[q, 2] += ax * my - ay * mx
        for q in range(p):
            d0 = A[q, 1] * pz - A[q, 2] * py - C[q, 0]
            d1 = A[q, 2] * px - A[q, 0] * pz - C[q, 1]
            d2 = A[q, 0] * py - A[q, 1] * px - C[q, 2]
            J[r0, q] = R[0, 0] * d0 + R[0, 1] * d1 + R[0, 2] * d2
            J[r0 + 1, q] = R[1, 0] * d0 + R[1, 1] * d1 + R[1, 2] * d2
            J[r0 + 2, q] = R[2, 0] * d0 + R[2, 1] * d1 + R[2, 2] * d2
    m = np.zeros(3)
    for j in range(n):
        for c3 in range(3):
            m[c3] += X[j, c3]
    m /= n
    for j in range(n):
        x = X[j, 0] - m[0]
        y = X[j, 1] - m[1]
        z = X[j, 2] - m[2]
        # small rotation w after R: d = w x X
        J[3 * j + 0, p + 1] = z
        J[3 * j + 0, p + 2] = -y
        J[3 * j + 1, p + 0] = -z
        J[3 * j + 1, p + 2] = x
        J[3 * j + 2, p + 0] = y
        J[3 * j + 2, p + 1] = -x
        J[3 * j + 0, p + 3] = 1.0
        J[3 * j + 1, p + 4] = 1.0
        J[3 * j + 2, p + 5] = 1.0
    return J


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


@njit(cache=True)
def _law_columns(s, knots, values, free_knots):
    """(n-1, p) derivatives of the step means: per value, then per inner knot position."""
    m = knots.shape[0]
    n = s.shape[0]
    p = m + (m - 2 if free_knots else 0)
    G = np.zeros((n - 1, p))
    I = np.empty(n)
    for j in range(m):
        # the step means of the hat of knot j (as _pwl_step_means of the unit vector, the same
        # arithmetic): its integral is 0 up to knots[j-1] and constant from knots[j+1]
        lo = knots[j - 1] if j > 0 else knots[0]
        hi = knots[j + 1] if j < m - 1 else knots[m - 1]
        i0 = 0 if j == 0 else 0.5 * (knots[j] - knots[j - 1]) * (0.0 + 1.0)
        after = i0 + (0.5 * (knots[j + 1] - knots[j]) * (1.0 + 0.0) if j < m - 1 else 0.0)
        for i in range(n):
            x = s[i]
            if x <= lo and j > 0:
                I[i] = 0.0
            elif x >= hi and j < m - 1:
                I[i] = after
            else:
                x = min(max(x, knots[0]), knots[m - 1])
                if j > 0 and x <= knots[j]:
                    a = j - 1  # the rising half: values 0 -> 1
                    d = knots[j] - knots[a]
                    v = 0.0 + (1.0 - 0.0) * (x - knots[a]) / d if d > 0 else 0.0
                    I[i] = 0.0 + 0.5 * (x - knots[a]) * (0.0 + v)
                else:
                    d = knots[j + 1] - knots[j] if j < m - 1 else 0.0
                    v = 1.0 + (0.0 - 1.0) * (x - knots[j]) / d if d > 0 else 1.0
                    I[i] = i0 + 0.5 * (x - knots[j]) * (1.0 + v)
        for i in range(n - 1):
            G[i, j] = (I[i + 1] - I[i]) / (s[i + 1] - s[i])
    if free_knots:
        for k in range(1, m - 1):
            t0, t1, t2 = knots[k - 1], knots[k], knots[k + 1]
            for i in range(n - 1):
                x = 0.5 * (s[i] + s[i + 1])
                if t0 < x <= t1:
                    G[i, m + k - 1] = -(values[k] - values[k - 1]) * (x - t0) / (t1 - t0) ** 2
                elif t1 < x < t2:
                    G[i, m + k - 1] = -(values[k + 1] - values[k]) * (t2 - x) / (t2 - t1) ** 2
    return G


@njit(cache=True)
def _lm_evaluate(s, kk, vk, kt, vt, data):
    P, T, N, B = _integrate(s, _pwl_step_means(s, kk, vk), _pwl_step_means(s, kt, vt),
                            np.eye(3), np.zeros(3), False)
    if not np.all(np.isfinite(P)):
        return np.inf, P, T, B, np.eye(3), P.copy()
    R, t = _kabsch(P, data)
    X = P @ R.T
    f = 0.0
    for j in range(X.shape[0]):
        for c in range(3):
            X[j, c] += t[c]
            d = X[j, c] - data[j, c]
            f += d * d
    return f, P, T, B, R, X


@njit(cache=True)
def _unpack_nb(q, kk, kt, free_knots):
    mk, mt = kk.shape[0], kt.shape[0]
    kk2 = kk.copy()
    kt2 = kt.copy()
    vk = q[:mk].copy()
    o = mk
    if free_knots and mk > 2:
        kk2[1:mk - 1] = q[o:o + mk - 2]
        o += mk - 2
    vt = q[o:o + mt].copy()
    o += mt
    if free_knots and mt > 2:
        kt2[1:mt - 1] = q[o:o + mt - 2]
    return kk2, vk, kt2, vt


@njit(cache=True)
def _min_gap_of(k):
    g = np.inf
    for i in range(k.shape[0] - 1):
        g = min(g, k[i + 1] - k[i])
    return g


@njit(cache=True)
def _lm_core(s, data, kk, vk, kt, vt, free_knots, min_gap, iterations, rtol):
    mk, mt = kk.shape[0], kt.shape[0]
    ik = mk - 2 if (free_knots and mk > 2) else 0
    it = mt - 2 if (free_knots and mt > 2) else 0
    npar = mk + ik + mt + it
    p = np.empty(npar)
    p[:mk] = vk
    p[mk:mk + ik] = kk[1:mk - 1][:ik]
    p[mk + ik:mk + ik + mt] = vt
    p[mk + ik + mt:] = kt[1:mt - 1][:it]
    is_knot = np.zeros(npar, dtype=np.bool_)
    is_knot[mk:mk + ik] = True
    is_knot[mk + ik + mt:] = True
    L = s[-1] - s[0]
    max_value_step = 1.0 / L
    max_knot_step = 0.1 * L
    gap_k = max(min(min_gap, 0.5 * _min_gap_of(kk)), 1e-6 * L)
    gap_t = max(min(min_gap, 0.5 * _min_gap_of(kt)), 1e-6 * L)
    ck = _unpack_nb(p, kk, kt, free_knots)
    f, P, T, B, R, X = _lm_evaluate(s, ck[0], ck[1], ck[2], ck[3], data)
    mu = 1e-4
    n = s.shape[0]
    if not np.isfinite(f):
        return ck[0], ck[1], ck[2], ck[3], f
    r = np.empty(3 * n)
    for _ in range(iterations):
        Gk = _law_columns(s, ck[0], ck[1], free_knots)
        Gt = _law_columns(s, ck[2], ck[3], free_knots)
        J = _lm_jacobian(s, P, T, B, R, X, Gk, Gt)
        for j in range(n):
            for c in range(3):
                r[3 * j + c] = X[j, c] - data[j, c]
        g = J.T @ r
        H = J.T @ J
        m = H.shape[0]
        tr = 0.0
        for i in range(m):
            tr += H[i, i]
        improved = False
        fq = f
        q = p
        cq = ck
        Pq, Tq, Bq, Rq, Xq = P, T, B, R, X
        if not np.all(np.isfinite(H)) or not np.all(np.isfinite(g)):
            break
        for _ in range(12):
            if mu > 1e12:
                break
            A = H.copy()
            for i in range(m):
                A[i, i] += mu * (H[i, i] + 1e-12 * tr + 1e-300)
            step = np.linalg.solve(A, -g)[:npar]
            ok = True
            for i in range(npar):
                v = step[i]
                if not np.isfinite(v):
                    ok = False
                elif is_knot[i]:
                    if abs(v) > max_knot_step:
                        ok = False
                elif abs(v) > max_value_step:
                    ok = False
            if not ok:
                mu *= 10.0
                continue
            q = p + step
            cq = _unpack_nb(q, kk, kt, free_knots)
            if _min_gap_of(cq[0]) < gap_k or _min_gap_of(cq[2]) < gap_t:
                mu *= 10.0
                continue
            fq, Pq, Tq, Bq, Rq, Xq = _lm_evaluate(s, cq[0], cq[1], cq[2], cq[3], data)
            if np.isfinite(fq) and fq < f:
                improved = True
                break
            mu *= 10.0
        if not improved:
            break
        rel = (f - fq) / max(f, 1e-300)
        p, ck, P, T, B, R, X, f = q, cq, Pq, Tq, Bq, Rq, Xq, fq
        mu = max(mu / 10.0, 1e-12)
        if rel < rtol:
            break
    return ck[0], ck[1], ck[2], ck[3], f


def _refine_laws_lm(s, data, kk, vk, kt, vt, *, free_knots=True, min_gap=1.0, iterations=40, rtol=1e-6):
    """Levenberg-Marquardt on the knot values (and inner knot positions), compiled.

    Residuals are the registered 3D errors. The Jacobian is analytic: a change
    :math:`\\delta` of the curvature over step ``i`` rotates the rest of the
    curve about :math:`B_i` through the step by :math:`h_i \\delta` (torsion:
    about :math:`T_i`), so :math:`\\partial P_j = \\sum_{i<j} h_i \\delta_i
    D_i \\times (P_j - P_i)`, two running sums; a parameter moves the step
    means through :func:`_law_columns`. The rigid registration's six freedoms
    are part of each step (variable projection). Each iteration changes a
    value by at most 1/L and a knot by at most L/10 (the reach of the linear
    model); knots stay ``min_gap`` mm apart.
    """
    f = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    kk2, vk2, kt2, vt2, sse = _lm_core(f(s), f(data), f(kk), f(vk), f(kt), f(vt), bool(free_knots),
                                       float(min_gap), int(iterations), float(rtol))
    return (kk2, vk2, kt2, vt2), float(sse)


# ---------------------------------------------------------------- the fit


@dataclass(frozen=True, eq=False)
class PWCFit:
    """A 3D piece-wise clothoid fitted to one centreline.

    Attributes
    ----------
    s_mm : (n,) float array
        Arc length of the smoothed data, mm (the fit's parameter).
    data_mm : (n, 3) float array
        The input resampled at uniform chord length: what the scores measure against.
    points_mm : (n, 3) float array
        The rebuilt piece-wise clothoid, registered onto ``data_mm``, mm.
    kappa_law, tau_law : PiecewiseLinearLaw
        The fitted laws (knots in mm along ``s_mm``, values 1/mm).
    kappa_fit, tau_fit : (n,) float arrays
        The laws at ``s_mm``.
    frames : FrenetFrames
        Smoothed curve, measured curvature and torsion, torsion flags.
    rotation : (3, 3) float array
    translation : (3,) float array
        Registration of the integrated curve (from the identity frame at the
        origin): ``points = P @ rotation.T + translation``.
    scores : FitScores
        R^2 and SSE (mm^2), entire / base quarter / tip quarter.
    penalty_kappa, penalty_tau : float
        Dimensionless penalties (module notes) for which the segmentations in
        ``bounds_kappa``, ``bounds_tau`` are optimal (for ``auto``: the
        geometric middle of the exact interval, or twice its lower end when
        that is unbounded).
    penalty_range_kappa, penalty_range_tau : (2,) float arrays
        The exact penalty interval of those segmentations.
    bounds_kappa, bounds_tau : (K + 1,) int arrays
        Sample boundaries of the penalty-optimal segmentations the fit started
        from (for ``auto``, the last path step taken). With ``refine`` the
        laws' knots are then moved (and, with insertions, added), so the
        laws' knots are the answer, not these.
    selection : str
        ``auto``, ``fixed`` or ``grid``.
    candidates : (m, 6) float array
        For ``auto``: every candidate evaluated, columns ``K_kappa, K_tau,
        R2, SSE_mm2, BIC, chosen``; empty otherwise.
    refined : bool
        Whether the knot values were adjusted on the 3D residuals.
    """

    s_mm: np.ndarray
    data_mm: np.ndarray
    points_mm: np.ndarray
    kappa_law: PiecewiseLinearLaw
    tau_law: PiecewiseLinearLaw
    kappa_fit: np.ndarray
    tau_fit: np.ndarray
    frames: FrenetFrames
    rotation: np.ndarray
    translation: np.ndarray
    scores: FitScores
    penalty_kappa: float
    penalty_tau: float
    penalty_range_kappa: np.ndarray
    penalty_range_tau: np.ndarray
    bounds_kappa: np.ndarray
    bounds_tau: np.ndarray
    selection: str
    candidates: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    refined: bool = False

    @property
    def n_segments_kappa(self) -> int:
        return self.kappa_law.n_segments

    @property
    def n_segments_tau(self) -> int:
        return self.tau_law.n_segments

    @property
    def r2(self) -> float:
        return self.scores.r2_entire

    @property
    def sse_mm2(self) -> float:
        return self.scores.sse_entire_mm2

    def segments(self) -> list[dict]:
        """Rows ``kind, segment, s0_mm, s1_mm, value_s0, value_s1`` (kappa then tau)."""
        rows = []
        for law in (self.kappa_law, self.tau_law):
            for i, (s0, s1, v0, v1) in enumerate(law.segments()):
                rows.append({"kind": law.kind, "segment": i, "s0_mm": s0, "s1_mm": s1,
                             "value_s0": v0, "value_s1": v1})
        return rows


def _mid_penalty(lo: float, hi: float) -> float:
    if not np.isfinite(hi):
        return float(max(lo, 0.0) * 2.0 if lo > 0 else 1.0)
    if lo <= 0:
        return float(hi / 2.0)
    return float(np.sqrt(lo * hi))


def _bic(sse: np.ndarray, n: int, k_kappa: np.ndarray, k_tau: np.ndarray) -> np.ndarray:
    m = 3 * n
    p = 2 * k_kappa + 2 * k_tau + 6
    return m * np.log(np.maximum(sse, 1e-300) / m) + p * np.log(m)


@dataclass(frozen=True, eq=False)
class _Prepared:
    fr: FrenetFrames
    s: np.ndarray
    data: np.ndarray
    wk: np.ndarray
    wt: np.ndarray
    Ck: np.ndarray
    Ct: np.ndarray
    free_knots: bool
    min_gap_mm: float


def _prepare(points_mm, smoothing_length_mm, score, min_segment_mm, n_points, free_knots=True):
    if smoothing_length_mm is None:
        smoothing_length_mm = auto_smoothing_length_mm(points_mm)
    fr = frenet_frames(points_mm, smoothing_length_mm=smoothing_length_mm, n=n_points)
    s = fr.s_mm
    n = s.size
    h = s[-1] / (n - 1)
    seg_mm = 0.5 * smoothing_length_mm if min_segment_mm is None else min_segment_mm
    min_size = int(max(3, np.ceil(seg_mm / h)))
    min_size = min(min_size, n)
    wk = np.ones(n)
    wt = fr.kappa ** 2 * fr.tau_defined
    if not wt.sum() > 0:
        wt = np.ones(n) * 1e-12
    Ck = line_costs(s, fr.kappa, weights=wk, score=score, min_size=min_size)
    Ct = line_costs(s, fr.tau, weights=wt, score=score, min_size=min_size)
    return _Prepared(fr, s, np.ascontiguousarray(fr.data_mm), wk, wt, Ck, Ct, free_knots, float(KNOT_GAP_SAMPLES * h))


def _refine_laws(prep, law_k, law_t, iterations=40, rtol=1e-6):
    s = prep.s
    (kk, vk, kt, vt), sse = _refine_laws_lm(
        s, prep.data, law_k.knots_mm, law_k.values, law_t.knots_mm, law_t.values,
        free_knots=prep.free_knots, min_gap=prep.min_gap_mm, iterations=iterations, rtol=rtol)
    return PiecewiseLinearLaw(kk, vk, "kappa"), PiecewiseLinearLaw(kt, vt, "tau"), sse


def _law_sse(prep, law_k, law_t):
    s = prep.s
    return float(_registered_sse(s, law_k.step_means(s), law_t.step_means(s), np.eye(3), np.zeros(3), prep.data))


def _finish(prep, law_k, law_t, *, bounds_k, bounds_t, pen_k, pen_t, rng_k, rng_t, selection,
            candidates, refined, positions):
    s, data, fr = prep.s, prep.data, prep.fr
    F0 = (fr.T[0], fr.N[0], fr.B[0])
    pts, R, t = rebuild_curve(s, law_k, law_t, data, frame0=F0, positions=positions)
    # report the registration from the identity frame at the origin
    Fm = _orthonormal_frame(*F0)
    R_id = R @ Fm.T
    t_id = t + R @ data[0]
    return PWCFit(
        s_mm=s, data_mm=data, points_mm=pts, kappa_law=law_k, tau_law=law_t,
        kappa_fit=law_k(s), tau_fit=law_t(s), frames=fr, rotation=R_id, translation=t_id,
        scores=fit_scores(pts, data, s), penalty_kappa=float(pen_k), penalty_tau=float(pen_t),
        penalty_range_kappa=np.asarray(rng_k, float), penalty_range_tau=np.asarray(rng_t, float),
        bounds_kappa=np.asarray(bounds_k), bounds_tau=np.asarray(bounds_t), selection=selection,
        candidates=candidates, refined=refined,
    )


def _check_options(selection, criterion, target_r2, max_segments, score, positions):
    if selection not in ("auto", "fixed"):
        raise ValueError(f"selection must be 'auto' or 'fixed', got {selection!r}")
    if criterion not in ("bic", "r2"):
        raise ValueError(f"criterion must be 'bic' or 'r2', got {criterion!r}")
    if not 0 < target_r2 < 1:
        raise ValueError(f"target_r2 must be in (0, 1), got {target_r2}")
    if max_segments < 1:
        raise ValueError(f"max_segments must be >= 1, got {max_segments}")
    if score not in ("l2", "l1"):
        raise ValueError(f"score must be 'l2' or 'l1', got {score!r}")
    if positions not in ("trapezoid", "exact"):
        raise ValueError(f"positions must be 'trapezoid' or 'exact', got {positions!r}")


def _preferred(x, y, target_r2, criterion):
    """Is scored candidate x preferred to y? Reaching target_r2 first; then BIC (or fewer segments)."""
    okx, oky = x[3] >= target_r2, y[3] >= target_r2
    if okx != oky:
        return okx
    if not okx:
        return x[3] > y[3]
    if criterion == "bic":
        return x[4] < y[4]
    return x[0].n_segments + x[1].n_segments < y[0].n_segments + y[1].n_segments


def _auto_search(prep, *, criterion, target_r2, max_segments, refine, lookahead, insertions,
                 quick_iterations, max_candidates):
    """The automatic selection of :func:`fit_piecewise_clothoid` on prepared signals."""
    s, fr = prep.s, prep.fr
    path_k = penalty_path(prep.Ck, kmax=max_segments)
    path_t = penalty_path(prep.Ct, kmax=max_segments)
    # continuity may merge segments, so several path entries can give one law: keep each once
    laws_k = _DistinctLaws(s, fr.kappa, prep.wk, path_k, "kappa")
    laws_t = _DistinctLaws(s, fr.tau, prep.wt, path_t, "tau")
    n = s.size
    sst = float(np.sum((prep.data - prep.data.mean(axis=0)) ** 2))
    rows: list[list[float]] = []
    quick = (quick_iterations, 1e-4)

    def scored(lk, lt, sse, row=None):
        """(lk, lt, sse, r2, bic, row index), recorded in the candidates table."""
        r2 = 1.0 - sse / sst
        bic = float(_bic(np.array(sse), n, np.array(lk.n_segments), np.array(lt.n_segments)))
        entry = [lk.n_segments, lt.n_segments, r2, sse, bic, 0.0]
        if row is None:
            rows.append(entry)
            row = len(rows) - 1
        else:
            rows[row] = entry
        return (lk, lt, sse, r2, bic, row)

    def from_path(a, b, cur=None, move=None):
        """Candidate (a, b) of the paths. Without refinement: the laws as they are.

        With refinement, from the best of three starts: the path law, the
        current refined law read at the path law's knots, and at the union of
        both knot sets (which starts exactly from the current fit); the other
        law (``move`` names the one that changes) keeps its current refined state.
        """
        if not refine:
            return scored(laws_k[a], laws_t[b], _law_sse(prep, laws_k[a], laws_t[b]))
        if cur is None:
            # the path laws, or constants (median curvature; curvature-weighted median
            # torsion, or none): noisy estimates can start the fit in a wrong basin
            ends_k, ends_t = laws_k[a].knots_mm, laws_t[b].knots_mm
            kc = PiecewiseLinearLaw(ends_k, np.full(ends_k.size, float(np.median(fr.kappa))), "kappa")
            tc = PiecewiseLinearLaw(ends_t, np.full(ends_t.size, _weighted_median(fr.tau, prep.wt)), "tau")
            t0 = PiecewiseLinearLaw(ends_t, np.zeros(ends_t.size), "tau")
            starts = [(laws_k[a], laws_t[b]), (kc, tc), (kc, t0), (laws_k[a], t0)]
        elif move == "k":
            k_new, k_cur, t_cur = laws_k[a].knots_mm, cur[0], cur[1]
            u = _merge_knots(k_new, k_cur.knots_mm, prep.min_gap_mm)
            starts = [(laws_k[a], t_cur), (PiecewiseLinearLaw(k_new, k_cur(k_new), "kappa"), t_cur),
                      (PiecewiseLinearLaw(u, k_cur(u), "kappa"), t_cur)]
        else:
            t_new, k_cur, t_cur = laws_t[b].knots_mm, cur[0], cur[1]
            u = _merge_knots(t_new, t_cur.knots_mm, prep.min_gap_mm)
            starts = [(k_cur, laws_t[b]), (k_cur, PiecewiseLinearLaw(t_new, t_cur(t_new), "tau")),
                      (k_cur, PiecewiseLinearLaw(u, t_cur(u), "tau"))]
        start_k, start_t = min(starts, key=lambda x: _law_sse(prep, x[0], x[1]))
        return scored(*_refine_laws(prep, start_k, start_t, *quick))

    def better(x, y):
        return _preferred(x, y, target_r2, criterion)

    # Forward search from one segment each: move to one of the next `lookahead`
    # segmentations of either penalty path, or (refine and insertions) add the knot
    # the score test asks for, while the criterion improves.
    state = (0, 0)
    cur = from_path(0, 0)
    while not (criterion == "r2" and cur[3] >= target_r2) and len(rows) < max_candidates:
        a0, b0 = state
        tried = [((a0 + d, b0), from_path(a0 + d, b0, cur, "k"))
                 for d in range(1, lookahead + 1) if laws_k.has(a0 + d)]
        tried += [((a0, b0 + d), from_path(a0, b0 + d, cur, "t"))
                  for d in range(1, lookahead + 1) if laws_t.has(b0 + d)]
        if refine and insertions:
            for which, found in zip("kt", _best_insertions(prep, cur[0], cur[1])):
                law = cur[0] if which == "k" else cur[1]
                if found is None or law.n_segments >= max_segments:
                    continue
                sk = _insert_knot(cur[0], found[0]) if which == "k" else cur[0]
                st = _insert_knot(cur[1], found[0]) if which == "t" else cur[1]
                tried.append(((a0, b0), scored(*_refine_laws(prep, sk, st, *quick))))
        if not tried:
            break
        m, cand = tried[0]
        for mm, cc in tried[1:]:
            if better(cc, cand):
                m, cand = mm, cc
        if not better(cand, cur):
            break
        if refine:  # candidates are compared after a few iterations; the chosen one converges
            cand = scored(*_refine_laws(prep, cand[0], cand[1]), row=cand[5])
        state, cur = m, cand
    a, b = state
    lk, lt, irow = cur[0], cur[1], cur[5]
    rows[irow][5] = 1.0
    candidates = np.array(rows)
    pa, pb = laws_k.idx[a], laws_t.idx[b]
    rk = (path_k.penalty_lo[pa], path_k.penalty_hi[pa])
    rt = (path_t.penalty_lo[pb], path_t.penalty_hi[pb])
    return {"prep": prep, "lk": lk, "lt": lt, "bounds_k": path_k.bounds[pa], "bounds_t": path_t.bounds[pb],
            "rk": rk, "rt": rt, "candidates": candidates, "best": cur}


def fit_piecewise_clothoid(
    points_mm: np.ndarray,
    *,
    selection: str = "auto",
    criterion: str = "bic",
    target_r2: float = 0.999,
    penalty_kappa: float = 0.01,
    penalty_tau: float = 0.01,
    score: str = "l2",
    smoothing_length_mm: float | None = None,
    min_segment_mm: float | None = None,
    max_segments: int = 10,
    refine: bool = True,
    positions: str = "trapezoid",
    n_points: int | None = None,
    lookahead: int = 1,
    insertions: bool = True,
    quick_iterations: int = 4,
    max_candidates: int = 40,
    retries: bool = True,
) -> PWCFit:
    """Fit a 3D piece-wise clothoid to an ordered centreline.

    Parameters
    ----------
    points_mm : (n, 3) float array
        Ordered centreline, base to tip, mm.
    selection : {"auto", "fixed"}, keyword-only
        ``auto``: the segmentations on both penalty paths, searched as in the
        module notes and chosen by ``criterion``; ``fixed``:
        ``penalty_kappa`` and ``penalty_tau``.
    criterion : {"bic", "r2"}, keyword-only
        ``bic``: least BIC of the 3D residuals, then more segments only if
        ``target_r2`` is not reached; ``r2``: the fewest segments reaching
        ``target_r2`` (the paper's stopping rule). See the module notes.
    target_r2 : float
        R^2 of the 3D points to reach (paper: 0.999).
    penalty_kappa, penalty_tau : float
        Dimensionless penalties for ``fixed`` (fraction of the signal's
        variance a segment must explain).
    score : {"l2", "l1"}
        Segment score: least squares, or the paper's absolute error.
    smoothing_length_mm : float, optional
        Half-gain wavelength of the Whittaker smoother, mm
        (:mod:`tendrilkit.frenet`); default: chosen per curve from its noise
        and coiling (:func:`tendrilkit.frenet.auto_smoothing_length_mm`,
        about 20 mm for 0.15 mm noise).
    min_segment_mm : float, optional
        Shortest segment, mm (default: half the smoothing length; at least 3 samples).
    max_segments : int
        Most segments per law considered by ``auto``.
    refine : bool
        Fit the knots' values and inner positions on the registered 3D points
        (module notes); off: the paper's curvature/torsion-space fit.
    positions : {"trapezoid", "exact"}
        Position rule of the rebuild (:func:`tendrilkit.frenet.integrate_frenet`).
    n_points : int, optional
        Resample to this many points (default: as many as given).
    lookahead : int
        ``auto``: how many further segmentations of each path a step may jump to.
    insertions : bool
        ``auto`` with ``refine``: also try the knot asked for by the score test.
    quick_iterations : int
        ``auto``: Levenberg-Marquardt iterations when comparing candidates (the
        chosen one is then refined to convergence).
    max_candidates : int
        ``auto``: the search stops after evaluating this many candidates (a
        bound on the time per frame on hard, noisy curves).
    retries : bool
        ``auto`` with ``refine``: when the search ends below ``target_r2``,
        search again with one more step of lookahead, then with half the
        smoothing length, and keep the preferred result.

    Returns
    -------
    PWCFit

    Raises
    ------
    DegenerateCurveError
        Too few distinct points, zero length.
    ValueError
        An option out of range (named).
    """
    _check_options(selection, criterion, target_r2, max_segments, score, positions)
    prep = _prepare(points_mm, smoothing_length_mm, score, min_segment_mm, n_points)
    s, fr = prep.s, prep.fr
    if selection == "fixed":
        bk, _ = segment_penalty(prep.Ck, penalty_kappa)
        bt, _ = segment_penalty(prep.Ct, penalty_tau)
        law_k = join_segments(s, fr.kappa, bk, weights=prep.wk, kind="kappa")
        law_t = join_segments(s, fr.tau, bt, weights=prep.wt, kind="tau")
        if refine:
            law_k, law_t, _ = _refine_laws(prep, law_k, law_t)
        return _finish(prep, law_k, law_t, bounds_k=bk, bounds_t=bt, pen_k=penalty_kappa,
                       pen_t=penalty_tau, rng_k=[penalty_kappa] * 2, rng_t=[penalty_tau] * 2,
                       selection="fixed", candidates=np.zeros((0, 6)), refined=refine, positions=positions)

    kw = dict(criterion=criterion, target_r2=target_r2, max_segments=max_segments, refine=refine,
              insertions=insertions, quick_iterations=quick_iterations, max_candidates=max_candidates)
    res = _auto_search(prep, lookahead=lookahead, **kw)
    if refine and retries and res["best"][3] < target_r2:
        # a search that misses the target may have taken a wrong turn: look further along
        # the paths, and smooth less (short segments); keep the preferred result
        tries = [(prep, lookahead + 1)]
        L_s = prep.fr.smoothing_length_mm
        if L_s > 8 * (s[-1] / (s.size - 1)):
            tries.append((_prepare(points_mm, 0.5 * L_s, score, min_segment_mm, n_points), lookahead))
        for prep_, look in tries:
            alt = _auto_search(prep_, lookahead=look, **kw)
            if _preferred(alt["best"], res["best"], target_r2, criterion):
                res = alt
            if res["best"][3] >= target_r2:
                break
    rk, rt = res["rk"], res["rt"]
    return _finish(res["prep"], res["lk"], res["lt"], bounds_k=res["bounds_k"], bounds_t=res["bounds_t"],
                   pen_k=_mid_penalty(*rk), pen_t=_mid_penalty(*rt), rng_k=rk, rng_t=rt,
                   selection="auto", candidates=res["candidates"], refined=refine, positions=positions)


def _best_insertions(prep, lk, lt):
    """Score test for one more knot: the best new knot position for each law.

    At the refined fit, adding a knot at ``x`` adds the hinge :math:`(s - x)_+`
    to the law's span; the first-order drop of the 3D SSE is
    :math:`(c_\\perp^T r)^2 / |c_\\perp|^2` with :math:`c` the hinge's
    Jacobian column made orthogonal to the current ones. Returns
    ``(x_kappa, gain_kappa), (x_tau, gain_tau)`` (``None`` where no room).
    """
    s, data = prep.s, prep.data
    f, P, T, B, R, X = _lm_evaluate(s, lk.knots_mm, lk.values, lt.knots_mm, lt.values, data)
    Gk = _law_columns(s, lk.knots_mm, lk.values, prep.free_knots)
    Gt = _law_columns(s, lt.knots_mm, lt.values, prep.free_knots)
    J = _lm_jacobian(s, P, T, B, R, X, Gk, Gt)
    # projection off the current columns by the (small) normal equations; column-scaled
    scale = np.sqrt(np.einsum("ij,ij->j", J, J)) + 1e-300
    Js = J / scale
    H = Js.T @ Js
    H[np.diag_indices_from(H)] += 1e-10
    r = (X - data).ravel()
    gap = prep.min_gap_mm
    xs = np.arange(s[0] + gap, s[-1] - gap, max(gap / 2, (s[-1] - s[0]) / 200))
    a, b = s[:-1, None], s[1:, None]
    hinge = np.where(b <= xs, 0.0, np.where(a >= xs, 0.5 * (a + b) - xs, (b - xs) ** 2 / (2 * (b - a))))
    none = np.zeros((s.size - 1, 0))
    out = []
    for law, cols in ((lk, (hinge, none)), (lt, (none, hinge))):
        ok = np.min(np.abs(xs[:, None] - law.knots_mm[None, :]), axis=1) >= gap
        if not ok.any():
            out.append(None)
            continue
        C = _lm_jacobian(s, P, T, B, R, X, np.ascontiguousarray(cols[0][:, ok] if cols[0].shape[1] else cols[0]),
                         np.ascontiguousarray(cols[1][:, ok] if cols[1].shape[1] else cols[1]))[:, : int(ok.sum())]
        Cp = C - Js @ np.linalg.solve(H, Js.T @ C)
        num = (Cp.T @ r) ** 2
        den = np.einsum("ij,ij->j", Cp, Cp) + 1e-300
        j = int(np.argmax(num / den))
        out.append((float(xs[ok][j]), float(num[j] / den[j])))
    return out


def _insert_knot(law, x):
    k = np.sort(np.concatenate([law.knots_mm, [x]]))
    return PiecewiseLinearLaw(k, law(k), law.kind)


def _weighted_median(y, w):
    if not w.sum() > 0:
        return 0.0
    o = np.argsort(y)
    c = np.cumsum(w[o])
    return float(y[o][np.searchsorted(c, 0.5 * c[-1])])


def _merge_knots(a, b, min_gap):
    """Union of two knot sets (same ends); knots of ``b`` closer than ``min_gap`` to one of ``a`` dropped."""
    extra = [x for x in b[1:-1] if np.min(np.abs(a - x)) >= min_gap]
    return np.sort(np.concatenate([a, extra])) if extra else a


def _distinct_laws(s, y, w, path, kind):
    """Continuous laws of a penalty path, one per distinct knot set (path indices kept)."""
    laws = _DistinctLaws(s, y, w, path, kind)
    laws.has(len(path.bounds))
    return laws.idx, laws.laws


class _DistinctLaws:
    """The continuous laws of a penalty path, one per distinct knot set, made on demand.

    The forward search looks at the first few entries of a path only; each law
    costs a join and a refit, so they are made in path order as far as asked.
    ``laws[a]`` is the ``a``-th distinct law, ``idx[a]`` its index in the path.
    """

    def __init__(self, s, y, w, path, kind):
        self.s, self.y, self.w, self.path, self.kind = s, y, w, path, kind
        self.idx: list[int] = []
        self.laws: list[PiecewiseLinearLaw] = []
        self._seen: set = set()
        self._next = 0

    def has(self, a: int) -> bool:
        """Is there an ``a``-th distinct law (made if needed)?"""
        while len(self.laws) <= a and self._next < len(self.path.bounds):
            i = self._next
            self._next += 1
            law = join_segments(self.s, self.y, self.path.bounds[i], weights=self.w, kind=self.kind)
            key = tuple(np.round(law.knots_mm, 9))
            if key not in self._seen:
                self._seen.add(key)
                self.idx.append(i)
                self.laws.append(law)
        return a < len(self.laws)

    def __getitem__(self, a: int) -> PiecewiseLinearLaw:
        if not self.has(a):
            raise IndexError(a)
        return self.laws[a]


# ---------------------------------------------------------------- the paper's grid search


@dataclass(frozen=True, eq=False)
class GridLevel:
    """One grid of the paper's penalty search.

    Attributes
    ----------
    penalty_kappa, penalty_tau : (G,) float arrays
        The grid's penalties (dimensionless); rows index kappa, columns tau.
    r2, sse_mm2 : (G, G) float arrays
        R^2 and SSE (mm^2) of the rebuilt curve for each cell.
    n_kappa, n_tau : (G, G) int arrays
        Segments of each cell's laws.
    best : tuple[int, int]
        The cell chosen (highest R^2, then lowest SSE).
    """

    penalty_kappa: np.ndarray
    penalty_tau: np.ndarray
    r2: np.ndarray
    sse_mm2: np.ndarray
    n_kappa: np.ndarray
    n_tau: np.ndarray
    best: tuple


@dataclass(frozen=True, eq=False)
class GridSearch:
    """The paper's grid search: its levels and the fit at the chosen penalties."""

    levels: tuple
    penalty_kappa: float
    penalty_tau: float
    converged: bool
    fit: PWCFit
    reason: str = ""  #: why the search stopped, in words


def grid_search_penalties(
    points_mm: np.ndarray,
    *,
    kappa_range: tuple[float, float] = (0.0, 0.2),
    tau_range: tuple[float, float] = (0.0, 0.2),
    grid: int = 10,
    refinements: int = 4,
    target_r2: float = 0.999,
    target_sse_mm2: float | None = None,
    score: str = "l2",
    smoothing_length_mm: float | None = None,
    min_segment_mm: float | None = None,
    refine: bool = False,
    positions: str = "trapezoid",
) -> GridSearch:
    """The paper's penalty selection: a 2D grid refined around the best cell.

    Each level evaluates a ``grid`` x ``grid`` grid of (curvature, torsion)
    penalties; the next level spans the neighbours of the best cell (highest
    R^2, ties broken by lowest SSE); it stops when the best cell reaches
    ``target_r2`` (and ``target_sse_mm2`` if given) or after
    ``refinements`` levels. (The paper reports about 200 s per frame and
    3-4 levels.) Here each cell is exact and cheap: the penalty paths give
    every cell's optimal segmentation without a programme per cell, and cells
    with the same segmentations share one rebuild.

    Parameters
    ----------
    points_mm : (n, 3) float array
        Ordered centreline, mm.
    kappa_range, tau_range : (float, float)
        Initial penalty ranges (dimensionless, :mod:`tendrilkit.pwc`; the
        paper's [0, 1350] and [0, 3450] are in its own unnormalised units).
    grid : int
        Cells per axis.
    refinements : int
        Most levels.
    target_r2, target_sse_mm2 : float
        Stopping rule (the paper: R^2 > 0.999 and SSE < 0.001 in an unstated
        unit; SSE here is in mm^2, ``None`` to ignore it).
    refine : bool
        Also fit the knots on the 3D points for the final fit (the paper does not).

    Returns
    -------
    GridSearch
    """
    _check_options("fixed", "bic", target_r2, 1, score, positions)
    if grid < 2:
        raise ValueError(f"grid must be >= 2, got {grid}")
    prep = _prepare(points_mm, smoothing_length_mm, score, min_segment_mm, None)
    s, fr = prep.s, prep.fr
    path_k = penalty_path(prep.Ck)
    path_t = penalty_path(prep.Ct)
    laws_k: dict[int, PiecewiseLinearLaw] = {}
    laws_t: dict[int, PiecewiseLinearLaw] = {}
    cells: dict[tuple[int, int], float] = {}
    sst = float(np.sum((prep.data - prep.data.mean(axis=0)) ** 2))

    def law(path, cache, i, y, w, kind):
        if i not in cache:
            cache[i] = join_segments(s, y, path.bounds[i], weights=w, kind=kind)
        return cache[i]

    levels = []
    (k0, k1), (t0, t1) = kappa_range, tau_range
    converged = False
    best_all = None  # (r2, -sse, pen_k, pen_t): the best cell of every level so far (refining never loses it)
    reason = f"{max(1, refinements)} levels without reaching R² > {target_r2:g}"
    for _ in range(max(1, refinements)):
        # the previous best cell is always on the refined grid
        pk = np.unique(np.r_[np.linspace(k0, k1, grid), [] if best_all is None else [best_all[2]]])
        pt = np.unique(np.r_[np.linspace(t0, t1, grid), [] if best_all is None else [best_all[3]]])
        ik = [path_k.index(p) for p in pk]
        it = [path_t.index(p) for p in pt]
        r2 = np.empty((len(pk), len(pt)))
        sse = np.empty_like(r2)
        nk = np.empty(r2.shape, int)
        nt = np.empty(r2.shape, int)
        for a, i in enumerate(ik):
            lk = law(path_k, laws_k, i, fr.kappa, prep.wk, "kappa")
            for b, j in enumerate(it):
                lt = law(path_t, laws_t, j, fr.tau, prep.wt, "tau")
                if (i, j) not in cells:
                    cells[(i, j)] = _law_sse(prep, lk, lt)
                sse[a, b] = cells[(i, j)]
                r2[a, b] = 1.0 - sse[a, b] / sst
                nk[a, b], nt[a, b] = lk.n_segments, lt.n_segments
        order = np.lexsort((sse.ravel(), -r2.ravel()))
        a, b = np.unravel_index(int(order[0]), r2.shape)
        levels.append(GridLevel(pk, pt, r2, sse, nk, nt, (int(a), int(b))))
        cand = (float(r2[a, b]), -float(sse[a, b]), float(pk[a]), float(pt[b]))
        improved = best_all is None or cand[:2] > best_all[:2]
        if improved:
            best_all = cand
        if best_all[0] > target_r2 and (target_sse_mm2 is None or -best_all[1] < target_sse_mm2):
            converged = True
            reason = f"R² {best_all[0]:.5f} > {target_r2:g} at level {len(levels)}"
            break
        if len(levels) > 1 and not improved:
            reason = (f"refining no longer improves R² (best {best_all[0]:.5f} < {target_r2:g}): the best cells already "
                      f"give the most segments these data support; a finer grid cannot reach the target")
            break
        k0, k1 = pk[max(a - 1, 0)], pk[min(a + 1, len(pk) - 1)]
        t0, t1 = pt[max(b - 1, 0)], pt[min(b + 1, len(pt) - 1)]
    pen_k, pen_t = best_all[2], best_all[3]
    i, j = path_k.index(pen_k), path_t.index(pen_t)
    lk, lt = laws_k[i], laws_t[j]
    if refine:
        lk, lt, _ = _refine_laws(prep, lk, lt)
    fit = _finish(prep, lk, lt, bounds_k=path_k.bounds[i], bounds_t=path_t.bounds[j], pen_k=pen_k, pen_t=pen_t,
                  rng_k=(path_k.penalty_lo[i], path_k.penalty_hi[i]), rng_t=(path_t.penalty_lo[j], path_t.penalty_hi[j]),
                  selection="grid", candidates=np.zeros((0, 6)), refined=refine, positions=positions)
    return GridSearch(tuple(levels), pen_k, pen_t, converged, fit, reason)


def penalty_table(points_mm: np.ndarray, penalties: list[tuple[float, float]], **options) -> list[dict]:
    """Table 3 of the paper: segments, R^2 and SSE for given penalty pairs.

    ``options`` go to :func:`fit_piecewise_clothoid` (``selection="fixed"``;
    ``refine`` defaults to False, as in the paper). One row per pair:
    ``penalty_kappa, penalty_tau, n_kappa, n_tau, r2_entire, r2_base, r2_tip,
    sse_entire_mm2, sse_base_mm2, sse_tip_mm2``.
    """
    options = {"refine": False, **options, "selection": "fixed"}
    rows = []
    for pk, pt in penalties:
        f = fit_piecewise_clothoid(points_mm, penalty_kappa=pk, penalty_tau=pt, **options)
        sc = f.scores
        rows.append({"penalty_kappa": pk, "penalty_tau": pt, "n_kappa": f.n_segments_kappa,
                     "n_tau": f.n_segments_tau, "r2_entire": sc.r2_entire, "r2_base": sc.r2_base,
                     "r2_tip": sc.r2_tip, "sse_entire_mm2": sc.sse_entire_mm2,
                     "sse_base_mm2": sc.sse_base_mm2, "sse_tip_mm2": sc.sse_tip_mm2})
    return rows
