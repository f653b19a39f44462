"""Calibration: ArUco detection and pose, the ijcv25 loader, bundle adjustment.

The unit tests render their own frames: a flat white board (the world
marker's plane, z = 0) carrying ArUco markers, seen through a camera with lens
distortion. Each pixel's ray (2 x 2 sub-samples) is intersected with the board
and the board's texture is looked up with ``cv2.remap``; then a slight blur,
noise and 8-bit quantisation.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tendrilkit.calibration import (
    RIG_DIR,
    BundleReport,
    CalibrationResult,
    bundle_adjust,
    calibrate,
    cameras_from_ijcv25,
    detect_markers,
    ijcv25_rig,
    marker_pose,
    rig_agreement_px,
)
from tendrilkit.camera import Camera, rotation_from_rvec
from tendrilkit.exceptions import ExperimentError
from tendrilkit.geometry import marker_corners
from tendrilkit.extrinsics import calibrate_experiment, calibrate_to_dir
from tendrilkit.calibration.synthetic import (
    BOARD_MARKERS,
    DICT,
    WORLD_ID,
    L,
    board_scene,
    distorted_rig,
    observe_markers,
    render_board,
    rot_err_deg,
    synthetic_markers,
    working_volume,
)
from tendrilkit.io import read_ijcv25_extrinsics, read_ijcv25_intrinsics

@pytest.fixture(scope="module")
def rendered():
    """One rendered frame per view of the distorted rig, with the exact marker corners."""
    tex, corners = board_scene()
    rng = np.random.default_rng(1)
    cams = distorted_rig()
    return cams, [render_board(c, tex, rng=rng, corners=corners) for c in cams], corners


# ---------------------------------------------------------------- detection
def test_marker_corners_order():
    c = marker_corners(24.0)
    assert c.shape == (4, 3)
    np.testing.assert_allclose(c[0], [-12, 12, 0])
    np.testing.assert_allclose(c[2], [12, -12, 0])


def test_detect_markers_corners_subpixel(rendered):
    cams, images, corners = rendered
    for cam, img in zip(cams, images):
        det = detect_markers(img, DICT, camera=cam)
        assert WORLD_ID in det
        for mid, c in det.items():
            truth = cam.project(corners[mid])
            err = np.linalg.norm(c - truth, axis=1)
            assert err.max() < 0.15, (mid, err)


def test_detect_markers_no_dilation_under_gamma():
    """A non-linear response (gamma 2.2 after the blur) shrinks every black square
    by ~0.8 px at the half-way level; the border-width measurement removes it."""
    tex, corners = board_scene()
    cam = distorted_rig()[1]
    img = render_board(cam, tex, rng=np.random.default_rng(4), blur_px=1.5, noise=1.0, corners=corners)
    img = np.clip(255 * (img / 255.0) ** (1 / 2.2), 0, 255).astype(np.uint8)
    det = detect_markers(img, DICT, camera=cam)
    radial = []
    for mid, c in det.items():
        truth = cam.project(corners[mid])
        out = truth - truth.mean(0)
        radial.append(np.sum((c - truth) * out / np.linalg.norm(out, axis=1)[:, None], axis=1))
        assert np.linalg.norm(c - truth, axis=1).max() < 0.15, mid
    assert abs(np.concatenate(radial).mean()) < 0.03
    plain = detect_markers(img, DICT, refine="subpix")
    truth = cam.project(corners[WORLD_ID])
    assert np.linalg.norm(plain[WORLD_ID] - truth, axis=1).mean() > 0.3  # what OpenCV alone gives


def test_detect_markers_dark_blob_at_a_corner(rendered):
    """Something dark touching a corner (a leaf, the stem) pulls OpenCV's corner
    by ~15 px; the side lines ignore it."""
    cams, images, corners = rendered
    cam, img = cams[1], images[1].copy()
    truth = cam.project(corners[WORLD_ID])
    x, y = (int(round(v)) for v in truth[1])  # top-right corner of the world marker
    cv2.line(img, (x - 2, y - 2), (x + 8, y + 8), (40, 60, 30), 5, cv2.LINE_AA)
    plain = detect_markers(img, DICT, refine="subpix")[WORLD_ID]
    ours = detect_markers(img, DICT, camera=cam)[WORLD_ID]
    assert np.linalg.norm(plain - truth, axis=1).max() > 5
    assert np.linalg.norm(ours - truth, axis=1).max() < 0.15


def test_marker_pose_round_trip(rendered):
    cams, images, corners = rendered
    for cam, img in zip(cams, images):
        det = detect_markers(img, DICT, camera=cam)
        R, t = marker_pose(det[WORLD_ID], cam, L)
        assert rot_err_deg(R, cam.R) < 0.5
        assert np.linalg.norm(t - cam.t_mm) < 1.0


@settings(max_examples=30, deadline=None)
@given(dist_mm=st.floats(150, 800), tilt_deg=st.floats(0, 65), azimuth_deg=st.floats(-180, 180),
       roll_deg=st.floats(-180, 180), k1=st.floats(-0.1, 0.1), length=st.floats(10, 60))
def test_marker_pose_exact_corners_property(dist_mm, tilt_deg, azimuth_deg, roll_deg, k1, length):
    """Project a marker's exact corners through a distorted camera; marker_pose gives the pose back.

    OpenCV 5's IPPE_SQUARE alone fails this (e.g. 5 degrees from frontal with
    the marker's edges along the image axes: both solutions 80 px off)."""
    from tendrilkit.camera import look_at

    a, t = np.radians(azimuth_deg), np.radians(tilt_deg)
    eye = dist_mm * np.array([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), np.cos(t)])
    up = np.array([np.cos(np.radians(roll_deg)), np.sin(np.radians(roll_deg)), 0.0])
    if abs(np.dot(up, eye / dist_mm)) > 0.95:
        up = np.array([0.0, 0.0, 1.0])
    R, tv = look_at(eye, np.zeros(3), up)
    K = np.array([[1750.0, 0, 960], [0, 1750.0, 540], [0, 0, 1]])
    cam = Camera(K, [k1, 0.01, 0, 0, 0], R, tv)
    corners = cam.project(marker_corners(length))
    R_est, t_est = marker_pose(corners, cam, length)
    assert rot_err_deg(R_est, R) < 0.01  # exactly frontal views are ill-conditioned in tilt
    assert np.linalg.norm(t_est - tv) < 1e-3 * dist_mm


def test_detect_markers_rejects_bad_dictionary():
    with pytest.raises(ValueError, match="dictionary"):
        detect_markers(np.zeros((50, 50, 3), np.uint8), "ARUCO_ORIGINAL")


def test_missing_world_marker_is_one_line_experiment_error(rendered):
    cams, images, _ = rendered
    blank = np.full_like(images[1], 220)
    with pytest.raises(ExperimentError) as e:
        calibrate([images[0], blank, images[2]], cams, dictionary=DICT, world_id=WORLD_ID, length_mm=L)
    assert str(e.value) == "view 2: world marker 815 (DICT_ARUCO_ORIGINAL) not found in frame 0"


def test_calibrate_rendered_rig_within_half_pixel(rendered):
    cams, images, _ = rendered
    res = calibrate(images, cams, dictionary=DICT, world_id=WORLD_ID, length_mm=L)
    assert isinstance(res, CalibrationResult) and res.source == "bundle"
    P = working_volume()
    mx_single, _ = rig_agreement_px(res.single_cameras, cams, P)
    mx, mean = rig_agreement_px(res.cameras, cams, P)
    assert mx.max() < 0.5, (mx_single, mx)
    assert set(res.markers.stage) == {"single", "adjusted"}
    adj = res.markers[res.markers.stage == "adjusted"]
    assert adj.mean_px.max() < 0.3
    assert list(res.markers.columns[:5]) == ["view", "marker_id", "stage", "mean_px", "max_px"]


# ------------------------------------------------------------------- ijcv25
def test_ijcv25_loader_reproduces_stored_corners():
    rig = ijcv25_rig()
    L_ = 24.0
    for i, cam in enumerate(rig):
        ext = read_ijcv25_extrinsics(RIG_DIR / f"CamExtrPara_Corners{i + 1}.csv")
        proj = cam.project(marker_corners(L_))
        assert np.abs(proj - ext["corners_xy"][0]).max() < 0.5
        ok, rv, tv = cv2.solvePnP(marker_corners(L_), ext["corners_xy"][0], cam.K, None,
                                  flags=cv2.SOLVEPNP_IPPE_SQUARE)
        assert np.abs(tv.ravel() - cam.t_mm).max() < 0.2
        # marker_pose (IPPE + LM polish) agrees with the stored pose as well
        R, t = marker_pose(ext["corners_xy"][0], cam, L_)
        assert np.abs(t - cam.t_mm).max() < 0.5


def test_cameras_from_ijcv25_picks_row_by_frame():
    rig = ijcv25_rig()
    files = [RIG_DIR / f"CamExtrPara_Corners{i + 1}.csv" for i in range(3)]
    tables = [read_ijcv25_extrinsics(f) for f in files]
    ext = tables[0]
    by_frame = cameras_from_ijcv25(tables, rig, frame=int(ext["frame"][2]))
    np.testing.assert_allclose(by_frame[0].t_mm, ext["t_mm"][2])
    absent = cameras_from_ijcv25(tables, rig, frame=0)
    np.testing.assert_allclose(absent[0].t_mm, ext["t_mm"][0])


def test_ijcv25_rig_is_the_package_data_files():
    """ijcv25_rig() holds the numbers of data/ijcv25_rig: exactly the intrinsics and first stored poses."""
    meta = read_ijcv25_intrinsics(RIG_DIR / "intrinsics.yaml")
    w, h = meta["image_size"]
    intr = [Camera(K=np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1.0]]), width=w, height=h)
            for c in meta["cameras"]]
    tables = [read_ijcv25_extrinsics(RIG_DIR / f"CamExtrPara_Corners{i + 1}.csv") for i in range(len(intr))]
    for a, b in zip(ijcv25_rig(), cameras_from_ijcv25(tables, intr)):
        assert (a.width, a.height) == (b.width, b.height)
        assert np.array_equal(a.K, b.K) and np.array_equal(a.dist, b.dist)
        assert np.array_equal(a.R, b.R) and np.array_equal(a.t_mm, b.t_mm)


def test_rodrigues_of_the_bundle_adjustment_is_scipys_rotation():
    """The adjustment's own vectorised Rodrigues (kept: scipy's Rotation differs in the last bits, which
    would move every adjusted rig) equals scipy.spatial.transform.Rotation.from_rotvec to rounding."""
    from scipy.spatial.transform import Rotation

    from tendrilkit.calibration.bundle import _rodrigues

    rng = np.random.default_rng(0)
    rv = rng.normal(size=(2000, 3)) * rng.uniform(0, 3, size=(2000, 1))
    rv[:3] = [[0, 0, 0], [1e-14, 0, 0], [np.pi, 0, 0]]
    np.testing.assert_allclose(_rodrigues(rv), Rotation.from_rotvec(rv).as_matrix(), rtol=0, atol=1e-13)


def _write_experiment(tmp_path: Path, images: list[np.ndarray], cams: list[Camera], extra: str = "") -> Path:
    lines = ["name: calib-test", "videos:"]
    for v, img in enumerate(images):
        d = tmp_path / f"view{v + 1}"
        d.mkdir()
        cv2.imwrite(str(d / "000000.png"), img)
        lines.append(f"  - view{v + 1}")
    lines += ["fps: 30", "reference_view: 2", "cameras:"]
    for v, c in enumerate(cams):
        lines.append(f"  - {{view: {v + 1}, fx: {float(c.K[0, 0])!r}, fy: {float(c.K[1, 1])!r}, cx: {float(c.K[0, 2])!r}, "
                     f"cy: {float(c.K[1, 2])!r}, dist: {c.dist.tolist()}}}")
    lines += [f"marker: {{dictionary: {DICT}, id: {WORLD_ID}, length_mm: {L}}}", "views:"]
    for v in range(len(cams)):
        lines.append(f"  - {{view: {v + 1}, roi: [800, 400, 400, 400], base_point: [1000, 450]}}")
    p = tmp_path / "experiment.yaml"
    p.write_text("\n".join(lines) + "\n" + extra)
    return p


def test_calibrate_to_dir_ijcv25_layout(tmp_path):
    rig = ijcv25_rig()
    small = [np.full((1080, 1920, 3), 200, np.uint8)] * 3
    files = [str(RIG_DIR / f"CamExtrPara_Corners{i + 1}.csv") for i in range(3)]
    exp = _write_experiment(tmp_path, small, rig, "extrinsics:\n  format: ijcv25\n  files: [" + ", ".join(files) + "]\n")
    summary = calibrate_to_dir(exp, tmp_path / "out")
    assert "ijcv25" in summary and "view 3" in summary
    from tendrilkit.io import read_cameras, read_csv

    got = read_cameras(tmp_path / "out" / "cameras.json")
    for a, b in zip(got, rig):
        np.testing.assert_allclose(a.R, b.R)
        np.testing.assert_allclose(a.t_mm, b.t_mm)
    t = read_csv(tmp_path / "out" / "calibration_markers.csv", required=("view", "marker_id", "stage", "mean_px", "max_px"))
    assert (t.max_px < 0.5).all()
    import json

    entries = json.loads((tmp_path / "out" / "cameras.json").read_text())  # stored poses: not assessed, never flagged
    assert [(e["rig_spread_px"], e["rig_flagged"]) for e in entries] == [(None, False)] * 3


def test_calibrate_to_dir_from_frames(tmp_path, rendered):
    cams, images, _ = rendered
    exp = _write_experiment(tmp_path, images, cams)
    summary = calibrate_to_dir(exp, tmp_path / "out")
    assert summary.count("\n") >= 4 and "->" in summary
    from tendrilkit.io import read_cameras

    got = read_cameras(tmp_path / "out" / "cameras.json")
    mx, _ = rig_agreement_px(got, cams, working_volume())
    assert mx.max() < 0.5
    import json

    # the rig's assessment is kept with the rig: a spread per view, flagged exactly where the summary says FLAGGED
    entries = json.loads((tmp_path / "out" / "cameras.json").read_text())
    assert all(isinstance(e["rig_spread_px"], float) and e["rig_spread_px"] > 0 for e in entries)
    flagged = {int(line.split()[2].rstrip(":")) for line in summary.splitlines() if line.startswith("FLAGGED: view")}
    assert {e["view"] for e in entries if e["rig_flagged"]} == flagged
    assert {e["view"] for e in entries if 2 * e["rig_spread_px"] > 0.5} == flagged


# ------------------------------------------------------- bundle adjustment
def test_bundle_adjust_recovers_perturbed_rig():
    rng = np.random.default_rng(7)
    truth = distorted_rig()
    markers = synthetic_markers(rng)
    obs = observe_markers(truth, markers, rng, 0.05)
    start = []
    for c in truth:  # 1.5 degrees and 3 mm off
        dR = rotation_from_rvec(rng.normal(size=3) * np.radians(1.5) / np.sqrt(3))
        start.append(c.with_pose(dR @ c.R, c.t_mm + rng.normal(0, 3 / np.sqrt(3), 3)))
    P = working_volume()
    before, _ = rig_agreement_px(start, truth, P)
    cams, rep = bundle_adjust(start, obs, world_id=WORLD_ID, length_mm=L)  # its time: benchmarks/bench_calibration.py speed
    after, mean = rig_agreement_px(cams, truth, P)
    assert isinstance(rep, BundleReport)
    assert rep.on_plane == sorted(BOARD_MARKERS)  # not the stands, not the raised marker
    assert before.min() > 5 and after.max() < 0.5, (before, after)
    assert rep.rms_after_px < rep.rms_before_px and rep.rms_after_px < 0.1
    t = rep.table
    assert set(t.stage) == {"single", "adjusted"}
    for stage_mean in (t[t.stage == "adjusted"].mean_px.mean(), ):
        assert stage_mean < t[t.stage == "single"].mean_px.mean()
    for m, s in rep.marker_lengths_mm.items():
        true_side = np.linalg.norm(markers[m][1] - markers[m][0])
        assert abs(s - true_side) < 0.05


def test_bundle_adjust_single_marker_poses_improve_on_noisy_corners():
    """From the paper's single-marker poses (IPPE on noisy corners) to the adjusted rig."""
    rng = np.random.default_rng(3)
    truth = distorted_rig()
    markers = synthetic_markers(rng)
    # 0.05 px: several times the edge-line corners' error on the rendered frames;
    # over 10 seeds single-marker poses give 1.3 px (median), the adjustment 0.25 px
    obs = observe_markers(truth, markers, rng, 0.05)
    single = [c.with_pose(*marker_pose(obs[v][WORLD_ID], c, L)) for v, c in enumerate(truth)]
    P = working_volume()
    s_max, _ = rig_agreement_px(single, truth, P)
    cams, rep = bundle_adjust(single, obs, world_id=WORLD_ID, length_mm=L)
    a_max, _ = rig_agreement_px(cams, truth, P)
    assert a_max.max() < 0.5 and a_max.max() < s_max.max(), (s_max, a_max)


def test_bundle_adjust_drops_a_wrong_detection():
    rng = np.random.default_rng(5)
    truth = distorted_rig()
    markers = synthetic_markers(rng)
    obs = observe_markers(truth, markers, rng, 0.05)
    obs[1][42] = obs[1][42] + [25.0, -10.0]  # a grossly wrong detection in view 2
    with pytest.warns(UserWarning, match="view 2 marker 42"):
        cams, rep = bundle_adjust(truth, obs, world_id=WORLD_ID, length_mm=L)
    assert rep.dropped == [(2, 42)]
    after, _ = rig_agreement_px(cams, truth, working_volume())
    assert after.max() < 0.5


def test_bundle_adjust_failure_keeps_initial_cameras():
    """From poses 20 degrees off the adjustment can end in a wrong minimum: it says so."""
    rng = np.random.default_rng(2)
    truth = distorted_rig()
    obs = observe_markers(truth, synthetic_markers(rng), rng, 0.05)
    start = []
    for c in truth:
        ax = rng.normal(size=3)
        start.append(c.with_pose(rotation_from_rvec(ax / np.linalg.norm(ax) * np.radians(20)) @ c.R,
                                 c.t_mm + rng.normal(size=3) / np.sqrt(3) * 40))
    with pytest.warns(UserWarning, match="did not converge"):
        cams, rep = bundle_adjust(start, obs, world_id=WORLD_ID, length_mm=L)
    assert not rep.converged
    assert all(np.allclose(a.R, b.R) for a, b in zip(cams, start))


def test_rig_agreement_px_shapes():
    rig = ijcv25_rig()
    mx, mean = rig_agreement_px(rig, rig, working_volume(50))
    assert mx.shape == (3,) and np.all(mx == 0) and np.all(mean == 0)
    with pytest.raises(ValueError, match="cameras_b"):
        rig_agreement_px(rig, rig[:2], working_volume(5))


# ------------------------------------------------------------------ phantom
@pytest.mark.slow
def test_phantom_experiment_calibrates_within_3px(tmp_path):
    """A phantom experiment's rig against its true cameras on the true centreline.

    Required < 3 px in every view; the goal is 0.5 px (the figures reached on
    every site and several seeds are in benchmarks/bench_calibration.py).
    """
    phantom = pytest.importorskip("tendrilkit.phantom")
    from tendrilkit.io import read_cameras, read_csv
    from tendrilkit.params import load_experiment

    path = phantom.write_phantom_experiment("S3", tmp_path / "S3", n_frames=1, seed=0)
    exp = load_experiment(path)
    res = calibrate_experiment(exp)
    gt = Path(path).parent / "ground_truth"
    truth = read_cameras(gt / "true_cameras.json")
    pts = read_csv(gt / "gt_curves.csv", required=("x_mm", "y_mm", "z_mm"))[["x_mm", "y_mm", "z_mm"]].to_numpy()
    mx, mean = rig_agreement_px(res.cameras, truth, pts)
    single, _ = rig_agreement_px(res.single_cameras, truth, pts)
    assert mx.max() < 3.0, f"required: within 3 px; got {mx} (single-marker {single})"
    assert mx.max() < 0.5, f"goal: within 0.5 px; got {mx} (single-marker {single})"  # reached: ~0.04 px
    assert res.bundle is not None and len(res.bundle.on_plane) >= 3


@pytest.mark.parametrize("module", ['tendrilkit.calibration', 'tendrilkit.calibration.bundle', 'tendrilkit.calibration.experiment', 'tendrilkit.calibration.ijcv25', 'tendrilkit.calibration.markers', 'tendrilkit.calibration.poses', 'tendrilkit.calibration.rig', 'tendrilkit.calibration.synthetic', 'tendrilkit.extrinsics'])
def test_docstring_examples_run(module):
    """The Examples of the tendrilkit.calibration docstrings (what ``pytest --doctest-modules`` runs)."""
    import doctest
    import importlib

    res = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert res.failed == 0, f"{res.failed} of {res.attempted} docstring example(s) of {module} failed"


# ------------------------------------------------- the marker's inner edges, the rig's spread
def test_grid_edges_of_an_all_black_marker():
    """A marker with no white cell has only its four sides: 7 pieces each, normals outwards."""
    from tendrilkit.calibration.markers import _grid_edges

    a, b, n = _grid_edges(np.zeros((7, 7), bool))
    assert len(a) == 28
    mid = (a + b) / 2
    np.testing.assert_allclose(np.abs(mid).max(axis=1), 0.5)  # every piece on the border
    assert np.all(np.sum(mid * n, axis=1) > 0)  # black inside, white outside
    np.testing.assert_allclose(np.linalg.norm(b - a, axis=1), 1 / 7)


def test_grid_edges_of_one_white_cell():
    """One white inner cell adds its four sides, their normals pointing into it."""
    from tendrilkit.calibration.markers import _grid_edges

    white = np.zeros((7, 7), bool)
    white[3, 3] = True  # the centre cell: x, y in [-0.5/7, 0.5/7]
    a, b, n = _grid_edges(white)
    assert len(a) == 32
    inner = np.abs((a + b) / 2).max(axis=1) < 0.1
    assert inner.sum() == 4
    assert np.all(np.sum(((a + b) / 2)[inner] * n[inner], axis=1) < 0)


def test_detect_markers_grid_beats_edges(rendered):
    """Every black-white edge of the cells (``grid``, the default) locates the corners better than the four
    sides alone (``edges``) on the same frames."""
    cams, images, corners = rendered
    errs = {"grid": [], "edges": []}
    for cam, img in zip(cams, images):
        for method in errs:
            det = detect_markers(img, DICT, camera=cam, refine=method)
            errs[method] += [np.linalg.norm(c - cam.project(corners[m]), axis=1) for m, c in det.items()]
    rms = {m: float(np.sqrt(np.mean(np.concatenate(e) ** 2))) for m, e in errs.items()}
    assert rms["grid"] < rms["edges"], rms
    assert rms["grid"] < 0.05, rms


def test_rig_uncertainty_follows_the_markers():
    """The rig's spread on the working volume grows with the corner noise and is larger with the world
    marker alone; it predicts the error the rig makes (within 3 sigma) and flags a rig that cannot be pinned."""
    from tendrilkit.calibration import assess_rig, calibrate_from_observations, rig_uncertainty_px

    cams = distorted_rig()
    intr = [Camera(c.K, c.dist, width=c.width, height=c.height) for c in cams]
    P = working_volume()
    markers = synthetic_markers(np.random.default_rng(3))
    spread = {}
    for sigma in (0.03, 0.3):
        obs = observe_markers(cams, markers, np.random.default_rng(5), sigma)
        res = calibrate_from_observations(obs, intr, world_id=WORLD_ID, length_mm=L)
        u = rig_uncertainty_px(res, P)
        err, _ = rig_agreement_px(res.cameras, cams, P)
        assert np.all(err <= 3 * u), (sigma, err, u)
        spread[sigma] = u
        flagged = assess_rig(res, P) if sigma < 0.1 else None
        if flagged is not None:
            assert flagged.flags == () and np.allclose(flagged.uncertainty_px, u)
    assert np.all(spread[0.3] > 5 * spread[0.03])
    alone = {v: {WORLD_ID: o[WORLD_ID]} for v, o in observe_markers(cams, markers, np.random.default_rng(5), 0.3).items()}
    with pytest.warns(UserWarning):
        single = calibrate_from_observations(alone, intr, world_id=WORLD_ID, length_mm=L)
    u1 = rig_uncertainty_px(single, P, world_id=WORLD_ID, length_mm=L)
    assert np.all(u1 > spread[0.3])
    with pytest.warns(UserWarning, match="pin the rig"):
        flagged = assess_rig(single, P, world_id=WORLD_ID, length_mm=L)
    assert len(flagged.flags) == 3 and "FLAGGED" in flagged.summary()
    q = flagged.view_quality()  # what cameras.json keeps of it
    assert [e["rig_flagged"] for e in q] == [True] * 3
    np.testing.assert_allclose([e["rig_spread_px"] for e in q], u1, atol=1e-4)
    well = calibrate_from_observations(observe_markers(cams, markers, np.random.default_rng(5), 0.03), intr,
                                       world_id=WORLD_ID, length_mm=L)
    assert [e["rig_flagged"] for e in assess_rig(well, P).view_quality()] == [False] * 3  # the well-pinned rig


def test_marks_volume_is_the_rois_hull_around_the_base():
    """The volume's points are seen inside every view's ROI, in front of the board, around the base."""
    from tendrilkit.calibration import marks_volume

    cams = distorted_rig()
    base = np.array([90.0, -40.0, 20.0])
    P = working_volume()
    rois = []
    for c in cams:
        xy = c.project(P)
        x0, y0 = np.floor(xy.min(axis=0)).astype(int)
        x1, y1 = np.ceil(xy.max(axis=0)).astype(int)
        rois.append([int(x0), int(y0), int(x1 - x0), int(y1 - y0)])
    vol = marks_volume(cams, [c.project(base[None])[0] for c in cams], rois)
    assert len(vol) > 50 and np.all(vol[:, 2] >= 0)
    for c, (x, y, w, h) in zip(cams, rois):
        xy = c.project(vol)
        assert np.all((xy[:, 0] >= x) & (xy[:, 0] <= x + w) & (xy[:, 1] >= y) & (xy[:, 1] <= y + h))
    assert np.linalg.norm(vol.mean(axis=0) - base) < 60
    none = marks_volume(cams, [None] * 3, [None] * 3)  # no marks: a 100 mm cube about the world marker
    assert np.allclose(none.mean(axis=0)[:2], 0.0) and none[:, 2].max() == 100.0


# ------------------------------------------------------- corners averaged over several frames
def test_average_detections_beats_one_frame():
    """The rig is static: corners averaged over frames with independent noise are nearer the truth than one
    frame's (about 1 / sqrt(frames) of the noise part)."""
    from tendrilkit.calibration import average_detections

    tex, corners = board_scene()
    cam = distorted_rig()[0]
    rng = np.random.default_rng(21)
    dets = [detect_markers(render_board(cam, tex, rng=rng, noise=8.0, corners=corners), DICT, camera=cam)
            for _ in range(6)]

    def rms(det):
        return float(np.sqrt(np.mean([np.sum((c - cam.project(corners[m])) ** 2, axis=1) for m, c in det.items()])))

    avg = average_detections(dets)
    assert set(avg) == set().union(*map(set, dets))
    single = [rms(d) for d in dets]
    assert rms(avg) < 0.75 * np.mean(single), (rms(avg), single)


def test_average_detections_leaves_out_a_frame_that_disagrees():
    """A frame whose corners of a marker are 2 px off (something over it) does not move the mean; a marker
    one frame shows is kept; no frame at all is a clear error."""
    from tendrilkit.calibration import average_detections

    c = cam_corners = np.array([[10.0, 10.0], [60.0, 11.0], [61.0, 60.0], [9.0, 59.0]])
    rng = np.random.default_rng(2)
    frames = [{5: c + rng.normal(0, 0.05, c.shape)} for _ in range(5)] + [{5: c + 2.0, 9: cam_corners + 1.0}]
    out = average_detections(frames)
    assert sorted(out) == [5, 9]
    assert np.abs(out[5] - c).max() < 0.1
    np.testing.assert_allclose(out[9], cam_corners + 1.0)
    with pytest.raises(ValueError, match="detections"):
        average_detections([])


def test_calibrate_from_several_frames(rendered):
    """Frames per view (a list each) calibrate like one frame, and a view whose frames all miss the world
    marker names how many were searched."""
    cams, images, _ = rendered
    tex, corners = board_scene()
    rng = np.random.default_rng(8)
    more = [[img] + [render_board(c, tex, rng=rng, corners=corners) for _ in range(2)] for c, img in zip(cams, images)]
    res = calibrate(more, cams, dictionary=DICT, world_id=WORLD_ID, length_mm=L)
    mx, _ = rig_agreement_px(res.cameras, cams, working_volume())
    assert mx.max() < 0.5, mx
    blank = np.full_like(images[1], 220)
    with pytest.raises(ExperimentError) as e:
        calibrate([more[0], [blank, blank], more[2]], cams, dictionary=DICT, world_id=WORLD_ID, length_mm=L, frame=3)
    assert str(e.value) == "view 2: world marker 815 (DICT_ARUCO_ORIGINAL) not found in any of 2 frames from frame 3"


def test_calibration_options_in_the_experiment_file(tmp_path):
    """``calibration.corner_refine`` defaults to ``grid`` and ``average_frames`` to 5; a wrong value is one line."""
    import yaml

    from tendrilkit.params import load_experiment
    from tests.test_params import GOOD

    p = tmp_path / "experiment.yaml"
    p.write_text(yaml.safe_dump(GOOD))
    cal = load_experiment(p, check_files=False).calibration
    assert (cal.corner_refine, cal.average_frames) == ("grid", 5)
    p.write_text(yaml.safe_dump({**GOOD, "calibration": {"average_frames": 0}}))
    with pytest.raises(ExperimentError) as e:
        load_experiment(p, check_files=False)
    assert "\n" not in str(e.value) and "calibration.average_frames" in str(e.value)


# ------------------------------------------------- the corners' noise model and the spread's floor
def test_corner_sigma_grows_for_small_and_glancing_markers():
    """A marker's expected corner error falls as one over the square root of its side and grows with its
    foreshortening beyond what the board's markers show seen obliquely (aspect up to 1.35)."""
    from tendrilkit.calibration.markers import CORNER_SIGMA_ASPECT_FREE, CORNER_SIGMA_ASPECT_POWER, CORNER_SIGMA_PX, corner_sigma_px

    sq = np.array([[0.0, 0.0], [100.0, 0.0], [100.0, 100.0], [0.0, 100.0]])
    assert corner_sigma_px(sq + 500.0) == pytest.approx(CORNER_SIGMA_PX)
    assert corner_sigma_px(sq * 0.25) == pytest.approx(2 * CORNER_SIGMA_PX)
    oblique = sq * [1.0, 1 / 1.3]  # aspect 1.3, mean side 88.5 px: only the size counts
    assert corner_sigma_px(oblique) == pytest.approx(CORNER_SIGMA_PX * np.sqrt(100 / 88.46), rel=1e-3)
    card = sq * [1.0, 1 / 2.7]  # aspect 2.7 (a card seen at a glancing angle)
    side = (100 + 100 / 2.7) / 2
    want = CORNER_SIGMA_PX * np.sqrt(100 / side) * (2.7 / CORNER_SIGMA_ASPECT_FREE) ** CORNER_SIGMA_ASPECT_POWER
    assert corner_sigma_px(card) == pytest.approx(want, rel=1e-9) and want > 5 * CORNER_SIGMA_PX
    rot = np.array([[np.cos(0.7), -np.sin(0.7)], [np.sin(0.7), np.cos(0.7)]])
    assert corner_sigma_px(card @ rot.T) == pytest.approx(corner_sigma_px(card))  # in-plane rotation: same


def test_rig_spread_is_floored_at_the_detector_noise():
    """Corners that agree better than any detector can (exact projections) do not make the rig's spread
    vanish: the adjustment's noise, and the world marker alone's, are at least the detector's measured
    noise, so the spread stays about what corners at that noise give (the adjustment's was ~0 before the
    floor; the world marker alone's was a fixed 0.02 px)."""
    from tendrilkit.calibration import calibrate_from_observations, rig_uncertainty_px
    from tendrilkit.calibration.markers import corner_sigma_px
    from tendrilkit.calibration.rig import _single_covariance

    cams = distorted_rig()
    intr = [Camera(c.K, c.dist, width=c.width, height=c.height) for c in cams]
    P = working_volume()
    markers = synthetic_markers(np.random.default_rng(3))
    exact = observe_markers(cams, markers, np.random.default_rng(5), 0.0)
    model = corner_sigma_px(exact[0][WORLD_ID])
    noisy = observe_markers(cams, markers, np.random.default_rng(5), model)
    res0 = calibrate_from_observations(exact, intr, world_id=WORLD_ID, length_mm=L)
    res1 = calibrate_from_observations(noisy, intr, world_id=WORLD_ID, length_mm=L)
    floor = min(corner_sigma_px(c) for o in exact.values() for c in o.values())
    assert res0.bundle.sigma_px >= floor
    u0, u1 = rig_uncertainty_px(res0, P), rig_uncertainty_px(res1, P)
    assert np.all(u0 > 0.5 * u1) and np.all(u0 < 2 * u1), (u0, u1)
    err, _ = rig_agreement_px(res1.cameras, cams, P)
    assert np.all(err <= 3 * u1), (err, u1)
    alone = {v: {WORLD_ID: o[WORLD_ID]} for v, o in exact.items()}
    with pytest.warns(UserWarning):
        single = calibrate_from_observations(alone, intr, world_id=WORLD_ID, length_mm=L)
    sigma, cov = _single_covariance(single, WORLD_ID, L)
    assert sigma == pytest.approx(np.sqrt(np.mean([corner_sigma_px(o[WORLD_ID]) ** 2 for o in exact.values()])))
    assert np.all(np.isfinite(cov)) and np.all(rig_uncertainty_px(single, P, world_id=WORLD_ID, length_mm=L) > 0.1)


def test_rig_flag_bounds_a_view_by_two_sigmas_plus_a_floor():
    """A view is flagged when 2 x its spread + 0.05 px exceeds 0.5 px (bench_calibration.py scenes, dev seeds
    3000-3039 and 4000-4039: the true error never exceeded that bound; 2 x spread alone, by up to 0.03 px
    where the spread is under 0.15 px). Site phantom S2's largest spread (0.188 px, true 0.21 px) is not
    flagged; 0.23 px is; an unconstrained view is; a view not assessed is not."""
    from tendrilkit.calibration import RIG_FLOOR_PX, RIG_LIMIT_PX, RIG_LIMIT_SIGMAS
    from tendrilkit.calibration.rig import _pins_too_loosely, _rig_bound_px

    assert (RIG_LIMIT_PX, RIG_LIMIT_SIGMAS, RIG_FLOOR_PX) == (0.5, 2.0, 0.05)
    assert _rig_bound_px(0.03) == pytest.approx(0.11)
    assert not _pins_too_loosely(0.1883) and not _pins_too_loosely(0.22)
    assert _pins_too_loosely(0.23) and _pins_too_loosely(np.inf) and not _pins_too_loosely(np.nan)


def test_detect_markers_leaves_out_a_marker_symmetric_under_a_turn():
    """Marker 1023 of DICT_ARUCO_ORIGINAL looks the same turned by half a turn: its corners' order is unknown,
    so detection leaves it out with a warning and keeps the other marker of the image."""
    dic = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_ARUCO_ORIGINAL)
    img = np.full((400, 700), 255, np.uint8)
    img[100:300, 100:300] = cv2.aruco.generateImageMarker(dic, 1023, 200)
    img[100:300, 400:600] = cv2.aruco.generateImageMarker(dic, 7, 200)
    with pytest.warns(UserWarning, match=r"\[1023\].*left out"):
        found = detect_markers(img, "DICT_ARUCO_ORIGINAL", refine="subpix")
    assert sorted(found) == [7]
