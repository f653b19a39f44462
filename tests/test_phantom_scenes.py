"""Random phantom scenes (tendrilkit.phantom.scenes): factors, ground truth, determinism, today's accuracy."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from tendrilkit.cli import main
from tendrilkit.phantom import PhantomError, read_ground_truth
from tendrilkit.phantom import scenes as S
from tendrilkit.phantom.scenes import BOOLEAN_FACTORS, GROUPS, SHAPES, active_factors, draw_factors
from tendrilkit.phantom.scenes.clutter import tube_clearance_mm
from tendrilkit.scoring import score_frames, summarise_scores


def _digest(folder: Path) -> dict[str, str]:
    return {str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(folder.rglob("*")) if p.is_file()}


# ------------------------------------------------------------------ fast
def test_presets_switch_one_factor_alone():
    for name in BOOLEAN_FACTORS:
        f = draw_factors(3, name)
        assert f[name] and sum(f[k] for k in BOOLEAN_FACTORS) == 1, name
        assert f["sampling"] == "timelapse" and f["look"] == "default"
    for shape in SHAPES:
        assert draw_factors(3, shape)["shape"] == shape
    assert active_factors(draw_factors(3, "clean")) == [f"shape={draw_factors(3, 'clean')['shape']}"]
    # random: drawn per seed, the same for the same seed
    assert draw_factors(7) == draw_factors(7)
    assert len({tuple(active_factors(draw_factors(s))) for s in range(20)}) > 10
    with pytest.raises(ValueError, match="scene: expected one of"):
        draw_factors(0, "bogus")


def test_cli_rejects_a_bad_scene(tmp_path, capsys):
    assert main(["phantom", "--scene", "bogus", "--out", str(tmp_path)]) == 2
    assert "scene: expected one of" in capsys.readouterr().err
    assert main(["phantom", "--out", str(tmp_path)]) == 2
    assert main(["phantom", "--site", "S1", "--scene", "random", "--out", str(tmp_path)]) == 2


def test_score_frames_flags():
    truth = pd.DataFrame({"frame": np.repeat([0, 1, 2], 50), "point": np.tile(np.arange(50), 3),
                          "x_mm": np.tile(np.linspace(0, 49, 50), 3), "y_mm": 0.0, "z_mm": 10.0})
    good = truth[truth.frame == 0].copy()
    wrong = truth[truth.frame == 1].copy()
    wrong["y_mm"] = 3.0  # 3 mm off everywhere, reported ok: a silent failure
    frames = pd.DataFrame({"frame": [0, 1, 2], "status": ["ok", "ok", "failed"], "message": ["", "", "lost"]})
    t = score_frames(pd.concat([good, wrong]), frames, truth, factors=["shape=coil", "jpeg"], scene="x")
    assert t.within.tolist() == [True, False, False]
    assert t.silent.tolist() == [False, True, False]
    assert np.isnan(t.mean_mm[2]) and t.status[2] == "failed"
    s = summarise_scores(t).set_index("factor")
    assert s.loc["all", "frames"] == 3 and s.loc["jpeg", "silent"] == 1
    assert s.loc["all", "failed_pct"] == pytest.approx(100 / 3)


# ------------------------------------------------------------------ slow
CHECKED = {  # preset -> key of ``realised`` that proves the factor is in the scene
    "over_leaf": "over_leaf", "over_stem": "over_stem", "alongside": "alongside", "tip_leaf": "tip_leaf",
    "second_tendril": "second_tendril", "occluding_leaf": "occluding_leaf", "careless_marks": "careless_marks",
    "sway": "sway", "leave_view": "leave_view", "distortion": "distortion", "markers": "markers",
}


#: presets checked one by one (the imaging factors together, in the ``imaging`` group)
ALONE = ("slight", "hook", "loop", "coil", "coil_endon", "multi_crossing", "sparse", "fps30", "pale",
         "careless_marks", "markers", "contact", "clutter", "imaging", "time")


@pytest.mark.slow
def test_every_factor_is_present_when_asked():
    for name in ALONE:
        ph = S.make_scene(11, scene=name, n_frames=3)
        names = active_factors(ph.factors)
        r = ph.realised
        for f in GROUPS.get(name, (name,)):
            if f in BOOLEAN_FACTORS:
                assert f in names, (name, f)
            if f in CHECKED:
                assert CHECKED[f] in r, (name, f)
        if name in SHAPES:
            assert names[0] == f"shape={name}"
        if name == "contact":
            assert 8.0 <= r["alongside"]["median_distance_px"] <= 35.0
            assert len(r["tip_leaf"]["touching_frames"]) >= 2
            for obj in ph.board_tubes:
                assert tube_clearance_mm(ph.curves_mm, ph.radius_mm, obj["pts"], obj["radius"]) >= 0.5
        if name == "clutter":
            v = r["occluding_leaf"]["view"] - 1
            assert ph.hidden_fraction[:, v].max() >= 0.03
            gap = tube_clearance_mm(ph.curves_mm, ph.radius_mm, ph.tubes[0]["pts"], ph.tubes[0]["radius"])
            assert gap >= 1.0
        if name == "time":
            v = r["leave_view"]["view"] - 1
            assert ph.hidden_fraction[:, v].max() >= 0.03
            assert 2.0 <= r["sway"]["tip_amplitude_mm"] <= 5.0
        if name == "coil_endon":
            assert r["shape"]["axis_to_camera_deg"] <= 12.0 and 4.0 <= r["shape"]["coil_radius_mm"] <= 10.0
        if name == "multi_crossing":
            assert sum(c >= 2 for c in r["shape"]["crossings_per_view"]) >= 2
        if name == "imaging":
            assert all(0.06 <= abs(c.dist[0]) <= 0.1 for c in ph.cameras)
            assert max(r["distortion"]["outer_third_fraction"]) >= 0.1
            g = np.asarray(ph.imaging["gain"])
            assert np.all(np.abs(g - 1) <= 0.15) and g.std() > 0
            im = ph.imaging
            assert im["vignetting"] >= 0.3 and im["noise_sigma"] >= 4 and im["shadow"] is not None
            assert len(im["motion_blur_px"]) == len(im["jpeg_quality"]) == 3
        if name == "pale":
            assert 0.8 <= ph.radius_mm[-1] * 2 < ph.radius_mm[0] * 2 <= 2.0
        if name == "sparse":
            assert np.diff(ph.design_time_s).min() > 60.0
        if name == "fps30":
            assert ph.fps == 30.0


@pytest.mark.slow
def test_random_scene_ground_truth_is_consistent_and_deterministic(tmp_path):
    from tendrilkit.phantom import write_scene_experiment

    a = write_scene_experiment(tmp_path / "a", seed=1, n_frames=1)
    b = write_scene_experiment(tmp_path / "b", seed=1, n_frames=1)
    assert _digest(a.parent) == _digest(b.parent)
    gt = read_ground_truth(a.parent)
    meta = gt.meta
    assert meta["scene"] == "random" and meta["active_factors"] == active_factors(meta["factors"])
    ph = S.make_scene(1, n_frames=1)
    assert not (ph.curves_mm.flags.writeable or ph.radius_mm.flags.writeable)  # shared safely, never cached
    for f in range(gt.curves.shape[0]):
        inside = [bool(np.all(cam.in_image(gt.projections[f, v]))) for v, cam in enumerate(gt.cameras)]
        assert sum(inside) >= 2
        assert len(meta["seen_whole_views"][f]) >= 2
        for v, cam in enumerate(gt.cameras):
            np.testing.assert_allclose(cam.project(gt.curves[f]), gt.projections[f, v], atol=1e-3)
        # no 3D self-contact: samples far apart along the tendril stay a tube width apart
        X, s = gt.curves[f], gt.s_mm
        d = np.linalg.norm(X[::4, None] - X[None, ::4], axis=-1)
        far = np.abs(s[::4, None] - s[None, ::4]) > 4.0
        assert d[far].min() > 2 * ph.radius_mm.max()
    for obj in ph.tubes + ph.board_tubes:
        assert tube_clearance_mm(ph.curves_mm, ph.radius_mm, obj["pts"], obj["radius"]) > 0.0
    assert (gt.curves[..., 2] - ph.radius_mm[None]).min() > 0.0


@pytest.mark.slow
def test_todays_method_on_easy_scenes(tmp_path):
    """What the method reaches on a clean scene (measured, asserted as reached; not a target)."""
    from tendrilkit.runner import run_reconstruct
    from tendrilkit.phantom import write_scene_experiment
    from tendrilkit.scoring import score_result

    exp = write_scene_experiment(tmp_path / "scene", seed=EASY_SEED, scene="clean", n_frames=2)
    run_reconstruct(exp, tmp_path / "out", workers=1, progress=False, fit=False)
    t = score_result(tmp_path / "out", tmp_path / "scene")
    assert (t.status == "ok").all()
    # measured 2026-11-29: mean 0.11 / 0.10 mm, max 1.11 / 0.58 mm, base 0.20 mm, tip 0.28 / 0.10 mm
    assert t.mean_mm.max() < 0.2 and t.max_mm.max() < 1.5
    assert t.base_mm.max() < 0.5 and t.tip_mm.max() < 0.5


EASY_SEED = 2  # a clean scene (an S3-family loop), 2 frames


def test_unknown_scene_is_a_phantom_error():
    with pytest.raises(PhantomError, match="scene: expected one of"):
        S.make_scene(0, scene="nope")


# ------------------------------------------- issue 11, second round: new factors
def _segment_distance_px(p: np.ndarray, poly: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Distance (m,) of pixels ``p`` (m, 2) to a polyline ``poly`` (k, 2), and the segment index of the nearest point."""
    a, b = poly[:-1], poly[1:]
    ab = b - a
    t = np.clip(np.einsum("mkd,kd->mk", p[:, None] - a[None], ab) / np.maximum((ab * ab).sum(1), 1e-12), 0, 1)
    d = np.linalg.norm(p[:, None] - (a[None] + t[..., None] * ab[None]), axis=-1)
    return d.min(axis=1), d.argmin(axis=1)


@pytest.mark.slow
def test_behind_stem_hides_the_tendril_where_the_truth_says():
    ph = S.make_scene(4, scene="behind_stem", n_frames=3)
    r = ph.realised["behind_stem"]
    v = r["view"] - 1
    tube = ph.tubes[0]
    assert r["in_front"] and v in tube["front_views"]
    # never touching in 3D
    assert tube_clearance_mm(ph.curves_mm, ph.radius_mm, tube["pts"], tube["radius"]) >= 1.0
    # the hidden arc-length ranges agree with an independent test (distance to the projected polyline)
    cam = ph.cameras[v]
    n_hidden = 0
    for f in range(ph.n_frames):
        X = ph.curves_mm[f]
        d, k = _segment_distance_px(cam.project(X), cam.project(tube["pts"]))
        depth_t = cam.world_to_cam(tube["pts"])[:, 2]
        r_px = tube["radius"] / depth_t * cam.K[0, 0]
        hidden = (d < r_px[k] - 0.5) & (depth_t[k] < cam.world_to_cam(X)[:, 2])
        ranges = r["hidden_s_mm"][f][v]
        flagged = np.zeros(len(X), bool)
        for s0, s1 in ranges:
            flagged |= (ph.s_mm >= s0 - 1e-6) & (ph.s_mm <= s1 + 1e-6)
        assert not np.any(hidden & ~flagged), f  # every sample surely behind the shoot is flagged hidden
        clear = (d > r_px[k] + 0.5)
        assert not np.any(flagged & clear), f  # and none flagged that is clear of it
        n_hidden += int(flagged.sum())
    assert n_hidden > 0
    assert ph.hidden_fraction[:, v].max() > 0.0
    assert all(len(w) >= 2 for w in [[u for u in range(3) if ph.hidden_fraction[f, u] <= 0.1]
                                      for f in range(ph.n_frames)])


@pytest.mark.slow
def test_petiole_crosses_the_projection_but_never_touches_in_3d():
    from tendrilkit.phantom.scenes.clutter import _crossing_2d, depth_order_mixed

    ph = S.make_scene(1, scene="petiole", n_frames=3)
    r = ph.realised["petiole"]
    v, f = r["view"] - 1, r["frame"]
    tube = ph.tubes[0]
    blade = ph.plates[0]["poly"]
    fill = np.vstack([blade, 0.5 * (blade + blade.mean(axis=0)), blade.mean(axis=0)[None]])
    assert tube_clearance_mm(ph.curves_mm, ph.radius_mm, tube["pts"], tube["radius"]) >= 1.0
    assert tube_clearance_mm(ph.curves_mm, ph.radius_mm, fill, np.zeros(len(fill))) >= 1.0
    gap, angle = _crossing_2d(ph.cameras[v], ph.curves_mm[f], ph.radius_mm, tube["pts"], tube["radius"])
    assert gap < 0 and angle >= 35.0  # the projections overlap, at a real angle
    assert (v in tube["front_views"]) == r["in_front"]
    assert not depth_order_mixed(ph.cameras, ph.curves_mm, ph.radius_mm, tube["pts"], tube["radius"])
    # it starts on the stem
    assert np.min(np.linalg.norm(ph.scene.stem_mm - tube["pts"][0], axis=1)) < 1e-6


@pytest.mark.slow
def test_glancing_marker_is_tilted_rendered_where_it_is_and_detected():
    from tendrilkit.calibration import detect_markers
    from tendrilkit.phantom.scenes.markers import card_corners_mm

    ph = S.make_scene(1, scene="glancing_marker", n_frames=1)
    card = ph.cards[0]
    r = ph.realised["glancing_marker"]
    assert max(r["incidence_deg"]) >= 60.0 and 58.0 <= r["tilt_deg"] <= 78.0
    corners = card_corners_mm(card)
    assert corners[:, 2].max() > 10.0  # off the board plane
    found = 0
    for v, cam in enumerate(ph.cameras):
        det = detect_markers(S.render_scene_view(ph, 0, v), "DICT_ARUCO_ORIGINAL", camera=cam)
        if card["id"] in det:
            found += 1
            np.testing.assert_allclose(det[card["id"]], cam.project(corners), atol=1.0)
    assert found >= 1


@pytest.mark.slow
def test_markers_as_taped_two_to_five_small_and_partly_outside():
    from tendrilkit.phantom.scene import _quiet_scale

    for seed in (0, 3):
        ph = S.make_scene(seed, scene="markers", n_frames=1)
        r = ph.realised["markers"]
        assert 2 <= len(ph.scene.markers) <= 5 and r["n_markers"] == len(ph.scene.markers)
        assert r["small"] and 16.0 <= ph.scene.markers[0].length_mm <= 24.0
        out = r["partly_outside"]
        mk = next(m for m in ph.scene.markers if m.id == out["id"])
        cam = ph.cameras[out["view"] - 1]
        inside = cam.in_image(cam.project(mk.corners_mm(_quiet_scale())))
        assert inside.any() and not inside.all()


@pytest.mark.slow
def test_a_seed_whose_first_round_fails_still_makes_its_scene():
    """Seed 157 (random) needs a second round (its tip-leaf never rests in round 0): made, all factors kept."""
    ph = S.make_scene(157, n_frames=6)
    assert ph.realised["generation"]["round"] >= 1
    assert ph.factors == draw_factors(157)
    assert len(ph.realised["tip_leaf"]["touching_frames"]) >= 2


@pytest.mark.slow
def test_new_factor_scenes_are_deterministic():
    import json

    from tendrilkit.phantom.scenes.experiment import scene_meta

    for name in ("behind_stem", "petiole", "glancing_marker"):
        a, b = S.make_scene(2, scene=name, n_frames=1), S.make_scene(2, scene=name, n_frames=1)
        assert json.dumps(scene_meta(a), sort_keys=True) == json.dumps(scene_meta(b), sort_keys=True)
        for v in range(3):
            assert S.render_scene_view(a, 0, v).tobytes() == S.render_scene_view(b, 0, v).tobytes()


def test_tip_leaf_on_the_outer_side_of_a_coil():
    """At the end of a coil the turn before the tip lies ahead of it along its tangent: no leaf there
    touches the tip (the first rounds give up); the later rounds find one on the coil's outer side,
    touching the tip in the resting frames without piercing the tendril (dev seed 90's design)."""
    from tendrilkit.phantom.scenes.clutter import _pierces, _place_tip_leaf, _plate3d, _Retry

    th = np.linspace(0, 5 * np.pi, 400)  # 2.5 turns, radius 6 mm, pitch 4 mm, axis along x, 30 mm above the board
    c = np.column_stack([4.0 * th / (2 * np.pi), 6.0 * np.cos(th), 30 + 6.0 * np.sin(th)])
    s = np.r_[0, np.cumsum(np.linalg.norm(np.diff(c, axis=0), axis=1))]
    ctx = {"curves": np.stack([c, c, c]), "radius": np.full(len(s), 0.6), "s": s}
    with pytest.raises(_Retry, match="tip_leaf"):
        _place_tip_leaf(dict(ctx, rest_frames=None), np.random.default_rng(0))
    out = _place_tip_leaf(dict(ctx, rest_frames=np.array([1, 2])), np.random.default_rng(0))
    assert {1, 2} <= set(out["touching_frames"])
    nrm = np.asarray(out["normal"])
    outward = c[-1] - c[s >= 0.75 * s[-1]].mean(axis=0)
    assert np.dot(nrm, outward) > 0
    poly = np.asarray(out["plate"])
    centre = poly.mean(axis=0)
    _, e1, e2 = _plate3d(centre, nrm, 1.0, 1.0, 0.0)
    a = np.linalg.norm(poly - centre, axis=1).max()
    b = np.linalg.norm(poly - centre, axis=1).min()
    assert not _pierces(ctx["curves"], ctx["radius"], centre, nrm, e1, e2, a, b)


def test_world_marker_cover_names_what_lies_over_it():
    """Dev seed 6013's case (the stem and its tape across the world marker in every view) and 8003's (an
    object in space over it in one view) are named; a leaf lying on the board under the marker's paper is not."""
    import dataclasses

    from tendrilkit.phantom.scenes.markers import world_marker_cover

    ph = S.make_scene(0, scene="clean", n_frames=1)
    sc, cams, curves, radius = ph.scene, ph.cameras, ph.curves_mm, ph.radius_mm
    assert world_marker_cover(sc, cams, curves, radius) is None
    far = sc.stem_mm[len(sc.stem_mm) // 3]
    across = dataclasses.replace(sc, stem_mm=sc.stem_mm - [far[0], far[1], 0.0],
                                 tapes=[(np.zeros(2), 90.0, 25.0, 10.0)])
    assert world_marker_cover(across, cams, curves, radius) == "the stem in views 1, 2, 3; a tape strip in views 1, 2, 3"
    # a stick in space on the line of sight from view 1 to the marker, 120 mm above the board
    c = cams[0].center_world
    mid = c * 120.0 / c[2]
    u = np.cross(c, [0.0, 0.0, 1.0])
    pts = mid + np.linspace(-15, 15, 61)[:, None] * (u / np.linalg.norm(u))
    stick = {"pts": pts, "radius": np.full(len(pts), 0.7)}
    assert world_marker_cover(sc, cams, curves, radius, tubes=[stick]) == "an object in space in view 1"
    leaf = {"centre": np.zeros(2), "angle_deg": 30.0, "a_mm": 30.0, "b_mm": 16.0, "petiole": np.array([[40.0, 0], [5, 0]])}
    assert world_marker_cover(dataclasses.replace(sc, leaves=[leaf]), cams, curves, radius) is None


@pytest.mark.slow
def test_world_marker_is_found_in_every_view_of_scenes_that_had_it_covered():
    """Dev seeds 6013 (stem and tape over the world marker in every view) and 8003 (a second tendril over it
    in view 1) were made with the marker covered and could not be calibrated; now they are redrawn."""
    from tendrilkit.calibration import detect_markers
    from tendrilkit.phantom.design import WORLD_MARKER_ID
    from tendrilkit.phantom.scenes.markers import world_marker_cover

    for seed in (6013, 8003):
        ph = S.make_scene(seed, n_frames=6)
        assert ph.factors == draw_factors(seed)
        assert world_marker_cover(ph.scene, ph.cameras, ph.curves_mm, ph.radius_mm, board_tubes=ph.board_tubes,
                                  tubes=ph.tubes, plates=ph.plates, cards=ph.cards) is None
        for v, cam in enumerate(ph.cameras):
            assert WORLD_MARKER_ID in detect_markers(S.render_scene_view(ph, 0, v), "DICT_ARUCO_ORIGINAL", camera=cam)


def test_the_world_marker_may_be_covered_by_the_tendril_after_the_frames_that_calibrate():
    """Only the first CALIBRATION_FRAMES frames (calibration.average_frames' default) calibrate: the tendril
    over the world marker in a later frame is a harder world, in one of those frames a broken one."""
    from tendrilkit.params import Calibration
    from tendrilkit.phantom.scenes.markers import CALIBRATION_FRAMES, world_marker_cover

    assert Calibration().average_frames == CALIBRATION_FRAMES
    ph = S.make_scene(0, scene="clean", n_frames=1)
    sc, cams, radius = ph.scene, ph.cameras, ph.radius_mm
    n = ph.curves_mm.shape[1]
    over = np.stack([np.linspace(-15, 15, n), np.linspace(-15, 15, n), np.full(n, 3.0)], axis=1)
    for f, expected in ((CALIBRATION_FRAMES, None), (CALIBRATION_FRAMES - 1, "the tendril in views 1, 2, 3")):
        curves = np.repeat(ph.curves_mm[:1], CALIBRATION_FRAMES + 2, axis=0)
        curves[f] = over
        assert world_marker_cover(sc, cams, curves, radius) == expected, f
        assert world_marker_cover(sc, cams, curves, radius, calibration_frames=len(curves)) is not None


def test_presets_combine_with_plus():
    """``a+b+c`` switches the factors of every part on a clean scene; the rest is drawn as a preset draws it."""
    from tendrilkit.phantom.scenes import scene_parts

    f = draw_factors(3, "coil+over_stem+tip_leaf")
    assert f == {**draw_factors(3, "clean"), "shape": "coil", "over_stem": True, "tip_leaf": True}
    assert active_factors(f) == ["shape=coil", "over_stem", "tip_leaf"]
    g = draw_factors(5, "time+pale+jpeg")
    assert g == {**draw_factors(5, "clean"), "look": "pale", "sway": True, "leave_view": True, "jpeg": True}
    assert draw_factors(5, "sway") == draw_factors(5, "sway+sway")
    assert scene_parts("random") == ("random",) and scene_parts("coil+sparse") == ("coil", "sparse")
    for bad, match in (("coil+loop", "one shape, got coil and loop"), ("sparse+fps30", "one sampling"),
                       ("pale+brown", "one look"), ("random+coil", "cannot be combined"),
                       ("clean+coil", "cannot be combined"), ("coil+bogus", "scene: expected one of"),
                       ("+".join(BOOLEAN_FACTORS), "at most 80 characters")):
        with pytest.raises(ValueError, match=match):
            draw_factors(0, bad)


def test_cli_rejects_a_combination_that_cannot_hold(tmp_path, capsys):
    assert main(["phantom", "--scene", "coil+hook", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "one shape, got coil and hook" in err and "Traceback" not in err


@pytest.mark.slow
def test_a_combined_scene_has_every_factor(tmp_path, capsys):
    """``phantom --scene coil+over_stem+tip_leaf`` writes a scene with the three factors realised."""
    import json

    assert main(["phantom", "--scene", "coil+over_stem+tip_leaf", "--seed", "5", "--frames", "3",
                 "--out", str(tmp_path / "s")]) == 0
    meta = json.loads((tmp_path / "s" / "ground_truth" / "gt_meta.json").read_text())
    assert meta["scene"] == "coil+over_stem+tip_leaf" and meta["scene_version"] == S.SCENE_VERSION
    assert meta["active_factors"] == ["shape=coil", "over_stem", "tip_leaf"]
    r = meta["realised"]
    assert 4.0 <= r["shape"]["coil_radius_mm"] <= 10.0
    assert "over_stem" in r and len(r["tip_leaf"]["touching_frames"]) >= 2
    assert meta["name"] == "scene-coil+over_stem+tip_leaf-seed5"
    from tendrilkit.params import load_experiment

    assert load_experiment(tmp_path / "s" / "experiment.yaml").name == meta["name"]


@pytest.mark.slow
def test_every_marker_is_drawn_where_the_ground_truth_records_it():
    """Dev seed 64 had marker 1023, the one id of DICT_ARUCO_ORIGINAL that looks the same turned by half a
    turn: the detector gave its corners in the other order, 177-213 px from the recorded ones. No scene
    places such an id now; in every view of several dev scenes (64; 38, a glancing card; 65, small markers;
    7, 21) every marker found lies within 1 px of its recorded corners, and the world marker is found."""
    from tendrilkit.calibration import detect_markers
    from tendrilkit.phantom.design import DICTIONARY, WORLD_MARKER_ID
    from tendrilkit.calibration.markers import ambiguous_marker_ids
    from tendrilkit.phantom.scenes.markers import card_corners_mm

    assert ambiguous_marker_ids(DICTIONARY) == frozenset({1023})
    for seed in (64, 38, 65, 7, 21):
        ph = S.make_scene(seed, n_frames=1)
        recorded = {m.id: m.corners_mm() for m in ph.scene.markers} | {c["id"]: card_corners_mm(c) for c in ph.cards}
        assert not set(recorded) & ambiguous_marker_ids(DICTIONARY), seed
        assert len(recorded) == len(ph.scene.markers) + len(ph.cards), seed  # no id twice
        for v, cam in enumerate(ph.cameras):
            found = detect_markers(S.render_scene_view(ph, 0, v), "DICT_ARUCO_ORIGINAL", camera=cam)
            assert WORLD_MARKER_ID in found, (seed, v)
            for mid, corners_xy in found.items():
                assert mid in recorded, (seed, v, mid)
                err = np.linalg.norm(corners_xy - cam.project(recorded[mid]), axis=1).max()
                assert err < 1.0, (seed, v, mid, err)


def test_a_curve_cutting_across_a_loop_is_not_within_the_truth():
    """Every point of a curve that skips a loop lies on the truth and its ends are right: the truth's own distance
    to the curve (``miss_mm``) tells (the issue's figures count a frame right only when no true point is off)."""
    s = np.linspace(0.0, 1.0, 400)
    line = np.c_[60.0 * s, np.zeros_like(s), np.zeros_like(s)]
    # the truth: a straight tendril with a loop of 6 mm diameter at 30 mm
    u = np.linspace(0.0, 2 * np.pi, 200)
    loop = np.c_[30.0 + 3.0 * np.sin(u), 3.0 - 3.0 * np.cos(u), 0.2 * u]
    truth_xyz = np.vstack([line[line[:, 0] < 30.0], loop, line[line[:, 0] > 30.0] + [0.0, 0.0, 0.2 * 2 * np.pi]])
    cut = np.vstack([truth_xyz[:len(line[line[:, 0] < 30.0])], truth_xyz[-len(line[line[:, 0] > 30.0]):]])

    def table(X):
        return pd.DataFrame({"frame": 0, "point": np.arange(len(X)), "x_mm": X[:, 0], "y_mm": X[:, 1],
                             "z_mm": X[:, 2]})

    frames = pd.DataFrame({"frame": [0], "status": ["ok"], "message": [""]})
    whole = score_frames(table(truth_xyz), frames, table(truth_xyz))
    assert bool(whole.within.iloc[0]) and whole.miss_mm.iloc[0] < 0.05
    t = score_frames(table(cut), frames, table(truth_xyz))
    assert t.mean_mm.iloc[0] < 0.5 and t.max_mm.iloc[0] < 2.0 and t.base_mm.iloc[0] < 2.0 and t.tip_mm.iloc[0] < 2.0
    assert t.miss_mm.iloc[0] > 5.0 and not bool(t.within.iloc[0])
