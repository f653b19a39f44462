"""N-view triangulation and the reprojection table (paper Table 1)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tendrilkit.calibration import ijcv25_rig
from tendrilkit.camera import Camera
from tendrilkit.geometry import point_to_polyline_distance
from tendrilkit.triangulation import reprojection_table, triangulate


def _rig():
    return [Camera(c.K, [-0.08, 0.04, 0.0005, -0.0005, 0.01], c.R, c.t_mm, c.width, c.height) for c in ijcv25_rig()]


def _points(n, seed=0):
    rng = np.random.default_rng(seed)
    return rng.uniform([-30, -30, 0], [30, 30, 40], size=(n, 3))


def test_round_trip_exact_with_distortion():
    cams = _rig()
    X = _points(200)
    obs = np.stack([c.project(X) for c in cams])
    for refine in (False, True):
        tri = triangulate(obs, cams, refine=refine)
        np.testing.assert_allclose(tri.points_mm, X, atol=1e-6)
        assert np.nanmax(tri.reproj_err_px) < 1e-5
        assert tri.n_views.tolist() == [3] * 200


def test_noise_refinement_lowers_reprojection_error():
    cams = _rig()
    X = _points(300, seed=1)
    rng = np.random.default_rng(2)
    obs = np.stack([c.project(X) for c in cams]) + rng.normal(0, 0.5, (3, 300, 2))
    lin = triangulate(obs, cams, refine=False)
    ref = triangulate(obs, cams, refine=True)
    assert np.nanmean(ref.reproj_err_px) <= np.nanmean(lin.reproj_err_px) + 1e-9
    assert np.nanmean(ref.reproj_err_px) < 0.6
    assert np.mean(np.linalg.norm(ref.points_mm - X, axis=1)) < 0.5


def test_missing_views():
    cams = _rig()
    X = _points(6, seed=3)
    obs = np.stack([c.project(X) for c in cams])
    obs[0, 0] = np.nan          # point 0 seen by views 2, 3
    obs[[0, 1], 1] = np.nan     # point 1 seen by view 3 only
    obs[:, 2] = np.nan          # point 2 seen by nobody
    tri = triangulate(obs, cams)
    assert tri.n_views.tolist() == [2, 1, 0, 3, 3, 3]
    assert np.isnan(tri.points_mm[[1, 2]]).all()
    np.testing.assert_allclose(tri.points_mm[[0, 3, 4, 5]], X[[0, 3, 4, 5]], atol=1e-6)
    assert np.isnan(tri.reproj_err_px[0, 0]) and np.isfinite(tri.reproj_err_px[1, 0])


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.floats(-40, 40), st.floats(-40, 40), st.floats(-10, 60)), min_size=1, max_size=20))
def test_project_then_triangulate_property(pts):
    cams = _rig()
    X = np.array(pts, dtype=float)
    obs = np.stack([c.project(X) for c in cams])
    tri = triangulate(obs, cams)
    np.testing.assert_allclose(tri.points_mm, X, atol=1e-5)


def test_triangulate_rejects_bad_shapes():
    cams = _rig()
    with pytest.raises(ValueError, match="n_views, k, 2"):
        triangulate(np.zeros((3, 5)), cams)
    with pytest.raises(ValueError, match="one entry per view"):
        triangulate(np.zeros((2, 5, 2)), cams)


def test_reprojection_table_sections():
    cams = _rig()
    s = np.linspace(0, 1, 200)
    X = np.c_[-30 + 60 * s, 5 * np.sin(3 * s), 20 + 3 * s]
    sk = [c.project(X) for c in cams]
    sk[2] = sk[2] + [0, 2.0]  # view 3's skeleton 2 px lower: its error is about 2 px (less where the curve runs down)
    t = reprojection_table(X, sk, cams)
    assert t.columns.tolist() == ["view", "section", "mean_px", "std_px", "max_px", "n_points"]
    assert t.view.tolist() == [1, 1, 1, 2, 2, 2, 3, 3, 3]
    assert t.section.tolist() == ["base", "tip", "entire"] * 3
    assert t[t.view < 3].mean_px.max() < 1e-6
    assert 0.2 < t[t.view == 3].mean_px.min() and t[t.view == 3].mean_px.max() <= 2.0 + 1e-9
    n = t.set_index(["view", "section"]).n_points
    assert n[(1, "entire")] == 200 and 45 <= n[(1, "base")] <= 55 and 45 <= n[(1, "tip")] <= 55


def test_refine_to_curves_corrects_matches_slid_along_the_curves():
    from tendrilkit.triangulation import refine_to_curves

    cams = _rig()
    s = np.linspace(0, 1, 400)
    X = np.c_[-30 + 60 * s, 8 * np.sin(5 * s), 20 + 6 * np.cos(4 * s)]
    curves = [c.project(X) for c in cams]
    # matches slid along the curve in view 3 (what a poor coupling does): off the curves in 3D
    obs = np.stack([curves[0][20:380], curves[1][20:380], curves[2][26:386]])
    tri = triangulate(obs, cams)

    def table1(P):
        return np.mean([point_to_polyline_distance(c.project(P), q).mean() for c, q in zip(cams, curves)])

    R = refine_to_curves(tri.points_mm, curves, cams)
    assert table1(R) < 0.3 * table1(tri.points_mm)
    d_before = point_to_polyline_distance_3d(tri.points_mm, X)
    d_after = point_to_polyline_distance_3d(R, X)
    assert d_after.mean() < 0.5 * d_before.mean()
    assert np.isnan(refine_to_curves(np.full((2, 3), np.nan), curves, cams)).all()


def point_to_polyline_distance_3d(P, X):
    return np.min(np.linalg.norm(P[:, None, :] - X[None, :, :], axis=2), axis=1)


@pytest.mark.parametrize("seed", range(12))
def test_distance_to_a_curve_searched_near_its_nearest_vertex_is_the_exhaustive_figure(seed):
    """reprojection_table's distances (segments near the nearest vertex only) equal the search over every segment."""
    from tendrilkit.geometry import point_to_polyline_distance
    from tendrilkit.triangulation import _distance_to_curve_px

    rng = np.random.default_rng(seed)
    s = np.linspace(0.0, 1.0, int(rng.integers(70, 1500)))
    turns = rng.uniform(0.5, 3.0)                       # a curl that crosses itself (a spiral drifting sideways)
    curve = np.c_[300 * s + 60 * np.cos(2 * np.pi * turns * s), 80 * np.sin(2 * np.pi * turns * s)]
    curve += rng.normal(0, 0.3, curve.shape)            # a skeleton's jitter
    along = curve[rng.integers(0, len(curve), 300)]
    pts = np.vstack([along + rng.normal(0, rng.choice([0.5, 3.0, 20.0]), along.shape),
                     rng.uniform(-100, 400, (50, 2)), [[np.nan, 1.0]]])
    got = _distance_to_curve_px(pts, curve)
    want = point_to_polyline_distance(pts, curve)
    assert np.array_equal(got, want, equal_nan=True)
