"""The paper's penalty selection: a grid over both penalties, refined around the best cell.

"Sensitivity of Fitting Parameters" (Fan et al., IJCV 2025): each cell's
segmentations read off the penalty paths, cells sharing laws rebuilt once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tendrilkit.pwc.fit import PWCFit, _check_options, _finish
from tendrilkit.pwc.costs import _check_signal
from tendrilkit.pwc.laws import PiecewiseLinearLaw, _Joiner
from tendrilkit.pwc.rebuild import _law_sse
from tendrilkit.pwc.refine import _refine_laws
from tendrilkit.pwc.search import penalty_path
from tendrilkit.pwc.signals import _prepare

__all__ = ["GridLevel", "GridSearch", "grid_search_penalties"]


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

    Examples
    --------
    >>> from tendrilkit.pwc.datasets import random_pwc_curve
    >>> g = grid_search_penalties(random_pwc_curve(3).points_mm, grid=4, refinements=2)
    >>> len(g.levels), g.converged, g.fit.r2 > 0.999
    (1, True, True)
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

    join_k = _Joiner(*_check_signal(s, fr.kappa, prep.wk))
    join_t = _Joiner(*_check_signal(s, fr.tau, prep.wt))

    def law(path, cache, i, joiner, kind):
        if i not in cache:
            cache[i] = joiner.join(path.bounds[i], kind)
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
            lk = law(path_k, laws_k, i, join_k, "kappa")
            for b, j in enumerate(it):
                lt = law(path_t, laws_t, j, join_t, "tau")
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
        lk, lt = _refine_laws(prep, lk, lt)[:2]
    fit = _finish(prep, lk, lt, bounds_k=path_k.bounds[i], bounds_t=path_t.bounds[j], pen_k=pen_k, pen_t=pen_t,
                  rng_k=(path_k.penalty_lo[i], path_k.penalty_hi[i]), rng_t=(path_t.penalty_lo[j], path_t.penalty_hi[j]),
                  selection="grid", candidates=np.zeros((0, 6)), refined=refine, positions=positions)
    return GridSearch(tuple(levels), pen_k, pen_t, converged, fit, reason)
