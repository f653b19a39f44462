"""Curve geometry shared by the stages (tendrilkit.geometry) and Camera's projection Jacobian."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import PchipInterpolator
from scipy.linalg import solveh_banded
from scipy.spatial.transform import Rotation

from tendrilkit.camera import Camera, look_at
from tendrilkit.exceptions import DegenerateCurveError, FrameError
from tendrilkit.geometry import (
    arc_length,
    marker_corners,
    nearest_on_polyline,
    pchip_interpolate,
    point_at_arc_length,
    point_at_index,
    point_to_polyline_distance,
    resample_polyline,
    rigid_fit,
    section_masks,
    whittaker_smooth,
)


def test_arc_length_of_a_polyline():
    P = np.array([[0.0, 0, 0], [3, 4, 0], [3, 4, 12]])
    np.testing.assert_allclose(arc_length(P), [0, 5, 17])


def test_resample_by_arclength_is_uniform():
    t = np.linspace(0, 3, 57) ** 2
    pts = np.c_[np.cos(t), np.sin(t)] * 10
    out = resample_polyline(pts, 40)
    step = np.linalg.norm(np.diff(out, axis=0), axis=1)
    assert out.shape == (40, 2)
    np.testing.assert_allclose(out[[0, -1]], pts[[0, -1]])
    assert step.std() / step.mean() < 0.02  # chords of a fine polyline: nearly equal


def test_resample_rejects_bad_input():
    with pytest.raises(ValueError, match="n must be"):
        resample_polyline(np.zeros((3, 2)), 1)
    with pytest.raises(FrameError):  # a zero-length curve is a frame's failure, not the user's
        resample_polyline(np.zeros((3, 2)), 5)
    with pytest.raises(DegenerateCurveError, match="zero length"):
        resample_polyline(np.zeros((3, 2)), 5)
    with pytest.raises(ValueError, match="finite"):
        resample_polyline(np.array([[0.0, 0], [np.nan, 1]]), 5)
    with pytest.raises(ValueError, match="method"):
        resample_polyline(np.eye(2), 5, method="cubic")


def test_resample_by_step_and_count():
    P = np.array([[0.0, 0.0], [10.0, 0.0]])
    assert len(resample_polyline(P, step=1.0)) == 11
    assert len(resample_polyline(P, 30, step=1.0)) == 30  # the larger count
    assert len(resample_polyline(P, 5, step=1.0)) == 11
    np.testing.assert_allclose(np.diff(resample_polyline(P, step=3.0)[:, 0]), 2.5)


def test_resample_drops_repeats():
    P = np.repeat(np.c_[np.linspace(0, 9, 10), np.zeros(10)], 2, axis=0)
    np.testing.assert_allclose(resample_polyline(P, 10)[:, 0], np.arange(10.0))
    np.testing.assert_allclose(resample_polyline(P, 10, method="pchip")[:, 0], np.arange(10.0))


@pytest.mark.parametrize("seed", range(6))
def test_own_pchip_is_scipys_pchip(seed):
    """The resampler's PCHIP is scipy's PchipInterpolator to rounding (kept for the site phantoms' last bits)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 80))
    u = np.r_[0.0, np.cumsum(rng.uniform(0.1, 2.0, n - 1))]
    y = np.cumsum(rng.normal(size=(n, 3)), axis=0)
    ui = np.linspace(0.0, u[-1], 97)
    np.testing.assert_allclose(pchip_interpolate(u, y, ui), PchipInterpolator(u, y, axis=0)(ui), rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("seed", range(6))
def test_own_whittaker_solver_is_scipys_banded_cholesky(seed):
    """The compiled pentadiagonal Cholesky equals scipy.linalg.solveh_banded to rounding (kept for the last bits)."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(3, 200))
    lam = float(10 ** rng.uniform(-1, 6))
    w = rng.uniform(0.0, 2.0, n)
    y = rng.normal(size=(n, 3))
    D = np.diff(np.eye(n), 2, axis=0)
    A = np.diag(w) + lam * D.T @ D
    ab = np.stack([np.r_[0.0, 0.0, np.diagonal(A, 2)], np.r_[0.0, np.diagonal(A, 1)], np.diagonal(A)])
    np.testing.assert_allclose(whittaker_smooth(y, lam=lam, weights=w), solveh_banded(ab, w[:, None] * y),
                               rtol=1e-9, atol=1e-9 * np.abs(y).max())


def test_point_at_index():
    Q = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]])
    out = point_at_index(Q, np.array([0.0, 0.5, 1.5, 2.0, 7.0, np.nan]))
    np.testing.assert_allclose(out[:5], [[0, 0], [1, 0], [2, 1], [2, 2], [2, 2]])
    assert np.isnan(out[5]).all()


def test_point_at_arc_length():
    Q = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 0.0], [2.0, 2.0]])  # a repeated vertex
    np.testing.assert_allclose(point_at_arc_length(Q, np.array([0.0, 1.0, 3.0, 9.0])), [[0, 0], [1, 0], [2, 1], [2, 2]])
    np.testing.assert_allclose(point_at_arc_length(Q, np.array([0.5]), normalised=True), [[2, 0]])
    with pytest.raises(DegenerateCurveError):
        point_at_arc_length(np.zeros((3, 3)), np.array([0.5]))
    with pytest.raises(ValueError, match="points"):
        point_at_arc_length(np.zeros((1, 3)), np.array([0.5]))


def test_point_to_polyline_distance():
    poly = np.array([[0.0, 0], [10, 0], [10, 10]])
    p = np.array([[5.0, 2], [12, 5], [-3, -4], [np.nan, 1]])
    d = point_to_polyline_distance(p, poly)
    np.testing.assert_allclose(d[:3], [2, 2, 5])
    assert np.isnan(d[3])
    np.testing.assert_allclose(point_to_polyline_distance(p[:1], poly[:1]), [np.hypot(5, 2)])


@pytest.mark.parametrize("dim", [2, 3])
def test_nearest_on_polyline_against_dense_sampling(dim):
    rng = np.random.default_rng(dim)
    Q = np.cumsum(rng.normal(size=(30, dim)), axis=0)
    P = Q[::3] + rng.normal(scale=0.7, size=(10, dim))
    r = nearest_on_polyline(P, Q)
    dense = resample_polyline(Q, 60001)
    d_dense = np.min(np.linalg.norm(P[:, None, :] - dense[None], axis=2), axis=1)
    np.testing.assert_allclose(r.distance, d_dense, atol=1e-3)
    assert np.all(r.distance <= d_dense + 1e-12)  # exact: never farther than any sample of the curve
    np.testing.assert_allclose(r.point, point_at_index(Q, r.t), atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(P - r.point, axis=1), r.distance, atol=1e-12)
    if dim == 2:
        np.testing.assert_allclose(np.linalg.norm(r.normal, axis=1), 1.0)
    else:
        assert np.isnan(r.normal).all()


def test_nearest_on_polyline_in_a_window():
    Q = np.c_[np.arange(20.0), np.zeros(20)]
    p = np.array([[15.2, 1.0]])
    assert nearest_on_polyline(p, Q).t[0] == pytest.approx(15.2)
    r = nearest_on_polyline(p, Q, start=np.array([3.0]), window=2)  # searches segments 1..5 only
    assert r.t[0] == pytest.approx(6.0) and r.distance[0] == pytest.approx(np.hypot(9.2, 1.0))
    with pytest.raises(ValueError, match="window"):
        nearest_on_polyline(p, Q, window=2)
    with pytest.raises(ValueError, match="polyline"):
        nearest_on_polyline(p, Q[:1])


@pytest.mark.parametrize("seed", range(4))
def test_rigid_fit_recovers_a_motion(seed):
    rng = np.random.default_rng(seed)
    P = rng.normal(size=(20, 3)) * 10
    R0 = Rotation.random(random_state=seed).as_matrix()
    t0 = rng.normal(size=3) * 5
    R, t = rigid_fit(P, P @ R0.T + t0)
    np.testing.assert_allclose(R, R0, atol=1e-10)
    np.testing.assert_allclose(t, t0, atol=1e-9)
    R, _ = rigid_fit(P, P * [1, 1, -1])  # a reflection: the best proper rotation
    assert np.linalg.det(R) == pytest.approx(1.0)


def test_section_masks_are_the_papers_quarters():
    s = np.linspace(10.0, 30.0, 81)  # any origin
    m = section_masks(s)
    assert m["base"].sum() == 21 and m["tip"].sum() == 21 and m["entire"].all()
    assert s[m["base"]].max() == 15.0 and s[m["tip"]].min() == 25.0


def test_marker_corners_order_and_turn():
    c = marker_corners(24.0)
    np.testing.assert_array_equal(c, [[-12, 12, 0], [12, 12, 0], [12, -12, 0], [-12, -12, 0]])
    c = marker_corners(10.0, centre_mm=[100.0, 50.0], angle_deg=90.0, scale=2.0)
    np.testing.assert_allclose(c[:, :2], [[90, 40], [90, 60], [110, 60], [110, 40]], atol=1e-12)


def test_project_jacobian_matches_differences():
    R, t = look_at(np.array([40.0, -200.0, 150.0]), np.zeros(3), np.array([0.0, 0.0, 1.0]))
    cam = Camera(K=np.array([[1700.0, 2.0, 960], [0, 1690, 540], [0, 0, 1]]), dist=[0.05, -0.01, 1e-3, -1e-3, 0.0],
                 R=R, t_mm=t)
    X = np.random.default_rng(0).normal(size=(7, 3)) * 20
    u, J = cam.project_jacobian(X)
    np.testing.assert_allclose(u, cam.project(X, distort=False), rtol=1e-12)
    h = 1e-5
    for a in range(3):
        Xh = X.copy()
        Xh[:, a] += h
        np.testing.assert_allclose(J[:, :, a], (cam.project(Xh, distort=False) - u) / h, rtol=1e-4, atol=1e-4)
    a = np.random.default_rng(1).normal(size=(7, 3))
    u_a, du = cam.project_jacobian(X, along=a)
    np.testing.assert_array_equal(u_a, u)
    np.testing.assert_allclose(du, np.einsum("kab,kb->ka", J, a), rtol=1e-10, atol=1e-10)
    with pytest.raises(ValueError, match="along"):
        cam.project_jacobian(X, distort=True, along=a)
    ud, Jd = cam.project_jacobian(X, distort=True)
    np.testing.assert_allclose(ud, cam.project(X))
    assert 0 < np.abs(Jd - J).max() < 0.2 * np.abs(J).max()  # the distortion changes the Jacobian a little


def test_compiled_pchip_is_the_array_formula_bit_for_bit():
    """pchip_interpolate's compiled path gives the bits of its numpy slopes and Hermite sum (flat steps,
    sign changes, points on the nodes and at the ends)."""
    from tendrilkit.geometry import _pchip_core, _pchip_slopes

    rng = np.random.default_rng(2)
    for trial in range(300):
        m, d = int(rng.integers(2, 60)), int(rng.integers(1, 4))
        u = np.cumsum(rng.uniform(0.01, 2, m))
        y = [rng.normal(size=(m, d)), np.cumsum(rng.normal(size=(m, d)), 0), np.round(rng.normal(size=(m, d)))][trial % 3]
        ui = np.sort(np.r_[rng.uniform(u[0], u[-1], 50), u[rng.integers(0, m, 3)], u[0], u[-1]])
        with np.errstate(all="ignore"):
            sl = _pchip_slopes(u, y)
            j = np.clip(np.searchsorted(u, ui, side="right") - 1, 0, u.size - 2)
            h = (u[j + 1] - u[j])[:, None]
            t = ((ui - u[j])[:, None]) / h
            t2, t3 = t * t, t * t * t
            ref = ((2 * t3 - 3 * t2 + 1) * y[j] + (t3 - 2 * t2 + t) * h * sl[j] + (-2 * t3 + 3 * t2) * y[j + 1]
                   + (t3 - t2) * h * sl[j + 1])
        assert _pchip_core(u, np.ascontiguousarray(y), ui).tobytes() == ref.tobytes()
