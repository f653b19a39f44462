"""Random experiment files thrown at the loader and the command line: a clean error or a success, never a traceback."""

from __future__ import annotations

import copy

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from tendrilkit import cli
from tendrilkit.exceptions import ExperimentError
from tendrilkit.inputs import check_against_images
from tendrilkit.params import load_experiment, parse_experiment
from tests.test_params import GOOD

KEYS = ["name", "stimulation_site", "videos", "fps", "reference_view", "frames", "cameras", "marker", "views",
        "points", "extrinsics", "segmentation", "fit", "bogus"]
SUBKEYS = ["view", "fx", "fy", "cx", "cy", "dist", "roi", "keep_out", "base_point", "id", "length_mm",
           "dictionary", "start", "stop", "step", "threshold", "channel", "format", "files", "x"]
values = st.recursive(
    st.none() | st.booleans() | st.integers(-5, 3000) | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=8),
    lambda children: st.lists(children, max_size=5) | st.dictionaries(st.sampled_from(SUBKEYS), children, max_size=4),
    max_leaves=12,
)


@st.composite
def mutated_experiments(draw):
    data = copy.deepcopy(GOOD)
    for _ in range(draw(st.integers(1, 4))):
        action = draw(st.sampled_from(["drop", "set", "set_nested", "retype"]))
        key = draw(st.sampled_from(KEYS))
        if action == "drop":
            data.pop(key, None)
        elif action == "set":
            data[key] = draw(values)
        elif action == "set_nested" and isinstance(data.get(key), list) and data[key]:
            item = draw(st.integers(0, len(data[key]) - 1))
            if isinstance(data[key][item], dict):
                data[key][item][draw(st.sampled_from(SUBKEYS))] = draw(values)
        elif action == "retype" and key in data:
            data[key] = str(data[key]) if not isinstance(data[key], str) else [data[key]]
    return data


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mutated_experiments())
def test_loader_never_raises_anything_but_a_clean_error(data):
    try:
        exp = parse_experiment(data)
    except ExperimentError as e:
        msg = str(e)
        assert msg and "\n" not in msg and "Traceback" not in msg
        return
    try:
        check_against_images(exp, [(1920, 1080)] * exp.n_views)
    except ExperimentError as e:
        assert "\n" not in str(e)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(mutated_experiments())
def test_command_line_gives_exit_2_and_one_line(tmp_path, capsys, data):
    f = tmp_path / "exp.yaml"
    f.write_text(yaml.safe_dump(data))
    for cmd in (["calibrate", str(f), "--out", str(tmp_path / "o")], ["reconstruct", str(f), "--out", str(tmp_path / "o")]):
        code = cli.main(cmd)
        err = capsys.readouterr().err
        # the videos of GOOD do not exist, so no run can succeed: the first mistake is reported
        assert code == 2, err
        assert len(err.strip().splitlines()) == 1 and "Traceback" not in err


@pytest.mark.parametrize("text", ["", "  \n", "name: [unclosed\n", "\t- tab", "a: b: c\n", "- 1\n- 2\n", "just a string"])
def test_garbage_files(tmp_path, text):
    f = tmp_path / "e.yaml"
    f.write_text(text)
    with pytest.raises(ExperimentError):
        load_experiment(f)


def test_binary_file(tmp_path):
    f = tmp_path / "e.yaml"
    f.write_bytes(bytes(range(256)))
    with pytest.raises(ExperimentError):
        load_experiment(f)


@pytest.mark.parametrize("key,value,words", [
    ("roi", [1800, 0, 300, 100], ["views[0].roi", "outside the 1920x1080"]),
    ("keep_out", [-5, 0, 10, 10], ["views[0].keep_out", "outside"]),
    ("base_point", [5000, 10], ["views[0].base_point", "outside the 1920x1080"]),
])
def test_marks_outside_the_image(key, value, words):
    data = copy.deepcopy(GOOD)
    data["views"][0][key] = value
    exp = parse_experiment(data)
    with pytest.raises(ExperimentError) as info:
        check_against_images(exp, [(1920, 1080)] * 3)
    for w in words:
        assert w in str(info.value)
