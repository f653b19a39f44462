"""Experiment-file validation: every mistake is one line naming key, value and expectation."""

from __future__ import annotations

import copy
import subprocess
import sys
import warnings
from pathlib import Path

import pytest
import yaml

from tendrilkit.exceptions import ExperimentError
from tendrilkit.params import load_experiment, parse_experiment

ROOT = Path(__file__).resolve().parents[1]

GOOD = {
    "name": "S3-tendril-a",
    "stimulation_site": "S3",
    "videos": ["view1.mp4", "view2.mp4", "view3.mp4"],
    "fps": 30,
    "reference_view": 2,
    "frames": {"start": 0, "stop": None, "step": 1},
    "cameras": [
        {"view": 1, "fx": 1756.3, "fy": 1755.4, "cx": 982.0, "cy": 502.6, "dist": [0, 0, 0, 0, 0]},
        {"view": 2, "fx": 1746.0, "fy": 1743.9, "cx": 989.8, "cy": 516.9},
        {"view": 3, "fx": 1767.0, "fy": 1764.0, "cx": 980.6, "cy": 521.8, "dist": [0.01, 0, 0, 0]},
    ],
    "marker": {"dictionary": "DICT_ARUCO_ORIGINAL", "id": 815, "length_mm": 24.0},
    "views": [
        {"view": 1, "roi": [800, 300, 600, 700], "keep_out": [900, 300, 60, 40], "base_point": [930, 345]},
        {"view": 2, "roi": [700, 300, 600, 700], "keep_out": [800, 300, 60, 40], "base_point": [830, 345]},
        {"view": 3, "roi": [600, 300, 600, 700], "keep_out": [700, 300, 60, 40], "base_point": [730, 345]},
    ],
    "points": 200,
}


def _write(tmp_path: Path, data) -> Path:
    p = tmp_path / "experiment.yaml"
    p.write_text(yaml.safe_dump(data) if not isinstance(data, str) else data)
    return p


def test_good_file_resolves_paths_and_defaults(tmp_path):
    exp = load_experiment(_write(tmp_path, GOOD), check_files=False)
    assert exp.videos[0] == (tmp_path / "view1.mp4").resolve()
    assert exp.n_views == 3
    assert exp.cameras[2].dist == [0.01, 0, 0, 0, 0]
    assert exp.segmentation.channel == "blue"
    assert exp.frames.stop is None


def _mutate(path, value):
    data = copy.deepcopy(GOOD)
    *parents, last = path
    cur = data
    for p in parents:
        cur = cur[p]
    if value is _DELETE:
        del cur[last]
    else:
        cur[last] = value
    return data


class _Delete:
    def __repr__(self) -> str:  # stable test ids (pytest-xdist workers must collect the same names)
        return "<deleted>"


_DELETE = _Delete()

BAD_CASES = [
    # (path, value, words that must appear in the message)
    (("bogus_key",), 1, ["unknown key", "bogus_key"]),
    (("views", 1, "colour"), "red", ["unknown key", "views[1].colour"]),
    (("name",), _DELETE, ["name", "missing"]),
    (("fps",), "fast", ["fps", "'fast'"]),
    (("fps",), -3, ["fps", "-3"]),
    (("cameras", 0, "fx"), "abc", ["cameras[0].fx", "'abc'"]),
    (("cameras", 1, "dist"), [1, 2], ["cameras[1].dist", "4, 5, 8, 12 or 14", "[1, 2]"]),
    (("cameras",), GOOD["cameras"][:2], ["cameras", "one entry per video (3)", "got 2"]),
    (("views",), GOOD["views"][:1], ["views", "one entry per video (3)", "got 1"]),
    (("videos",), ["a.mp4"], ["videos", "at least 2"]),
    (("reference_view",), 4, ["reference_view", "1..3", "4"]),
    (("views", 0, "roi"), [1, 2, 3], ["views[0].roi", "[1, 2, 3]"]),
    (("views", 0, "roi"), [10, 10, 0, 5], ["views[0].roi", "positive width"]),
    (("views", 2, "base_point"), "centre", ["views[2].base_point", "'centre'"]),
    (("marker", "dictionary"), "DICT_NOPE", ["marker.dictionary", "DICT_NOPE"]),
    (("marker", "length_mm"), 0, ["marker.length_mm", "greater than or equal to 0.1"]),
    (("frames",), {"start": 10, "stop": 5}, ["frames", "stop (5)", "start (10)"]),
    (("stimulation_site",), "S5", ["stimulation_site", "'S5'"]),
    (("segmentation",), {"threshold": 300}, ["segmentation.threshold", "'otsu'", "255", "300"]),
    (("cameras", 2, "view"), 4, ["cameras", "[1, 2, 3]", "[1, 2, 4]"]),
    (("points",), 3, ["points", "3"]),
    (("name",), "a/b", ["name", "'a/b'"]),
]


@pytest.mark.parametrize("path,value,words", BAD_CASES, ids=[".".join(map(str, c[0])) + f"={c[1]!r}"[:30] for c in BAD_CASES])
def test_each_mistake_is_one_clear_line(tmp_path, path, value, words):
    f = _write(tmp_path, _mutate(path, value))
    with pytest.raises(ExperimentError) as info:
        load_experiment(f, check_files=False)
    msg = str(info.value)
    assert "\n" not in msg
    assert msg.startswith(str(f))
    for w in words:
        assert w in msg, f"{w!r} not in {msg!r}"


def test_empty_file(tmp_path):
    with pytest.raises(ExperimentError, match="empty"):
        load_experiment(_write(tmp_path, ""), check_files=False)


def test_not_a_mapping(tmp_path):
    with pytest.raises(ExperimentError, match="mapping"):
        load_experiment(_write(tmp_path, "- a\n- b\n"), check_files=False)


def test_yaml_syntax_error_names_the_line(tmp_path):
    text = "name: x\nvideos: [a.mp4, b.mp4\nfps: 30\n"
    with pytest.raises(ExperimentError, match=r"line \d+, column \d+"):
        load_experiment(_write(tmp_path, text), check_files=False)


def test_missing_experiment_file(tmp_path):
    with pytest.raises(ExperimentError, match="not found"):
        load_experiment(tmp_path / "nope.yaml")


def test_missing_video_named(tmp_path):
    f = _write(tmp_path, GOOD)
    with pytest.raises(ExperimentError, match=r"videos\[0\]: file not found: .*view1.mp4"):
        load_experiment(f)


def test_missing_extrinsics_file_named(tmp_path):
    data = copy.deepcopy(GOOD)
    data["extrinsics"] = {"format": "ijcv25", "files": ["a.csv", "b.csv", "c.csv"]}
    for v in data["videos"]:
        (tmp_path / v).write_bytes(b"")
    with pytest.raises(ExperimentError, match=r"extrinsics.files\[0\]: file not found"):
        load_experiment(_write(tmp_path, data))


def test_extrinsics_count_must_match(tmp_path):
    data = copy.deepcopy(GOOD)
    data["extrinsics"] = {"format": "ijcv25", "files": ["a.csv"]}
    with pytest.raises(ExperimentError, match=r"extrinsics.files: expected one file per video \(3\), got 1"):
        parse_experiment(data)


@pytest.mark.slow
def test_command_line_prints_one_line_and_exits_2(tmp_path):
    f = _write(tmp_path, _mutate(("cameras", 0, "fx"), "abc"))
    out = subprocess.run([sys.executable, "-m", "tendrilkit", "calibrate", str(f), "--out", str(tmp_path / "o")],
                         capture_output=True, text=True, cwd=ROOT)
    assert out.returncode == 2
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert "cameras[0].fx" in lines[0] and "Traceback" not in out.stderr


def test_example_ijcv25_params_file_loads():
    exp = load_experiment(ROOT / "params" / "example_ijcv25.yaml", check_files=False)
    assert exp.extrinsics is not None and all(f.is_file() for f in exp.extrinsics.files)
    assert [v.suffix for v in exp.videos] == [".MOV"] * 3
    assert exp.frames.step == 3600


def test_a_correspondence_method_the_multiview_reconstruction_ignores_is_warned_of():
    data = copy.deepcopy(GOOD)
    data["correspondence"] = {"method": "frechet"}
    with pytest.warns(UserWarning, match="correspondence.method: frechet is read only with reconstruction.method: chain"):
        parse_experiment(data)  # multiview, the default
    data["reconstruction"] = {"method": "chain"}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert parse_experiment(data).correspondence.method == "frechet"  # read: no warning
