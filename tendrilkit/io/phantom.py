"""The files of synthetic experiments (phantoms and random scenes): writing them, reading the truth back.

:mod:`tendrilkit.phantom` makes the data, the text and the frames and never
touches the disk; these functions write them (videos, experiment file,
ground truth, a stamp that skips regeneration) with :mod:`tendrilkit.io`'s
atomic writers and read the ground truth back. :mod:`tendrilkit.phantom`
re-exports them (its public paths).
"""

from __future__ import annotations

import json
from pathlib import Path

from tendrilkit.exceptions import ExperimentError
from tendrilkit.io import (check_writable_dir, read_cameras, read_csv, write_cameras, write_csv, write_json, write_text,
                           write_video)

_STAMP = ".phantom_stamp.json"


def _stamp_matches(out: Path, stamp: dict, outputs: tuple[str, ...]) -> bool:
    """True if ``out`` holds every output and the same stamp; otherwise the stale stamp is removed."""
    path = out / _STAMP
    if path.is_file() and all((out / f).is_file() for f in outputs):
        try:
            if json.loads(path.read_text(encoding="utf-8")) == json.loads(json.dumps(stamp)):
                return True
        except json.JSONDecodeError:
            pass
    if path.exists():
        path.unlink()
    return False


def _write_synthetic(out: Path, ph, render, *, text: str, stamp: dict, meta: dict | None = None) -> Path:
    """Videos (``render(ph, frame, view)`` per frame), ground truth, experiment file, then the stamp."""
    for v in range(len(ph.cameras)):
        write_video((render(ph, f, v) for f in range(ph.n_frames)), out / f"view{v + 1}.mp4",
                    fps=float(ph.options["container_fps"]))
    write_ground_truth(ph, out / "ground_truth", meta=meta)
    write_text(text, out / "experiment.yaml")
    write_json(stamp, out / _STAMP)
    return out / "experiment.yaml"


def write_phantom_experiment(site: str, out_dir: str | Path, *, n_frames: int | None = None, seed: int = 0,
                             **options) -> Path:
    """Write a phantom experiment: three videos, the experiment file and the ground truth.

    Parameters
    ----------
    site : {"S1", "S2", "S3", "S4"}
    out_dir : path
        Created if needed. If it already holds the same experiment (same
        site, seed, frames, options and generator version, recorded in
        ``.phantom_stamp.json``) nothing is regenerated.
    n_frames : int, optional, keyword-only
        Default :data:`tendrilkit.phantom.DEFAULT_N_FRAMES` (60: one frame every 15 s for 15 min).
    seed : int, keyword-only
    **options
        See :data:`tendrilkit.phantom.DEFAULT_OPTIONS`.

    Returns
    -------
    Path
        ``out_dir/experiment.yaml``.

    Notes
    -----
    Files: ``view1.mp4 .. view3.mp4`` (mp4v at the ``container_fps`` option);
    ``experiment.yaml`` (:func:`tendrilkit.phantom.phantom_params_yaml`);
    ``ground_truth/``: ``gt_curves.csv``, ``gt_laws.csv``,
    ``gt_projections.csv`` (:func:`tendrilkit.phantom.experiment.ground_truth_tables`),
    ``true_cameras.json`` (cameras.json format) and ``gt_meta.json``
    (:func:`tendrilkit.phantom.experiment.phantom_meta`).
    """
    from tendrilkit.phantom.design import DEFAULT_N_FRAMES
    from tendrilkit.phantom.experiment import OUTPUTS, params_yaml_of, phantom_stamp
    from tendrilkit.phantom.make import _resolve_options, make_phantom
    from tendrilkit.phantom.render import render_view

    n = DEFAULT_N_FRAMES if n_frames is None else int(n_frames)
    opts = _resolve_options(options)
    out = check_writable_dir(out_dir)
    stamp = phantom_stamp(site, seed, n, opts)
    if _stamp_matches(out, stamp, OUTPUTS):
        return out / "experiment.yaml"
    ph = make_phantom(site, n_frames=n, seed=seed, **options)
    return _write_synthetic(out, ph, render_view, text=params_yaml_of(ph), stamp=stamp)


def write_scene_experiment(out_dir: str | Path, *, seed: int, scene: str = "random",
                           n_frames: int | None = None) -> Path:
    """Write a random phantom scene (:func:`tendrilkit.phantom.scenes.make_scene`) like a phantom experiment.

    Same files as :func:`write_phantom_experiment` (so ``reconstruct`` and
    :func:`read_ground_truth` work on it); ``gt_meta.json`` also holds the
    scene's factors (:func:`tendrilkit.phantom.scenes.experiment.scene_meta`).
    An existing folder with the same stamp (seed, scene, frames, scene
    version) is left alone. Returns ``out_dir/experiment.yaml``.
    """
    from tendrilkit.phantom.experiment import OUTPUTS
    from tendrilkit.phantom.scenes.experiment import scene_meta, scene_params_yaml, scene_stamp
    from tendrilkit.phantom.scenes.make import DEFAULT_SCENE_FRAMES, make_scene
    from tendrilkit.phantom.scenes.render import render_scene_view

    n = DEFAULT_SCENE_FRAMES if n_frames is None else int(n_frames)
    out = check_writable_dir(out_dir)
    stamp = scene_stamp(seed, scene, n)
    if _stamp_matches(out, stamp, OUTPUTS):
        return out / "experiment.yaml"
    ph = make_scene(seed, scene=scene, n_frames=n)
    return _write_synthetic(out, ph, render_scene_view, text=scene_params_yaml(ph), stamp=stamp, meta=scene_meta(ph))


def write_ground_truth(phantom, folder: str | Path, *, meta: dict | None = None) -> Path:
    """Write a phantom's ground truth into ``folder``: three CSV tables, ``true_cameras.json``, ``gt_meta.json``.

    ``meta`` replaces :func:`tendrilkit.phantom.experiment.phantom_meta` (a scene's has more keys).
    """
    from tendrilkit.phantom.experiment import ground_truth_tables, phantom_meta

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    tables = ground_truth_tables(phantom)
    for name, fmt in (("gt_curves", "%.6f"), ("gt_laws", "%.9g"), ("gt_projections", "%.4f")):
        write_csv(tables[name], folder / f"{name}.csv", float_format=fmt)
    write_cameras(phantom.cameras, folder / "true_cameras.json")
    write_json(phantom_meta(phantom) if meta is None else meta, folder / "gt_meta.json")
    return folder


def find_ground_truth(exp):
    """The :class:`~tendrilkit.phantom.GroundTruth` beside a phantom experiment file, or ``None`` for a real one."""
    if exp.source is None:
        return None
    folder = Path(exp.source).parent / "ground_truth"
    if not (folder / "gt_meta.json").is_file():
        # params/phantom_S*.yaml point at the generated videos: the truth is beside them
        folder = Path(exp.videos[0]).parent / "ground_truth"
        if not (folder / "gt_meta.json").is_file():
            return None
    return read_ground_truth(folder)


def read_ground_truth(folder: str | Path):
    """Read a phantom's :class:`~tendrilkit.phantom.GroundTruth` (its folder or its ``ground_truth`` folder)."""
    from tendrilkit.phantom.experiment import GroundTruth

    folder = Path(folder)
    if (folder / "ground_truth").is_dir():
        folder = folder / "ground_truth"
    meta_path = folder / "gt_meta.json"
    if not meta_path.is_file():
        raise ExperimentError(f"{folder}: no phantom ground truth (gt_meta.json) here")
    meta = json.loads(meta_path.read_text(encoding="utf-8"))
    cur = read_csv(folder / "gt_curves.csv", required=("frame", "time_s", "point", "s_mm", "x_mm", "y_mm", "z_mm"))
    nf = int(cur["frame"].max()) + 1
    npt = int(cur["point"].max()) + 1
    cur = cur.sort_values(["frame", "point"])
    curves = cur[["x_mm", "y_mm", "z_mm"]].to_numpy().reshape(nf, npt, 3)
    s = cur["s_mm"].to_numpy()[:npt]
    t = cur["time_s"].to_numpy().reshape(nf, npt)[:, 0]
    pr = read_csv(folder / "gt_projections.csv", required=("frame", "view", "point", "x_px", "y_px"))
    nv = int(pr["view"].max())
    pr = pr.sort_values(["frame", "view", "point"])
    proj = pr[["x_px", "y_px"]].to_numpy().reshape(nf, nv, npt, 2)
    laws = read_csv(folder / "gt_laws.csv", required=("frame", "kind", "segment", "s0_mm", "s1_mm", "value_s0", "value_s1"))
    return GroundTruth(curves=curves, s_mm=s, time_s=t, laws=laws, projections=proj,
                       cameras=read_cameras(folder / "true_cameras.json"), meta=meta)
