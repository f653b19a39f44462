"""Issue 14, fast cases: no silent wrong result, nothing written where it does not belong, no input that hangs.

Every case of the issue that needs no video is here (the experiment file's
YAML, numbers, names, per-frame files, writes, the ``fit`` input); the cases
on real videos are in ``test_reliability_videos.py``, the resume cases in
``test_resume.py``.
"""

from __future__ import annotations

import copy
import errno
import json
import math
import os
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tendrilkit import cli
from tendrilkit import limits as L
from tendrilkit.camera import Camera
from tendrilkit.exceptions import ExperimentError, OutputWriteError
from tendrilkit.inputs import check_against_images
from tendrilkit.params import (folder_name_problem, load_experiment, parse_experiment,
                               short_repr)
from tests.test_params import GOOD


def _write(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "experiment.yaml"
    p.write_text(text)
    return p


def _one_line(capsys_err: str) -> str:
    lines = capsys_err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in capsys_err, capsys_err
    return lines[0]


# ------------------------------------------------------------------ the YAML file
def test_key_given_twice_is_an_error_naming_the_key(tmp_path):
    text = yaml.safe_dump(GOOD, sort_keys=False) + "fps: 15\n"
    with pytest.raises(ExperimentError, match=r"key 'fps' is given twice \(first on line \d+\)"):
        load_experiment(_write(tmp_path, text), check_files=False)
    nested = yaml.safe_dump({k: v for k, v in GOOD.items() if k != "marker"}, sort_keys=False)
    nested += "marker: {dictionary: DICT_ARUCO_ORIGINAL, id: 815, length_mm: 24.0, length_mm: 12.0}\n"
    with pytest.raises(ExperimentError, match=r"key 'length_mm' is given twice"):
        load_experiment(_write(tmp_path, nested), check_files=False)


def test_anchors_and_merge_keys_still_work(tmp_path):
    text = yaml.safe_dump(GOOD, sort_keys=False) + "segmentation: &s {channel: hsv}\nfit: {selection: fixed}\n"
    assert load_experiment(_write(tmp_path, text), check_files=False).segmentation.channel == "hsv"


def test_alias_bomb_is_refused_quickly(tmp_path):
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    for i in range(1, 12):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]")
    lines.append("name: *a11")
    t0 = time.perf_counter()
    with pytest.raises(ExperimentError, match="expands to more than"):
        load_experiment(_write(tmp_path, "\n".join(lines) + "\n"), check_files=False)
    assert time.perf_counter() - t0 < 30  # a guard against a hang, not a speed measurement


def test_alias_bomb_under_the_node_limit_gives_a_short_message(tmp_path):
    # 10^4 leaves: under the limit, so pydantic sees it; the message is built from a bounded repr
    lines = ["a0: &a0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    for i in range(1, 4):
        lines.append(f"a{i}: &a{i} [" + ", ".join([f"*a{i - 1}"] * 10) + "]")
    text = yaml.safe_dump(GOOD, sort_keys=False).replace("fps: 30", "fps: *a3") + "\n".join(lines) + "\n"
    with pytest.raises(ExperimentError) as info:
        load_experiment(_write(tmp_path, text), check_files=False)
    assert len(str(info.value)) < 400 and "\n" not in str(info.value)


def test_short_repr_is_bounded_on_shared_nested_data():
    x: list = [1] * 10
    for _ in range(30):  # 10^30 leaves if expanded
        x = [x] * 10
    assert len(short_repr(x)) <= 80


@pytest.mark.parametrize("how", ["big", "dev_zero", "deep", "recursive"])
def test_files_that_would_hang_or_explode(tmp_path, how):
    if how == "big":
        f = _write(tmp_path, "# " + "x" * (L.MAX_EXPERIMENT_BYTES + 10) + "\n")
        words = "larger than 1 MB"
    elif how == "dev_zero":
        if not Path("/dev/zero").exists():
            pytest.skip("no /dev/zero")
        f = Path("/dev/zero")
        words = "special file"
    elif how == "deep":
        f = _write(tmp_path, "name: " + "[" * 3000 + "]" * 3000 + "\n")
        words = "nested too deeply"
    else:
        f = _write(tmp_path, "name: &a [*a]\n")
        words = "refers to its own anchor"
    with pytest.raises(ExperimentError, match=words):
        load_experiment(f, check_files=False)


# ------------------------------------------------------------------ numbers
NUMERIC = [("fps",), ("reference_view",), ("points",), ("frames", "start"), ("frames", "stop"), ("frames", "step"),
           ("cameras", 0, "fx"), ("cameras", 1, "fy"), ("cameras", 2, "cx"), ("cameras", 0, "cy"),
           ("cameras", 0, "dist", 1), ("cameras", 1, "view"), ("marker", "id"), ("marker", "length_mm"),
           ("views", 0, "roi", 2), ("views", 1, "keep_out", 0), ("views", 2, "base_point", 1), ("views", 0, "view"),
           ("segmentation", "opening_radius_px"), ("segmentation", "min_component_px"), ("segmentation", "threshold"),
           ("skeleton", "prune_px"), ("skeleton", "merge_width"), ("skeleton", "smooth_px"), ("skeleton", "tip_inset"),
           ("ordering", "tangent_window_px"), ("ordering", "zone_width"), ("ordering", "max_unused_fraction"),
           ("correspondence", "max_distance_px"), ("correspondence", "depth_smoothing"), ("smoothing", "length_mm"),
           ("fit", "target_r2"), ("fit", "penalty_kappa"), ("fit", "penalty_tau"), ("fit", "max_segments"),
           ("calibration", "max_corner_rms_px")]
ABSURD = st.sampled_from([1e308, -1e308, math.inf, -math.inf, math.nan, 1e30, 10**30, -(10**30), 10**400, 2**63,
                          5e-324, -1, 0]) | st.floats() | st.integers(-(2**80), 2**80)


def _set(data: dict, path: tuple, value) -> None:
    cur = data
    for p in path[:-1]:
        if isinstance(p, str) and p not in cur:
            cur[p] = {}
        cur = cur[p]
    cur[path[-1]] = value


def _numbers(obj):
    if isinstance(obj, bool):
        return
    if isinstance(obj, (int, float)):
        yield obj
    elif isinstance(obj, dict):
        for v in obj.values():
            yield from _numbers(v)
    elif isinstance(obj, (list, tuple)):
        for v in obj:
            yield from _numbers(v)


def _key(path: tuple) -> str:
    out = ""
    for p in path:
        out += f"[{p}]" if isinstance(p, int) else ("." if out else "") + p
    return out


@pytest.mark.slow
@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(changes=st.lists(st.tuples(st.sampled_from(NUMERIC), ABSURD), min_size=1, max_size=3))
def test_absurd_numbers_in_every_numeric_key(tmp_path_factory, changes):
    """Huge, tiny, non-finite numbers anywhere: one line naming a changed key, or values in plausible ranges."""
    data = copy.deepcopy(GOOD)
    for path, value in changes:
        _set(data, path, value)
    f = tmp_path_factory.mktemp("absurd") / "e.yaml"
    f.write_text(yaml.safe_dump(data))
    try:
        exp = load_experiment(f, check_files=False)
    except ExperimentError as e:
        msg = str(e)
        assert "\n" not in msg and len(msg) < 600
        named = [_key(p) for p, _ in changes] + [_key(p[:-1]) for p, _ in changes] + ["cameras", "views", "frames",
                                                                                     "reference_view", "marker"]
        assert any(k in msg for k in named), msg
        return
    from tendrilkit.params import experiment_to_dict

    for x in _numbers(experiment_to_dict(exp)):
        assert math.isfinite(x) and abs(x) <= 1e9, (x, changes)
    try:
        check_against_images(exp, [(1920, 1080)] * 3)
    except ExperimentError as e:
        assert "\n" not in str(e)


@pytest.mark.parametrize("path,value,words", [
    (("cameras", 0, "fx"), "1e308", ["cameras[0].fx", "less than or equal to 100000"]),
    (("cameras", 0, "cx"), -1e305, ["cameras[0].cx"]),
    (("fps",), ".inf", ["fps"]),
    (("marker", "id"), 815, ["marker.id", "DICT_4X4_50 holds ids 0..49", "815"]),
])
def test_absurd_values_one_line(tmp_path, path, value, words):
    data = copy.deepcopy(GOOD)
    _set(data, path, value)
    if path == ("marker", "id"):
        data["marker"]["dictionary"] = "DICT_4X4_50"
    text = yaml.safe_dump(data).replace("'.inf'", ".inf")
    with pytest.raises(ExperimentError) as info:
        load_experiment(_write(tmp_path, text), check_files=False)
    for w in words:
        assert w in str(info.value), (w, str(info.value))


@pytest.mark.parametrize("n", [4, 5, 8, 12, 14])
def test_distortion_models_opencv_supports(n):
    data = copy.deepcopy(GOOD)
    dist = [0.01, -0.02, 0.001, -0.001, 0.003, 0.002, -0.001, 0.0005, 0.0002, -0.0001, 0.0003, 0.0001, 0.001, -0.002][:n]
    data["cameras"][0]["dist"] = dist
    exp = parse_experiment(data)
    assert exp.cameras[0].dist[:n] == dist and len(exp.cameras[0].dist) == max(n, 5)
    import cv2

    cam = Camera(K=np.array([[1500.0, 0, 960], [0, 1500, 540], [0, 0, 1]]), dist=np.array(exp.cameras[0].dist),
                 t_mm=np.array([0.0, 0.0, 300.0]))
    X = np.random.default_rng(0).uniform(-60, 60, (50, 3))
    uv, _ = cv2.projectPoints(X.reshape(-1, 1, 3), np.zeros(3), cam.t_mm, cam.K, cam.dist)
    assert np.allclose(cam.project(X), uv.reshape(-1, 2), atol=1e-6)
    und = cam.undistort_points(cam.project(X))
    assert np.allclose(und, cam.project(X, distort=False), atol=1e-3)
    for bad in (6, 7, 15):
        data["cameras"][0]["dist"] = [0.0] * bad
        with pytest.raises(ExperimentError, match=r"cameras\[0\].dist: expected 4, 5, 8, 12 or 14"):
            parse_experiment(data)


# ------------------------------------------------------------------ intrinsics and marks vs the image
@pytest.mark.parametrize("change,size,words", [
    (lambda d: d["cameras"][0].update(cx=2500.0), (1920, 1080), ["cameras[0]", "outside the 1920x1080"]),
    (lambda d: None, (3840, 2160), ["cameras[0]", "far from the centre", "3840x2160"]),
    (lambda d: d["cameras"][1].update(fx=100.0), (1920, 1080), ["cameras[1].fx", "not a plausible focal length"]),
    (lambda d: d["cameras"][2].update(fy=5000.0), (1920, 1080), ["cameras[2]", "fy / fx"]),
    (lambda d: d["views"][0].update(base_point=[780, 500]), (1920, 1080), ["views[0].base_point", "outside the roi"]),
    (lambda d: d["views"][1].update(keep_out=[100, 100, 20, 20]), (1920, 1080), ["views[1].keep_out", "does not overlap"]),
    (lambda d: d["views"][1].update(keep_out=[690, 290, 620, 720]), (1920, 1080), ["views[1].keep_out", "covers 100 %"]),
    (lambda d: d["views"][2].update(keep_out=[1000, 800, 30, 30]), (1920, 1080), ["views[2].keep_out", "from the base point"]),
])
def test_intrinsics_and_marks_against_the_image(change, size, words):
    data = copy.deepcopy(GOOD)
    change(data)
    exp = parse_experiment(data)
    with pytest.raises(ExperimentError) as info:
        check_against_images(exp, [size] * 3)
    for w in words:
        assert w in str(info.value), (w, str(info.value))
    check_against_images(parse_experiment(GOOD), [(1920, 1080)] * 3)  # the good file passes


def test_container_fps_disagreeing_is_a_warning():
    from tendrilkit.inputs import check_video_fps

    exp = parse_experiment({**GOOD, "fps": 30})
    with pytest.warns(UserWarning, match=r"videos\[1\]: view2.mp4 is stored at 25 fps but the experiment file says fps: 30"):
        check_video_fps(exp, [30.0, 25.0, None])
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_video_fps(exp, [29.97, 30.0, None])  # the same rate
        check_video_fps(parse_experiment({**GOOD, "fps": 0.05}), [4.0, 30.0, 25.0])  # a time-lapse


def test_same_video_for_two_views_is_refused(tmp_path):
    data = copy.deepcopy(GOOD)
    for v in data["videos"]:
        (tmp_path / v).write_bytes(b"x")
    data["videos"] = ["view1.mp4", "view2.mp4", "./view1.mp4"]
    with pytest.raises(ExperimentError, match=r"videos\[2\]: the same file as videos\[0\]"):
        load_experiment(_write(tmp_path, yaml.safe_dump(data)))


def test_zero_baseline_rig_is_a_failed_calibration():
    from tendrilkit.calibration import CalibrationResult, check_calibration

    K = np.array([[1750.0, 0, 960], [0, 1750, 540], [0, 0, 1]])
    cams = [Camera(K=K, t_mm=np.array([0.0, 0.0, 350.0])), Camera(K=K, t_mm=np.array([0.1, 0.0, 350.0])),
            Camera(K=K, t_mm=np.array([120.0, 0.0, 350.0]))]
    table = pd.DataFrame({"view": [1, 2, 3], "marker_id": 815, "stage": "single", "mean_px": 0.02, "max_px": 0.03,
                          "n_corners": 4})
    res = CalibrationResult(cameras=cams, single_cameras=cams, markers=table, observations={}, markers_world={})
    with pytest.raises(ExperimentError, match="views 1 and 2 are 0.1 mm apart"):
        check_calibration(res)
    ok = CalibrationResult(cameras=[cams[0], cams[2]], single_cameras=cams, markers=table, observations={},
                           markers_world={})
    check_calibration(ok)
    bad = ok.markers.assign(mean_px=[0.02, 6.3, 0.1])
    with pytest.raises(ExperimentError, match=r"view 2: marker corners reproject 6.30 px off.*--accept-calibration"):
        check_calibration(CalibrationResult(cameras=cams[:1] + cams[2:], single_cameras=cams, markers=bad,
                                            observations={}, markers_world={}))
    with pytest.warns(UserWarning, match="calibration accepted although view 2"):
        check_calibration(CalibrationResult(cameras=cams[:1] + cams[2:], single_cameras=cams, markers=bad,
                                            observations={}, markers_world={}), max_corner_rms_px=None)


# ------------------------------------------------------------------ names and batch
@settings(max_examples=300, deadline=None)
@given(st.text(min_size=0, max_size=12) | st.sampled_from([".", "..", "../x", "a/..", "..\\x", " a", "a\x00b",
                                                           "a\nb", ".hidden", "x" * 101, "CON", "ok-name"]))
def test_random_names_are_safe_folder_names_or_refused(name):
    problem = folder_name_problem(name)
    data = {**GOOD, "name": name}
    if problem is not None:
        with pytest.raises(ExperimentError, match="name"):
            parse_experiment(data)
        return
    reports = Path("/tmp/reports-root")
    target = reports / name
    assert os.path.normpath(target) == str(target) and target.parent == reports and target.name == name
    assert parse_experiment(data).name == name


def _batch_files(tmp_path, names):
    files = []
    for i, n in enumerate(names):
        f = tmp_path / f"e{i}.yaml"
        f.write_text(yaml.safe_dump({**GOOD, "name": n}))
        files.append(f)
    return files


@pytest.mark.parametrize("names,words", [
    ([".."], ["e0.yaml", "name", "'..'"]),
    (["."], ["e0.yaml", "name"]),
    (["a\tb"], ["e0.yaml", "control characters"]),
    (["same", "other", "same"], ["e2.yaml", "'same' is also the name of", "e0.yaml"]),
    (["comparison"], ["e0.yaml", "cross-site"]),
])
def test_batch_refuses_unsafe_or_repeated_names_before_running(tmp_path, capsys, names, words):
    reports = tmp_path / "sub" / "reports"
    code = cli.main(["batch", *map(str, _batch_files(tmp_path, names)), "--reports", str(reports)])
    line = _one_line(capsys.readouterr().err)
    assert code == 2
    for w in words:
        assert w in line, (w, line)
    assert not (tmp_path / "sub").exists()  # nothing was written anywhere


# ------------------------------------------------------------------ writing
@pytest.mark.parametrize("umask,mode", [(0o022, 0o644), (0o002, 0o664), (0o077, 0o600)])
def test_written_files_honour_the_umask(tmp_path, umask, mode):
    from tendrilkit.io import write_csv, write_json, write_text

    old = os.umask(umask)
    try:
        write_csv(pd.DataFrame({"a": [1.0]}), tmp_path / "t.csv")
        write_json({"a": 1}, tmp_path / "t.json")
        write_text("x", tmp_path / "t.txt")
    finally:
        os.umask(old)
    for p in tmp_path.iterdir():
        assert p.stat().st_mode & 0o777 == mode, (p.name, oct(p.stat().st_mode))


def test_disk_full_is_an_output_write_error_naming_the_file(tmp_path, monkeypatch):
    from tendrilkit.io import write_csv

    target = tmp_path / "t.csv"
    write_csv(pd.DataFrame({"a": [1.0]}), target)

    def full(self, path, **kw):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(pd.DataFrame, "to_csv", full)
    with pytest.raises(OutputWriteError, match=r"t.csv: cannot write \(No space left on device\)"):
        write_csv(pd.DataFrame({"a": [2.0]}), target)
    assert [p.name for p in tmp_path.iterdir()] == ["t.csv"]


def test_fit_on_a_full_disk_exits_74(tmp_path, capsys, monkeypatch):
    csv = tmp_path / "curves.csv"
    _curve(0).to_csv(csv, index=False)

    import tendrilkit.io.columns

    def full(*a, **kw):
        raise OSError(errno.ENOSPC, "No space left on device")

    # the fit command writes with the csv module (io.columns), not pandas
    monkeypatch.setattr(tendrilkit.io.columns.csv, "writer", full)
    code = cli.main(["fit", str(csv), "--out", str(tmp_path / "out")])
    line = _one_line(capsys.readouterr().err)
    assert code == 74 and "No space left on device" in line and "pwc_curves.csv" in line


@pytest.mark.parametrize("how", ["existing file", "under a file"])
def test_out_naming_a_file_says_so(tmp_path, capsys, how):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    out = blocker if how == "existing file" else blocker / "sub" / "out"
    csv = tmp_path / "curves.csv"
    _curve(0).to_csv(csv, index=False)
    code = cli.main(["fit", str(csv), "--out", str(out)])
    line = _one_line(capsys.readouterr().err)
    assert code == 2
    assert ("an existing file has this name" if how == "existing file" else f"{blocker} is a file") in line


def test_file_errors_never_echo_the_content(tmp_path):
    from tendrilkit.io import read_cameras, read_ijcv25_extrinsics

    secret = tmp_path / "passwd"
    secret.write_text("root:x:0:0:SECRET-LINE:/root:/bin/bash\n")
    for reader in (read_ijcv25_extrinsics, read_cameras):
        with pytest.raises(ExperimentError) as info:
            reader(secret)
        assert "SECRET" not in str(info.value) and "root:x" not in str(info.value)
        assert str(secret) in str(info.value) and "expected" in str(info.value)
    secret.write_text(",".join(["1"] * 21) + ",SECRET\n")
    with pytest.raises(ExperimentError) as info:
        read_ijcv25_extrinsics(secret)
    assert "SECRET" not in str(info.value)


def test_image_folder_named_by_timestamps(tmp_path):
    import cv2

    from tendrilkit.io import FrameSource

    stamps = [1700000000, 1700000120, 1700000240, 1700086400]
    for k, t in enumerate(stamps):
        cv2.imwrite(str(tmp_path / f"{t}.png"), np.full((20, 30, 3), 10 * k, np.uint8))
    t0 = time.perf_counter()
    with FrameSource(tmp_path) as s:
        assert s.frame_count == 4
        assert [int(s.read(k)[0, 0, 0]) for k in range(4)] == [0, 10, 20, 30]  # frame k = k-th in number order
    assert time.perf_counter() - t0 < 30  # a guard against allocating up to 1.7e9, not a speed measurement


# ------------------------------------------------------------------ per-frame files and fingerprints
def _record(frame: int = 2) -> dict:
    from tendrilkit.pipeline import FrameResult

    rng = np.random.default_rng(frame)
    return FrameResult(frame=frame, time_s=frame / 30, status="ok", message="", points_mm=rng.normal(size=(6, 3)),
                       pwc_mm=rng.normal(size=(6, 3)), quality={"views_used": 3, "length_mm": 12.5},
                       reprojection=[{"view": 1, "section": "entire", "mean_px": 0.4, "std_px": 0.1, "max_px": 1.0,
                                      "n_points": 6}], centroids=[[1.0, 2.0], None, [3.0, 4.0]],
                       n_components=[1, None, 2]).to_json()


def _mutate_json(obj, rng_draw):
    """A copy of obj with one leaf replaced, one key removed or one value set to null."""
    obj = copy.deepcopy(obj)
    paths = []

    def walk(o, p):
        if isinstance(o, dict):
            for k, v in o.items():
                paths.append(p + (k,))
                walk(v, p + (k,))
        elif isinstance(o, list):
            for i, v in enumerate(o):
                paths.append(p + (i,))
                walk(v, p + (i,))

    walk(obj, ())
    path = paths[rng_draw(st.integers(0, len(paths) - 1))]
    cur = obj
    for k in path[:-1]:
        cur = cur[k]
    how = rng_draw(st.sampled_from(["null", "value", "delete"]))
    if how == "delete" and isinstance(cur, dict):
        del cur[path[-1]]
    else:
        cur[path[-1]] = None if how == "null" else rng_draw(st.one_of(st.integers(-5, 5), st.floats(allow_nan=False),
                                                                       st.text(max_size=3)))
    return obj


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_random_mutations_of_a_frame_file_never_pass_as_another_result(tmp_path, data):
    """Edited, truncated, byte-flipped or copied frame files: read back exactly, or refused (recomputed)."""
    from tendrilkit.io import read_frame_record, write_frame_record

    fp = "f" * 64
    p = tmp_path / "frame_000002.json"
    original = _record(2)
    write_frame_record(p, fp, 2, original)
    assert read_frame_record(p, fp, 2) == original
    raw = p.read_bytes()
    how = data.draw(st.sampled_from(["truncate", "flip", "edit", "edit_whole", "copy", "frame"]))
    if how == "truncate":
        p.write_bytes(raw[: data.draw(st.integers(0, len(raw) - 1))])
    elif how == "flip":
        i = data.draw(st.integers(0, len(raw) - 1))
        p.write_bytes(raw[:i] + bytes([raw[i] ^ data.draw(st.integers(1, 255))]) + raw[i + 1:])
    elif how == "edit":
        d = json.loads(raw)
        d["result"] = _mutate_json(d["result"], data.draw)
        p.write_text(json.dumps(d))
    elif how == "edit_whole":
        p.write_text(json.dumps(_mutate_json(json.loads(raw), data.draw)))
    elif how == "copy":  # frame_000001.json copied over frame_000002.json
        write_frame_record(tmp_path / "frame_000001.json", fp, 1, _record(1))
        p.write_bytes((tmp_path / "frame_000001.json").read_bytes())
    else:
        d = json.loads(raw)
        d["frame"] = d["result"]["frame"] = data.draw(st.integers(0, 5).filter(lambda f: f != 2))
        p.write_text(json.dumps(d))
    got = read_frame_record(p, fp, 2)
    assert got is None or got == original
    if got is not None:
        from tendrilkit.pipeline import FrameResult

        assert FrameResult.from_json(got).frame == 2


def test_video_replaced_by_another_of_the_same_size_is_noticed(tmp_path):
    from tendrilkit.io import file_stamp

    v = tmp_path / "view1.mp4"
    rng = np.random.default_rng(0)
    v.write_bytes(rng.bytes(3_000_000))
    st0 = v.stat()
    before = file_stamp(v)
    data = bytearray(v.read_bytes())
    data[1_500_000:1_600_000] = rng.bytes(100_000)  # another file, same size and same modification time
    v.write_bytes(bytes(data))
    os.utime(v, ns=(st0.st_atime_ns, st0.st_mtime_ns))
    assert v.stat().st_size == before["bytes"] and v.stat().st_mtime_ns == before["mtime_ns"]
    assert file_stamp(v) != before
    folder = tmp_path / "imgs"
    folder.mkdir()
    (folder / "000000.png").write_bytes(b"a" * 100)
    f0 = file_stamp(folder)
    (folder / "000000.png").write_bytes(b"b" * 100)
    os.utime(folder / "000000.png", ns=(st0.st_atime_ns, st0.st_mtime_ns))
    assert file_stamp(folder) != f0


def test_run_fingerprint_includes_frames_start_and_step():
    from tendrilkit.runner import frame_fingerprint

    cams = [Camera(K=np.eye(3))] * 3
    base = parse_experiment(GOOD)
    fp = frame_fingerprint(base, cams, [])
    for frames, same in (({"start": 0, "stop": 7, "step": 1}, True), ({"start": 0, "step": 2}, False),
                         ({"start": 3, "step": 1}, False)):
        other = parse_experiment({**GOOD, "frames": frames})
        assert (frame_fingerprint(other, cams, []) == fp) is same, frames


# ------------------------------------------------------------------ the fit command's input
def _curve(frame: int, n: int = 40) -> pd.DataFrame:
    s = np.linspace(0, 1, n)
    return pd.DataFrame({"frame": frame, "time_s": 0.5 * frame, "point": np.arange(n), "x_mm": 40 * s,
                         "y_mm": 8 * np.sin(3 * s), "z_mm": 5 * s ** 2})


@pytest.mark.parametrize("case,words", [
    ("frame twice", ["frame 1", "listed twice"]),
    ("text coordinate", ["column y_mm", "row 5", "text where a number is expected"]),
    ("huge coordinates", ["column x_mm", "expected a finite coordinate within 1e+06 mm"]),
    ("infinite coordinate", ["column z_mm", "finite coordinate"]),
    ("too many points", ["frame 0", "100000 points", "at most 5000"]),
])
def test_fit_input_that_cannot_be_right(tmp_path, capsys, case, words):
    csv = tmp_path / "curves.csv"
    if case == "frame twice":
        df = pd.concat([_curve(0), _curve(1), _curve(1)])
    elif case == "text coordinate":
        df = _curve(0).astype({"y_mm": object})
        df.loc[3, "y_mm"] = "abc"
    elif case == "huge coordinates":
        df = _curve(0)
        df[["x_mm", "y_mm", "z_mm"]] *= 1e305
    elif case == "infinite coordinate":
        df = _curve(0)
        df.loc[2, "z_mm"] = np.inf
    else:
        df = _curve(0, n=100_000)
    df.to_csv(csv, index=False)
    code = cli.main(["fit", str(csv), "--out", str(tmp_path / "out")])
    line = _one_line(capsys.readouterr().err)
    assert code == 2
    for w in words:
        assert w in line, (w, line)


def test_fit_minimum_point_count_is_the_same_everywhere(tmp_path):
    from tendrilkit.fitting import fit_curves

    same = _curve(2, n=20).assign(x_mm=1.0, y_mm=2.0, z_mm=3.0)  # 20 points at 1 place
    _, _, met = fit_curves(pd.concat([_curve(0, n=5), _curve(1, n=7), same]))
    assert (met.status == "failed").all()
    assert all(f"at least {L.MIN_FIT_POINTS} are needed" in m for m in met.message), met.message.tolist()


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero")
def test_special_files_as_inputs_are_refused_not_read(tmp_path, capsys):
    from tendrilkit.io import FrameSource, file_stamp

    for fn in (FrameSource, file_stamp):
        with pytest.raises(ExperimentError, match="special file"):
            fn(Path("/dev/zero"))
    code = cli.main(["fit", "/dev/zero", "--out", str(tmp_path / "out")])
    assert code == 2 and "special file" in _one_line(capsys.readouterr().err)


@pytest.mark.skipif(not Path("/proc/self").is_dir(), reason="no /proc")
def test_out_in_a_system_folder_says_so(tmp_path, capsys):
    csv = tmp_path / "curves.csv"
    _curve(0).to_csv(csv, index=False)
    code = cli.main(["fit", str(csv), "--out", "/proc/tendrilkit-test/out"])
    line = _one_line(capsys.readouterr().err)
    assert code == 2 and "/proc does not accept new folders" in line
