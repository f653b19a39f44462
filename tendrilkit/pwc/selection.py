"""Automatic selection of the penalties: a forward search along both penalty paths.

``selection="auto"`` of :func:`tendrilkit.pwc.fit_piecewise_clothoid`
(:mod:`tendrilkit.pwc` notes, "Selection of the penalties"): the distinct
continuous laws of the two paths, compared by BIC of the 3D residuals (or the
paper's target R^2), each candidate refined from the current fit.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from tendrilkit.pwc.laws import PiecewiseLinearLaw, _insert_knot, _Joiner, _merge_knots
from tendrilkit.pwc.rebuild import _law_sse
from tendrilkit.pwc.refine import _best_insertions, _hinge_positions, _refine_laws, _refine_starts
from tendrilkit.pwc.search import penalty_path

__all__: list[str] = []

#: Levenberg-Marquardt iterations of the candidate each step of the search moves to (the
#: final one is then refined to convergence).
STEP_ITERATIONS = 10

#: Skip the candidates that cannot win (an exact bound: ``_auto_search``'s ``hopeless``). Off: every
#: candidate is evaluated, the same fits more slowly (tests, benchmarks).
SKIP_HOPELESS = True


def _mid_penalty(lo: float, hi: float) -> float:
    if not np.isfinite(hi):
        return float(max(lo, 0.0) * 2.0 if lo > 0 else 1.0)
    if lo <= 0:
        return float(hi / 2.0)
    return float(np.sqrt(lo * hi))


def _bic(sse: float, n: int, k_kappa: int, k_tau: int) -> float:
    """BIC of a fit of ``n`` 3D points with ``k_kappa`` + ``k_tau`` segments and SSE ``sse`` (mm^2).

    On numpy float64 scalars (the same bits as on 0-d arrays, a tenth of the time: it runs for
    every candidate).
    """
    m = 3 * n
    p = 2 * k_kappa + 2 * k_tau + 6
    return float(m * np.log(np.float64(max(sse, 1e-300)) / m) + p * _log_count(m))


@lru_cache(maxsize=64)
def _log_count(m: int) -> np.float64:
    """``np.log(np.float64(m))``, once per count of residuals (the same for every candidate of a fit)."""
    return np.log(np.float64(m))


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
                 quick_iterations, max_candidates, memo=None, precision_mm=0.0):
    """The automatic selection of :func:`fit_piecewise_clothoid` on prepared signals.

    ``memo``: a dict shared by the searches of one ``prep`` (a retry with more lookahead
    repeats the first search's steps until it turns elsewhere): refinements and score
    tests already computed from the same laws are looked up, not redone (the same bits), and
    so are the penalty paths with their laws and the evaluations of the starts.
    ``precision_mm``: BIC counts an SSE down to this rms (mm) only (the candidates table's
    BIC column too); 0: every SSE as it is.
    """
    memo = {} if memo is None else memo

    def laws_key(tag, lk, lt):
        return (tag, lk.knots_mm.tobytes(), lk.values.tobytes(), lt.knots_mm.tobytes(), lt.values.tobytes())

    def refined(lk, lt, iterations=40, rtol=1e-6, state=None):
        """``(lk, lt, sse)`` refined; the refined laws' evaluation is kept as their start's."""
        key = laws_key("refine", lk, lt) + (iterations, rtol)
        if key not in memo:
            if state is None:  # laws a refinement ended on: their evaluation is known
                state = memo.get(laws_key("start", lk, lt))
            lk2, lt2, sse, end = _refine_laws(prep, lk, lt, iterations, rtol, state)
            memo[key] = (lk2, lt2, sse)
            memo.setdefault(laws_key("start", lk2, lt2), end)  # the same bits as _law_state of them
        return memo[key]

    def refined_best(starts, iterations, rtol):
        """``(lk, lt, sse)``: the first of ``starts`` of least SSE (their evaluations), refined.

        One compiled call (:func:`_refine_starts`) unless every start's evaluation is known: the
        same laws as the starts evaluated one by one and the best refined from its evaluation.
        """
        keys = [laws_key("start", lk, lt) for lk, lt in starts]
        if all(k in memo for k in keys):
            i = min(range(len(starts)), key=lambda j: memo[keys[j]][0])
            return refined(*starts[i], iterations, rtol, state=memo[keys[i]])
        ckey = ("best",) + tuple(keys) + (iterations, rtol)
        if ckey not in memo:
            i, (kk, vk, kt, vt), sse, end = _refine_starts(
                prep.s, prep.data, starts, free_knots=prep.free_knots, min_gap=prep.min_gap_mm,
                iterations=iterations, rtol=rtol)
            lk2, lt2 = PiecewiseLinearLaw(kk, vk, "kappa"), PiecewiseLinearLaw(kt, vt, "tau")
            memo[ckey] = memo[laws_key("refine", *starts[i]) + (iterations, rtol)] = (lk2, lt2, sse)
            memo.setdefault(laws_key("start", lk2, lt2), end)  # the same bits as _law_state of them
        return memo[ckey]

    def insertions_at(lk, lt):
        key = laws_key("insert", lk, lt)
        if key not in memo:
            memo[key] = _best_insertions(prep, lk, lt, memo.get(laws_key("start", lk, lt)))
        return memo[key]

    s, fr = prep.s, prep.fr
    key = ("paths", max_segments)
    if key not in memo:  # the paths and their laws depend on prep and max_segments only: a retry reuses them
        path_k = penalty_path(prep.Ck, kmax=max_segments)
        path_t = penalty_path(prep.Ct, kmax=max_segments)
        # continuity may merge segments, so several path entries can give one law: keep each once
        memo[key] = (path_k, path_t, _DistinctLaws(s, fr.kappa, prep.wk, path_k, "kappa"),
                     _DistinctLaws(s, fr.tau, prep.wt, path_t, "tau"))
    path_k, path_t, laws_k, laws_t = memo[key]
    n = s.size
    sst = prep.sst_mm2 if prep.sst_mm2 is not None else float(np.sum((prep.data - prep.data.mean(axis=0)) ** 2))
    sse_floor = 3 * n * precision_mm ** 2  # residuals below the precision asked for explain nothing more
    rows: list[list[float]] = []
    quick = (quick_iterations, 1e-4)

    def scored(lk, lt, sse, row=None):
        """(lk, lt, sse, r2, bic, row index), recorded in the candidates table."""
        r2 = 1.0 - sse / sst
        bic = _bic(max(sse, sse_floor), n, lk.n_segments, lt.n_segments)
        entry = [lk.n_segments, lt.n_segments, r2, sse, bic, 0.0]
        if row is None:
            rows.append(entry)
            row = len(rows) - 1
        else:
            rows[row] = entry
        return (lk, lt, sse, r2, bic, row)

    defined = fr.tau[prep.wt > 0]
    tau_lo, tau_hi = (float(defined.min()), float(defined.max())) if defined.size else (0.0, 0.0)

    def path_tau(b):
        """The torsion path law ``b`` as a start: its values within the range of the torsion where defined."""
        k = ("path_tau", max_segments, b)  # of prep's signals and the path: made once
        if k not in memo:
            law = laws_t[b]
            v = np.clip(law.values, tau_lo, tau_hi)
            memo[k] = law if np.array_equal(v, law.values) else PiecewiseLinearLaw(law.knots_mm, v, "tau")
        return memo[k]

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
            if "medians" not in memo:  # of prep's signals: a retry reads them again
                memo["medians"] = (float(np.median(fr.kappa)), _weighted_median(fr.tau, prep.wt))
            med_k, med_t = memo["medians"]
            kc = PiecewiseLinearLaw(ends_k, np.full(ends_k.size, med_k), "kappa")
            tc = PiecewiseLinearLaw(ends_t, np.full(ends_t.size, med_t), "tau")
            t0 = PiecewiseLinearLaw(ends_t, np.zeros(ends_t.size), "tau")
            starts = [(laws_k[a], path_tau(b)), (kc, tc), (kc, t0), (laws_k[a], t0)]
        elif move == "k":
            k_new, k_cur, t_cur = laws_k[a].knots_mm, cur[0], cur[1]
            u = _merge_knots(k_new, k_cur.knots_mm, prep.min_gap_mm)
            starts = [(laws_k[a], t_cur), (PiecewiseLinearLaw(k_new, k_cur(k_new), "kappa"), t_cur),
                      (PiecewiseLinearLaw(u, k_cur(u), "kappa"), t_cur)]
        else:
            t_new, k_cur, t_cur = laws_t[b].knots_mm, cur[0], cur[1]
            u = _merge_knots(t_new, t_cur.knots_mm, prep.min_gap_mm)
            starts = [(k_cur, path_tau(b)), (k_cur, PiecewiseLinearLaw(t_new, t_cur(t_new), "tau")),
                      (k_cur, PiecewiseLinearLaw(u, t_cur(u), "tau"))]
        # compared by the SSE of the refinement's own evaluation, from which the best is refined
        return scored(*refined_best(starts, *quick))

    def better(x, y):
        return _preferred(x, y, target_r2, criterion)

    # Forward search from one segment each: move to one of the next `lookahead`
    # segmentations of either penalty path, or (refine and insertions) add the knot
    # the score test asks for, while the criterion improves.
    state = (0, 0)
    cur = from_path(0, 0)
    skipped = 0  # candidates that could not win, counted towards max_candidates as if evaluated

    def hopeless(k_segments, t_segments):
        """Can no candidate with these segment counts win over ``cur``, whatever its fit?

        With ``precision_mm`` the SSE in BIC is floored: a candidate's BIC is at least that of the
        floor with its segments. ``cur`` reaching ``target_r2`` with a BIC at or below that bound
        wins over it (``_preferred``), and so over every candidate that it beats: an exact bound,
        the search takes the same steps without evaluating it.
        """
        return (SKIP_HOPELESS and criterion == "bic" and sse_floor > 0 and cur[3] >= target_r2
                and _bic(sse_floor, n, k_segments, t_segments) >= cur[4])

    while not (criterion == "r2" and cur[3] >= target_r2) and len(rows) + skipped < max_candidates:
        a0, b0 = state
        tried = []
        for d in range(1, lookahead + 1):  # the fewest segments of a path candidate: its path law's
            if laws_k.has(a0 + d):
                if refine and hopeless(laws_k[a0 + d].n_segments, cur[1].n_segments):
                    skipped += 1
                else:
                    tried.append(((a0 + d, b0), from_path(a0 + d, b0, cur, "k")))
        for d in range(1, lookahead + 1):
            if laws_t.has(b0 + d):
                if refine and hopeless(cur[0].n_segments, laws_t[b0 + d].n_segments):
                    skipped += 1
                else:
                    tried.append(((a0, b0 + d), from_path(a0, b0 + d, cur, "t")))
        if refine and insertions:
            if hopeless(cur[0].n_segments + 1, cur[1].n_segments) and hopeless(cur[0].n_segments,
                                                                               cur[1].n_segments + 1):
                # neither insertion could win: no score test (the candidates it would give are counted)
                found_kt = [(0.0, 0.0) if ok.any() else None for ok in _hinge_positions(prep, cur[0], cur[1])[1]]
                skip_insertions = True
            else:
                found_kt = insertions_at(cur[0], cur[1])
                skip_insertions = False
            for which, found in zip("kt", found_kt):
                law = cur[0] if which == "k" else cur[1]
                if found is None or law.n_segments >= max_segments:
                    continue
                if skip_insertions:
                    skipped += 1
                    continue
                sk = _insert_knot(cur[0], found[0]) if which == "k" else cur[0]
                st = _insert_knot(cur[1], found[0]) if which == "t" else cur[1]
                tried.append(((a0, b0), scored(*refined(sk, st, *quick))))
        if not tried:
            break
        m, cand = tried[0]
        for mm, cc in tried[1:]:
            if better(cc, cand):
                m, cand = mm, cc
        if not better(cand, cur):
            break
        if refine:  # candidates are compared after a few iterations; the chosen one goes further
            cand = scored(*refined(cand[0], cand[1], STEP_ITERATIONS), row=cand[5])
        state, cur = m, cand
    if refine:  # and the last one converges
        cur = scored(*refined(cur[0], cur[1]), row=cur[5])
    a, b = state
    lk, lt, irow = cur[0], cur[1], cur[5]
    rows[irow][5] = 1.0
    candidates = np.array(rows)
    pa, pb = laws_k.idx[a], laws_t.idx[b]
    rk = (path_k.penalty_lo[pa], path_k.penalty_hi[pa])
    rt = (path_t.penalty_lo[pb], path_t.penalty_hi[pb])
    return {"prep": prep, "lk": lk, "lt": lt, "bounds_k": path_k.bounds[pa], "bounds_t": path_t.bounds[pb],
            "rk": rk, "rt": rt, "candidates": candidates, "best": cur}


def _weighted_median(y, w):
    """The smallest ``y`` whose cumulative weight reaches half the total (0 without weight)."""
    if not w.sum() > 0:
        return 0.0
    # np.quantile(y, 0.5, weights=w, method="inverted_cdf")'s steps for one 1-d array of finite
    # values and weights >= 0 (the same sort, cumulative weights and search: the same value) without
    # its generic set-up, a third of its time
    if not (y.ndim == 1 and y.shape == w.shape and np.isfinite(y).all() and (w >= 0).all()):
        return float(np.quantile(y, 0.5, weights=w, method="inverted_cdf"))
    order = np.argsort(y, axis=0)
    cdf = w[order].cumsum(dtype=np.float64)
    cdf /= cdf[-1]
    if np.isnan(cdf[-1]):
        return float(np.quantile(y, 0.5, weights=w, method="inverted_cdf"))  # its error
    if cdf[0] == 0:
        cdf[cdf == 0] = -1
    return float(y[order[min(int(np.searchsorted(cdf, 0.5, side="left")), y.size - 1)]])


class _DistinctLaws:
    """The continuous laws of a penalty path, one per distinct knot set, made on demand.

    The forward search looks at the first few entries of a path only; each law
    costs a join and a refit, so they are made in path order as far as asked.
    ``laws[a]`` is the ``a``-th distinct law, ``idx[a]`` its index in the path.
    """

    def __init__(self, s, y, w, path, kind):
        self.path, self.kind = path, kind
        # the prepared curve's arrays, checked when their cost tables were made (line_costs)
        self.joiner = _Joiner(s, y, w)
        self.idx: list[int] = []
        self.laws: list[PiecewiseLinearLaw] = []
        self._seen: set = set()
        self._next = 0

    def has(self, a: int) -> bool:
        """Is there an ``a``-th distinct law (made if needed)?"""
        while len(self.laws) <= a and self._next < len(self.path.bounds):
            i = self._next
            self._next += 1
            law = self.joiner.join(self.path.bounds[i], self.kind)
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
