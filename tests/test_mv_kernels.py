"""The compiled kernels of the multi-view method give what the plain numpy / k-d tree computations give, bit for bit.

They replace whole-array numpy expressions and k-d tree queries for speed (issue 12: 150 ms per frame); the
results of a reconstruction must not move, so each is compared here with the computation it replaced.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

from tendrilkit.camera import Camera
from tendrilkit.evidence import view_evidence
from tendrilkit.mv_acquire import _frames, _nearest_distance
from tendrilkit.mv_evidence import _near_foreground, mark_near, skeleton_distance, skeleton_evidence


@pytest.fixture(scope="module")
def ev():
    """A view of a dark wavy line, a crossing bar and specks (a skeleton of a few hundred pixels)."""
    img = np.full((120, 200, 3), 255, np.uint8)
    x = np.arange(10, 190)
    y = (60 + 25 * np.sin(x / 17.0)).astype(np.int32)
    cv2.polylines(img, [np.c_[x, y].astype(np.int32)], False, (20, 20, 20), 3)
    cv2.line(img, (100, 5), (110, 115), (20, 20, 20), 3)
    cv2.circle(img, (30, 20), 4, (20, 20, 20), -1)
    vw = view_evidence(img, roi=[5, 2, 190, 116], keep_out=[5, 40, 12, 30], base_point_xy=[12, 60],
                       opening_radius_px=0, min_component_px=10)
    cam = Camera(K=np.array([[400.0, 0, 100], [0, 400.0, 60], [0, 0, 1]]), dist=np.array([-0.1, 0.02, 1e-3, -1e-3, 0.0]))
    return skeleton_evidence(vw, cam)


def _points(ev, rng, n, spread):
    p = ev.skeleton_xy[rng.integers(0, len(ev.skeleton_xy), n)] + rng.normal(0.0, spread, (n, 2))
    p[0] = ev.skeleton_xy[3] + [0.5, 0.5]  # equally near several skeleton pixels
    p[1] = np.nan
    p[2] = [-50.0, 30.0]                     # outside the crop
    return p


@pytest.mark.parametrize("spread", [0.3, 3.0, 40.0])
def test_skeleton_distance_nearest_is_the_kd_trees(ev, spread):
    """The grid's nearest skeleton pixel (and "none within outside_px") is the k-d tree's, ties included."""
    rng = np.random.default_rng(0)
    p = _points(ev, rng, 300, spread)
    for outside in (2.0, 10.0, 1e3):
        d, g, seen, near, bg, cov = skeleton_distance(ev, p, outside_px=outside, index=True)
        h, w = ev.seen.shape
        x, y = p[:, 0] - ev.offset_xy[0], p[:, 1] - ev.offset_xy[1]
        ok = np.isfinite(x) & np.isfinite(y) & (x >= -0.5) & (y >= -0.5) & (x < w - 0.5) & (y < h - 0.5)
        dd, idx = ev.tree.query(p[ok], distance_upper_bound=outside)
        np.testing.assert_array_equal(near[ok], np.where(np.isfinite(dd), idx, -1))
        assert np.all(near[~ok] == -1) and np.all(d[~ok] == outside)
        # the distance to the nearest pixel's line piece: the numpy formula it replaced
        j = near >= 0
        diff = p[j] - ev.centre_xy[near[j]]
        t = ev.tangent_xy[near[j]]
        nrm = np.column_stack([-t[:, 1], t[:, 0]])
        dn = np.einsum("ka,ka->k", diff, nrm)
        ex = np.maximum(np.abs(np.einsum("ka,ka->k", diff, t)) - 1.0, 0.0)
        np.testing.assert_array_equal(d[j], np.hypot(dn, ex))
        assert np.all(d[ok & ~j] == outside) and np.all(g[~j] == 0.0)


def test_mark_near_marks_the_ball_query_pixels(ev):
    rng = np.random.default_rng(1)
    p = _points(ev, rng, 200, 5.0)[2:]  # the k-d tree's ball query refuses NaN
    p[0] = ev.skeleton_xy[10] + [4.0, 0.0]  # exactly at the radius: inclusive
    for r in (1.0, 4.0, 7.5):
        want = np.zeros(len(ev.skeleton_xy), bool)
        for lst in ev.tree.query_ball_point(p, r):
            want[lst] = True
        got = np.zeros(len(ev.skeleton_xy), bool)
        mark_near(ev, got, p, r)
        np.testing.assert_array_equal(got, want)
        assert want.any() and not want.all()


def test_near_foreground_is_the_chamfer_distance_within_2px():
    rng = np.random.default_rng(2)
    for _ in range(50):
        fg = rng.random(tuple(rng.integers(3, 80, 2))) < rng.choice([0.002, 0.02, 0.3])
        D = cv2.distanceTransform(cv2.compare(fg.view(np.uint8), 0, cv2.CMP_EQ), cv2.DIST_L2, 5)
        want = D <= 2.0 if fg.any() else np.full(fg.shape, np.hypot(*fg.shape) <= 2.0)
        np.testing.assert_array_equal(_near_foreground(fg), want)


def test_camera_project_is_the_numpy_formula():
    """Camera.project (compiled) against OpenCV's 5-coefficient model written as whole-array numpy."""
    rng = np.random.default_rng(3)
    R = cv2.Rodrigues(np.array([0.1, -0.3, 0.05]))[0]
    cam = Camera(K=np.array([[1500.0, 0.5, 960], [0, 1490.0, 540], [0, 0, 1]]),
                 dist=np.array([-0.04, 0.003, -5e-4, 3e-4, 1e-4]), R=R, t_mm=np.array([5.0, -3.0, 300.0]))
    X = rng.normal(0.0, 40.0, (500, 3))
    X[0] = np.nan
    Xc = X @ cam.R.T + cam.t_mm
    with np.errstate(divide="ignore", invalid="ignore"):
        x, y = Xc[:, 0] / Xc[:, 2], Xc[:, 1] / Xc[:, 2]
    k1, k2, p1, p2, k3 = cam.dist
    r2 = x * x + y * y
    radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    K = cam.K
    want = np.stack([K[0, 0] * xd + K[0, 1] * yd + K[0, 2], K[1, 1] * yd + K[1, 2]], axis=1)
    np.testing.assert_array_equal(cam.project(X), want)
    pin = np.stack([K[0, 0] * x + K[0, 1] * y + K[0, 2], K[1, 1] * y + K[1, 2]], axis=1)
    np.testing.assert_array_equal(cam.project(X, distort=False), pin)


def test_acquisition_helpers_are_the_numpy_expressions():
    rng = np.random.default_rng(4)
    P, Q = rng.normal(0, 5, (37, 3)), rng.normal(0, 5, (120, 3))
    np.testing.assert_array_equal(_nearest_distance(P, Q), np.min(np.linalg.norm(P[:, None] - Q[None], axis=2), axis=1))
    A = rng.normal(0, 1, (16, 3))
    A[0] = [0.95, 0.1, 0.1]  # the other reference direction
    F = _frames(A)
    a = A / np.linalg.norm(A, axis=1, keepdims=True)
    ref = np.where(np.abs(a[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
    p = np.cross(a, ref)
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    np.testing.assert_array_equal(F, np.stack([p, np.cross(a, p), a], axis=2))
