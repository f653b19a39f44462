"""Degenerate geometry thrown at every public geometry function.

Repeated points, collinear points, NaN, inf, one or two points, empty arrays:
each function returns a clear result (NaN only where the convention says a
missing observation is NaN) or raises a named tendrilkit exception or a
``ValueError`` with a message; never an ``IndexError``, ``ZeroDivisionError``,
``LinAlgError`` or a silent NaN result that claims success.
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import pytest

from tendrilkit import correspondence as co
from tendrilkit import frenet as fr
from tendrilkit import geometry as geo
from tendrilkit import pwc
from tendrilkit import sequence as sq
from tendrilkit import skeleton as sk
from tendrilkit import triangulation as tr
from tendrilkit.camera import Camera
from tendrilkit.exceptions import TendrilkitError

_s = np.linspace(0.0, 1.0, 60)
HELIX = np.c_[30 * _s, 5 * np.sin(4 * _s), 5 * np.cos(4 * _s)]
CAMS = [Camera(K=np.array([[1000.0, 0, 500], [0, 1000, 500], [0, 0, 1]]), t_mm=np.array([tx, 0.0, 200.0]))
        for tx in (-40.0, 0.0, 40.0)]
DIST_CAM = Camera(K=CAMS[0].K, dist=np.array([0.1, 0, 0, 0, 0]), t_mm=np.array([0.0, 0, 200]))


def _with_bad_row(X, value):
    Y = X.copy()
    Y[7] = value
    return Y


CASES_3D = {
    "empty": np.zeros((0, 3)),
    "one": HELIX[:1],
    "two": HELIX[:2],
    "repeated": np.tile([[1.0, 2.0, 3.0]], (50, 1)),
    "collinear": np.c_[np.linspace(0, 50, 50), np.zeros(50), np.zeros(50)],
    "nan": _with_bad_row(HELIX, np.nan),
    "inf": _with_bad_row(HELIX, np.inf),
    "all_nan": np.full((20, 3), np.nan),
}
# the 2D cases are the same curves seen from the top
CASES_2D = {k: v[:, :2] for k, v in CASES_3D.items()}

# functions whose contract lets NaN through (a NaN input point is a missing observation:
# its own output row is NaN, the others stay finite)
NAN_IN_NAN_OUT = {"project", "undistort_points", "triangulate", "point_to_polyline_distance(points)",
                  "nearest_on_polyline(points)"}


def _views(x):
    return np.stack([x, x, x])


FUNCTIONS_2D = {
    "undistort_points": lambda x: DIST_CAM.undistort_points(x),
    "resample_polyline": lambda x: geo.resample_polyline(x, 20),
    "discrete_frechet": lambda x: co.discrete_frechet(x, x[::-1]),
    "match_epipolar": lambda x: co.match_epipolar([x, x + 1.0, x - 1.0], CAMS, reference=1, k=20),
    "match_frechet": lambda x: co.match_frechet([x, x + 1.0, x - 1.0], CAMS, reference=1, k=20),
    "triangulate": lambda x: tr.triangulate(_views(x), CAMS),
    "refine_to_curves": lambda x: tr.refine_to_curves(HELIX, [x, x, x], CAMS),
    "point_to_polyline_distance(points)": lambda x: geo.point_to_polyline_distance(x, HELIX[:, :2]),
    "point_to_polyline_distance(polyline)": lambda x: geo.point_to_polyline_distance(HELIX[:, :2], x),
    "reprojection_table": lambda x: tr.reprojection_table(HELIX, [x, x, x], CAMS),
    "nearest_on_polyline(points)": lambda x: geo.nearest_on_polyline(x, HELIX[:, :2]),
    "nearest_on_polyline(polyline)": lambda x: geo.nearest_on_polyline(HELIX[:, :2], x),
}

_I3 = np.eye(3)
FUNCTIONS_3D = {
    "project": lambda X: CAMS[0].project(X),
    "triangulate(projected)": lambda X: tr.triangulate(np.stack([c.project(X) for c in CAMS]), CAMS),
    "reprojection_table(points)": lambda X: tr.reprojection_table(X, [c.project(HELIX) for c in CAMS], CAMS),
    "resample_curve": lambda X: fr.resample_curve(X, 20),
    "frenet_frames": lambda X: fr.frenet_frames(X),
    "noise_sigma_mm": lambda X: fr.noise_sigma_mm(X),
    "auto_smoothing_length_mm": lambda X: fr.auto_smoothing_length_mm(X),
    "integrate_frenet(kappa=x)": lambda X: fr.integrate_frenet(np.arange(len(X), dtype=float), X[:, 0], np.zeros(len(X)),
                                                               _I3[0], _I3[1], _I3[2], np.zeros(3)),
    "fit_piecewise_clothoid": lambda X: pwc.fit_piecewise_clothoid(X),
    "register_rigid": lambda X: pwc.register_rigid(X, X + 1.0),
    "resample_normalised": lambda X: sq.resample_normalised(X, np.linspace(0, 1, 5)),
    "resample_polyline(pchip)": lambda X: geo.resample_polyline(X, 20, method="pchip"),
    "point_at_arc_length": lambda X: geo.point_at_arc_length(X, np.linspace(0, 1, 5), normalised=True),
    "rigid_fit": lambda X: geo.rigid_fit(X, X + 1.0),
    "marker_corners(length=x)": lambda X: geo.marker_corners(float(X[0, 0]) if len(X) else np.nan),
}


def _arrays(result):
    """Every float array inside a result (tuples, dataclasses, DataFrames)."""
    if isinstance(result, np.ndarray):
        return [result] if result.dtype.kind == "f" else []
    if isinstance(result, pd.DataFrame):
        return [result.select_dtypes("number").to_numpy(float)]
    if isinstance(result, (tuple, list)):
        return [a for r in result for a in _arrays(r)]
    if hasattr(result, "__dataclass_fields__"):
        # a penalty range [0, inf) is a legitimate bound (every penalty gives the same fit), not a result
        return [a for name in result.__dataclass_fields__ if not name.startswith("penalty_range")
                for a in _arrays(getattr(result, name))]
    if isinstance(result, float):
        return [np.array([result])]
    return []


def _call(name, f, x):
    """Run ``f(x)``: a named error with a message, or a result checked for silent NaN."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # warnings are allowed; only the outcome is checked here
        try:
            result = f(x)
        except (TendrilkitError, ValueError) as e:
            assert str(e).strip(), f"{name}: {type(e).__name__} without a message"
            # a named error, or a plain ValueError naming the argument: never a raw numerical error that
            # subclasses ValueError (numpy's LinAlgError, AxisError)
            assert isinstance(e, TendrilkitError) or type(e) is ValueError, f"{name}: raw {type(e).__name__}: {e}"
            return None
    # anything else (IndexError, ZeroDivisionError, LinAlgError, TypeError, ...) propagates: test failure
    x = np.asarray(x, float)
    input_finite = bool(np.all(np.isfinite(x)))
    for a in _arrays(result):
        if a.size == 0 or np.all(np.isfinite(a)):
            continue
        # NaN is allowed only as the missing-observation convention: non-finite input rows
        # (or the epipolar matcher's unmatched points, checked separately)
        assert not input_finite or name.startswith(("match_epipolar", "triangulate", "reprojection_table")), \
            f"{name}: finite input gave a non-finite result"
        assert name in NAN_IN_NAN_OUT or name.startswith(("match_epipolar", "triangulate", "reprojection_table")), \
            f"{name}: non-finite input gave a non-finite result instead of an error"
    return result


@pytest.mark.parametrize("case", list(CASES_2D))
@pytest.mark.parametrize("name", list(FUNCTIONS_2D))
def test_2d_functions(name, case):
    _call(name, FUNCTIONS_2D[name], CASES_2D[case])


@pytest.mark.parametrize("case", list(CASES_3D))
@pytest.mark.parametrize("name", list(FUNCTIONS_3D))
def test_3d_functions(name, case):
    _call(name, FUNCTIONS_3D[name], CASES_3D[case])


def test_nan_in_nan_out_keeps_the_other_rows():
    """Where NaN passes through, it stays in its own row."""
    X = CASES_3D["nan"]
    p = CAMS[0].project(X)
    assert np.isnan(p[7]).all() and np.isfinite(np.delete(p, 7, axis=0)).all()
    tri = tr.triangulate(np.stack([c.project(X) for c in CAMS]), CAMS)
    assert np.isnan(tri.points_mm[7]).all()
    np.testing.assert_allclose(np.delete(tri.points_mm, 7, axis=0), np.delete(X, 7, axis=0), atol=1e-6)


def test_triangulation_of_unmatched_points_is_nan_not_a_guess():
    """One view only (the others NaN): the point cannot be triangulated."""
    x = CAMS[0].project(HELIX)
    obs = np.stack([x, np.full_like(x, np.nan), np.full_like(x, np.nan)])
    tri = tr.triangulate(obs, CAMS)
    assert np.isnan(tri.points_mm).all()


def test_straight_curve_fits_with_torsion_flagged_undefined():
    """A straight tendril: curvature 0, torsion undefined everywhere, the fit still succeeds."""
    X = CASES_3D["collinear"]
    f = pwc.fit_piecewise_clothoid(X)
    assert np.isfinite(f.points_mm).all() and f.scores.rmse_mm < 1e-6
    assert not f.frames.tau_defined.any()
    assert np.allclose(f.frames.kappa, 0.0, atol=1e-9) and np.all(f.frames.tau == 0.0)
    ff = fr.frenet_frames(X)
    assert not ff.tau_defined.any() and np.isfinite(ff.T).all()


def test_integrate_frenet_rejects_repeated_arc_length_and_a_zero_frame():
    s = np.linspace(0, 10, 20)
    z = np.zeros(20)
    with pytest.raises(ValueError, match="strictly increasing"):
        fr.integrate_frenet(np.zeros(20), z, z, _I3[0], _I3[1], _I3[2], np.zeros(3))
    with pytest.raises(ValueError):
        fr.integrate_frenet(s, z, z, np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3))
    with pytest.raises(ValueError, match="tau"):
        fr.integrate_frenet(s, z, np.r_[np.nan, z[1:]], _I3[0], _I3[1], _I3[2], np.zeros(3))


MASKS = {
    "empty": np.zeros((40, 40), bool),
    "one_pixel": np.pad(np.ones((1, 1), bool), 20),
    "small_block": np.pad(np.ones((3, 3), bool), 20),
}


@pytest.mark.parametrize("case", list(MASKS))
def test_order_skeleton_on_tiny_masks(case):
    from tendrilkit.exceptions import EmptySkeletonError

    with pytest.raises(EmptySkeletonError) as info:
        sk.order_skeleton(MASKS[case], base_point_xy=(20, 20))
    assert str(info.value)


def test_order_skeleton_on_a_line():
    oc = sk.order_skeleton(np.pad(np.ones((3, 40), bool), 20), base_point_xy=(20, 21))
    assert len(oc.points_xy) >= 2 and np.isfinite(oc.points_xy).all()


def _table(curves):
    rows = [dict(frame=f, time_s=10.0 * f, point=i, x_mm=p[0], y_mm=p[1], z_mm=p[2])
            for f, P in enumerate(curves) for i, p in enumerate(P)]
    return pd.DataFrame(rows, columns=["frame", "time_s", "point", "x_mm", "y_mm", "z_mm"])


SEQUENCES = {
    "empty": _table([]),
    "repeated": _table([CASES_3D["repeated"]] * 3),
    "collinear": _table([CASES_3D["collinear"]] * 3),
    "one_point": _table([HELIX[:1]] * 3),
    "nan_frame": _table([HELIX, CASES_3D["nan"], 1.1 * HELIX]),
    "repeated_frame": _table([HELIX, CASES_3D["repeated"], 1.1 * HELIX]),
}
SEQUENCE_FUNCTIONS = {
    "shape_change": lambda t: sq.shape_change(t),
    "shape_change(rigid)": lambda t: sq.shape_change(t, align="rigid"),
    "curvature_torsion_maps": lambda t: sq.curvature_torsion_maps(t),
    "tip_trajectory": lambda t: sq.tip_trajectory(t),
    "tip_path_stats": lambda t: sq.tip_path_stats(sq.tip_trajectory(t)),
    "response_times": lambda t: sq.response_times(sq.shape_change(t)),
    "summarize_experiment": lambda t: sq.summarize_experiment(t),
}


@pytest.mark.parametrize("case", list(SEQUENCES))
@pytest.mark.parametrize("name", list(SEQUENCE_FUNCTIONS))
def test_sequence_functions(name, case):
    """Degenerate frames are excluded (listed in a warning) or the call fails with a message."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            result = SEQUENCE_FUNCTIONS[name](SEQUENCES[case])
        except (TendrilkitError, ValueError) as e:
            assert str(e).strip()
            return
    if isinstance(result, pd.DataFrame) and case == "nan_frame":
        assert 1 not in set(result["frame"]), "a frame with NaN coordinates was used"


def test_views_sharing_a_centre_have_no_depth():
    """Zero baseline: triangulation gives NaN (not an arbitrary point on the ray), no epipolar geometry."""
    same = [CAMS[1]] * 3
    x = CAMS[1].project(HELIX)
    tri = tr.triangulate(np.stack([x, x, x]), same)
    assert np.isnan(tri.points_mm).all()
    with pytest.raises(ValueError, match="share a centre"):
        co.fundamental_matrix(CAMS[1], CAMS[1])
    with pytest.raises((TendrilkitError, ValueError)):
        co.match_epipolar([x, x, x], same, reference=1, k=20)


@pytest.mark.parametrize("call", [
    lambda: __import__("tendrilkit.camera", fromlist=["look_at"]).look_at(np.zeros(3), np.zeros(3), np.array([0, 0, 1.0])),
    lambda: __import__("tendrilkit.camera", fromlist=["look_at"]).look_at(np.zeros(3), np.array([0, 0, 1.0]), np.array([0, 0, 1.0])),
    lambda: __import__("tendrilkit.camera", fromlist=["look_at"]).look_at(np.array([np.nan, 0, 0]), np.array([0, 0, 1.0]), np.array([0, 1.0, 0])),
    lambda: __import__("tendrilkit.camera", fromlist=["rotation_from_rvec"]).rotation_from_rvec(np.array([np.nan, 0, 0])),
    lambda: geo.whittaker_smooth(_with_bad_row(HELIX, np.nan), lam=10.0),
    lambda: pwc.segment_penalty(np.zeros((0, 0)), 1.0),
    lambda: pwc.fit_scores(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)),
    lambda: pwc.fit_scores(CASES_3D["nan"], HELIX, np.arange(60.0)),
    lambda: pwc.line_costs(np.zeros(10), np.zeros(10)),
], ids=["look_at(eye=target)", "look_at(up parallel)", "look_at(nan)", "rotation_from_rvec(nan)",
        "whittaker_smooth(nan)", "segment_penalty(empty)", "fit_scores(empty)", "fit_scores(nan)",
        "line_costs(repeated s)"])
def test_helpers_reject_degenerate_input(call):
    with pytest.raises((TendrilkitError, ValueError)) as info:
        call()
    assert str(info.value).strip()
    assert isinstance(info.value, TendrilkitError) or type(info.value) is ValueError, repr(info.value)
