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
from tendrilkit.multiview import _add_view, _banded_normal, _bending_blocks
from tendrilkit.mv_evidence import (COVER_DEPTH_PX, COVER_PX, _near_foreground, mark_near, skeleton_distance,
                                    skeleton_evidence)


def _wavy_view(draw_more) -> object:
    """The multi-view evidence of a dark wavy line on a white board, with ``draw_more(img)`` drawn on it too."""
    img = np.full((120, 200, 3), 255, np.uint8)
    x = np.arange(10, 190)
    y = (60 + 25 * np.sin(x / 17.0)).astype(np.int32)
    cv2.polylines(img, [np.c_[x, y].astype(np.int32)], False, (20, 20, 20), 3)
    draw_more(img)
    vw = view_evidence(img, roi=[5, 2, 190, 116], keep_out=[5, 40, 12, 30], base_point_xy=[12, 60],
                       opening_radius_px=0, min_component_px=10)
    cam = Camera(K=np.array([[400.0, 0, 100], [0, 400.0, 60], [0, 0, 1]]), dist=np.array([-0.1, 0.02, 1e-3, -1e-3, 0.0]))
    return skeleton_evidence(vw, cam)


@pytest.fixture(scope="module")
def ev():
    """A view of a dark wavy line, a crossing bar and specks (a skeleton of a few hundred pixels)."""
    def bar_and_speck(img):
        cv2.line(img, (100, 5), (110, 115), (20, 20, 20), 3)
        cv2.circle(img, (30, 20), 4, (20, 20, 20), -1)
    return _wavy_view(bar_and_speck)


@pytest.fixture(scope="module")
def ev_blob():
    """The wavy line running into a filled dark blob (a leaf): deep inside it, far from the skeleton, is covered."""
    return _wavy_view(lambda img: cv2.ellipse(img, (140, 55), (30, 22), 20.0, 0, 360, (20, 20, 20), -1))


def _skeleton_distance_d79ec45(ev, points_xy, *, outside_px=50.0, index=False):
    """skeleton_distance as it was at d79ec45 (k-d tree and whole-array numpy), copied unchanged."""
    p = np.asarray(points_xy, float)
    x = p[:, 0] - ev.offset_xy[0]
    y = p[:, 1] - ev.offset_xy[1]
    h, w = ev.seen.shape
    ok = np.isfinite(x) & np.isfinite(y) & (x >= -0.5) & (y >= -0.5) & (x < w - 0.5) & (y < h - 0.5)
    d = np.full(len(p), float(outside_px))
    g = np.zeros((len(p), 2))
    seen = np.zeros(len(p), bool)
    nearest = np.full(len(p), -1)
    background = np.zeros(len(p), bool)
    covered = np.zeros(len(p), bool)
    if ok.any():
        dd, idx = ev.tree.query(p[ok], distance_upper_bound=outside_px)
        near = np.isfinite(dd)
        # distance to the local line piece of the nearest skeleton pixel, beyond its ends to the piece
        j = idx[near]
        diff = p[ok][near] - ev.centre_xy[j]
        t = ev.tangent_xy[j]
        nrm = np.column_stack([-t[:, 1], t[:, 0]])
        dn = np.einsum("ka,ka->k", diff, nrm)
        dt = np.einsum("ka,ka->k", diff, t)
        ex = np.maximum(np.abs(dt) - 1.0, 0.0)
        dl = np.hypot(dn, ex)
        gl = (dn[:, None] * nrm + (ex * np.sign(dt))[:, None] * t) / np.maximum(dl, 1e-9)[:, None]
        gl[dl < 1e-9] = nrm[dl < 1e-9]
        gg = np.zeros((ok.sum(), 2))
        gg[near] = gl
        dv = np.full(ok.sum(), float(outside_px))
        dv[near] = dl
        d[ok] = dv
        g[ok] = gg
        yi, xi = np.rint(y[ok]).astype(int), np.rint(x[ok]).astype(int)
        seen[ok] = ev.seen[yi, xi]
        nearest[ok] = np.where(near, idx, -1)
        background[ok] = seen[ok] & ~ev.near_foreground[yi, xi]
        covered[ok] = seen[ok] & (ev.inside_px[yi, xi] >= COVER_DEPTH_PX) & (d[ok] > COVER_PX)
    return (d, g, seen, nearest, background, covered) if index else (d, g, seen)


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


@pytest.mark.parametrize("which", ["ev", "ev_blob"])
@pytest.mark.parametrize("spread", [0.3, 3.0, 40.0])
def test_skeleton_distance_is_the_d79ec45_function(which, spread, request):
    """Every output (d, gradient, seen, nearest, background, covered) is the old k-d tree function's, bit for bit."""
    ev = request.getfixturevalue(which)
    rng = np.random.default_rng(5)
    h, w = ev.seen.shape
    p = np.concatenate([_points(ev, rng, 300, spread),
                        ev.offset_xy + rng.uniform(-3.0, 3.0, (300, 2)) + rng.uniform(0, 1, (300, 2)) * [w, h],
                        ev.offset_xy + rng.integers(0, [w, h], (100, 2)) + 0.5])  # halfway: np.rint's ties
    p[3] = ev.centre_xy[7]  # on a line piece: d = 0, the gradient is the normal
    n_covered = 0
    for outside in (2.0, 10.0, 1e3):
        want = _skeleton_distance_d79ec45(ev, p, outside_px=outside, index=True)
        got = skeleton_distance(ev, p, outside_px=outside, index=True)
        for a, b, name in zip(got, want, ["d", "g", "seen", "nearest", "background", "covered"]):
            np.testing.assert_array_equal(a, b, err_msg=name)
            assert a.dtype.kind == b.dtype.kind, name
        for a, b in zip(skeleton_distance(ev, p, outside_px=outside), want[:3]):
            np.testing.assert_array_equal(a, b)
        n_covered += want[5].sum()
        assert want[2].any() and want[3].max() >= 0 and want[4].any()
    if which == "ev_blob":
        assert n_covered > 0  # the blob's inside: the covered check is not vacuous
    else:
        assert n_covered == 0


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


# ---- refine_curve's kernels (multiview.py) against the numpy of d79ec45's refine_curve / _bending_blocks ----

def _bending_blocks_d79ec45(n):
    D = np.zeros((n, n))
    for i in range(1, n - 1):
        D[i - 1:i + 2, i - 1:i + 2] += np.outer([1, -2, 1], [1, -2, 1])
    return np.stack([np.r_[np.zeros(2), np.diagonal(D, 2)], np.r_[0.0, np.diagonal(D, 1)], np.diagonal(D)])


def _add_view_d79ec45(Hd, g, d, gd, seen, J, huber_px, cap):
    """One view's terms as d79ec45's refine_curve added them (in place)."""
    w = np.where(d <= huber_px, 1.0, huber_px / np.maximum(d, 1e-9)) * (seen & (d <= cap))
    row = np.einsum("ka,kai->ki", gd, J)
    Hd += w[:, None, None] * np.einsum("ki,kj->kij", row, row)
    g += (w * d)[:, None] * row


def _banded_normal_d79ec45(Hd, tt, bend):
    n = len(Hd)
    N = 3 * n
    ab = np.zeros((9, N))
    for a in range(3):
        for b in range(a, 3):
            ab[8 - (b - a), 3 * np.arange(n) + b] += Hd[:, a, b]
        for b in range(3):  # the length blocks between node i and i+1: -tt
            off = 3 + b - a
            ab[8 - off, 3 * np.arange(1, n) + b] -= tt[:, a, b]
    for k in range(3):  # bending: (D2^T D2) kron I3, node offsets 0, 1, 2 -> scalar offsets 0, 3, 6
        ab[8 - 3 * k, :] += np.repeat(bend[2 - k], 3)
    ab[8] += 1e-3 * ab[8].max() * 1e-3 + 1e-6
    ab[8] *= 1.0 + 1e-3
    return ab


def test_bending_blocks_is_the_d79ec45_sum():
    for n in range(2, 51):
        want = _bending_blocks_d79ec45(n)
        got = _bending_blocks(n)
        assert got.shape == want.shape == (3, n)
        np.testing.assert_array_equal(got, want)


def _view_inputs(rng, n):
    """One view's (d, gd, seen, J) as skeleton_distance and the projection's differences give them."""
    d = np.abs(rng.standard_cauchy(n)) * rng.choice([0.5, 3.0, 30.0], n)
    d[rng.random(n) < 0.1] = 1e3                    # nothing near: outside_px
    d[rng.random(n) < 0.1] = 0.0                    # on the line piece
    d[rng.random(n) < 0.1] = 2.0                    # exactly huber_px
    d[rng.random(n) < 0.1] = 8.0                    # exactly the cap
    a = rng.uniform(0, 2 * np.pi, n)
    gd = np.c_[np.cos(a), np.sin(a)] * (d < 1e3)[:, None]
    seen = rng.random(n) < 0.8
    J = rng.normal(0.0, 1.0, (n, 2, 3)) * rng.choice([1.0, 50.0, 400.0], (n, 1, 1))
    return d, gd, seen, J


@pytest.mark.parametrize("seed", range(3))
def test_add_view_is_the_d79ec45_numpy(seed):
    rng = np.random.default_rng(100 + seed)
    for n in range(2, 51):
        Hd0, g0 = rng.normal(0, 10, (n, 3, 3)), rng.normal(0, 10, (n, 3))
        Hd1, g1, Hd2, g2 = Hd0.copy(), g0.copy(), Hd0.copy(), g0.copy()
        for _ in range(3):  # views add up in place
            d, gd, seen, J = _view_inputs(rng, n)
            for huber_px, cap in ((2.0, 8.0), (1.5, 1e3)):
                _add_view(Hd1, g1, d, gd, seen, J, huber_px, cap)
                _add_view_d79ec45(Hd2, g2, d, gd, seen, J, huber_px, cap)
        np.testing.assert_array_equal(Hd1, Hd2)
        np.testing.assert_array_equal(g1, g2)
        assert not np.array_equal(Hd1, Hd0)


def test_add_view_with_nan_is_the_d79ec45_numpy():
    """A node that projects to NaN (behind or at a camera, or NaN itself): skeleton_distance gives d = outside_px,
    gradient 0, unseen; its J is NaN, and the old numpy's 0 * NaN put NaN in that node's terms."""
    rng = np.random.default_rng(7)
    n = 20
    d, gd, seen, J = _view_inputs(rng, n)
    bad = np.array([0, 5, 19])
    d[bad], gd[bad], seen[bad] = 1e3, 0.0, False
    J[bad] = np.nan
    J[9, 1, 2] = np.nan  # one NaN difference of a seen node
    seen[9], d[9] = True, 1.0
    gd[12] = np.nan      # and a NaN gradient
    Hd1, g1 = rng.normal(0, 1, (n, 3, 3)), rng.normal(0, 1, (n, 3))
    Hd2, g2 = Hd1.copy(), g1.copy()
    _add_view(Hd1, g1, d, gd, seen, J, 2.0, 8.0)
    _add_view_d79ec45(Hd2, g2, d, gd, seen, J, 2.0, 8.0)
    np.testing.assert_array_equal(Hd1, Hd2)
    np.testing.assert_array_equal(g1, g2)
    assert np.isnan(Hd2[bad]).all() and np.isnan(Hd2[9]).any() and np.isnan(Hd2[12]).any()


def _normal_inputs(rng, n):
    Hd = rng.normal(0, 1, (n, 3, 3)) * rng.choice([1e-3, 1.0, 1e4], (n, 1, 1))
    Hd = Hd + Hd.transpose(0, 2, 1)
    t = rng.normal(0, 1, (n - 1, 3))
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    tt = rng.uniform(0.1, 10.0) ** 2 * np.einsum("ki,kj->kij", t, t)
    bend = _bending_blocks_d79ec45(n) * rng.uniform(0.1, 30.0) ** 2
    return Hd, tt, bend


@pytest.mark.parametrize("seed", range(3))
def test_banded_normal_is_the_d79ec45_numpy(seed):
    rng = np.random.default_rng(200 + seed)
    for n in range(2, 51):
        Hd, tt, bend = _normal_inputs(rng, n)
        np.testing.assert_array_equal(_banded_normal(Hd, tt, bend), _banded_normal_d79ec45(Hd, tt, bend))
        # general (not symmetric) blocks and a bending band of any values: every entry's place and order
        Hd, tt, bend = rng.normal(0, 5, (n, 3, 3)), rng.normal(0, 5, (n - 1, 3, 3)), rng.normal(0, 5, (3, n))
        np.testing.assert_array_equal(_banded_normal(Hd, tt, bend), _banded_normal_d79ec45(Hd, tt, bend))


def test_banded_normal_with_nan_is_the_d79ec45_numpy():
    """A NaN node block (from _add_view's NaN): the old ab[8].max() was NaN, the whole diagonal NaN."""
    rng = np.random.default_rng(8)
    for n, where in ((12, (4, 0, 0)), (12, (0, 1, 2)), (2, (1, 2, 2)), (30, (29, 2, 2))):
        Hd, tt, bend = _normal_inputs(rng, n)
        Hd[where] = np.nan
        want = _banded_normal_d79ec45(Hd, tt, bend)
        np.testing.assert_array_equal(_banded_normal(Hd, tt, bend), want)
        assert np.isnan(want).any()
    Hd, tt, bend = _normal_inputs(rng, 10)
    tt[3, 0, 1] = np.nan
    np.testing.assert_array_equal(_banded_normal(Hd, tt, bend), _banded_normal_d79ec45(Hd, tt, bend))


def _cone_with_np_cross(axis, max_deg, rings):
    """The cone of mv_acquire.cone_directions as first written (np.cross, the rings' angles every call)."""
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    p = np.cross(a, [1.0, 0.0, 0.0] if abs(a[0]) < 0.9 else [0.0, 1.0, 0.0])
    p /= np.linalg.norm(p)
    q = np.cross(a, p)
    out = [a]
    for k in range(1, rings + 1):
        th = np.radians(max_deg * k / rings)
        n_az = max(6, int(round(2 * np.pi * np.sin(th) / np.radians(max_deg / rings))))
        az = 2 * np.pi * (np.arange(n_az) + 0.5 * (k % 2)) / n_az
        out.append(np.cos(th) * a + np.sin(th) * (np.cos(az)[:, None] * p + np.sin(az)[:, None] * q))
    return np.vstack(out)


def test_cone_directions_are_those_of_np_cross():
    """The cone's directions, byte for byte (signed zeros too), on random axes, near-x axes and every cone used."""
    from tendrilkit.mv_acquire import cone_directions

    rng = np.random.default_rng(7)
    axes = rng.normal(size=(300, 3)) * rng.choice([1e-3, 1.0, 1e3], size=(300, 1))
    axes[::5, 1:] *= 1e-3  # along x: the other reference vector
    axes = np.vstack([axes, np.eye(3), -np.eye(3)])
    for ax in axes:
        for deg, rings in ((30.0, 3), (30.0, 2), (25.0, 8), (20.0, 2), (12.5, 3)):
            assert cone_directions(ax, deg, rings).tobytes() == _cone_with_np_cross(ax, deg, rings).tobytes()


def test_skeleton_seen_px_counts_the_whole_crop():
    """The seen pixels per skeleton component, read at the skeleton's pixels: those of the whole crop's count."""
    def more(img):
        cv2.line(img, (30, 100), (170, 15), (20, 20, 20), 2)       # a second line crossing the first
        cv2.line(img, (150, 100), (190, 110), (20, 20, 20), 2)     # a separate one

    ev = _wavy_view(more)
    lab = ev.skeleton_labels
    assert lab.max() >= 2
    ref = np.bincount(lab[ev.seen], minlength=int(lab.max()) + 1)
    assert ev.skeleton_seen_px.dtype == ref.dtype and np.array_equal(ev.skeleton_seen_px, ref)


def _support_on_the_whole_crop(X_mm, evidence, tol_px=3.0):
    """multiview.curve_support as first written: the line drawn on the whole crop."""
    from tendrilkit.multiview import _length
    from tendrilkit.mv_acquire import point_costs
    from tendrilkit.geometry import resample_polyline

    Xd = resample_polyline(X_mm, max(int(_length(X_mm) / 0.5), 4))
    d, seen = point_costs(evidence, Xd)
    prec, cov = np.full(len(evidence), np.nan), np.full(len(evidence), np.nan)
    for v, ev in enumerate(evidence):
        if seen[v].sum() >= 3:
            prec[v] = float(np.mean(d[v][seen[v]] <= tol_px))
        u = ev.camera.project(Xd) - ev.offset_xy
        drawn = np.zeros(ev.skeleton.shape, np.uint8)
        pts = np.round(u[np.all(np.isfinite(u), axis=1)] * 4).astype(np.int32)
        cv2.polylines(drawn, [pts], False, 1, int(2 * tol_px + 1), cv2.LINE_8, 2)
        lab = ev.skeleton_labels
        near = (drawn > 0) & (lab > 0)
        touched = np.unique(lab[near])
        touched = touched[touched > 0]
        if len(touched) == 0:
            cov[v] = 0.0 if seen[v].any() else np.nan
            continue
        comp = int(np.bincount(lab[ev.seen], minlength=int(lab.max()) + 1)[touched].sum())
        cov[v] = float(np.count_nonzero(near & ev.seen) / max(comp, 1))
    return prec, cov


def test_curve_support_draws_on_the_box_it_paints(ev):
    """Precision and coverage with the curve drawn on its box only: those of the whole crop, bit for bit."""
    from tendrilkit.multiview import curve_support

    rng = np.random.default_rng(11)
    cam = ev.camera
    for k in range(40):
        # curves in front of the camera, in, across and out of the view's crop (its edge, far outside)
        n = int(rng.integers(2, 30))
        start = rng.uniform([-0.35, -0.2, 0.9], [0.35, 0.2, 1.1]) * (1.0 if k % 5 else 3.0)
        X = start + np.cumsum(rng.normal(0, 0.02 if k % 3 else 0.1, (n, 3)), axis=0)
        X_mm = X  # the camera at the world origin looking along +z
        got, want = curve_support(X_mm, [ev]), _support_on_the_whole_crop(X_mm, [ev])
        assert np.array_equal(got[0], want[0], equal_nan=True) and np.array_equal(got[1], want[1], equal_nan=True)


@pytest.mark.parametrize("seed", range(6))
def test_skeleton_labels_on_the_box_are_the_whole_crops(seed):
    """The skeleton's components labelled on its box (even start): the whole crop's labels, pixel for pixel."""
    rng = np.random.default_rng(seed)

    def more(img):
        for _ in range(int(rng.integers(1, 6))):
            p, q = rng.integers([20, 5], [190, 115], (2, 2))
            cv2.line(img, tuple(int(v) for v in p), tuple(int(v) for v in q), (20, 20, 20), int(rng.integers(1, 4)))

    ev = _wavy_view(more)
    want = cv2.connectedComponents(ev.skeleton.astype(np.uint8), connectivity=8)[1]
    assert ev.skeleton_labels.dtype == want.dtype and np.array_equal(ev.skeleton_labels, want)


# ---- refine_curve's compiled step (multiview._view_terms, _assemble, _take_step) against its numpy of 245f631 ----

def _refine_curve_245f631(X0_mm, evidence, *, base_mm, segment_mm, iterations=20, bend_weight=20.0, length_weight=30.0,
                          base_weight=3.0, huber_px=1.5, cap_px=(25.0, 8.0)):
    """multiview.refine_curve as it was at 245f631 (numpy steps around the kernels), copied unchanged."""
    from scipy.linalg import solveh_banded

    X = np.array(X0_mm, float)
    n = len(X)
    if n < 3:
        return X
    bend = _bending_blocks(n) * bend_weight ** 2
    B = np.asarray(base_mm, float)
    step_h = 1e-3
    for it in range(iterations):
        cap = max(cap_px[1], cap_px[0] * 0.75 ** it)
        Hd = np.zeros((n, 3, 3))
        g = np.zeros((n, 3))
        for ev in evidence:
            u, J = ev.camera.project_jacobian(X, distort=True, step_mm=step_h)
            d, gd, seen = skeleton_distance(ev, u, outside_px=1e3)
            _add_view(Hd, g, d, gd, seen, J, huber_px, cap)
        Hd[0] += base_weight ** 2 * np.eye(3)
        g[0] += base_weight ** 2 * (X[0] - B)
        e = np.diff(X, axis=0)
        L = np.linalg.norm(e, axis=1)
        t = e / np.maximum(L, 1e-9)[:, None]
        r = L - segment_mm
        tt = length_weight ** 2 * np.einsum("ki,kj->kij", t, t)
        Hd[:-1] += tt
        Hd[1:] += tt
        g[:-1] -= length_weight ** 2 * r[:, None] * t
        g[1:] += length_weight ** 2 * r[:, None] * t
        ab = _banded_normal(Hd, tt, bend)
        g += (bend[2][:, None] * X)
        g[:-1] += bend[1][1:, None] * X[1:]
        g[1:] += bend[1][1:, None] * X[:-1]
        g[:-2] += bend[0][2:, None] * X[2:]
        g[2:] += bend[0][2:, None] * X[:-2]
        try:
            step = -solveh_banded(ab, g.ravel(), check_finite=False).reshape(n, 3)
        except np.linalg.LinAlgError:
            break
        big = np.max(np.linalg.norm(step, axis=1))
        if big > 1.0:
            step *= 1.0 / big
        X = X + step
        if big < 5e-3:
            break
    return X


@pytest.fixture(scope="module")
def tube_views():
    """Three views of a curled tube (the IJCV25 rig, no distortion) and its true centre line."""
    from tendrilkit.phantom import render_tube_views

    s = np.linspace(0, 1, 1500)
    th = np.clip(s - 0.4, 0, None) * 6 * np.pi
    X = np.c_[-5 + 50 * s, 6 * np.sin(th), 20 + 6 * (1 - np.cos(th))]
    images, cams, exp = render_tube_views(X, width_px=9, margin_px=40, name="refine")
    evidence = [skeleton_evidence(view_evidence(im, roi=m.roi, keep_out=m.keep_out, base_point_xy=m.base_point), c)
                for im, c, m in zip(images, cams, exp.views)]
    return X, evidence


def _with_distortion(evidence, dist):
    from dataclasses import replace

    return [replace(ev, camera=Camera(K=ev.camera.K, dist=np.asarray(dist, float), R=ev.camera.R, t_mm=ev.camera.t_mm,
                                      width=ev.camera.width, height=ev.camera.height)) for ev in evidence]


@pytest.mark.parametrize("distort", [False, True])
def test_refine_curve_is_the_245f631_numpy(tube_views, distort):
    """Node chains started on, near, off and far from the tube (converging, the 1 mm step limit, nodes no view
    sees), every iteration count, cameras without and with OpenCV's 5-coefficient distortion: the compiled steps
    give the old function's nodes, bit for bit."""
    from tendrilkit.geometry import resample_polyline
    from tendrilkit.multiview import refine_curve

    X, evidence = tube_views
    if distort:
        evidence = _with_distortion(evidence, [-0.04, 0.003, -5e-4, 3e-4, 1e-4])
    assert all(ev.camera.has_distortion == distort and ev.camera.dist.size == 5 for ev in evidence)
    rng = np.random.default_rng(12)
    moved = 0
    for k in range(12):
        m = int(rng.integers(3, 60))
        start = resample_polyline(X[: int(rng.integers(200, 1500))], m)
        start = start + rng.normal(0.0, [0.05, 0.5, 2.0, 6.0][k % 4], start.shape)
        if k == 11:
            start[-5:] += [0.0, 0.0, 400.0]  # far behind the views' crops: unseen, no skeleton within the cap
        seg = float(np.median(np.linalg.norm(np.diff(start, axis=0), axis=1)))
        for its in (1, 3, 20):
            kw = dict(base_mm=X[0] + rng.normal(0, 0.3, 3), segment_mm=seg, iterations=its)
            want = _refine_curve_245f631(start, evidence, **kw)
            got = refine_curve(start, evidence, **kw)
            assert got.tobytes() == want.tobytes(), (k, its, np.nanmax(np.abs(got - want)))
            moved += not np.array_equal(want, start)
    assert moved == 36


def test_refine_curve_with_opencv_distortion_is_the_245f631_numpy(tube_views):
    """A camera with 8 coefficients (OpenCV's projection: the general path) among 5-coefficient ones."""
    from tendrilkit.geometry import resample_polyline
    from tendrilkit.multiview import refine_curve

    X, evidence = tube_views
    five = _with_distortion(evidence, [-0.04, 0.003, -5e-4, 3e-4, 1e-4])
    mixed = [five[0], _with_distortion(evidence[1:2], [-0.04, 0.003, -5e-4, 3e-4, 1e-4, 1e-3, 0.0, 0.0])[0], five[2]]
    assert mixed[1].camera.dist.size == 8
    start = resample_polyline(X[:900], 25) + np.random.default_rng(13).normal(0.0, 0.8, (25, 3))
    kw = dict(base_mm=X[0], segment_mm=1.2)
    assert refine_curve(start, mixed, **kw).tobytes() == _refine_curve_245f631(start, mixed, **kw).tobytes()


def test_grid_search_starts_past_the_empty_rings(ev):
    """mv_evidence._empty_rings: per cell, the Chebyshev distance (cells) to the nearest cell with a skeleton pixel."""
    from tendrilkit.mv_evidence import _empty_rings

    start, _, cell = ev._grid
    _, rows, cols = cell
    full = np.argwhere((np.diff(start) > 0).reshape(rows, cols))
    rr, cc = np.mgrid[0:rows, 0:cols]
    want = np.min(np.maximum(np.abs(rr[..., None] - full[:, 0]), np.abs(cc[..., None] - full[:, 1])), axis=2)
    np.testing.assert_array_equal(ev._grid_reach, want)
    assert want.max() > 3 and (want == 0).any()
    empty = np.zeros_like(start)
    assert np.all(_empty_rings(empty, cell) == max(rows, cols))


def _one_per_cell_and_way_245f631(P_mm, dirs, cell_mm):
    """mv_acquire._one_per_cell_and_way as it was at 245f631 (the rows' np.unique(axis=0)), copied unchanged."""
    cell = np.floor(np.asarray(P_mm, float) / cell_mm).astype(np.int64)
    if len(cell) == 0:
        return np.zeros(0, int)
    _, first, inv = np.unique(cell, axis=0, return_index=True, return_inverse=True)
    inv = inv.ravel()
    against = np.flatnonzero(np.einsum("ij,ij->i", dirs, dirs[first[inv]]) < 0.0)
    _, second = np.unique(inv[against], return_index=True)
    return np.sort(np.r_[first, against[second]])


def test_one_per_cell_and_way_is_the_245f631_rows():
    """The cells keyed as one integer: the same rows kept as with np.unique over the rows, on beams of every size,
    crowded (many per cell) and spread, on both sides of the origin, and far out (the rows' fallback)."""
    from tendrilkit.mv_acquire import _one_per_cell_and_way

    rng = np.random.default_rng(14)
    for k in range(300):
        n = int(rng.integers(1, 400))
        P = rng.normal(0.0, [0.5, 3.0, 30.0][k % 3], (n, 3)) + rng.normal(0.0, 100.0, 3)
        if k % 7 == 0:
            P[: n // 2] = P[0]  # many on one spot
        if k % 50 == 1:
            P[-1] = [1e19, -1e19, 0.0]  # cells too far apart for one integer
        dirs = rng.normal(size=(n, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        got = _one_per_cell_and_way(P, dirs, 3.0)
        assert got.tolist() == _one_per_cell_and_way_245f631(P, dirs, 3.0).tolist(), k


@pytest.mark.parametrize("which", ["ev", "ev_blob"])
def test_project_distance_is_skeleton_distance_of_the_projection(which, request):
    """mv_evidence.project_distance (one compiled call): skeleton_distance of Camera.project, every output bit for
    bit; through a camera mapping (x, y, 1) to pixel (x, y) exactly, points halfway between skeleton pixels (ties:
    the k-d tree's choice) and off the crop; through the view's distorted camera, points in front of it."""
    from dataclasses import replace

    from tendrilkit.mv_evidence import project_distance

    ev = request.getfixturevalue(which)
    rng = np.random.default_rng(15)
    plain = replace(ev, camera=Camera(K=np.eye(3)))
    xy = np.concatenate([_points(ev, rng, 300, s) for s in (0.3, 3.0, 40.0)]
                        + [ev.skeleton_xy[:50] + 0.5, ev.skeleton_xy[50:100] + [0.5, 0.0]])
    P = np.c_[xy, np.ones(len(xy))]
    Q = np.c_[rng.uniform(-0.3, 0.3, (500, 2)), rng.uniform(0.5, 2.0, 500)]
    Q[:3] = [np.nan, 0.0, 1.0], [0.0, 0.0, 0.0], [0.1, 0.1, -1.0]  # NaN, at the camera, behind it
    n_ties = 0
    for e, pts in ((plain, P), (ev, Q)):
        for outside in (2.0, 10.0, 50.0, 1e3):
            want = skeleton_distance(e, e.camera.project(pts), outside_px=outside, index=True)
            got = project_distance(e, pts, outside_px=outside)
            for a, b, name in zip(got, want, ["d", "g", "seen", "nearest", "background", "covered"]):
                assert a.tobytes() == b.tobytes() and a.dtype == b.dtype, name
        u = e.camera.project(pts)
        ok = np.all(np.isfinite(u), axis=1)
        dd = e.tree.query(u[ok], k=2)[0]
        n_ties += int(np.sum(dd[:, 0] == dd[:, 1]))
    assert n_ties > 0


def test_refine_curve_with_a_nan_node_is_the_245f631_numpy(tube_views):
    """A NaN node (NaN in the normal equations: LAPACK's answer, then np.max's NaN): the old function's nodes."""
    from tendrilkit.geometry import resample_polyline
    from tendrilkit.multiview import refine_curve

    X, evidence = tube_views
    for where in (0, 7, 19):
        start = resample_polyline(X[:800], 20)
        start[where] = np.nan
        kw = dict(base_mm=X[0], segment_mm=1.0, iterations=4)
        want = _refine_curve_245f631(start, evidence, **kw)
        got = refine_curve(start, evidence, **kw)
        np.testing.assert_array_equal(got, want)  # NaN where NaN


def _advance_245f631(evidence, A_mm, B_mm, *, fraction=0.3):
    """mv_acquire.advance as it was at 245f631 (whole-array numpy), copied unchanged."""
    A = np.asarray(A_mm, float).reshape(-1, 3)
    Bp = np.asarray(B_mm, float).reshape(-1, 3)
    L = np.linalg.norm(Bp - A, axis=1)
    out = np.empty((len(evidence), len(A)), bool)
    for v, ev in enumerate(evidence):
        cam = ev.camera
        z = Bp @ cam.R[2] + cam.t_mm[2]
        px = np.linalg.norm(cam.project(Bp) - cam.project(A), axis=1)
        out[v] = px >= fraction * L * cam.K[0, 0] / np.maximum(z, 1e-9)
    return out


def test_advance_is_the_245f631_numpy(tube_views):
    """Steps of every direction and length (along the lines of sight too, NaN, behind a camera), cameras without
    distortion, with OpenCV's 5 coefficients and with 8 (the general path): the old function's answers."""
    from tendrilkit.mv_acquire import advance

    X, evidence = tube_views
    views = [evidence, _with_distortion(evidence, [-0.04, 0.003, -5e-4, 3e-4, 1e-4]),
             _with_distortion(evidence, [-0.04, 0.003, -5e-4, 3e-4, 1e-4, 1e-3, 0.0, 0.0])]
    rng = np.random.default_rng(16)
    A = X[rng.integers(0, len(X), 400)] + rng.normal(0.0, 2.0, (400, 3))
    D = rng.normal(size=(400, 3)) * rng.choice([0.01, 1.0, 5.0], (400, 1))
    cam = evidence[1].camera
    D[:40] = (cam.center_world - A[:40]) * 1e-3  # towards a camera: barely moves in its image
    B = A + D
    B[40] = np.nan
    B[41] = cam.center_world + (cam.center_world - A[41])  # behind the camera
    for ev in views:
        for fraction in (0.3, 0.0, 1.0):
            want = _advance_245f631(ev, A, B, fraction=fraction)
            got = advance(ev, A, B, fraction=fraction)
            np.testing.assert_array_equal(got, want)
            assert want.any() and not want.all()


# ---- the acquisition's compiled pieces (mv_acquire.py) against the Python / numpy of af99752 ----

def test_mark_near_rows_is_mark_near_per_row(ev):
    """Several curves' points marked at once, each on its own row: what ``mark_near`` marks per curve."""
    from tendrilkit.mv_evidence import mark_near_rows

    rng = np.random.default_rng(21)
    p = _points(ev, rng, 300, 5.0)
    rows = rng.integers(0, 4, len(p))
    got = rng.random((5, len(ev.skeleton_xy))) < 0.1  # rows marked already keep their marks
    want = got.copy()
    mark_near_rows(ev, got, rows, p, 4.0)
    for r in range(5):
        mark_near(ev, want[r], p[rows == r], 4.0)
    np.testing.assert_array_equal(got, want)
    assert not np.array_equal(got[4], got[0])


def _light_band_af99752(evidence, A_mm, P_mm, *, reach_px=6.0):
    """mv_acquire.light_band as it was at af99752 (numpy samples, _on_crop_mask), copied unchanged."""
    from tendrilkit.mv_acquire import _on_crop_mask

    P = np.asarray(P_mm, float).reshape(-1, 3)
    A0 = np.asarray(A_mm, float).reshape(-1, 3)
    k = np.arange(1.0, reach_px + 1e-9)
    out = np.zeros((len(evidence), len(P)), bool)
    for v, ev in enumerate(evidence):
        uA, uP = ev.camera.project(A0), ev.camera.project(P)
        t = uP - uA
        t = t / np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-9)
        n = np.c_[-t[:, 1], t[:, 0]]
        sides = [_on_crop_mask(ev.near_foreground, ev.offset_xy,
                               uP[:, None, :] + sign * k[None, :, None] * n[:, None, :]).any(axis=1)
                 for sign in (1.0, -1.0)]
        out[v] = sides[0] & sides[1]
    return out


def test_light_band_is_the_af99752_numpy(tube_views):
    """Points on, beside and far off the tube (off the crops too, NaN, at the line's start), from one start and
    from one start per point: the old function's answers."""
    from tendrilkit.mv_acquire import light_band

    X, evidence = tube_views
    rng = np.random.default_rng(22)
    P = X[rng.integers(0, len(X), 600)] + rng.normal(0.0, 1.0, (600, 3)) * rng.choice([0.3, 1.0, 4.0, 40.0], (600, 1))
    P[0] = np.nan
    A = P + rng.normal(0.0, 1.0, P.shape)
    A[1] = P[1]  # no direction
    for reach in (6.0, 2.0):
        for a in (X[700], A):
            want = _light_band_af99752(evidence, a, P, reach_px=reach)
            np.testing.assert_array_equal(light_band(evidence, a, P, reach_px=reach), want)
            assert want.any() and not want.all()


def test_self_near_and_per_parent_are_the_af99752_loops():
    """grow_curve's self-avoidance and its per-parent limit, compiled: the old loops' answers."""
    from tendrilkit.mv_acquire import _nodes_but_last, _per_parent, _self_near

    rng = np.random.default_rng(23)
    for trial in range(50):
        width = int(rng.integers(1, 40))
        hyps = [(np.cumsum(rng.normal(0.0, 1.0, (int(rng.integers(1, 30)), 3)), axis=0),) for _ in range(8)]
        pts = np.vstack([h[0][-1] + rng.normal(0.0, 1.0, (width, 3)) for h in hyps])
        want = np.zeros(len(pts), bool)
        for h, hyp in enumerate(hyps):
            if len(hyp[0]) > 6:
                sel = slice(h * width, (h + 1) * width)
                want[sel] = _nearest_distance(pts[sel], hyp[0][:-5]) < 1.2
        np.testing.assert_array_equal(_self_near(pts, width, *_nodes_but_last(hyps, 5)), want)
        own = np.repeat(np.arange(len(hyps)), width)
        idx = rng.permutation(len(pts))[:int(rng.integers(0, len(pts) + 1))]
        beam = int(rng.integers(1, 12))
        kept, per_parent = [], np.zeros(len(hyps), int)
        for i in idx:
            if per_parent[own[i]] < 2:
                kept.append(i)
                per_parent[own[i]] += 1
                if len(kept) == beam:
                    break
        assert _per_parent(idx, own, len(hyps), 2, beam).tolist() == kept


def test_apart_is_the_af99752_loop():
    """bridge_gap's places refined: each 1.5 steps from those taken before it (the old loop's norms), at most
    ``MAX_REFINED``."""
    from tendrilkit.mv_acquire import _apart

    rng = np.random.default_rng(24)
    for trial in range(40):
        H = rng.normal(0.0, [1.0, 3.0, 10.0][trial % 3], (int(rng.integers(1, 300)), 3))
        if trial % 5 == 0:
            H[3::7] = np.nan
        most = [100, 5, 1000][trial % 3]
        tried, want = [], []
        for i, here in enumerate(H):
            if len(tried) == most:
                break
            if tried and np.linalg.norm(np.asarray(tried) - here, axis=1).min() < 1.5:
                continue
            tried.append(here)
            want.append(i)
        assert _apart(H, 1.5, most).tolist() == want


def _point_costs_af99752(evidence, P_mm, *, cap_px=10.0, nearest=False, covered=False):
    """mv_acquire.point_costs as it was at af99752 (project_distance, then numpy), copied unchanged."""
    from tendrilkit.mv_evidence import project_distance

    P = np.asarray(P_mm, float).reshape(-1, 3)
    d = np.empty((len(evidence), len(P)))
    seen = np.empty((len(evidence), len(P)), bool)
    near = np.empty((len(evidence), len(P)), int)
    bg = np.empty((len(evidence), len(P)), bool)
    cov = np.empty((len(evidence), len(P)), bool)
    for v, ev in enumerate(evidence):
        dv, _, sv, near[v], bg[v], cov[v] = project_distance(ev, P, outside_px=cap_px)
        d[v] = np.minimum(dv, cap_px)
        seen[v] = sv & ~cov[v]
    return (d, seen) + ((near, bg) if nearest else ()) + ((cov,) if covered else ())


@pytest.mark.parametrize("which", ["ev", "ev_blob"])
def test_point_costs_is_the_af99752_numpy(which, request):
    """point_costs through project_costs (the arrays it reads, written in place): the old function's arrays, bit for
    bit, with ties (the k-d tree's path), points off the crop, NaN, behind the camera; a camera with OpenCV's
    8 coefficients (the general path)."""
    from dataclasses import replace

    from tendrilkit.mv_acquire import point_costs

    ev = request.getfixturevalue(which)
    rng = np.random.default_rng(25)
    plain = replace(ev, camera=Camera(K=np.eye(3)))
    xy = np.concatenate([_points(ev, rng, 300, s) for s in (0.3, 3.0, 40.0)] + [ev.skeleton_xy[:50] + 0.5])
    P = np.c_[xy, np.ones(len(xy))]
    Q = np.c_[rng.uniform(-0.3, 0.3, (500, 2)), rng.uniform(0.5, 2.0, 500)]
    Q[:3] = [np.nan, 0.0, 1.0], [0.0, 0.0, 0.0], [0.1, 0.1, -1.0]  # NaN, at the camera, behind it
    long = replace(ev, camera=Camera(K=ev.camera.K, dist=np.r_[ev.camera.dist[:5], 1e-3, 0.0, 0.0]))
    for evs, pts in (([plain], P[50:]), ([plain, ev], P), ([ev, long, ev], Q)):
        for cap in (2.5, 10.0):
            want = _point_costs_af99752(evs, pts, cap_px=cap, nearest=True, covered=True)
            got = point_costs(evs, pts, cap_px=cap, nearest=True, covered=True)
            for a, b, name in zip(got, want, ["d", "seen", "nearest", "background", "covered"]):
                assert a.tobytes() == b.tobytes() and a.dtype == b.dtype, name
            assert want[1].any() and not want[1].all()


def _front_line_mask_per_channel(crop_bgr, foreground, contrast, sigma_px=1.0, disk_px=11):
    """front_line_mask as of f6a558a: each channel's top-hat and board level on its own, in NumPy floats."""
    from tendrilkit.segmentation.lines import _on_box, board_level

    fg = np.where(np.asarray(foreground) > 0, np.uint8(255), np.uint8(0))
    out = np.zeros(fg.shape, bool)
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (int(disk_px) | 1,) * 2)
    wide = _on_box(fg, cv2.MORPH_OPEN, disk)
    x, y, w, h = cv2.boundingRect(wide)
    if w == 0:
        return out
    H, W = fg.shape
    m = int(disk_px)
    r0, r1, c0, c1 = max(y - m, 0), min(y + h + m, H), max(x - m, 0), min(x + w + m, W)
    rel = np.zeros((r1 - r0, c1 - c0), np.float32)
    for ch in cv2.split(np.ascontiguousarray(crop_bgr)):
        top = cv2.morphologyEx(ch[r0:r1, c0:c1], cv2.MORPH_TOPHAT, disk).astype(np.float32)
        level = cv2.max(board_level(ch), 1)  # 2-D: the level of f6a558a (cv2.max)
        np.maximum(rel, top / level[r0:r1, c0:c1].astype(np.float32), out=rel)
    rel = cv2.GaussianBlur(rel, (0, 0), float(sigma_px))
    cand = ((rel > float(contrast)) & (wide[r0:r1, c0:c1] > 0)).astype(np.uint8)
    cand = cv2.morphologyEx(cand, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3)))
    out[r0:r1, c0:c1] = cand > 0
    return out


@pytest.mark.parametrize("seed", range(4))
def test_front_line_mask_is_the_per_channel_f6a558a(seed):
    """The channels at once (board level, top-hat, compiled ratios) give the pixels of each channel on its own,
    and the relative lightness is the same float32 numbers; the board level of a 3-channel image is each
    channel's own."""
    from tendrilkit.mv_evidence import _largest_ratio, front_line_mask
    from tendrilkit.segmentation.lines import board_level

    rng = np.random.default_rng(seed)
    h, w = rng.integers(90, 260, 2)
    img = np.clip(rng.normal(215, 12, (h, w, 3)), 0, 255).astype(np.uint8)  # an uneven board
    img[:, : w // 5] = rng.integers(0, 40, (h, w // 5, 3))  # a dark edge (a board level down to 1)
    for _ in range(3):  # leaves, mottled, with tendrils across them lighter in some channel
        cy, cx, ry, rx = rng.integers(10, h - 10), rng.integers(10, w - 10), rng.integers(8, 40), rng.integers(8, 50)
        cv2.ellipse(img, (int(cx), int(cy)), (int(rx), int(ry)), 0, 0, 360, tuple(int(v) for v in rng.integers(30, 130, 3)), -1)
        img = cv2.add(img, rng.integers(0, 18, img.shape, dtype=np.uint8))
        cv2.line(img, tuple(int(v) for v in rng.integers(0, w, 2)), tuple(int(v) for v in rng.integers(0, h, 2)),
                 tuple(int(v) for v in rng.integers(40, 200, 3)), int(rng.integers(1, 5)))
    fg = img[:, :, 0] < 120
    ref = _front_line_mask_per_channel(img, fg, 0.09)
    assert ref.any()
    assert np.array_equal(front_line_mask(img, fg, contrast=0.09), ref)
    assert np.array_equal(front_line_mask(img, fg.astype(np.uint8) * 7, contrast=0.09), ref)  # any nonzero
    y0, x0 = 3, 5  # a crop of the image (a view, not C order) as skeleton_evidence passes it
    assert np.array_equal(front_line_mask(img[y0:, x0:], fg[y0:, x0:], contrast=0.09),
                          _front_line_mask_per_channel(img[y0:, x0:], fg[y0:, x0:], 0.09))
    level = board_level(img)
    for c in range(3):
        assert np.array_equal(level[:, :, c], cv2.max(board_level(np.ascontiguousarray(img[:, :, c])), 1))
    top = rng.integers(0, 256, (h - 10, w - 7, 3), dtype=np.uint8)
    q = top.astype(np.float32) / level[4:h - 6, 2:w - 5].astype(np.float32)
    assert np.array_equal(_largest_ratio(top, level, 4, 2), np.maximum(np.maximum(q[..., 0], q[..., 1]), q[..., 2]))


@pytest.mark.parametrize("seed", range(4))
def test_front_line_pixels_are_the_f6a558a_pieces(seed):
    """The pieces read at their pixels (labels without the box's statistics) are those of f6a558a's labelling."""
    from tendrilkit.mv_evidence import (FRONT_END_MIN_PX, FRONT_MIN_PX, _near_skeleton_ends, front_line_mask,
                                        front_line_pixels)
    from tendrilkit.skeleton.thinning import thin

    rng = np.random.default_rng(seed)
    h, w = 200, 240
    img = np.full((h, w, 3), 220, np.uint8)
    for _ in range(4):  # leaves with lines across them, some short (a tip resting on the leaf)
        cy, cx = (int(v) for v in rng.integers(30, 170, 2))
        cv2.ellipse(img, (cx, cy), (int(rng.integers(15, 45)),) * 2, 0, 0, 360, (48, 128, 62), -1)
        for _ in range(3):
            p = (cx + int(rng.integers(-20, 20)), cy + int(rng.integers(-20, 20)))
            q = (p[0] + int(rng.integers(-40, 40)), p[1] + int(rng.integers(-40, 40)))
            cv2.line(img, p, q, (50, 150, 110), int(rng.integers(2, 5)))
    fg = img[:, :, 0] < 120
    skeleton = np.zeros((h, w), bool)
    skeleton[rng.integers(0, h, 60), rng.integers(0, w, 60)] = True  # ends here and there
    skeleton[100, 20:200] = True
    seen = np.ones((h, w), bool)
    seen[:30, :40] = False
    # f6a558a: every piece's size from the box's statistics
    m = front_line_mask(img, fg, contrast=0.09) & seen
    x, y, bw, bh = cv2.boundingRect(m.view(np.uint8))
    y0, y1, x0, x1 = max(y - 1, 0), min(y + bh + 1, h), max(x - 1, 0), min(x + bw + 1, w)
    mb = np.ascontiguousarray(m[y0:y1, x0:x1])
    fresh = thin(mb) & ~skeleton[y0:y1, x0:x1]
    _, lab, stats, _ = cv2.connectedComponentsWithStats(fresh.view(np.uint8), connectivity=8)
    area = stats[:, cv2.CC_STAT_AREA]
    keep = area >= FRONT_MIN_PX
    short = (area >= FRONT_END_MIN_PX) & ~keep
    short[0] = False
    if short.any():
        keep[np.unique(lab[_near_skeleton_ends(skeleton, y0, y1, x0, x1) & short[lab]])] = True
    keep[0] = False
    rb, cb = np.nonzero(keep[lab])
    half = cv2.distanceTransform(mb.view(np.uint8), cv2.DIST_L2, 3)[rb, cb]
    rr, cc, hh = front_line_pixels(img, fg, skeleton, seen, contrast=0.09)
    assert len(rr) > 0
    assert np.array_equal(rr, rb + y0) and np.array_equal(cc, cb + x0) and np.array_equal(hh, half)


# ---- grow_curve's step on arrays and compiled kernels, against the Python / numpy of d0679b9 ----

def _split_siblings_d0679b9(rows, own, dirs, cos_max):
    """mv_acquire._split_siblings as it was at d0679b9 (numpy), copied unchanged (its docstring left out)."""
    rows = np.asarray(rows, int)
    if len(rows) == 0:
        return rows
    parents, at = np.unique(own[rows], return_index=True)
    first = np.full(int(own.max()) + 1, -1)
    first[parents] = rows[at]
    f = first[own]
    other = (f >= 0) & (np.einsum("ij,ij->i", dirs, dirs[np.maximum(f, 0)]) < cos_max)
    kept = np.zeros(len(own), bool)
    kept[rows] = True
    split = np.zeros(len(first), bool)  # the parents with a kept child the other way already
    split[own[other & kept]] = True
    cand = np.flatnonzero(other & ~kept & ~split[own] & (np.arange(len(own)) > f))
    _, at = np.unique(own[cand], return_index=True)
    return np.sort(np.r_[rows, cand[at]])


def _grow_curve_d0679b9(evidence, base_mm, *, step_mm=2.0, beam=8, n_seeds=6, cone_deg=40.0, max_length_mm=400.0,
                        max_unseen_steps=6, candidates=1, colour_px=0.0):
    """mv_acquire.grow_curve as it was at d0679b9 (a tuple per hypothesis, numpy per step), copied unchanged but
    for its module's names (``A.``) and its docstring."""
    import tendrilkit.mv_acquire as A
    from tendrilkit.mv_evidence import mark_near_rows

    B = np.asarray(base_mm, float)
    seeds = A._seeds(evidence, B, n_seeds)
    if len(seeds) == 0:
        none_ = np.vstack([B, B])  # nothing any two views agree on
        return none_ if candidates <= 1 else [(none_, 0.0)]
    # a hypothesis: (nodes (m, 3), score, unconfirmed tail, last direction, its row of claims, blind tail); claims:
    # per view, the skeleton pixels each hypothesis explains (a row per hypothesis, a column per pixel)
    V = len(evidence)
    use_col = colour_px > 0 and all(ev.skeleton_chroma is not None for ev in evidence)
    # ... and, last, per view the colour (chromaticity) the hypothesis followed so far (NaN: none seen yet)
    hyps = [(B[None], 0.0, 0, d, h, 0, np.full((V, 3), np.nan)) for h, d in enumerate(seeds)]
    claims = [np.zeros((len(seeds), len(ev.skeleton_xy)), bool) for ev in evidence]
    f_claim = np.linspace(0, 1, 5)[:, None]
    split_cos = np.cos(np.radians(A.SPLIT_DEG))
    finished: list[tuple[np.ndarray, float, int]] = []
    look = np.array([2.0, 3.0, 4.0])
    cone = A._local_cone(cone_deg, 3)
    narrow = A._local_cone(20.0, 2)
    for _ in range(int(max_length_mm / step_mm)):
        first = len(hyps[0][0]) == 1
        local = narrow if first else cone
        lasts = np.array([h[3] for h in hyps])
        dirs = np.einsum("hij,cj->hci", A._frames(lasts), local).reshape(-1, 3)
        own = np.repeat(np.arange(len(hyps)), len(local))
        tips_h = np.array([h[0][-1] for h in hyps])
        pts = tips_h[own] + step_mm * dirs
        N = len(pts)
        mids = pts - 0.5 * step_mm * dirs
        d, seen, near, bg = A.point_costs(evidence, np.vstack([pts, mids]), nearest=True)
        m, n = A._mean_seen(d, seen)
        m_end, n_end = m[:N], n[:N]
        m_mid, n_mid = m[N:], n[N:]
        vis = (n_end >= 2) & (n_mid >= 2)
        # new evidence: on a view's skeleton at a pixel this hypothesis has not explained already
        claimed = np.zeros((len(evidence), N), bool)
        for v in range(len(evidence)):
            i = near[v, :N]
            claimed[v] = claims[v][own, np.maximum(i, 0)] & (i >= 0)
        new = seen[:, :N] & (d[:, :N] <= A.ON_PX) & ~claimed & A.advance(evidence, tips_h[own], pts)
        contradicted = bg[:, :N].any(axis=0) | bg[:, N:].any(axis=0)
        confirmed = vis & (new.sum(axis=0) >= 2) & ~contradicted
        cost = np.where(confirmed, 0.5 * (m_end + m_mid), np.maximum(0.5 * (m_end + m_mid), A.NEUTRAL_PX))
        blind = ~vis
        if blind.any():  # fewer than two views see it: the evidence further along the direction
            ahead = pts[blind][:, None, :] + step_mm * (look[None, :, None] - 1) * dirs[blind][:, None, :]
            da, sa = A.point_costs(evidence, ahead.reshape(-1, 3))
            ma, na = A._mean_seen(da, sa)
            cost[blind] = 0.5 * (A.NEUTRAL_PX + np.where(na >= 2, ma, A.NEUTRAL_PX).reshape(-1, len(look)).mean(
                axis=1))
        if use_col:  # a step onto a line of another colour than its hypothesis's so far (a shoot, another tendril)
            follow = np.stack([h[6] for h in hyps])[own]  # (N, V, 3)
            step_col = np.full((N, V, 3), np.nan)
            dev = np.zeros(N)
            n_dev = np.zeros(N)
            for v, ev in enumerate(evidence):
                i = near[v, :N]
                on = seen[v, :N] & (d[v, :N] <= A.ON_PX) & (i >= 0)
                ch = ev.skeleton_chroma[np.maximum(i, 0)]
                step_col[on, v] = ch[on]
                known = on & np.isfinite(follow[:, v, 0])
                dev += np.where(known, np.abs(ch - np.nan_to_num(follow[:, v])).sum(axis=1), 0.0)
                n_dev += known
            off_colour = np.where(n_dev >= 2, dev / np.maximum(n_dev, 1), 0.0)
            cost = cost + colour_px * np.clip((off_colour - A.COLOUR_TOL) / A.COLOUR_TOL, 0.0, A.COLOUR_CAP)
        if not first:  # bending
            turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", dirs, lasts[own]), -1, 1)))
            cost = cost + A.TURN_PX * (turn / cone_deg) ** 2
        # self-avoidance: a candidate within 1.2 mm of its hypothesis's nodes but the last five
        self_near = A._self_near(pts, len(local), *A._nodes_but_last(hyps, 5))
        cost += np.where(self_near, 5.0, 0.0)
        tail = np.where(confirmed, 0, np.array([h[2] for h in hyps])[own] + 1)
        # steps no two views see (keep-out box, occlusion): at most max_unseen_steps in a row; steps the views
        # see on pixels the curve explained already (passes over each other in two views): three times more
        blind_tail = np.where(confirmed | vis, 0, np.array([h[5] for h in hyps])[own] + 1)
        ok = ((cost <= A.STOP_PX) & (blind_tail <= max_unseen_steps) & (tail <= 3 * max_unseen_steps)
              & ~contradicted)
        score = np.array([h[1] for h in hyps])[own] + cost - A.NEUTRAL_PX
        has = np.bincount(own[ok], minlength=len(hyps)) > 0
        finished.extend(hyps[h][:3] for h in np.flatnonzero(~has))
        idx = np.flatnonzero(ok)
        idx = idx[np.argsort(score[idx], kind="stable")]
        ranked = idx
        # diversity: per cell of 1.5 steps the best hypothesis and the best heading against it, at most two
        # children per parent, so that the branches of a crossing both stay in the beam; and besides the beam, up to
        # SPLIT_EXTRA children heading over SPLIT_DEG away from their parent's best kept one (a junction's branches)
        rows = A._one_per_cell_and_way(pts[idx], dirs[idx], 1.5 * step_mm)
        both = _split_siblings_d0679b9(rows, own[idx], dirs[idx], split_cos)  # rank order
        diverse = idx[both]  # (the trace's)
        split = idx[np.setdiff1d(both, rows)]
        count = np.zeros(len(hyps), np.int64)  # children kept per parent, the beam's and then the split's
        idx = A._per_parent_counted(idx[rows], own, count, 2, beam)
        if len(split):  # the junctions' other branches besides the beam, not instead of its best
            idx = np.r_[idx, A._per_parent_counted(split, own, count, 2, A.SPLIT_EXTRA)]
        if A._TRACE is not None:
            A._TRACE("step", hyps=hyps, own=own, pts=pts, ranked=ranked, diverse=diverse, kept=idx, cost=cost, ok=ok,
                   m_end=m_end, m_mid=m_mid, vis=vis, confirmed=confirmed, contradicted=contradicted,
                   blind_tail=blind_tail, tail=tail, self_near=self_near, dirs=dirs, d=d, seen=seen, bg=bg)
        # claim what each kept hypothesis explained two steps back (all at once: one projection per view)
        parents = [hyps[i] for i in own[idx].tolist()]
        claims = [c[own[idx]] for c in claims]  # each kept candidate starts from its parent's claims
        grown = [k for k, h in enumerate(parents) if len(h[0]) >= 3]
        if grown:
            P = np.vstack([parents[k][0][-3] + f_claim * (parents[k][0][-2] - parents[k][0][-3]) for k in grown])
            rows = np.repeat(np.asarray(grown, np.int64), len(f_claim))
            for v, ev in enumerate(evidence):
                mark_near_rows(ev, claims[v], rows, ev.camera.project(P), 4.0)
        if use_col:  # each kept step's views that see it on their skeleton update its colour (a running mean)
            colours = [np.where(np.isfinite(step_col[i]), np.where(np.isfinite(follow[i]), (1.0 - A.COLOUR_EMA)
                                                                   * follow[i] + A.COLOUR_EMA * step_col[i],
                                                                   step_col[i]), follow[i])
                       for i in idx.tolist()]
        else:
            colours = [hyps[0][6]] * len(idx)
        hyps = [(np.concatenate([parents[j][0], pts[i][None]]), float(score[i]), int(tail[i]), dirs[i], j,
                 int(blind_tail[i]), colours[j]) for j, i in enumerate(idx.tolist())]
        if not hyps:
            break
    finished.extend(h[:3] for h in hyps)

    return A._best_finished(evidence, finished, step_mm, candidates)  # the ends' choice: not what is pinned


def _with_chroma(evidence, seed):
    """The views with a chromaticity per skeleton pixel (smooth across the image, noisy, a few NaN rows: black
    pixels), so that the colour a hypothesis follows changes its steps' costs."""
    from dataclasses import replace

    rng = np.random.default_rng(seed)
    out = []
    for ev in evidence:
        xy = ev.skeleton_xy
        c = np.c_[1.0 + np.sin(xy[:, 0] / 40.0), 1.0 + np.cos(xy[:, 1] / 30.0), np.ones(len(xy))]
        c = c * rng.uniform(0.9, 1.1, c.shape)
        c /= c.sum(axis=1, keepdims=True)
        c[rng.random(len(c)) < 0.02] = np.nan
        out.append(replace(ev, skeleton_chroma=c))
    return out


@pytest.mark.parametrize("colour_px", [0.0, 1.0, 3.0])
def test_grow_curve_is_the_d0679b9_loop(tube_views, colour_px):
    """The beam search with its hypotheses in arrays and its step's arithmetic compiled: the old function's curve
    and candidates (nodes and scores), bit for bit, from the tube's base and from a point beside it, with the colour
    off and on, on cameras without and with OpenCV's 5 coefficients and with 8 (the general path, in every view or
    one), narrower beams and cones."""
    from tendrilkit.mv_acquire import grow_curve

    X, evidence = tube_views
    five = _with_distortion(evidence, [-0.04, 0.003, -5e-4, 3e-4, 1e-4])
    eight = _with_distortion(evidence, [-0.04, 0.003, -5e-4, 3e-4, 1e-4, 1e-3, 0.0, 0.0])  # the general path
    views = [_with_chroma(evidence, 26), _with_chroma(five, 27), _with_chroma(evidence, 28),
             _with_chroma(five, 29), _with_chroma(eight, 30), [_with_chroma(eight, 31)[0]] + _with_chroma(five, 31)[1:]]
    runs = [dict(), dict(candidates=6), dict(beam=3, cone_deg=25.0, candidates=4), dict(step_mm=1.5, beam=12),
            dict(candidates=3), dict()]
    for evs, kw in zip(views, runs):
        for B in (X[0], X[0] + [0.3, 0.6, -0.4]):
            want = _grow_curve_d0679b9(evs, B, colour_px=colour_px, **kw)
            got = grow_curve(evs, B, colour_px=colour_px, **kw)
            if kw.get("candidates", 1) <= 1:
                want, got = [(want, 0.0)], [(got, 0.0)]
            assert len(got) == len(want)
            for (g, gs), (w, ws) in zip(got, want):
                assert g.tobytes() == w.tobytes() and g.shape == w.shape and gs == ws
            assert len(want[0][0]) > 10 or B is not X[0]


def test_step_kernels_are_the_d0679b9_numpy():
    """grow_curve's compiled step (_new_and_colour, _step_costs, _step_finish, _self_near_nodes: the nodes that can
    be near only, :func:`_siblings`) on random rows (NaN distances, colours and nodes, views seeing nothing, every
    tail): the old loop's whole-array expressions."""
    import tendrilkit.mv_acquire as A

    rng = np.random.default_rng(28)
    n_near = 0
    for trial in range(60):
        V = int(rng.integers(1, 5))
        H = int(rng.integers(1, 10))
        width = int(rng.integers(1, 40))
        N = H * width
        own = np.repeat(np.arange(H), width)
        d = rng.choice([0.0, 1.0, 2.5, 3.0, 10.0], (V, 2 * N)) * rng.random((V, 2 * N))
        d[rng.random(d.shape) < 0.02] = np.nan
        seen = rng.random((V, 2 * N)) < rng.uniform(0.2, 1.0)
        bg = rng.random((V, 2 * N)) < 0.05
        k = int(rng.integers(1, 50))
        near = np.where(rng.random((V, 2 * N)) < 0.8, rng.integers(0, k, (V, 2 * N)), -1)
        adv = rng.random((V, N)) < 0.9
        claims = [rng.random((H, k)) < 0.3 for _ in range(V)]
        chroma = [rng.dirichlet([3.0, 3.0, 3.0], k) for _ in range(V)]
        for c in chroma:
            c[rng.random(k) < 0.1] = np.nan
        h_col = np.where(rng.random((H, V, 1)) < 0.3, np.nan, rng.dirichlet([3.0, 3.0, 3.0], (H, V)))
        h_col[0, 0, 1] = np.inf  # np.nan_to_num's largest double
        use_col = trial % 3 > 0
        # the old loop's expressions
        claimed = np.zeros((V, N), bool)
        for v in range(V):
            i = near[v, :N]
            claimed[v] = claims[v][own, np.maximum(i, 0)] & (i >= 0)
        new_w = seen[:, :N] & (d[:, :N] <= A.ON_PX) & ~claimed & adv
        m, n = A._mean_seen(d, seen)
        m_end, n_end, m_mid, n_mid = m[:N], n[:N], m[N:], n[N:]
        vis = (n_end >= 2) & (n_mid >= 2)
        contradicted = bg[:, :N].any(axis=0) | bg[:, N:].any(axis=0)
        confirmed = vis & (new_w.sum(axis=0) >= 2) & ~contradicted
        cost_w = np.where(confirmed, 0.5 * (m_end + m_mid), np.maximum(0.5 * (m_end + m_mid), A.NEUTRAL_PX))
        got = A._step_costs(d, seen, bg, new_w, A.NEUTRAL_PX)
        for a, b in zip(got, (m_end, m_mid, vis, contradicted, confirmed, cost_w)):
            assert a.tobytes() == b.tobytes() and a.dtype == b.dtype
        follow = h_col[own]
        step_col_w = np.full((N, V, 3), np.nan)
        dev = np.zeros(N)
        n_dev = np.zeros(N)
        new = np.empty((V, N), bool)
        step_col = np.full((V, N, 3), np.nan)
        col_dev, col_known = np.zeros((V, N)), np.zeros((V, N), bool)
        for v in range(V):
            i = near[v, :N]
            on = seen[v, :N] & (d[v, :N] <= A.ON_PX) & (i >= 0)
            ch = chroma[v][np.maximum(i, 0)]
            step_col_w[on, v] = ch[on]
            known = on & np.isfinite(follow[:, v, 0])
            dev += np.where(known, np.abs(ch - np.nan_to_num(follow[:, v])).sum(axis=1), 0.0)
            n_dev += known
            A._new_and_colour(d[v], seen[v], near[v], adv[v], claims[v], own, A.ON_PX, use_col,
                              chroma[v] if use_col else np.zeros((0, 3)), h_col[:, v], new[v], step_col[v],
                              col_dev[v], col_known[v])
        np.testing.assert_array_equal(new, new_w)
        cost = cost_w.copy()
        if use_col:
            assert step_col.transpose(1, 0, 2).tobytes() == step_col_w.tobytes()
            off_colour = np.where(n_dev >= 2, dev / np.maximum(n_dev, 1), 0.0)
            with np.errstate(over="ignore"):  # the largest double's differences
                cost = cost + 1.5 * np.clip((off_colour - A.COLOUR_TOL) / A.COLOUR_TOL, 0.0, A.COLOUR_CAP)
        else:
            assert np.isnan(step_col).all() and not col_known.any()
        first = trial % 4 == 0
        lasts = rng.normal(size=(H, 3))
        lasts /= np.linalg.norm(lasts, axis=1, keepdims=True)
        dirs = rng.normal(size=(N, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        turn = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", dirs, lasts[own]), -1, 1)))
        if not first:
            cost = cost + A.TURN_PX * (turn / 40.0) ** 2
        nodes = np.cumsum(rng.normal(0.0, 1.0, (H, int(rng.integers(1, 30)), 3)), axis=1)
        pts = nodes[own, -1] + rng.normal(0.0, 1.0, (N, 3)) * rng.choice([0.5, 2.0], (N, 1))
        if trial % 5 == 1:  # a NaN node, a NaN candidate
            nodes[0, 0, 1] = np.nan
            pts[-1, 2] = np.nan
        hyps = [(nodes[h],) for h in range(H)]
        self_near = A._self_near(pts, width, *A._nodes_but_last(hyps, 5))
        assert A._self_near_nodes(pts, width, nodes, 5).tobytes() == self_near.tobytes()
        n_near += self_near.sum()
        cost += np.where(self_near, 5.0, 0.0)
        rows = np.flatnonzero(rng.random(N) < 0.3)
        both, extra = A._siblings(rows, own, dirs, np.cos(np.radians(A.SPLIT_DEG)))
        want = _split_siblings_d0679b9(rows, own, dirs, np.cos(np.radians(A.SPLIT_DEG)))
        assert both.tolist() == want.tolist() and extra.tolist() == np.setdiff1d(want, rows).tolist()
        h_tail, h_blind = rng.integers(0, 20, H), rng.integers(0, 8, H)
        h_score = rng.normal(0.0, 10.0, H)
        tail = np.where(confirmed, 0, h_tail[own] + 1)
        blind_tail = np.where(confirmed | vis, 0, h_blind[own] + 1)
        ok = (cost <= A.STOP_PX) & (blind_tail <= 6) & (tail <= 3 * 6) & ~contradicted
        score = h_score[own] + cost - A.NEUTRAL_PX
        has = np.bincount(own[ok], minlength=H) > 0
        got = A._step_finish(cost_w, use_col, col_dev, col_known, 1.5, A.COLOUR_TOL, A.COLOUR_CAP,
                             np.zeros(0) if first else turn, 40.0, A.TURN_PX, self_near, confirmed, vis, contradicted,
                             own, h_score, h_tail, h_blind, A.NEUTRAL_PX, A.STOP_PX, 6)
        for a, b in zip(got, (cost, tail, blind_tail, ok, score, has)):
            assert a.tobytes() == b.tobytes() and a.dtype == b.dtype
    assert n_near > 50  # candidates near their hypothesis's nodes, measured


def test_mark_projected_is_mark_near_rows_of_the_projection(tube_views):
    """grow_curve's claims, projected and marked in one compiled call: what ``mark_near_rows`` marks at
    ``Camera.project``'s pixels (cameras without and with OpenCV's 5 coefficients; NaN points)."""
    from tendrilkit.mv_acquire import _mark_projected, _step_fixed
    from tendrilkit.mv_evidence import mark_near_rows

    X, evidence = tube_views
    rng = np.random.default_rng(32)
    P = X[rng.integers(0, len(X), 400)] + rng.normal(0.0, 0.5, (400, 3))
    P[5] = np.nan
    rows = rng.integers(0, 6, len(P))
    for ev in evidence + _with_distortion(evidence, [-0.04, 0.003, -5e-4, 3e-4, 1e-4]):
        want = rng.random((6, len(ev.skeleton_xy))) < 0.05
        got = want.copy()
        mark_near_rows(ev, want, rows, ev.camera.project(P), 4.0)
        RT, t, _, _, args = _step_fixed(ev)
        _mark_projected(P @ RT + t, args[0], args[1], args[2], rows, args[4], args[5], args[6], args[7], args[8], 4.0,
                        got)
        np.testing.assert_array_equal(got, want)
        assert want.sum() > 100
    assert _step_fixed(_with_distortion(evidence, [-0.04, 0.003, -5e-4, 3e-4, 1e-4, 1e-3, 0.0, 0.0])[0]) is None
