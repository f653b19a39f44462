"""Intrinsics from rendered board videos with known K and distortion (tendrilkit.intrinsics, boards)."""

from __future__ import annotations

import re

import numpy as np
import pytest
import yaml

from tendrilkit import cli
from tendrilkit.boards import board_poses, parse_board, render_board_frames
from tendrilkit.camera import Camera
from tendrilkit.intrinsics import calibrate_source
from tendrilkit.io import write_video
from tendrilkit.params import load_experiment

TRUE_K = np.array([[980.0, 0.0, 652.0], [0.0, 985.0, 355.0], [0.0, 0.0, 1.0]])
TRUE_DIST = np.array([-0.12, 0.05, 0.0008, -0.0005, 0.0])
CAMERA = Camera(TRUE_K, TRUE_DIST, width=1280, height=720)
CHARUCO = "charuco:7,5,30,22,DICT_5X5_100"


def _board_video(folder, board_text, n, *, seed, cells="all"):
    board = parse_board(board_text)
    poses = board_poses(board, CAMERA, n, seed=seed, cells=cells)
    write_video(render_board_frames(board, CAMERA, poses, seed=seed), folder)
    return folder


@pytest.fixture(scope="module")
def charuco_video(tmp_path_factory):
    return _board_video(tmp_path_factory.mktemp("charuco") / "board", CHARUCO, 20, seed=3)


def _entry(path, view):
    data = yaml.safe_load(path.read_text())
    return next(c for c in data["cameras"] if c["view"] == view)


def test_charuco_video_gives_the_true_intrinsics(charuco_video, tmp_path):
    out = tmp_path / "cam2.yaml"
    code = cli.main(["intrinsics", str(charuco_video), "--board", CHARUCO, "--view", "2", "--write", str(out)])
    assert code == 0
    c = _entry(out, 2)
    assert abs(c["fx"] / TRUE_K[0, 0] - 1) < 0.005 and abs(c["fy"] / TRUE_K[1, 1] - 1) < 0.005
    assert abs(c["cx"] - TRUE_K[0, 2]) < 2.0 and abs(c["cy"] - TRUE_K[1, 2]) < 2.0
    rms = float(re.search(r"RMS ([0-9.]+) px", out.read_text()).group(1))
    assert rms <= 0.3
    # the distortion it found undistorts like the true one (k3 and k2 trade off; compare the mapping)
    est = Camera(np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1]]), np.array(c["dist"]),
                 width=1280, height=720)
    xy = np.stack(np.meshgrid(np.linspace(40, 1240, 9), np.linspace(40, 680, 7)), -1).reshape(-1, 2)
    rays_true = CAMERA.ray_directions_cam(xy)
    rays_est = est.ray_directions_cam(xy)
    ang = np.degrees(np.arccos(np.clip(np.sum(rays_true * rays_est, 1) / np.linalg.norm(rays_true, axis=1)
                                       / np.linalg.norm(rays_est, axis=1), -1, 1)))
    assert ang.max() < 0.1  # degrees: about 1.7 px at this focal length


def test_write_fills_an_experiment_file_and_keeps_its_comments(charuco_video, tmp_path):
    from tests.test_params import GOOD

    exp = tmp_path / "exp.yaml"
    text = "# my notes on this recording\n" + yaml.safe_dump(GOOD, sort_keys=False).replace(
        "cameras:", "cameras:   # filled by tendrilkit intrinsics\n  # view 1 was calibrated in May", 1)
    exp.write_text(text)
    code = cli.main(["intrinsics", str(charuco_video), "--board", CHARUCO, "--view", "1", "--write", str(exp)])
    assert code == 0
    new = exp.read_text()
    assert "# my notes on this recording" in new and "# view 1 was calibrated in May" in new
    c = _entry(exp, 1)
    assert abs(c["fx"] / 980.0 - 1) < 0.005
    assert [c["view"] for c in yaml.safe_load(new)["cameras"]] == [1, 2, 3]
    assert _entry(exp, 2) == GOOD["cameras"][1]
    load_experiment(exp, check_files=False)


@pytest.mark.slow
def test_checkerboard_video_gives_the_true_intrinsics(tmp_path):
    video = _board_video(tmp_path / "board", "checkerboard:9,6,25", 14, seed=5)
    result, cov, problems, size = calibrate_source(video, parse_board("checkerboard:9,6,25"))
    assert problems == [] and size == (1280, 720)
    assert np.all(np.abs(np.diag(result.K)[:2] / np.diag(TRUE_K)[:2] - 1) < 0.005)
    assert np.all(np.abs(result.K[:2, 2] - TRUE_K[:2, 2]) < 2.0)
    assert result.rms_px <= 0.3


def test_poorly_spread_video_says_what_to_film(tmp_path, capsys):
    video = _board_video(tmp_path / "board", CHARUCO, 12, seed=4, cells="centre-right")
    out = tmp_path / "cam.yaml"
    code = cli.main(["intrinsics", str(video), "--board", CHARUCO, "--write", str(out)])
    text = capsys.readouterr().out
    assert code == 1
    assert "the board never reached the image's left third; film it there too" in text
    assert not out.exists()


def test_too_few_frames_says_what_to_film(tmp_path, capsys):
    video = _board_video(tmp_path / "board", CHARUCO, 3, seed=6)
    code = cli.main(["intrinsics", str(video), "--board", CHARUCO])
    text = capsys.readouterr().out
    assert code == 1 and "found in 3 of 3 frames" in text and "at least 8 needed" in text


@pytest.mark.parametrize("board, words", [
    ("charuco:7,5,30,40,DICT_5X5_100", "MARKER_MM"),
    ("charuco:7,5,30,22,DICT_NOPE", "unknown ArUco dictionary"),
    ("checkerboard:9,6", "checkerboard:COLS,ROWS,SQUARE_MM"),
    ("chess:9,6,25", "expected charuco:"),
])
def test_bad_board_is_one_line_exit_2(tmp_path, capsys, board, words):
    (tmp_path / "v").mkdir()
    code = cli.main(["intrinsics", str(tmp_path / "v"), "--board", board])
    err = capsys.readouterr().err
    assert code == 2 and words in err and len(err.strip().splitlines()) == 1
