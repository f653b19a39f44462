"""Frenet frames, smoothing and the integration of a frame (tendrilkit.frenet)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

from tendrilkit.exceptions import DegenerateCurveError
from tendrilkit.frenet import (
    frenet_frames,
    integrate_frenet,
    resample_curve,
    whittaker_lambda,
)
from tendrilkit.geometry import whittaker_smooth


def helix(a=8.0, c=3.0, length=150.0, n=200):
    """Helix of radius a, pitch 2 pi c: kappa = a / (a^2 + c^2), tau = c / (a^2 + c^2)."""
    w = 1.0 / np.hypot(a, c)
    s = np.linspace(0.0, length, n)
    P = np.c_[a * np.cos(w * s), a * np.sin(w * s), c * w * s]
    T0 = np.array([0.0, a * w, c * w])
    N0 = np.array([-1.0, 0.0, 0.0])
    return s, P, a * w * w, c * w * w, (T0, N0, np.cross(T0, N0))


def solve_frenet(s, kappa_fn, tau_fn, F0):
    """Reference integration of the Frenet-Serret equations (scipy, tight tolerances)."""
    def rhs(u, y):
        T, N, B = y[3:6], y[6:9], y[9:12]
        k, t = kappa_fn(u), tau_fn(u)
        return np.concatenate([T, k * N, -k * T + t * B, -t * N])

    y0 = np.concatenate([np.zeros(3), *F0])
    sol = solve_ivp(rhs, (s[0], s[-1]), y0, t_eval=s, rtol=1e-11, atol=1e-12, method="DOP853")
    return sol.y[:3].T


# ------------------------------------------------------------------ smoothing


def test_whittaker_half_gain_at_the_smoothing_length():
    h, L = 0.5, 10.0
    x = np.arange(4000) * h
    y = np.sin(2 * np.pi * x / L)
    z = whittaker_smooth(y, lam=whittaker_lambda(L, h))
    mid = slice(1000, 3000)
    gain = np.abs(z[mid]).max() / np.abs(y[mid]).max()
    assert gain == pytest.approx(0.5, abs=0.03)
    # three times the length passes almost untouched
    y3 = np.sin(2 * np.pi * x / (3 * L))
    z3 = whittaker_smooth(y3, lam=whittaker_lambda(L, h))
    assert np.abs(z3[mid]).max() > 0.98


def test_whittaker_lambda_is_independent_of_the_number_of_points():
    # the same physical length on a twice finer grid gives the same cut-off in mm
    assert whittaker_lambda(10.0, 0.25) == pytest.approx(16 * whittaker_lambda(10.0, 0.5))


# ------------------------------------------------------------------ Frenet


def test_helix_curvature_and_torsion():
    s, P, k, t, _ = helix()
    fr = frenet_frames(P, smoothing_length_mm=0)
    assert np.allclose(fr.kappa[2:-2], k, rtol=2e-3)
    assert np.allclose(fr.tau[3:-3], t, rtol=2e-3)
    assert fr.tau_defined.all()
    F = np.stack([fr.T, fr.N, fr.B], axis=1)
    assert np.allclose(F @ F.transpose(0, 2, 1), np.eye(3), atol=1e-9)
    assert np.allclose(np.linalg.det(F), 1.0)


def test_smoothing_keeps_the_helix_with_noise():
    s, P, k, t, _ = helix()
    rng = np.random.default_rng(0)
    fr = frenet_frames(P + rng.normal(0, 0.15, P.shape), smoothing_length_mm=20.0)
    assert np.median(np.abs(fr.kappa - k)) < 0.05 * k
    assert np.median(np.abs(fr.tau - t)) < 0.5 * t
    # the padded smoother does not straighten the ends
    assert abs(fr.kappa[0] - k) < 0.2 * k and abs(fr.kappa[-1] - k) < 0.2 * k


def test_straight_line_flags_torsion_undefined():
    P = np.c_[np.linspace(0, 100, 50), np.zeros(50), np.zeros(50)]
    fr = frenet_frames(P, smoothing_length_mm=5.0)
    assert np.allclose(fr.kappa, 0.0, atol=1e-9)
    assert not fr.tau_defined.any()
    assert np.all(fr.tau == 0.0)
    assert np.allclose(np.linalg.norm(fr.N, axis=1), 1.0)
    assert np.allclose(np.einsum("ij,ij->i", fr.N, fr.T), 0.0, atol=1e-9)


def test_planar_curve_has_zero_torsion():
    u = np.linspace(0, 3, 120)
    P = np.c_[30 * np.cos(u), 20 * np.sin(u), np.zeros_like(u)]
    fr = frenet_frames(P, smoothing_length_mm=0)
    assert np.abs(fr.tau).max() < 1e-9
    assert np.allclose(np.abs(fr.B[:, 2]), 1.0)


def test_repeated_points_are_dropped():
    s, P, k, t, _ = helix(n=100)
    Q = np.repeat(P, 2, axis=0)
    out = resample_curve(Q, 100)
    assert np.abs(out - P).max() < 1e-6


@pytest.mark.parametrize("points, match", [
    (np.zeros((10, 3)), "zero length"),
    (np.array([[0, 0, 0], [1, 0, 0], [1, 0, 0], [0, 0, 0.0]]), "distinct"),
])
def test_degenerate_curves_raise_a_named_error(points, match):
    with pytest.raises(DegenerateCurveError, match=match):
        frenet_frames(points)


def test_bad_input_is_a_value_error_naming_the_argument():
    with pytest.raises(ValueError, match="points_mm"):
        frenet_frames(np.zeros((10, 2)))
    with pytest.raises(ValueError, match="points_mm"):
        frenet_frames(np.full((10, 3), np.nan))


# ------------------------------------------------------------------ integration


@pytest.mark.parametrize("positions, tol", [("exact", 1e-9), ("trapezoid", 0.02)])
def test_integrate_a_helix(positions, tol):
    s, P, k, t, F0 = helix()
    Q, T, N, B = integrate_frenet(s, np.full(s.size, k), np.full(s.size, t), *F0, P[0], positions=positions)
    assert np.abs(Q - P).max() < tol
    F = np.stack([T, N, B], axis=1)
    assert np.allclose(F @ F.transpose(0, 2, 1), np.eye(3), atol=1e-12)


def test_integrator_is_second_order_on_varying_laws():
    """Against scipy on a piece-wise clothoid: halving the step quarters the error."""
    knots = np.array([0.0, 40.0, 90.0, 140.0])
    kv, tv = np.array([0.02, 0.09, 0.04, 0.07]), np.array([0.03, -0.02, 0.04, 0.0])
    F0 = (np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0]))
    errs = []
    for n in (141, 281):
        s = np.linspace(0, 140, n)
        ref = solve_frenet(s, lambda u: np.interp(u, knots, kv), lambda u: np.interp(u, knots, tv), F0)
        Q, *_ = integrate_frenet(s, np.interp(s, knots, kv), np.interp(s, knots, tv), *F0, np.zeros(3))
        errs.append(np.abs(Q - ref).max())
    assert errs[0] < 0.05
    assert errs[1] < errs[0] / 3.0


@settings(max_examples=15, deadline=None)
@given(
    kv=st.lists(st.floats(0.01, 0.1), min_size=3, max_size=3),
    tv=st.lists(st.floats(-0.05, 0.05), min_size=3, max_size=3),
)
def test_integrate_then_measure(kv, tv):
    """Round trip: curvature and torsion measured on the integrated curve are the laws."""
    knots = np.array([0.0, 60.0, 120.0])
    s = np.linspace(0, 120, 1201)
    k, t = np.interp(s, knots, kv), np.interp(s, knots, tv)
    P, *_ = integrate_frenet(s, k, t, [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0], positions="exact")
    fr = frenet_frames(P, smoothing_length_mm=0)
    inner = slice(20, -20)
    assert np.abs(fr.kappa - k)[inner].max() < 2e-3
    assert np.abs(fr.tau - t)[inner].max() < 1e-2
    assert fr.s_mm[-1] == pytest.approx(120.0, rel=1e-4)


def test_integrate_frenet_checks_its_inputs():
    s = np.linspace(0, 1, 5)
    with pytest.raises(ValueError, match="kappa"):
        integrate_frenet(s, np.zeros(4), np.zeros(5), [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0])
    with pytest.raises(ValueError, match="s_mm"):
        integrate_frenet(s[::-1], np.zeros(5), np.zeros(5), [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0])


def test_integrator_stays_orthonormal_with_large_steps():
    """About one radian per step for 500 steps: the frame must not drift (it once diverged)."""
    s = np.linspace(0, 500, 501)
    P, T, N, B = integrate_frenet(s, np.full(501, 0.4), np.full(501, -1.1), [1, 0, 0], [0, 1, 0], [0, 0, 1],
                                  [0, 0, 0], positions="exact")
    F = np.stack([T, N, B], axis=1)
    assert np.allclose(F @ F.transpose(0, 2, 1), np.eye(3), atol=1e-12)
    # a helix of radius kappa / (kappa^2 + tau^2) about the Darboux axis through P0 + r N0
    k, t = 0.4, -1.1
    r = k / (k * k + t * t)
    axis = (t * T[0] + k * B[0]) / np.hypot(k, t)
    rel = P - (P[0] + r * N[0])
    dist = np.linalg.norm(rel - np.outer(rel @ axis, axis), axis=1)
    assert np.allclose(dist, r, atol=1e-9)


def test_noise_estimate_and_automatic_smoothing_length():
    from tendrilkit.frenet import auto_smoothing_length_mm, noise_sigma_mm

    s, P, k, t, _ = helix()
    rng = np.random.default_rng(1)
    for sigma in (0.05, 0.15, 0.5):
        assert noise_sigma_mm(P + rng.normal(0, sigma, P.shape)) == pytest.approx(sigma, rel=0.2)
    L1 = auto_smoothing_length_mm(P + rng.normal(0, 0.15, P.shape))
    L2 = auto_smoothing_length_mm(P + rng.normal(0, 0.6, P.shape))
    assert 5 < L1 < L2


def test_weighted_whittaker_matches_dense_normal_equations():
    rng = np.random.default_rng(3)
    for n in (3, 4, 7, 60):
        y = rng.normal(size=n)
        w = rng.uniform(0.0, 2.0, n)
        w[1] = 0.0  # a sample with no weight is interpolated
        D = np.diff(np.eye(n), 2, axis=0)
        expected = np.linalg.solve(np.diag(w) + 7.3 * D.T @ D, w * y)
        np.testing.assert_allclose(whittaker_smooth(y, lam=7.3, weights=w), expected, atol=1e-10)



@settings(max_examples=60, deadline=None)
@given(st.integers(3, 120), st.integers(0, 2**31 - 1), st.sampled_from(["helix", "walk", "uniform"]))
def test_compiled_derivatives_are_numpys_steps_bit_for_bit(n, seed, kind):
    """_curve_derivatives (one compiled call) gives the bits of the numpy steps it replaced: arc length,
    three np.gradient (both of its branches: steps equal or not), the speed, tangent, d1 x d2 and its norm."""
    from tendrilkit.frenet import _curve_derivatives
    from tendrilkit.geometry import arc_length

    rng = np.random.default_rng(seed)
    if kind == "helix":
        t = np.linspace(0, 10, n)
        z = np.c_[np.cos(t), np.sin(t), 0.3 * t] * rng.uniform(1, 50) + rng.normal(0, rng.uniform(0, 0.5), (n, 3))
    elif kind == "walk":
        z = np.cumsum(rng.normal(size=(n, 3)), axis=0)
    else:
        z = np.c_[np.arange(n) * 0.7, np.zeros(n), np.zeros(n)]
    s = arc_length(z)
    got = _curve_derivatives(z)
    assert got[-1]
    d1 = np.gradient(z, s, axis=0, edge_order=2)
    d2 = np.gradient(d1, s, axis=0, edge_order=2)
    d3 = np.gradient(d2, s, axis=0, edge_order=2)
    sp = np.linalg.norm(d1, axis=1)
    cr = np.cross(d1, d2)
    for a, b in zip(got[:-1], (s, d1, d2, d3, sp, d1 / sp[:, None], cr, np.linalg.norm(cr, axis=1))):
        assert a.tobytes() == b.tobytes()
