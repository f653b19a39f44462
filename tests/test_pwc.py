"""Piece-wise clothoid fit (tendrilkit.pwc): exact programmes, continuity, rebuild, accuracy."""

from __future__ import annotations

import doctest
import functools
import importlib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import cumulative_trapezoid
from scipy.interpolate import make_lsq_spline
from scipy.spatial.transform import Rotation

from tendrilkit.exceptions import DegenerateCurveError
from tendrilkit.frenet import integrate_frenet
from tendrilkit.pwc import (
    PiecewiseLinearLaw,
    fit_piecewise_clothoid,
    fit_scores,
    grid_search_penalties,
    join_segments,
    line_costs,
    penalty_path,
    penalty_table,
    rebuild_curve,
    register_rigid,
    segment_penalty,
)
from tendrilkit.pwc.datasets import mean_distance_mm, random_pwc_curve
from tendrilkit.pwc.laws import _merge_knots
from tendrilkit.pwc.search import _dp_counts


# ------------------------------------------------------------------ reference programme


def interval_dp(C: np.ndarray, pen: float) -> float:
    """The paper's O(n^3) interval programme J(a, b) = min(pen + E(a, b), min_m J(a, m) + J(m, b))."""
    n = C.shape[0] - 1

    @functools.lru_cache(maxsize=None)
    def J(a: int, b: int) -> float:
        best = pen + C[a, b]
        for m in range(a + 1, b):
            best = min(best, J(a, m) + J(m, b))
        return best

    return J(0, n)


signals = st.tuples(
    st.integers(8, 26),                      # n
    st.integers(2, 4),                       # min_size
    st.integers(0, 2**31 - 1),               # seed
    st.sampled_from(["l2", "l1"]),
)


@settings(max_examples=40, deadline=None)
@given(signals, st.floats(0.0, 0.5))
def test_prefix_dp_equals_the_interval_dp(sig, pen):
    n, min_size, seed, score = sig
    rng = np.random.default_rng(seed)
    s = np.cumsum(rng.uniform(0.5, 1.5, n))
    y = np.where(s > s.mean(), 1.0, -0.5) * rng.uniform(0, 2) + rng.normal(0, 0.3, n)
    C = line_costs(s, y, score=score, min_size=min_size)
    bounds, cost = segment_penalty(C, pen)
    assert cost == pytest.approx(interval_dp(C, pen), rel=1e-9, abs=1e-12)
    assert cost == pytest.approx(sum(C[a, b] for a, b in zip(bounds[:-1], bounds[1:])) + pen * (len(bounds) - 1))


@settings(max_examples=30, deadline=None)
@given(signals, st.lists(st.floats(0.0, 1.0), min_size=1, max_size=5))
def test_penalty_path_gives_the_optimum_of_every_penalty(sig, pens):
    n, min_size, seed, score = sig
    rng = np.random.default_rng(seed)
    s = np.cumsum(rng.uniform(0.5, 1.5, n))
    y = np.sin(s / 3) * rng.uniform(0, 2) + rng.normal(0, 0.2, n)
    C = line_costs(s, y, score=score, min_size=min_size)
    path = penalty_path(C)
    assert np.all(np.diff(path.counts) > 0) and np.all(np.diff(path.costs) < 0)
    for pen in pens:
        _, cost = segment_penalty(C, pen)
        i = path.index(pen)
        assert path.costs[i] + path.counts[i] * pen == pytest.approx(cost, rel=1e-9, abs=1e-12)
        assert path.penalty_lo[i] <= pen + 1e-12 and pen <= path.penalty_hi[i] + 1e-12


def dp_counts_full(C: np.ndarray, kmax: int) -> tuple[np.ndarray, np.ndarray]:
    """G_k(j) = min_i G_{k-1}(i) + C[i, j] over every i (first minimum), in plain Python."""
    n = C.shape[0] - 1
    G = np.full((kmax + 1, n + 1), np.inf)
    back = np.zeros((kmax + 1, n + 1), dtype=np.int64)
    G[0, 0] = 0.0
    for k in range(1, kmax + 1):
        for j in range(1, n + 1):
            for i in range(j):
                v = G[k - 1, i] + C[i, j]
                if v < G[k, j]:
                    G[k, j], back[k, j] = v, i
    return G, back


@settings(max_examples=40, deadline=None)
@given(signals, st.floats(0.0, 0.6))
def test_count_programme_skips_only_infinite_intervals(sig, holes):
    """_dp_counts skips the intervals shorter than the shortest finite one: the same G and
    back-pointers as the full loop, also for tables with infinite costs anywhere."""
    n, min_size, seed, score = sig
    rng = np.random.default_rng(seed)
    s = np.cumsum(rng.uniform(0.5, 1.5, n))
    y = np.sin(s / 3) * rng.uniform(0, 2) + rng.normal(0, 0.2, n)
    C = line_costs(s, y, score=score, min_size=min_size)
    C[rng.uniform(size=C.shape) < holes] = np.inf
    kmax = n // min_size
    G, back = _dp_counts(C, kmax)
    G_ref, back_ref = dp_counts_full(C, kmax)
    assert np.array_equal(G, G_ref)
    assert np.array_equal(back[np.isfinite(G_ref)], back_ref[np.isfinite(G_ref)])


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(1.0, 99.0), max_size=6), st.lists(st.floats(1.0, 99.0), max_size=6), st.floats(0.5, 20.0))
def test_merge_knots_keeps_the_knots_of_b_far_from_a(inner_a, inner_b, gap):
    a = np.sort(np.r_[0.0, inner_a, 100.0])
    b = np.sort(np.r_[0.0, inner_b, 100.0])
    extra = [x for x in b[1:-1] if np.min(np.abs(a - x)) >= gap]
    assert np.array_equal(_merge_knots(a, b, gap), np.sort(np.r_[a, extra]))


def test_l2_costs_are_least_squares_lines():
    rng = np.random.default_rng(1)
    s = np.sort(rng.uniform(0, 50, 30))
    y = rng.normal(size=30)
    w = rng.uniform(0.1, 2, 30)
    C = line_costs(s, y, weights=w, min_size=3)
    sw = w.sum()
    var = (w @ (y - (w @ y) / sw) ** 2) / sw
    scale2 = var + (1e-2 / (s[-1] - s[0])) ** 2
    for a, b in [(0, 30), (3, 11), (10, 13)]:
        coef = np.polyfit(s[a:b], y[a:b], 1, w=np.sqrt(w[a:b]))
        sse = w[a:b] @ (np.polyval(coef, s[a:b]) - y[a:b]) ** 2
        assert C[a, b] == pytest.approx(sse / scale2 / sw, rel=1e-8)
    assert np.isinf(C[0, 2])


def test_l2_cost_table_is_the_one_interval_at_a_time_table_bit_for_bit():
    """``_line_costs`` grows the sums of all the intervals ending at a sample together (vectorised): the same
    bits as one interval start at a time (``_line_costs_one_by_one``, the absolute error's route), zero
    weights (intervals of no weight cost 0), repeated positions (no slope) and constant signals included."""
    from tendrilkit.pwc.costs import _line_costs, _line_costs_one_by_one

    rng = np.random.default_rng(17)
    for t in range(400):
        n = int(rng.integers(2, 120))
        x = np.sort(rng.random(n)) - 0.5
        if t % 7 == 0:
            x = np.round(x, 1)
        y = rng.standard_normal(n) * 10.0 ** int(rng.integers(-3, 3))
        if t % 13 == 0:
            y[:] = 1.0
        w = rng.random(n)
        if t % 3 == 0:
            w[rng.random(n) < 0.5] = 0.0
        if t % 11 == 0:
            w[:] = 0.0
        w = w / max(w.sum(), 1e-300)
        ms = int(rng.integers(2, 6))
        assert _line_costs(x, y, w, ms, False).tobytes() == _line_costs_one_by_one(x, y, w, ms, False).tobytes()


def test_penalties_do_not_depend_on_units_or_point_count():
    s = np.linspace(0, 100, 201)
    y = np.interp(s, [0, 40, 100], [0.02, 0.08, 0.03]) + np.random.default_rng(2).normal(0, 0.003, s.size)
    C = line_costs(s, y)
    C_units = line_costs(s * 1e-3, y * 1e3)     # metres and 1/m
    assert np.allclose(C, C_units, rtol=1e-9, equal_nan=True)
    # twice the points: the segmentation at a given penalty is the same
    s2 = np.linspace(0, 100, 401)
    y2 = np.interp(s2, s, y)
    for pen in (0.003, 0.03):
        b1, _ = segment_penalty(C, pen)
        b2, _ = segment_penalty(line_costs(s2, y2), pen)
        assert len(b1) == len(b2)


def test_single_segment_optimum_does_not_crash():
    s = np.linspace(0, 10, 20)
    C = line_costs(s, 2 * s + 1)
    bounds, cost = segment_penalty(C, 1.0)
    assert list(bounds) == [0, 20] and cost == pytest.approx(1.0)
    law = join_segments(s, 2 * s + 1, bounds)
    assert law.n_segments == 1 and np.allclose(law.values, [1, 21])


# ------------------------------------------------------------------ continuity


def test_joins_recover_a_continuous_law():
    s = np.linspace(0, 120, 241)
    true = PiecewiseLinearLaw(np.array([0.0, 37.0, 81.0, 120.0]), np.array([0.02, 0.09, 0.03, 0.06]))
    y = true(s)
    C = line_costs(s, y)
    bounds, _ = segment_penalty(C, 1e-3)
    law = join_segments(s, y, bounds)
    assert law.n_segments == 3
    assert np.allclose(law.knots_mm, true.knots_mm, atol=0.5)
    assert np.abs(law(s) - y).max() < 1e-3


def test_overshooting_join_is_merged():
    s = np.linspace(0, 30, 31)
    y = np.r_[np.full(10, 1.0), np.full(10, 1.01), np.full(11, 1.0)] + 0.1 * s
    # nearly parallel neighbours intersect far outside their span: merged
    law = join_segments(s, y, np.array([0, 10, 20, 31]))
    assert law.n_segments < 3
    assert np.all(np.diff(law.knots_mm) > 0)


def test_refit_is_the_best_continuous_fit_with_those_knots():
    rng = np.random.default_rng(3)
    s = np.linspace(0, 60, 121)
    y = np.interp(s, [0, 25, 60], [1.0, 3.0, 0.0]) + rng.normal(0, 0.1, s.size)
    law = join_segments(s, y, np.array([0, 50, 121]))
    base = np.sum((law(s) - y) ** 2)
    for j in range(law.values.size):          # no knot value can do better
        for d in (-1e-3, 1e-3):
            v = law.values.copy()
            v[j] += d
            assert np.sum((PiecewiseLinearLaw(law.knots_mm, v)(s) - y) ** 2) >= base


# ------------------------------------------------------------------ registration and rebuild


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**31 - 1))
def test_registration_recovers_known_rotations(seed):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(50, 3)) * [30, 10, 5]
    R = Rotation.random(random_state=seed).as_matrix()
    t = rng.normal(size=3) * 100
    R_est, t_est = register_rigid(P, P @ R.T + t)
    assert np.allclose(R_est, R, atol=1e-9) and np.allclose(t_est, t, atol=1e-7)
    assert np.linalg.det(R_est) == pytest.approx(1.0)


def test_rebuild_with_the_true_laws_is_the_true_curve():
    tc = random_pwc_curve(5, noise_mm=0.0)
    kl, tl = PiecewiseLinearLaw(*tc.kappa_knots), PiecewiseLinearLaw(*tc.tau_knots)
    R = Rotation.from_rotvec([0.3, -1.2, 0.5]).as_matrix()
    data = tc.clean_mm @ R.T + [10, -20, 5]
    pts, R_est, _ = rebuild_curve(tc.s_mm, kl, tl, data)
    assert np.abs(pts - data).max() < 0.02
    sc = fit_scores(pts, data, tc.s_mm)
    assert sc.r2_entire > 0.999999 and sc.r2_base > 0.9999 and sc.r2_tip > 0.9999


# ------------------------------------------------------------------ the fit


def test_noise_free_piecewise_clothoid_recovers_its_laws():
    tc = random_pwc_curve(3, noise_mm=0.0)
    f = fit_piecewise_clothoid(tc.points_mm)
    s = f.s_mm
    assert f.r2 > 0.99999
    assert mean_distance_mm(f.points_mm, tc.dense_mm) < 0.05
    inner = (s > 10) & (s < s[-1] - 10)
    assert np.median(np.abs(f.kappa_fit - np.interp(s, *tc.kappa_knots))[inner]) < 2e-3
    assert np.median(np.abs(f.tau_fit - np.interp(s, *tc.tau_knots))[inner]) < 5e-3


def test_helix_is_one_segment_each():
    s = np.linspace(0, 150, 200)
    P, *_ = integrate_frenet(s, np.full(200, 0.08), np.full(200, 0.03), [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0],
                             positions="exact")
    f = fit_piecewise_clothoid(P + np.random.default_rng(0).normal(0, 0.05, P.shape))
    assert f.n_segments_kappa <= 2 and f.n_segments_tau <= 2
    assert np.median(f.kappa_fit) == pytest.approx(0.08, rel=0.02)
    assert np.median(f.tau_fit) == pytest.approx(0.03, rel=0.1)


def test_straight_line_and_planar_curve():
    x = np.linspace(0, 100, 100)
    line = np.c_[x, 0.5 * x, np.zeros_like(x)]
    f = fit_piecewise_clothoid(line)
    assert f.scores.rmse_mm < 1e-3
    assert not f.frames.tau_defined.any()
    assert np.abs(f.kappa_fit).max() < 1e-3
    u = np.linspace(0, 2.5, 150)
    arc = np.c_[40 * np.cos(u), 40 * np.sin(u), np.zeros_like(u)]
    f = fit_piecewise_clothoid(arc)
    assert f.scores.rmse_mm < 0.01 and np.abs(f.points_mm[:, 2]).max() < 0.01


def test_degenerate_inputs_raise_named_errors():
    with pytest.raises(DegenerateCurveError):
        fit_piecewise_clothoid(np.zeros((20, 3)))
    with pytest.raises(DegenerateCurveError):
        fit_piecewise_clothoid(np.array([[0, 0, 0], [1, 0, 0], [0, 0, 0.0]]))
    with pytest.raises(ValueError, match="selection"):
        fit_piecewise_clothoid(np.random.default_rng(0).normal(size=(20, 3)), selection="magic")


def test_fixed_penalties_and_the_l1_score():
    tc = random_pwc_curve(7)
    few = fit_piecewise_clothoid(tc.points_mm, selection="fixed", penalty_kappa=0.2, penalty_tau=0.2, refine=False)
    many = fit_piecewise_clothoid(tc.points_mm, selection="fixed", penalty_kappa=1e-3, penalty_tau=1e-3,
                                  refine=False, score="l1")
    assert few.n_segments_kappa <= many.n_segments_kappa
    assert few.penalty_range_kappa[0] == 0.2


def test_accuracy_on_noisy_ground_truth():
    """Issue figures: 0.15 mm noise, mean distance <= 0.3 mm and R^2 >= 0.999 on >= 95 % of curves."""
    dist, r2, knot_err = [], [], []
    for seed in range(20):
        tc = random_pwc_curve(seed)
        f = fit_piecewise_clothoid(tc.points_mm)
        dist.append(mean_distance_mm(f.points_mm, tc.dense_mm))
        r2.append(f.r2)
        true = tc.kappa_knots[0][1:-1]
        found = f.kappa_law.knots_mm[1:-1]
        if true.size and found.size:
            knot_err.extend(np.min(np.abs(found[:, None] - true[None, :]), axis=0))
    dist, r2 = np.array(dist), np.array(r2)
    assert np.mean(dist <= 0.3) >= 0.95, dist
    assert np.mean(r2 >= 0.999) >= 0.95, r2
    # breakpoints: the true curvature knots are found within a few mm (median)
    assert np.median(knot_err) < 5.0, knot_err


def test_grid_search_and_penalty_table():
    tc = random_pwc_curve(2)
    g = grid_search_penalties(tc.points_mm, grid=6, refinements=3)
    assert g.levels and g.levels[0].r2.shape == (6, 6)
    assert g.fit.r2 == pytest.approx(g.levels[-1].r2[g.levels[-1].best])
    if g.converged:
        assert g.fit.r2 > 0.999
    rows = penalty_table(tc.points_mm, [(0.001, 0.001), (0.3, 0.3)])
    assert rows[0]["n_kappa"] >= rows[1]["n_kappa"]
    assert {"r2_entire", "r2_base", "r2_tip", "sse_entire_mm2"} <= set(rows[0])


@pytest.mark.parametrize("site", ["S2", "S3"])
def test_phantom_centrelines(site):
    """The phantom experiments' true centrelines (200 points, 0.15 mm noise), every 6th frame."""
    phantom = pytest.importorskip("tendrilkit.phantom")
    from tendrilkit.frenet import resample_curve

    ph = phantom.make_phantom(site)
    rng = np.random.default_rng(0)
    dist, r2 = [], []
    for f in range(0, ph.n_frames, 6):
        X = resample_curve(ph.curves_mm[f], 200) + rng.normal(0, 0.15, (200, 3))
        fit = fit_piecewise_clothoid(X)
        dist.append(mean_distance_mm(fit.points_mm, ph.curves_mm[f]))
        r2.append(fit.r2)
    dist, r2 = np.array(dist), np.array(r2)
    assert np.mean(r2 >= 0.999) >= 0.9, r2
    # S3's loop has 7 mm ramps, shorter than the knots' minimum spacing (9 samples): weaker
    assert np.mean(dist <= (0.3 if site != "S3" else 1.0)) >= 0.9, dist


# ------------------------------------------------------------------ pinned to libraries, examples


@pytest.mark.parametrize("seed", range(5))
def test_registration_is_scipys_least_squares_rotation(seed):
    """The compiled Kabsch fit (used inside the numba kernels) equals scipy's on noisy, inexact data."""
    rng = np.random.default_rng(seed)
    P = rng.normal(0, 30, (50, 3))
    Q = P @ Rotation.random(random_state=seed).as_matrix().T + rng.normal(0, 5, 3) + rng.normal(0, 2.0, P.shape)
    R, t = register_rigid(P, Q)
    ref, _ = Rotation.align_vectors(Q - Q.mean(axis=0), P - P.mean(axis=0))
    np.testing.assert_allclose(R, ref.as_matrix(), atol=1e-10)
    np.testing.assert_allclose(t, Q.mean(axis=0) - R @ P.mean(axis=0), atol=1e-9)


@pytest.mark.parametrize("seed", range(8))
def test_quaternion_registration_is_the_kabsch_fit(seed):
    """geometry.rigid_fit (Horn's quaternion, Jacobi in scalars; the refinement's registration) gives the rotation of
    Kabsch's SVD with its determinant correction (numpy's SVD here).

    Noisy rotated points, a nearly planar set, and a set whose best proper rotation is far from the
    reflection that fits it (Kabsch's determinant correction); the SSE is never above Kabsch's.
    """
    from tendrilkit.geometry import _rigid_fit_core, rigid_fit

    def kabsch(P, Q):
        mp, mq = P.mean(0), Q.mean(0)
        U, _, Vt = np.linalg.svd((P - mp).T @ (Q - mq))
        D = np.diag([1.0, 1.0, np.sign(np.linalg.det(Vt.T @ U.T))])
        R = Vt.T @ D @ U.T
        return R, mq - R @ mp

    rng = np.random.default_rng(seed)
    P = rng.normal(0, 1, (200, 3)) * rng.uniform(0.1, 30, 3) + rng.normal(0, 50, 3)
    if seed % 4 == 1:
        P[:, 2] = 1e-4 * P[:, 2]
    A = Rotation.random(random_state=seed).as_matrix()
    Q = (-P if seed % 4 == 2 else P @ A.T) + rng.normal(0, 5, 3) + rng.normal(0, rng.uniform(0, 2), P.shape)
    R0, t0 = kabsch(P, Q)
    R, t = rigid_fit(P, Q)
    Rc, tc = _rigid_fit_core(P, Q)
    assert np.array_equal(R, Rc) and np.array_equal(t, tc)  # the checks add nothing to a valid input
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    sse0 = np.sum((P @ R0.T + t0 - Q) ** 2)
    assert np.sum((P @ R.T + t - Q) ** 2) <= sse0 * (1 + 1e-12)
    np.testing.assert_allclose(R, R0, atol=1e-8)
    np.testing.assert_allclose(t, t0, atol=1e-6)


@pytest.mark.parametrize("seed", range(5))
def test_step_means_are_the_exact_integral_of_the_law(seed):
    """A law's mean over each step equals the trapezoidal integral on a grid holding every knot (exact)."""
    rng = np.random.default_rng(seed)
    L = 150.0
    knots = np.r_[0.0, np.sort(rng.uniform(5, L - 5, int(rng.integers(0, 6)))), L]
    law = PiecewiseLinearLaw(knots, rng.normal(0, 0.05, knots.size), "kappa")
    s = np.r_[0.0, np.sort(rng.uniform(0, L, 80)), L]
    grid = np.union1d(s, knots)
    integral = cumulative_trapezoid(law(grid), grid, initial=0.0)[np.searchsorted(grid, s)]
    np.testing.assert_allclose(law.step_means(s), np.diff(integral) / np.diff(s), rtol=1e-9, atol=1e-12)


def test_refinement_jacobian_matches_finite_differences():
    """Each column of the analytic Jacobian (knot values, inner knot positions) against a finite
    difference of the registered points; the Jacobian is first order in the step (values) and
    takes the knot derivative at step midpoints (positions), hence the tolerances."""
    from tendrilkit.pwc.laws import _pwl_step_means
    from tendrilkit.frenet import _integrate
    from tendrilkit.pwc.refine import _law_columns, _lm_evaluate, _lm_jacobian

    tc = random_pwc_curve(7)
    s, data = tc.s_mm.copy(), tc.points_mm
    kk, vk = (a.copy() for a in tc.kappa_knots)
    kt, vt = (a.copy() for a in tc.tau_knots)
    _, P, T, B, R, X = _lm_evaluate(s, kk, vk, kt, vt, data)
    J = _lm_jacobian(s, P, T, B, R, X, _law_columns(s, kk, vk, True), _law_columns(s, kt, vt, True))
    t = X[0] - R @ P[0]

    def points(kk, vk, kt, vt):
        Q = _integrate(s, _pwl_step_means(s, kk, vk), _pwl_step_means(s, kt, vt), np.eye(3), np.zeros(3), False)[0]
        return (Q @ R.T + t).ravel()

    base = points(kk, vk, kt, vt)
    cols, is_knot = [], []
    for law in ("k", "t"):
        knots, values = (kk, vk) if law == "k" else (kt, vt)
        for q in range(values.size):
            v = values.copy()
            v[q] += 1e-7
            args = (kk, v, kt, vt) if law == "k" else (kk, vk, kt, v)
            cols.append((points(*args) - base) / 1e-7)
            is_knot.append(False)
        for q in range(1, knots.size - 1):
            x = knots.copy()
            x[q] += 1e-5
            args = (x, vk, kt, vt) if law == "k" else (kk, vk, x, vt)
            cols.append((points(*args) - base) / 1e-5)
            is_knot.append(True)
    Jn = np.array(cols).T
    assert J.shape == (3 * s.size, Jn.shape[1] + 6)
    err = np.abs(J[:, : Jn.shape[1]] - Jn).max(axis=0) / np.abs(Jn).max(axis=0)
    is_knot = np.array(is_knot)
    assert np.all(err[~is_knot] < 3e-3), err
    assert np.all(err[is_knot] < 0.15), err


def test_hinge_step_means_are_the_mean_of_the_hinge():
    """The score test's columns: the mean of (s - x)_+ over each step, by fine quadrature."""
    from tendrilkit.pwc.refine import _hinge_means

    s = np.cumsum(np.r_[0.0, np.random.default_rng(3).uniform(0.5, 1.5, 30)])
    xs = np.array([0.2, 3.3, s[7], 12.0, s[-1] - 0.1])
    G = _hinge_means(s, xs)
    u = np.linspace(0.0, 1.0, 20001)
    for i in range(s.size - 1):
        seg = s[i] + u * (s[i + 1] - s[i])
        ref = np.trapezoid(np.maximum(seg[:, None] - xs[None, :], 0.0), u, axis=0)
        assert np.allclose(G[i], ref, rtol=0, atol=1e-8), (i, G[i], ref)


def test_fit_reuses_the_frames_that_chose_the_smoothing():
    """The frames computed to choose the smoothing length are the fit's frames: the same as
    smoothing again at that length; the public length is unchanged."""
    from tendrilkit.frenet import _auto_smoothing, auto_smoothing_length_mm, frenet_frames
    from tendrilkit.pwc.signals import _prepare

    P = random_pwc_curve(11).points_mm
    assert _auto_smoothing(P, of_resampled=True)[0] == auto_smoothing_length_mm(P)
    fr = _prepare(P, None, "l2", None, None).fr
    ref = frenet_frames(P, smoothing_length_mm=fr.smoothing_length_mm)
    for name in ("data_mm", "smooth_mm", "s_mm", "T", "N", "B", "kappa", "tau", "tau_defined"):
        assert np.array_equal(getattr(fr, name), getattr(ref, name)), name
    assert fr.smoothing_length_mm == _auto_smoothing(P)[0]


@pytest.mark.parametrize("seed", range(3))
def test_knot_refit_is_scipys_least_squares_linear_spline(seed):
    """The weighted continuous refit at the surviving knots equals scipy's least-squares linear B-spline
    (ours adds a ridge of 1e-6 on the second differences, for knots without weight)."""
    rng = np.random.default_rng(seed)
    s = np.linspace(0, 60, 121)
    y = np.interp(s, [0, 25, 40, 60], [1.0, 3.0, -1.0, 0.0]) + rng.normal(0, 0.1, s.size)
    w = rng.uniform(0.1, 2.0, s.size)
    law = join_segments(s, y, np.array([0, 50, 80, 121]), weights=w)
    k = law.knots_mm
    ref = make_lsq_spline(s, y, np.r_[k[0], k, k[-1]], k=1, w=np.sqrt(w))
    np.testing.assert_allclose(law.values, ref(k), atol=1e-8)


@pytest.mark.parametrize("module", ["costs", "search", "laws", "rebuild", "fit", "grid", "datasets"])
def test_docstring_examples_run(module):
    mod = importlib.import_module(f"tendrilkit.pwc.{module}")
    res = doctest.testmod(mod, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert res.attempted > 0
    assert res.failed == 0


def test_run_fingerprint_covers_sub_packages(tmp_path, monkeypatch):
    """A changed file in a sub-package (tendrilkit/pwc/) changes the code digest, so resumed runs recompute."""
    # the digest lives in pipeline (or runner, where the pipeline's run is its own module)
    try:
        owner = importlib.import_module("tendrilkit.runner")
    except ImportError:
        owner = importlib.import_module("tendrilkit.pipeline")
    (tmp_path / "sub").mkdir()
    (tmp_path / "top.py").write_text("a = 1\n")
    (tmp_path / "sub" / "deep.py").write_text("b = 1\n")
    monkeypatch.setattr(owner, "__file__", str(tmp_path / "top.py"))
    before = owner._code_digest()
    (tmp_path / "sub" / "deep.py").write_text("b = 2\n")
    assert owner._code_digest() != before


def test_searches_sharing_a_memo_give_the_same_fits(monkeypatch):
    """A retry with more lookahead looks up the refinements, penalty paths and starts' SSE the first
    search made (same laws in, same bits out): its result equals a search without the memo, with
    fewer refinements."""
    import tendrilkit.pwc.selection as S
    from tendrilkit.pwc.signals import _prepare

    calls, paths, sses = [], [], []
    refine, path, starts = S._refine_laws, S.penalty_path, S._refine_starts
    monkeypatch.setattr(S, "_refine_laws", lambda *a: calls.append(1) or refine(*a))
    monkeypatch.setattr(S, "penalty_path", lambda *a, **k: paths.append(1) or path(*a, **k))
    # a path candidate's starts evaluated and the best refined, in one call
    monkeypatch.setattr(S, "_refine_starts", lambda *a, **k: sses.append(1) or starts(*a, **k))
    prep = _prepare(random_pwc_curve(3).points_mm, None, "l2", None, None)
    kw = dict(criterion="bic", target_r2=0.999, max_segments=10, refine=True, insertions=True,
              quick_iterations=4, max_candidates=40)
    memo: dict = {}
    S._auto_search(prep, lookahead=1, memo=memo, **kw)
    n0, p0, e0 = len(calls), len(paths), len(sses)
    shared = S._auto_search(prep, lookahead=2, memo=memo, **kw)
    n_shared, p_shared, e_shared = len(calls) - n0, len(paths) - p0, len(sses) - e0
    fresh = S._auto_search(prep, lookahead=2, **kw)
    n_fresh, p_fresh, e_fresh = len(calls) - n0 - n_shared, len(paths) - p0 - p_shared, len(sses) - e0 - e_shared
    assert 0 < n_shared < n_fresh
    # the penalty paths (and their laws) are made once per prep; the starts' evaluations are looked up
    assert p0 == 2 and p_shared == 0 and p_fresh == 2
    assert e_shared < e_fresh
    assert np.array_equal(shared["candidates"], fresh["candidates"])
    for key in ("lk", "lt"):
        assert np.array_equal(shared[key].knots_mm, fresh[key].knots_mm)
        assert np.array_equal(shared[key].values, fresh[key].values)


def test_refinement_from_the_starts_evaluation_is_the_same():
    """The selection refines a start from the evaluation that chose it (``state``): the same bits as
    a refinement that evaluates the start itself."""
    from tendrilkit.pwc.laws import join_segments
    from tendrilkit.pwc.refine import _law_state, _refine_laws
    from tendrilkit.pwc.signals import _prepare

    prep = _prepare(random_pwc_curve(5).points_mm, None, "l2", None, None)
    L = prep.s[-1]
    lk = join_segments(prep.s, prep.fr.kappa, np.searchsorted(prep.s, [0, L / 2, L + 1]), kind="kappa")
    lt = join_segments(prep.s, prep.fr.tau, np.array([0, prep.s.size]), weights=prep.wt, kind="tau")
    for iterations, rtol in ((2, 1e-4), (40, 1e-6)):
        a = _refine_laws(prep, lk, lt, iterations, rtol)
        b = _refine_laws(prep, lk, lt, iterations, rtol, state=_law_state(prep, lk, lt))
        assert a[2] == b[2] and a[2] < _law_state(prep, lk, lt)[0]
        for x, y in zip(a[:2], b[:2]):
            assert np.array_equal(x.knots_mm, y.knots_mm) and np.array_equal(x.values, y.values)


def test_refinement_returns_the_evaluation_of_its_laws():
    """A refinement's end state is the refined laws' evaluation (``_law_state``), bit for bit: the search
    starts their further refinement and their score test from it instead of evaluating them again."""
    from tendrilkit.pwc.laws import join_segments
    from tendrilkit.pwc.refine import _best_insertions, _law_state, _refine_laws
    from tendrilkit.pwc.signals import _prepare

    for seed in (5, 11):
        prep = _prepare(random_pwc_curve(seed).points_mm, None, "l2", None, None)
        L = prep.s[-1]
        lk = join_segments(prep.s, prep.fr.kappa, np.searchsorted(prep.s, [0, L / 3, L + 1]), kind="kappa")
        lt = join_segments(prep.s, prep.fr.tau, np.array([0, prep.s.size]), weights=prep.wt, kind="tau")
        for iterations, rtol in ((0, 1e-4), (2, 1e-4), (10, 1e-6), (40, 1e-6)):
            lk2, lt2, sse, end = _refine_laws(prep, lk, lt, iterations, rtol)
            ref = _law_state(prep, lk2, lt2)
            assert end[0] == sse == ref[0]
            for a, b in zip(end[1:], ref[1:]):
                assert a.tobytes() == b.tobytes()
            assert _best_insertions(prep, lk2, lt2, end) == _best_insertions(prep, lk2, lt2)


def test_best_of_starts_is_the_starts_evaluated_one_by_one():
    """``_refine_starts`` (one compiled call per path candidate) gives, bit for bit, what the compiled
    functions called one by one give: every start evaluated (``_lm_evaluate``), the first of least SSE
    refined from its evaluation (``_lm_from``); ties and a start that cannot be integrated included."""
    from tendrilkit.pwc.laws import PiecewiseLinearLaw, join_segments
    from tendrilkit.pwc.refine import _lm_evaluate, _lm_from, _refine_starts
    from tendrilkit.pwc.signals import _prepare

    for seed in (5, 11):
        prep = _prepare(random_pwc_curve(seed).points_mm, None, "l2", None, None)
        L = prep.s[-1]
        lk = join_segments(prep.s, prep.fr.kappa, np.searchsorted(prep.s, [0, L / 3, L + 1]), kind="kappa")
        lt = join_segments(prep.s, prep.fr.tau, np.array([0, prep.s.size]), weights=prep.wt, kind="tau")
        kc = PiecewiseLinearLaw(lk.knots_mm, np.full(lk.knots_mm.size, float(np.median(prep.fr.kappa))), "kappa")
        t0 = PiecewiseLinearLaw(np.array([0.0, L / 2, L]), np.zeros(3), "tau")
        wild = PiecewiseLinearLaw(lk.knots_mm, np.full(lk.knots_mm.size, np.inf), "kappa")
        for starts in ([(lk, lt), (kc, t0), (lk, t0)], [(kc, t0), (lk, lt)], [(lk, lt), (lk, lt)],
                       [(wild, lt), (kc, t0)], [(wild, lt)], [(lk, t0)]):
            for iterations, rtol in ((0, 1e-4), (2, 1e-4), (40, 1e-6)):
                i, laws, sse, end = _refine_starts(prep.s, prep.data, starts, free_knots=True,
                                                   min_gap=prep.min_gap_mm, iterations=iterations, rtol=rtol)
                evals = [_lm_evaluate(prep.s, a.knots_mm, a.values, b.knots_mm, b.values, prep.data) for a, b in starts]
                j = min(range(len(starts)), key=lambda q: evals[q][0])
                a, b = starts[j]
                ref = _lm_from(prep.s, prep.data, a.knots_mm, a.values, b.knots_mm, b.values, True, prep.min_gap_mm,
                               iterations, rtol, *evals[j])
                assert i == j and (sse == ref[4] or (np.isinf(sse) and np.isinf(ref[4])))
                for x, y in zip(laws + end[1:], ref[:4] + ref[5:]):
                    assert x.tobytes() == y.tobytes()


def test_frame_columns_write_every_entry_once():
    """``_frame_columns`` fills an uncleared array: with ``ak``, ``at`` short of the columns (the score test's
    hinges, which move only the points after them) the columns they leave out are +0.0 and the others the bits
    of the full computation; ``_rigid_columns`` writes every entry of its six columns (its zeros too)."""
    from tendrilkit.pwc.refine import _frame_columns, _hinge_means, _law_state, _rigid_columns
    from tendrilkit.pwc.laws import join_segments
    from tendrilkit.pwc.signals import _prepare

    prep = _prepare(random_pwc_curve(7).points_mm, None, "l2", None, None)
    s, L = prep.s, prep.s[-1]
    lk = join_segments(s, prep.fr.kappa, np.searchsorted(s, [0, L / 3, L + 1]), kind="kappa")
    lt = join_segments(s, prep.fr.tau, np.array([0, s.size]), weights=prep.wt, kind="tau")
    f, P, T, B, R, X = _law_state(prep, lk, lt)
    xk, xt = np.linspace(5.0, L - 5.0, 17), np.linspace(3.0, L - 3.0, 9)
    Mk, Mt = _hinge_means(s, xk), _hinge_means(s, xt)
    n = s.size
    for _ in range(3):  # fresh (uncleared) arrays each time: the same bits
        part = _frame_columns(s, P, T, B, Mk, Mt, np.searchsorted(xk, s), np.searchsorted(xt, s))
        full = _frame_columns(s, P, T, B, Mk, Mt, np.full(n, xk.size), np.full(n, xt.size))
        left = np.zeros(part.shape, bool)  # the entries not visited
        for j in range(n):
            left[3 * j:3 * j + 3, np.searchsorted(xk, s[j]):xk.size] = True
            left[3 * j:3 * j + 3, xk.size + np.searchsorted(xt, s[j]):] = True
        left[:3] = True
        assert left.any() and (~left).any()
        assert part[left].tobytes() == np.zeros(int(left.sum())).tobytes()
        assert part[~left].tobytes() == full[~left].tobytes()
    out = np.full((3 * n, 8), np.nan)
    _rigid_columns(P, out, 1)
    y = P - P.mean(axis=0)
    ref = np.zeros((3 * n, 6))
    for j in range(n):
        ref[3 * j:3 * j + 3, :3] = np.eye(3)
        for k in range(3):
            ref[3 * j:3 * j + 3, 3 + k] = np.cross(np.eye(3)[k], y[j])
    assert np.isnan(out[:, [0, 7]]).all() and not np.isnan(out[:, 1:7]).any()
    np.testing.assert_allclose(out[:, 1:7], ref, rtol=0, atol=1e-12)
    assert (out[:, 1:7] == 0).sum() == (ref == 0).sum()


def test_compiled_score_test_matches_its_numpy_form():
    """``_score_gains`` (the score test in one compiled call) against the projection written in numpy:
    the same gains to round-off, the same best knot per law."""
    from tendrilkit.pwc.laws import join_segments
    from tendrilkit.pwc.refine import (_best_insertions, _hinge_means, _hinge_positions, _law_columns,
                                       _law_state, _lm_jacobian, _refine_laws)
    from tendrilkit.pwc.signals import _prepare

    for seed in (5, 11, 17):
        prep = _prepare(random_pwc_curve(seed).points_mm, None, "l2", None, None)
        s, data, L = prep.s, prep.data, prep.s[-1]
        lk = join_segments(s, prep.fr.kappa, np.searchsorted(s, [0, L / 3, L + 1]), kind="kappa")
        lt = join_segments(s, prep.fr.tau, np.array([0, s.size]), weights=prep.wt, kind="tau")
        lk, lt = _refine_laws(prep, lk, lt, 10, 1e-6)[:2]
        f, P, T, B, R, X = _law_state(prep, lk, lt)
        J = _lm_jacobian(s, P, T, B, R, X, _law_columns(s, lk.knots_mm, lk.values, True),
                         _law_columns(s, lt.knots_mm, lt.values, True))
        Js = J / (np.sqrt(np.einsum("ij,ij->j", J, J)) + 1e-300)
        H = Js.T @ Js + 1e-10 * np.eye(J.shape[1])
        xs, oks = _hinge_positions(prep, lk, lt)
        nk = int(oks[0].sum())
        C = _lm_jacobian(s, P, T, B, R, X, _hinge_means(s, xs[oks[0]]), _hinge_means(s, xs[oks[1]]))
        C = C[:, : nk + int(oks[1].sum())]
        Cp = C - Js @ np.linalg.solve(H, Js.T @ C)
        gain = (Cp.T @ (X - data).ravel()) ** 2 / (np.einsum("ij,ij->j", Cp, Cp) + 1e-300)
        got = _best_insertions(prep, lk, lt)
        for ok, g, found in zip(oks, (gain[:nk], gain[nk:]), got):
            j = int(np.argmax(g))
            assert found[0] == xs[ok][j] and found[1] == pytest.approx(g[j], rel=1e-9)


def test_gap_fraction_keeps_knots_apart():
    """The fraction of a knot step that keeps consecutive knots ``gap`` apart (0.99 of the room)."""
    from tendrilkit.pwc.refine import _gap_fraction

    knots = np.array([0.0, 10.0, 12.0, 30.0])
    # knot 1 moves 5 mm towards knot 2 (2 mm away, 1 mm of room above the gap)
    assert _gap_fraction(knots, np.array([5.0, 0.0]), 1.0) == pytest.approx(0.99 * 1.0 / 5.0)
    # both move apart, or together the same way: no limit
    assert _gap_fraction(knots, np.array([-3.0, 3.0]), 1.0) == 1.0
    assert _gap_fraction(knots, np.array([4.0, 4.0]), 1.0) == 1.0
    # the last inner knot towards the end; no inner knots at all
    assert _gap_fraction(knots, np.array([0.0, 20.0]), 1.0) == pytest.approx(0.99 * 17.0 / 20.0)
    assert _gap_fraction(np.array([0.0, 30.0]), np.zeros(0), 1.0) == 1.0
    for step in (np.array([5.0, 0.0]), np.array([-9.5, 7.0]), np.array([3.0, -4.0])):
        moved = knots + np.concatenate([[0.0], _gap_fraction(knots, step, 1.0) * step, [0.0]])
        assert np.min(np.diff(moved)) >= 1.0


def test_refinement_recovers_a_far_tip_value_in_few_iterations():
    """A tip value's step is capped by its own reach (1 / the width of its segment), not 1/L:
    a torsion tip value 6/L off comes back in 10 iterations as far as in 200."""
    from tendrilkit.pwc.refine import _refine_laws_lm

    tc = random_pwc_curve(7)
    s, data = tc.s_mm, tc.clean_mm
    kk, vk = tc.kappa_knots
    kt, vt = tc.tau_knots
    L = s[-1] - s[0]
    vt_off = vt.copy()
    vt_off[-1] += 6.0 / L
    sse = {}
    for it in (10, 200):
        _, sse[it], _ = _refine_laws_lm(s, data, kk, vk, kt, vt_off, free_knots=False, iterations=it, rtol=0.0)
    _, sse_true, _ = _refine_laws_lm(s, data, kk, vk, kt, vt, free_knots=False, iterations=0)
    assert sse[200] <= sse_true  # as close as the true laws (the data are the exact positions)
    assert sse[10] <= 1.01 * sse[200], (sse, sse_true)


def test_auto_searches_again_when_residuals_exceed_the_noise():
    """``_missed``: below target R^2, or an rms residual above RETRY_NOISE_RATIO of the noise."""
    import tendrilkit.pwc.fit as F
    from tendrilkit.frenet import noise_sigma_mm

    P = random_pwc_curve(3).points_mm
    sigma, n = noise_sigma_mm(P), len(P)
    sse_at = lambda ratio: (ratio * sigma) ** 2 * 3 * n  # noqa: E731
    assert not F._missed((None, None, sse_at(0.8), 0.9999), 0.999, sigma, n)
    assert F._missed((None, None, sse_at(1.2 * F.RETRY_NOISE_RATIO), 0.9999), 0.999, sigma, n)
    assert F._missed((None, None, sse_at(0.5), 0.99), 0.999, sigma, n)


def test_retry_yardstick_is_the_noise_or_a_fraction_of_what_the_target_allows():
    """Noisy points: their noise; a smoothed curve (noise ~0): RETRY_ALLOWANCE_FRACTION of the rms the target R^2
    allows, so that a fit leaving 0.01 mm on a smooth 150 mm curve is not searched again, one leaving 0.1 mm is."""
    import tendrilkit.pwc.fit as F
    from tendrilkit.frenet import noise_sigma_mm

    tc = random_pwc_curve(3)
    P = tc.points_mm
    assert F._retry_yardstick_mm(P, P, 0.999) == noise_sigma_mm(P)
    smooth = tc.dense_mm[::10]
    sst = np.sum((smooth - smooth.mean(axis=0)) ** 2)
    allowed = np.sqrt(0.001 * sst / (3 * len(smooth)))
    assert noise_sigma_mm(smooth) < 0.01 * allowed
    y = F._retry_yardstick_mm(smooth, smooth, 0.999)
    assert y == pytest.approx(F.RETRY_ALLOWANCE_FRACTION * allowed)
    n = len(smooth)
    sse_at = lambda rms: rms ** 2 * 3 * n  # noqa: E731
    assert not F._missed((None, None, sse_at(0.01), 0.99999), 0.999, y, n)
    assert F._missed((None, None, sse_at(0.1), 0.99999), 0.999, y, n)


def test_bic_counts_residuals_down_to_the_precision_asked_for(monkeypatch):
    """A smooth curve with ripples far below the rms the target R^2 allows (as a reconstruction's curves): with
    BIC's SSE floored at BIC_PRECISION_FRACTION of that rms, the search stops at the true 2 + 2 segments instead
    of chasing the ripples with more; noisy points never reach the floor and fit exactly as without it."""
    import tendrilkit.pwc.fit as F

    tc = random_pwc_curve(3)
    rippled = tc.dense_mm[::100].copy()
    rippled[:, 2] += 0.01 * np.sin(np.linspace(0, 12 * np.pi, len(rippled)))
    floored, noisy = fit_piecewise_clothoid(rippled), fit_piecewise_clothoid(tc.points_mm)
    monkeypatch.setattr(F, "BIC_PRECISION_FRACTION", 0.0)
    chased, noisy0 = fit_piecewise_clothoid(rippled), fit_piecewise_clothoid(tc.points_mm)
    assert (floored.n_segments_kappa, floored.n_segments_tau) == (2, 2)
    assert chased.n_segments_kappa + chased.n_segments_tau > 4
    assert len(floored.candidates) < len(chased.candidates)
    assert floored.scores.rmse_mm < 0.02 * F._allowed_rms_mm(floored.data_mm, 0.999)
    assert np.array_equal(noisy.points_mm, noisy0.points_mm)
    assert np.array_equal(noisy.candidates, noisy0.candidates)


def test_candidates_that_cannot_win_are_not_evaluated(monkeypatch):
    """With BIC's SSE floored (a smooth curve whose fit reaches the floor), a candidate whose BIC at the floor is
    no better than the current fit's cannot win: skipping it (and the score test when no insertion could win)
    gives the same fit with fewer refinements; noisy points never reach the floor and skip nothing."""
    import tendrilkit.pwc.selection as S

    tc = random_pwc_curve(3)
    rippled = tc.dense_mm[::100].copy()
    rippled[:, 2] += 0.01 * np.sin(np.linspace(0, 12 * np.pi, len(rippled)))
    calls = []
    refine = S._refine_laws
    monkeypatch.setattr(S, "_refine_laws", lambda *a: calls.append(1) or refine(*a))
    fits, counts = {}, {}
    for skip in (True, False):
        monkeypatch.setattr(S, "SKIP_HOPELESS", skip)
        for name, P in (("rippled", rippled), ("noisy", tc.points_mm)):
            calls.clear()
            fits[name, skip] = fit_piecewise_clothoid(P)
            counts[name, skip] = len(calls)
    for name in ("rippled", "noisy"):
        a, b = fits[name, True], fits[name, False]
        assert np.array_equal(a.points_mm, b.points_mm)
        for law in ("kappa_law", "tau_law"):
            assert np.array_equal(getattr(a, law).knots_mm, getattr(b, law).knots_mm)
            assert np.array_equal(getattr(a, law).values, getattr(b, law).values)
    assert counts["rippled", True] < counts["rippled", False]
    assert counts["noisy", True] == counts["noisy", False]
    assert np.array_equal(fits["noisy", True].candidates, fits["noisy", False].candidates)


def test_torsion_path_laws_start_within_the_torsion_measured():
    """Phantom S3 at frame 44 has a straight proximal part (curvature about 0, torsion undefined): a torsion path
    law's line fitted where the torsion has weight extrapolated to about 7 /mm there, and from that start the fit
    locked into a tight helix standing for the straight part (SSE 43 mm^2, |tau| up to 31 /mm). Started within
    the range of the torsion measured, the fit follows the straight part."""
    from tendrilkit.frenet import resample_curve
    from tendrilkit.phantom import make_phantom

    C = resample_curve(make_phantom("S3").curves_mm[44], 200)
    X = C + np.random.default_rng(44).normal(0, 0.005, C.shape)
    f = fit_piecewise_clothoid(X)
    assert f.sse_mm2 < 2.0
    assert np.abs(f.tau_law.values).max() < 1.0
    assert mean_distance_mm(f.points_mm, resample_curve(make_phantom("S3").curves_mm[44], 4000)) < 0.05



def _python_join(s, y, w, bounds):
    """The join of a segmentation as it was written in Python (before _join_core): the reference."""
    from tendrilkit.pwc.laws import _Lines, _refit_values

    line, h_min = _Lines(s, y, w), float(np.min(np.diff(s)))
    b = [int(v) for v in bounds]
    while True:
        lines = [line(a, c) for a, c in zip(b[:-1], b[1:])]
        knots, bad = [float(s[0])], None
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
    kn = np.array(knots + [float(s[-1])])
    return kn, _refit_values(s, y, w, kn)


def test_compiled_join_is_the_python_join_bit_for_bit():
    """_join_core (lines, overshoot merges, refit in one compiled call) gives the Python join's bits,
    merges included, on weighted and unweighted signals."""
    from tendrilkit.pwc.laws import _Joiner

    rng = np.random.default_rng(7)
    merged = 0
    for trial in range(300):
        n = int(rng.integers(6, 200))
        s = np.cumsum(rng.uniform(0.2, 1.5, n))
        y = (rng.normal(size=n) * 0.01 if trial % 3 == 0 else
             np.interp(s, np.sort(rng.uniform(s[0], s[-1], 4)), rng.normal(size=4)) + rng.normal(0, 0.001, n))
        w = np.ones(n) if trial % 3 != 2 else rng.uniform(0, 1, n) * (rng.uniform(size=n) > 0.3)
        k = int(rng.integers(1, min(10, n // 3) + 1))
        b = np.r_[0, np.sort(rng.choice(np.arange(1, n), k - 1, replace=False)), n]
        law = _Joiner(s, y, w).join(b)
        kn, v = _python_join(s, y, w, b)
        merged += kn.size < b.size
        assert law.knots_mm.tobytes() == kn.tobytes() and law.values.tobytes() == v.tobytes()
    assert merged > 50


def test_weighted_median_is_numpys_inverted_cdf_quantile():
    """The torsion start's weighted median (np.quantile's steps without its set-up): the same values, ties
    and zero weights included."""
    from tendrilkit.pwc.selection import _weighted_median

    rng = np.random.default_rng(4)
    for t in range(500):
        n = int(rng.integers(1, 200))
        y = rng.normal(size=n) if t % 2 else np.round(rng.normal(size=n), 1)
        w = rng.uniform(size=n) ** 2 * (rng.uniform(size=n) > [0.0, 0.5, 0.9][t % 3])
        if w.sum() > 0:
            assert _weighted_median(y, w) == float(np.quantile(y, 0.5, weights=w, method="inverted_cdf"))
