"""Issue 14 on real videos: inputs that used to give a silent wrong result are refused in one line (exit 2).

Wrong intrinsics (a failed calibration), a video of another size than its
intrinsics, marks that cannot be right, the same video for every view, and the
warning about a container frame rate. Each case runs through the command line
on a copy of the 4-frame S3 phantom of ``test_robustness``.
"""

from __future__ import annotations

import shutil

import cv2
import pytest
import yaml

from tests.test_robustness import (assert_one_line_error, copy_experiment, image_folder_experiment,
                                   phantom_experiment, run_cli)

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def phantom(tmp_path_factory):
    return phantom_experiment(tmp_path_factory)


def _edit(exp, change) -> None:
    data = yaml.safe_load(exp.read_text())
    change(data)
    exp.write_text(yaml.safe_dump(data, sort_keys=False))


def _last_line(err: str) -> str:
    assert "Traceback" not in err, err
    lines = err.strip().splitlines()
    # warnings (one line each, "tendrilkit: warning: ...") may come first; the error is the last line
    assert all(x.startswith("tendrilkit: warning: ") for x in lines[:-1]), err
    return lines[-1]


def _double_view1(d):
    d["cameras"][0]["fx"] *= 2
    d["cameras"][0]["fy"] *= 2


def _all_fx_x2_cx_300(d):
    for c in d["cameras"]:
        c["fx"] *= 2
        c["cx"] += 300


def _all_f_x2_cx_300(d):
    for c in d["cameras"]:
        c["fx"] *= 2
        c["fy"] *= 2
        c["cx"] += 300


def test_focal_lengths_of_different_pixels_are_refused(phantom, tmp_path, capsys):
    """Every fx doubled (fy not) and cx + 300 px: pixels twice as wide as high, refused before calibrating."""
    exp = copy_experiment(phantom, tmp_path / "exp")
    _edit(exp, _all_fx_x2_cx_300)
    code, _, err = run_cli(capsys, "calibrate", exp, "--out", tmp_path / "cal")
    assert_one_line_error(code, err, "cameras[0]", "fy / fx = 0.5")


@pytest.mark.parametrize("case,change,view", [("view 1 fx, fy doubled", _double_view1, "view 1"),
                                              ("all fx, fy x2, cx + 300", _all_f_x2_cx_300, "view")])
def test_wrong_intrinsics_fail_the_calibration(phantom, tmp_path, capsys, case, change, view):
    exp = copy_experiment(phantom, tmp_path / "exp")
    _edit(exp, change)
    code, _, err = run_cli(capsys, "calibrate", exp, "--out", tmp_path / "cal")
    line = _last_line(err)
    assert code == 2 and line.startswith("tendrilkit: error: calibration failed: " + view), err
    assert "px off" in line and "--accept-calibration" in line
    assert not (tmp_path / "cal" / "cameras.json").exists()
    # through reconstruct: stopped before any frame
    code, _, err = run_cli(capsys, "reconstruct", exp, "--out", tmp_path / "out", "--workers", "1", "--quiet")
    assert code == 2 and "calibration failed" in _last_line(err)
    assert not list((tmp_path / "out").rglob("frame_*.json"))
    # the flag proceeds anyway, saying so
    code, out, err = run_cli(capsys, "calibrate", exp, "--out", tmp_path / "cal", "--accept-calibration")
    assert code == 0, err
    assert "calibration accepted although" in err and (tmp_path / "cal" / "cameras.json").is_file()


def test_video_of_another_size_than_its_intrinsics(tmp_path_factory, tmp_path, capsys):
    """View 1 recorded at 3840x2160 while intrinsics and marks are for 1920x1080."""
    exp = copy_experiment(image_folder_experiment(tmp_path_factory), tmp_path / "exp")
    folder = exp.parent / "view1"
    first = cv2.imread(str(folder / "000000.png"))
    for p in folder.iterdir():
        p.unlink()
    cv2.imwrite(str(folder / "000000.png"), cv2.resize(first, (3840, 2160)))
    for cmd in (["calibrate", exp, "--out", tmp_path / "cal"],
                ["reconstruct", exp, "--out", tmp_path / "out", "--workers", "1", "--quiet"]):
        code, _, err = run_cli(capsys, *cmd)
        assert_one_line_error(code, err, "cameras[0]", "3840x2160", "another image size")


@pytest.mark.parametrize("case,change,words", [
    ("base point on the background",
     lambda v: v.update(base_point=[v["roi"][0] + v["roi"][2] - 30, v["roi"][1] + v["roi"][3] - 30],
                        keep_out=[v["roi"][0] + v["roi"][2] - 36, v["roi"][1] + v["roi"][3] - 36, 12, 12]),
     ["views[0].base_point", "on the background of frame 0", "px away"]),
    ("base point outside the roi", lambda v: v.update(base_point=[v["roi"][0] - 20, v["base_point"][1]]),
     ["views[0].base_point", "outside the roi"]),
    ("keep-out far outside the roi", lambda v: v.update(keep_out=[1700, 20, 30, 30]),
     ["views[0].keep_out", "does not overlap the roi"]),
    ("keep-out covering the roi", lambda v: v.update(keep_out=list(v["roi"])),
     ["views[0].keep_out", "covers 100 % of the roi"]),
])
def test_marks_that_cannot_be_right(phantom, tmp_path, capsys, case, change, words):
    exp = copy_experiment(phantom, tmp_path / "exp")
    _edit(exp, lambda d: change(d["views"][0]))
    code, _, err = run_cli(capsys, "reconstruct", exp, "--out", tmp_path / "out", "--workers", "1", "--quiet")
    assert_one_line_error(code, err, *words)
    if "background" not in case:  # calibrate checks the marks' geometry, not the frame's content
        code, _, err = run_cli(capsys, "calibrate", exp, "--out", tmp_path / "cal")
        assert_one_line_error(code, err, *words)
    assert not list((tmp_path / "out").rglob("frame_*.json"))


def test_same_video_for_every_view(phantom, tmp_path, capsys):
    exp = copy_experiment(phantom, tmp_path / "exp")
    _edit(exp, lambda d: d.update(videos=[d["videos"][0]] * 3))
    code, _, err = run_cli(capsys, "reconstruct", exp, "--out", tmp_path / "out", "--workers", "1", "--quiet")
    assert_one_line_error(code, err, "videos[1]: the same file as videos[0]")
    # copies of one video (different files): an impossible rig, refused at calibration
    for v in ("view2.mp4", "view3.mp4"):
        shutil.copy(exp.parent / "view1.mp4", exp.parent / v)

    def same(d):
        d["videos"] = ["view1.mp4", "view2.mp4", "view3.mp4"]
        d["cameras"] = [{**d["cameras"][0], "view": i + 1} for i in range(3)]
        d["views"] = [{**d["views"][0], "view": i + 1} for i in range(3)]

    _edit(exp, same)
    code, _, err = run_cli(capsys, "calibrate", exp, "--out", tmp_path / "cal")
    line = _last_line(err)
    assert code == 2 and "calibration failed: views 1 and 2 are" in line and "same video" in line, err


def test_container_fps_disagreeing_with_the_file_is_mentioned(phantom, tmp_path, capsys):
    exp = copy_experiment(phantom, tmp_path / "exp")
    _edit(exp, lambda d: d.update(fps=5.0))  # the phantom's containers say 4 fps
    code, _, err = run_cli(capsys, "calibrate", exp, "--out", tmp_path / "cal")
    assert code == 0, err
    lines = err.strip().splitlines()
    assert lines and all(x.startswith("tendrilkit: warning: videos[") for x in lines), err
    assert "view1.mp4 is stored at 4 fps but the experiment file says fps: 5" in lines[0]


from hypothesis import HealthCheck, event, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from tests.test_reliability import ABSURD, NUMERIC, _set  # noqa: E402


@settings(max_examples=12, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(changes=st.lists(st.tuples(st.sampled_from(NUMERIC), ABSURD), min_size=1, max_size=2))
def test_absurd_numbers_on_real_videos(phantom, tmp_path_factory, capsys, changes):
    """Huge, tiny and non-finite numbers in any numeric key next to real videos: one line and exit 2, or a calibration."""
    d = yaml.safe_load(phantom.read_text())
    d["videos"] = [str(phantom.parent / v) for v in d["videos"]]
    for path, value in changes:
        _set(d, path, value)
    folder = tmp_path_factory.mktemp("absurd_video")
    exp = folder / "experiment.yaml"
    exp.write_text(yaml.safe_dump(d))
    code, _, err = run_cli(capsys, "calibrate", exp, "--out", folder / "cal")
    event(f"exit {code}")
    assert "Traceback" not in err and code in (0, 2), err
    if code == 2:
        assert _last_line(err).startswith("tendrilkit: error: ")
