"""One route for options: every key of every optional section reaches its stage function, with one default.

The defaults live in the stage functions' signatures (:data:`tendrilkit.options.STAGE_FUNCTIONS`);
:func:`tendrilkit.options.stage_options` hands them to the stages. These tests fail when a key is
dropped or renamed on either side, when a default differs, and when the pipeline stops passing a key.
"""

from __future__ import annotations

import inspect
import types

import numpy as np
import pytest

from tendrilkit.options import STAGE_FUNCTIONS, STAGE_SECTIONS, SWITCHES, stage_options, stage_signature_defaults
from tendrilkit.params import example_experiment_data, parse_experiment

#: Written out by hand: a key dropped or renamed anywhere fails here.
EXPECTED = {
    "segmentation": {"channel", "threshold", "opening_radius_px", "min_component_px", "local_contrast", "local_noise_k",
                     "background_px", "local_window_px", "local_margin_px", "local_exclude_dark", "line_width_px",
                     "bridge_gap_px"},
    "ordering": {"prune_px", "merge_width", "smooth_px", "tip_inset", "method", "tangent_window_px", "zone_width",
                 "max_unused_fraction", "overrides"},
    "correspondence": {"max_distance_px", "depth_smoothing"},
    "triangulation": {"refine"},
    "multiview": {"segment_mm", "choice_candidates", "colour_px"},
    "fit": {"selection", "criterion", "target_r2", "penalty_kappa", "penalty_tau", "score", "max_segments", "refine",
            "smoothing_length_mm"},
}

#: A value other than the default for every option (the sections as an experiment file writes them).
NON_DEFAULT = {
    "segmentation": {"channel": "hsv", "threshold": 90, "opening_radius_px": 2, "min_component_px": 7,
                     "local_contrast": 0.2, "local_noise_k": 3.0, "background_px": 48, "local_window_px": 5,
                     "local_margin_px": 3, "local_exclude_dark": False, "line_width_px": 9,
                     "bridge_gap_px": 12},
    "skeleton": {"prune_px": 5.0, "merge_width": 2.5, "smooth_px": 0.5, "tip_inset": 0.5},
    "ordering": {"method": "paper", "tangent_window_px": 9.0, "zone_width": 1.5, "max_unused_fraction": 0.3,
                 "overrides": [{"frame": 0, "view": 1, "junction": 0, "branch": 1}]},
    "correspondence": {"method": "epipolar", "max_distance_px": 5.5, "depth_smoothing": 7.0},
    "triangulation": {"refine": False, "to_curves": False, "base_from_marks": False},
    "reconstruction": {"method": "chain", "chunk_frames": 3, "segment_mm": 2.0, "choice_candidates": 1,
                       "front_line_contrast": 0.15},
    "smoothing": {"length_mm": 12.0},
    "fit": {"selection": "fixed", "criterion": "r2", "target_r2": 0.99, "penalty_kappa": 0.02, "penalty_tau": 0.03,
            "score": "l1", "max_segments": 4, "refine": False},
}


def _experiment(**sections):
    return parse_experiment({**example_experiment_data(), **sections})


@pytest.mark.parametrize("stage", sorted(STAGE_SECTIONS))
def test_every_option_is_a_keyword_of_its_stage_with_the_same_default(stage):
    defaults = stage_signature_defaults(stage)  # read from the source without importing the stage
    real = {k: p.default for k, p in inspect.signature(_stage_function(stage)).parameters.items()
            if p.default is not inspect.Parameter.empty}
    assert defaults == real, "the defaults read from the source differ from the imported function's"
    exp = _experiment()
    opts = stage_options(exp, stage)
    assert set(opts) == EXPECTED[stage]
    for key, value in opts.items():
        assert key in defaults, f"{STAGE_FUNCTIONS[stage]} has no keyword {key!r} with a default"
        want = defaults[key]
        if isinstance(want, tuple):  # overrides: () in the signature, [] in the experiment file
            assert list(want) == value, key
        else:
            assert value == want and type(value) is type(want), (key, value, want)
    inspect.signature(_stage_function(stage)).bind_partial(**opts)  # every option is accepted by name


def test_every_section_key_is_a_stage_option_or_a_switch():
    exp = _experiment()
    reached = {(section, prefix + k) for stage, secs in STAGE_SECTIONS.items() for section, prefix in secs
               for k in getattr(exp, section).model_dump()}
    for section in ("segmentation", "skeleton", "ordering", "correspondence", "triangulation", "reconstruction",
                    "smoothing", "fit"):
        for key in type(getattr(exp, section)).model_fields:
            prefixes = [p for stage, secs in STAGE_SECTIONS.items() for s, p in secs if s == section]
            assert key in SWITCHES.get(section, ()) or any((section, p + key) in reached for p in prefixes), \
                f"{section}.{key} reaches no stage"


def test_non_default_values_come_through():
    exp = _experiment(**NON_DEFAULT)
    assert stage_options(exp, "correspondence") == {"max_distance_px": 5.5, "depth_smoothing": 7.0}
    assert stage_options(exp, "fit")["smoothing_length_mm"] == 12.0
    assert stage_options(exp, "ordering")["overrides"] == [{"frame": 0, "view": 1, "junction": 0, "branch": 1}]
    with pytest.raises(ValueError, match="stage must be one of"):
        stage_options(exp, "skeleton")


class _Reached(Exception):
    """Raised by a recording stand-in once the options are recorded."""


def _record(calls: dict, name: str, result=None, stop: bool = False):
    def fn(*args, **kwargs):
        calls[name] = kwargs
        if stop:
            raise _Reached(name)
        return result() if callable(result) else result
    return fn


def test_the_pipeline_passes_every_option(monkeypatch):
    """reconstruct_frame hands each stage the experiment's values (stand-ins record what they get)."""
    from tendrilkit import pipeline
    from tendrilkit.camera import Camera

    exp = _experiment(**NON_DEFAULT)
    calls: dict = {}
    seg = types.SimpleNamespace(centroid_xy=(1.0, 2.0), n_components=1, mask_roi=np.ones((4, 4), bool),
                                roi_offset_xy=(0, 0), foreground=None)
    oc = types.SimpleNamespace(points_xy=np.c_[np.arange(5.0), np.arange(5.0)], n_crossings=0, decisions=[])
    monkeypatch.setattr(pipeline, "segment_view", _record(calls, "segmentation", seg))
    monkeypatch.setattr(pipeline, "order_skeleton", _record(calls, "ordering", oc))
    monkeypatch.setattr(pipeline, "match_epipolar", _record(calls, "correspondence", np.zeros((2, exp.points, 2))))
    monkeypatch.setattr(pipeline, "triangulate", _record(calls, "triangulation", stop=True))
    cams = [Camera(K=np.eye(3), t_mm=np.zeros(3)) for _ in range(2)]
    with pytest.raises(_Reached):
        pipeline.reconstruct_frame([np.zeros((4, 4, 3), np.uint8)] * 2, cams, exp, frame=0)
    for stage in ("segmentation", "ordering", "correspondence", "triangulation"):
        got = calls[stage]
        for key, value in stage_options(exp, stage).items():
            assert got[key] == value, (stage, key, got.get(key), value)

    import tendrilkit.pwc

    monkeypatch.setattr(tendrilkit.pwc, "fit_piecewise_clothoid", _record(calls, "fit", stop=True))
    with pytest.raises(_Reached):
        pipeline._fit(np.c_[np.arange(20.0), np.zeros(20), np.zeros(20)], exp, 0, 0.0)
    assert {k: calls["fit"][k] for k in EXPECTED["fit"]} == stage_options(exp, "fit")


def test_the_multiview_pipeline_passes_its_options(monkeypatch):
    import tendrilkit.evidence
    import tendrilkit.multiview
    import tendrilkit.mv_evidence
    from tendrilkit import pipeline
    from tendrilkit.camera import Camera

    exp = _experiment(**{**NON_DEFAULT, "reconstruction": {"method": "multiview", "segment_mm": 2.0,
                                                                           "choice_candidates": 1,
                                                                           "front_line_contrast": 0.15,
                                                                           "colour_px": 0.5}})
    calls: dict = {}
    monkeypatch.setattr(tendrilkit.evidence, "view_evidence", _record(calls, "segmentation", object()))
    monkeypatch.setattr(tendrilkit.mv_evidence, "skeleton_evidence", _record(calls, "evidence", object()))
    monkeypatch.setattr(tendrilkit.multiview, "base_point_from_marks", _record(calls, "base", np.zeros(3)))
    monkeypatch.setattr(tendrilkit.mv_evidence, "attach_chroma", lambda ev, image: calls.setdefault("chroma", []).append(ev))
    monkeypatch.setattr(tendrilkit.multiview, "reconstruct_multiview", _record(calls, "multiview", stop=True))
    cams = [Camera(K=np.eye(3), t_mm=np.zeros(3)) for _ in range(2)]
    with pytest.raises(_Reached):
        pipeline.reconstruct_frame([np.zeros((4, 4, 3), np.uint8)] * 2, cams, exp, frame=0)
    assert calls["multiview"]["segment_mm"] == 2.0
    assert calls["multiview"]["choice_candidates"] == 1
    assert calls["multiview"]["colour_px"] == 0.5 and len(calls["chroma"]) == 2  # each view's colour read
    assert calls["evidence"]["front_line_contrast"] == 0.15
    for key, value in stage_options(exp, "segmentation").items():
        assert calls["segmentation"][key] == value


def _stage_function(stage: str):
    import importlib

    module, name = STAGE_FUNCTIONS[stage].split(":")
    return getattr(importlib.import_module(module), name)


def test_params_holds_no_second_default():
    """The sections' defaults are read from the signatures: none is written in params.py; validating an
    experiment imports no stage module (an error in the file is reported at once)."""
    for stage, secs in STAGE_SECTIONS.items():
        for section, prefix in secs:
            cls = type(getattr(_experiment(), section))
            for key, info in cls.model_fields.items():
                if key in SWITCHES.get(section, ()):
                    continue
                assert info.default_factory is not None, f"{section}.{key} holds its own default"
    import subprocess
    import sys

    code = ("import sys; from tendrilkit.params import example_experiment_data, parse_experiment; "
            "parse_experiment(example_experiment_data()); "
            "print(sorted(m for m in sys.modules if m.startswith('tendrilkit.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert "segmentation" not in out and "pwc" not in out and "skeleton" not in out, out
