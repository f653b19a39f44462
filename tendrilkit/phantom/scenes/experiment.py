"""A random scene's files as text: the experiment file and ``gt_meta.json`` (no disk access).

Written by :func:`tendrilkit.io.write_scene_experiment` with the site
phantoms' ground-truth tables (:func:`tendrilkit.phantom.experiment.ground_truth_tables`).
"""

from __future__ import annotations

import numpy as np

from tendrilkit.phantom.experiment import _fmt, phantom_meta, rig_and_marks_yaml
from tendrilkit.phantom.scenes.factors import active_factors
from tendrilkit.phantom.scenes.make import SCENE_VERSION, ScenePhantom


def scene_stamp(seed: int, scene: str, n_frames: int) -> dict:
    """What makes a scene's files: if a folder's ``.phantom_stamp.json`` equals it, nothing is regenerated."""
    return {"scene_version": SCENE_VERSION, "scene": scene, "seed": int(seed), "n_frames": int(n_frames)}


def scene_params_yaml(ph: ScenePhantom) -> str:
    """The experiment file (EXPERIMENT_FORMAT.md) of a scene, as text (videos beside it)."""
    fmt = _fmt
    world = ph.scene.markers[0]
    lines = [
        f"# Random phantom scene '{ph.scene_name}', seed {ph.seed}: a synthetic tendril with exact ground truth,",
        f"# made by tendrilkit.scenes (scene version {SCENE_VERSION}, {ph.n_frames} frames).",
        f"#   python -m tendrilkit phantom --scene {ph.scene_name} --seed {ph.seed} --frames {ph.n_frames} --out <folder>",
        "# Factors: " + ", ".join(scene_meta(ph)["active_factors"]),
        "# The marks (roi, keep_out, base_point) are what a user marked on frame 0.",
        f"name: {ph.name}",
        f"videos: [{', '.join(f'view{v + 1}.mp4' for v in range(len(ph.cameras)))}]",
        f"fps: {fmt(ph.fps)}",
        "reference_view: 2",
        *rig_and_marks_yaml(ph.cameras, ph.views, marker_id=world.id, marker_mm=world.length_mm),
    ]
    return "\n".join(lines) + "\n"


def scene_meta(ph: ScenePhantom) -> dict:
    """``gt_meta.json`` of a scene: the phantom's keys plus ``scene``, ``factors``, ``active_factors``,
    ``realised``, ``imaging``, ``design_time_s``, ``hidden_fraction`` and ``seen_whole_views``."""
    meta = phantom_meta(ph)
    meta.update({
        "scene": ph.scene_name, "scene_version": SCENE_VERSION, "factors": ph.factors, "active_factors": active_factors(ph.factors),
        "realised": _jsonable(ph.realised), "imaging": _jsonable(ph.imaging),
        "design_time_s": [float(t) for t in ph.design_time_s],
        "hidden_fraction": np.round(ph.hidden_fraction, 4).tolist(),
        "seen_whole_views": [[v + 1 for v in range(ph.hidden_fraction.shape[1]) if ph.hidden_fraction[f, v] <= 0.1]
                             for f in range(ph.n_frames)],
    })
    return meta


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.floating,)):
        return float(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    return x
