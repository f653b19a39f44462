"""Correspondence across views: Fréchet (paper) and epipolar matching."""

from __future__ import annotations

import functools

import numpy as np
import pytest

from tendrilkit.calibration import ijcv25_rig
from tendrilkit.camera import Camera
from tendrilkit.correspondence import (
    discrete_frechet,
    epipolar_distance,
    fundamental_matrix,
    match_epipolar,
    match_frechet,
)
from tendrilkit.exceptions import CorrespondenceError
from tendrilkit.geometry import resample_polyline
from tendrilkit.triangulation import triangulate


def _brute_frechet(P, Q):
    @functools.lru_cache(maxsize=None)
    def c(i, j):
        d = float(np.linalg.norm(P[i] - Q[j]))
        if i == 0 and j == 0:
            return d
        if i == 0:
            return max(c(0, j - 1), d)
        if j == 0:
            return max(c(i - 1, 0), d)
        return max(min(c(i - 1, j), c(i - 1, j - 1), c(i, j - 1)), d)

    return c(len(P) - 1, len(Q) - 1)


@pytest.mark.parametrize("seed", range(12))
def test_discrete_frechet_matches_brute_force(seed):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(rng.integers(1, 8), 2))
    Q = rng.normal(size=(rng.integers(1, 8), 2))
    d, c = discrete_frechet(P, Q)
    assert d == pytest.approx(_brute_frechet(P, Q), abs=1e-12)
    # a valid coupling: from (0, 0) to the ends, monotone steps of one
    assert c[0].tolist() == [0, 0] and c[-1].tolist() == [len(P) - 1, len(Q) - 1]
    steps = np.diff(c, axis=0)
    assert np.all((steps >= 0) & (steps <= 1)) and np.all(steps.sum(axis=1) >= 1)
    assert np.max(np.linalg.norm(P[c[:, 0]] - Q[c[:, 1]], axis=1)) == pytest.approx(d, abs=1e-12)


def test_discrete_frechet_long_curves_no_recursion_limit():
    t = np.linspace(0, 1, 3000)
    P = np.c_[t, np.sin(6 * t)]
    d, c = discrete_frechet(P, P + [0, 0.1])
    assert d == pytest.approx(0.1)
    assert len(c) >= 3000


# ----------------------------------------------------------- epipolar matching
def _rig(distorted=True):
    cams = ijcv25_rig()
    if not distorted:
        return cams
    return [Camera(c.K, [-0.08, 0.04, 0.0005, -0.0005, 0.0], c.R, c.t_mm, c.width, c.height) for c in cams]


def _curve(kind, n=3000):
    s = np.linspace(0, 1, n)
    if kind == "hang":  # hangs along world x (down the images): crosses the epipolar lines
        return np.c_[-30 + 60 * s, 5 * np.sin(3 * s), 20 + 3 * s]
    if kind == "curl":  # a coil at the tip, axis along x
        th = np.clip(s - 0.5, 0, None) * 8 * np.pi
        return np.c_[-30 + 50 * s, 6 * np.sin(th), 20 + 6 * (1 - np.cos(th))]
    if kind == "along":  # an arc that runs along the epipolar lines (world y) for a while
        th = 1.5 * np.pi * s
        return np.c_[-20 + 25 * np.sin(th), 25 * (1 - np.cos(th)) - 10, 15 + 5 * s]
    raise ValueError(kind)


def _views(X, cams, noise, seed):
    rng = np.random.default_rng(seed)
    out = []
    for c in cams:
        p = c.project(X)
        n = int(np.linalg.norm(np.diff(p, axis=0), axis=1).sum())  # ~1 px apart, like a skeleton
        p = resample_polyline(p, n)
        out.append(p + rng.normal(0, noise, p.shape))
    return out


def _dist_to_curve(P, X):
    return np.array([np.min(np.linalg.norm(X - p, axis=1)) for p in P])


def test_fundamental_matrix_vanishes_on_true_pairs():
    cams = _rig(distorted=False)
    X = _curve("curl")[::100]
    F = fundamental_matrix(cams[1], cams[2])
    a, b = cams[1].project(X), cams[2].project(X)
    d = np.diag(epipolar_distance(F, a, b))
    assert d.max() < 1e-6


@pytest.mark.parametrize("kind", ["hang", "curl", "along"])
def test_epipolar_matching_recovers_the_curve(kind):
    cams = _rig()
    X = _curve(kind)
    views = _views(X, cams, noise=0.3, seed=1)
    M = match_epipolar(views, cams, reference=1, k=200)
    assert M.shape == (3, 200, 2)
    tri = triangulate(M, cams)
    P = tri.points_mm[np.all(np.isfinite(tri.points_mm), axis=1)]
    assert len(P) >= 190
    d = _dist_to_curve(P, X)
    assert d.mean() < 0.3 and d.max() < 1.5
    assert np.linalg.norm(P[0] - X[0]) < 1.0 and np.linalg.norm(P[-1] - X[-1]) < 1.0
    assert np.nanmean(tri.reproj_err_px) < 0.5


def test_epipolar_matching_two_views_and_truncated_ends():
    cams = _rig()
    X = _curve("hang")
    views = _views(X, cams, noise=0.2, seed=2)
    views[0] = views[0][60:]  # view 1 misses the base
    M = match_epipolar(views[:2], cams[:2], reference=1, k=100)
    assert np.isnan(M[0, :3]).all()  # the reference's first points have no match in view 1
    tri = triangulate(M, cams[:2])
    P = tri.points_mm[np.all(np.isfinite(tri.points_mm), axis=1)]
    assert len(P) > 80
    assert _dist_to_curve(P, X).mean() < 0.3


def test_frechet_matching_runs_and_is_worse_off_plane():
    cams = _rig()
    X = _curve("curl")
    views = _views(X, cams, noise=0.3, seed=3)
    M = match_frechet(views, cams, reference=1, k=200)
    assert M.shape == (3, 200, 2) and np.isfinite(M).all()
    tri = triangulate(M, cams)
    e = _dist_to_curve(tri.points_mm, X).mean()
    M2 = match_epipolar(views, cams, reference=1, k=200)
    t2 = triangulate(M2, cams)
    e2 = _dist_to_curve(t2.points_mm[np.all(np.isfinite(t2.points_mm), axis=1)], X).mean()
    assert e2 < e


def test_match_rejects_bad_input():
    cams = _rig()
    with pytest.raises(ValueError, match="at least 2 views"):
        match_epipolar([np.zeros((5, 2))], cams[:1], reference=0)
    with pytest.raises(ValueError, match="reference"):
        match_epipolar([np.c_[np.arange(5.0), np.zeros(5)]] * 2, cams[:2], reference=2)
    with pytest.raises(ValueError, match="shape"):
        match_epipolar([np.zeros((5, 3))] * 2, cams[:2], reference=0)
