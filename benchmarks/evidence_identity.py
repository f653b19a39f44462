"""Check that this checkout's per-frame evidence equals a cached run's, field by field, bit for bit; or time it.

    PYTHONPATH=. .venv/bin/python benchmarks/evidence_identity.py OUT [--scenes N] [--frames K] [--workers 2]
    PYTHONPATH=. .venv/bin/python benchmarks/evidence_identity.py OUT --time [--scenes N] [--frames K] [--repeat R]

``OUT`` is a ``benchmarks/rerun_multiview.py`` folder with ``OUT/evidence-cache/SCENE-FRAME.pkl`` (the
``(views, evidence, notes)`` of :func:`tendrilkit.pipeline.multiview_evidence`, made by the code to compare
with). Every cached frame of the first ``N`` scenes (frames ``0..K-1``) is read as the runner reads it
(:func:`tendrilkit.runner._read_views`), its evidence computed again and compared with the pickle: every
array's dtype, shape and bytes, every dataclass field and cached property (recursively), the k-d trees' data
and index arrays, the notes. Prints the frames that differ (and the first difference) and exits 1 if any.

With ``--time``: the frames are read first, then each frame's :func:`tendrilkit.evidence.view_evidence` and
:func:`tendrilkit.mv_evidence.skeleton_evidence` are timed per view (CPU, ``time.process_time``), ``R`` times
over all frames after one warm-up pass; prints one JSON line (medians over views and frames, ms). Run it with
the old and the new checkout's ``PYTHONPATH`` alternately to compare them on a shared machine.
"""

from __future__ import annotations

import argparse
import dataclasses
import functools
import json
import os
import pickle
import struct
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))  # rerun_multiview, beside it


def _scenes(out: Path, n: int | None) -> list[Path]:
    scenes = sorted((d for d in out.glob("random-*") if (d / "result-multiview" / "cameras.json").is_file()),
                    key=lambda d: int(d.name.rsplit("-", 1)[1]))
    return scenes if n is None else scenes[:n]


def _load_scene(folder: Path):
    """The scene's experiment (method forced to multiview) and cameras, as ``rerun_multiview`` reads them."""
    from rerun_multiview import scene_experiment

    return scene_experiment(folder)


def _frames(out: Path, folder: Path, k: int) -> list[int]:
    return [f for f in range(k) if (out / "evidence-cache" / f"{folder.name}-{f}.pkl").is_file()]


def _read(exp, frames: list[int]):
    from tendrilkit.io import open_views
    from tendrilkit.runner import _read_views

    sources = open_views(list(exp.videos))
    try:
        return [_read_views(sources, f) for f in frames]
    finally:
        for src in sources:
            src.close()


def _float_bits(x: float) -> bytes:
    return struct.pack("<d", x)


def difference(a, b, path: str = "") -> str | None:
    """Where ``a`` and ``b`` first differ (a path and why), None if they are the same bit for bit."""
    if type(a) is not type(b):
        return f"{path}: type {type(a).__name__} != {type(b).__name__}"
    if isinstance(a, np.ndarray):
        if a.dtype != b.dtype or a.shape != b.shape:
            return f"{path}: {a.dtype}{a.shape} != {b.dtype}{b.shape}"
        if a.dtype == object:
            for i, (x, y) in enumerate(zip(a.ravel(), b.ravel())):
                d = difference(x, y, f"{path}[{i}]")
                if d:
                    return d
            return None
        if np.ascontiguousarray(a).tobytes() != np.ascontiguousarray(b).tobytes():
            n = int(np.sum(~((a == b) | ((a != a) & (b != b))))) if a.dtype.kind in "fc" else int(np.sum(a != b))
            return f"{path}: {n} of {a.size} values differ"
        return None
    if isinstance(a, float):
        return None if _float_bits(a) == _float_bits(b) else f"{path}: {a!r} != {b!r}"
    if isinstance(a, (int, str, bool, bytes, type(None), np.generic)):
        return None if (a == b or (a != a and b != b)) else f"{path}: {a!r} != {b!r}"
    if isinstance(a, (list, tuple)):
        if len(a) != len(b):
            return f"{path}: length {len(a)} != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            d = difference(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    if isinstance(a, dict):
        if set(a) != set(b):
            return f"{path}: keys {sorted(map(str, a))} != {sorted(map(str, b))}"
        for k in a:
            d = difference(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        return None
    if type(a).__name__ == "cKDTree":
        for name in ("data", "indices", "leafsize", "m", "n", "maxes", "mins", "size"):
            d = difference(getattr(a, name), getattr(b, name), f"{path}.{name}")
            if d:
                return d
        return None
    if dataclasses.is_dataclass(a) or hasattr(a, "__dict__"):
        # the fields and every cached property computed on both sides (they are in the pickle too); a cached
        # property computed on one side only is not a difference of the evidence (the cache's cameras, e.g.,
        # were pickled after a reconstruction had read their ``has_distortion``)
        va, vb = dict(vars(a)), dict(vars(b))
        cached = {k for k in set(va) ^ set(vb) if isinstance(getattr(type(a), k, None), functools.cached_property)}
        return difference({k: v for k, v in va.items() if k not in cached},
                          {k: v for k, v in vb.items() if k not in cached}, path)
    return None if a == b else f"{path}: {a!r} != {b!r}"


def check_scene(args) -> list[str]:
    """The differences of one scene's cached frames (one line per differing frame)."""
    out, folder, k = args
    import cv2

    cv2.setNumThreads(1)
    from tendrilkit.pipeline import multiview_evidence

    exp, cameras = _load_scene(folder)
    frames = _frames(out, folder, k)
    lines = []
    for f, (images, errors) in zip(frames, _read(exp, frames)):
        new = multiview_evidence(images, cameras, exp, read_errors=errors)
        old = pickle.loads((out / "evidence-cache" / f"{folder.name}-{f}.pkl").read_bytes())
        d = difference(old, new, "")
        lines.append(f"{folder.name}-{f}: " + ("same" if d is None else f"DIFFERS {d}"))
    return lines


def time_frames(out: Path, scenes: list[Path], k: int, repeat: int) -> dict:
    """Per-view CPU times of view_evidence and skeleton_evidence, ms (medians), and per frame."""
    import cv2

    cv2.setNumThreads(1)
    from tendrilkit.evidence import view_evidence
    from tendrilkit.mv_evidence import skeleton_evidence
    from tendrilkit.pipeline import stage_options

    work = []
    for folder in scenes:
        exp, cameras = _load_scene(folder)
        frames = _frames(out, folder, k)
        for images, _ in _read(exp, frames):
            work.append((exp, cameras, images, stage_options(exp, "segmentation")))
    ve, se, fr = [], [], []
    for r in range(repeat + 1):
        for exp, cameras, images, seg in work:
            t_frame = 0.0
            for v, image in enumerate(images):
                m = exp.views[v]
                t0 = time.process_time()
                view = view_evidence(image, roi=m.roi, keep_out=m.keep_out, base_point_xy=m.base_point, **seg)
                t1 = time.process_time()
                skeleton_evidence(view, cameras[v], image_bgr=image,
                                  front_line_contrast=exp.reconstruction.front_line_contrast)
                t2 = time.process_time()
                if r:
                    ve.append(t1 - t0)
                    se.append(t2 - t1)
                t_frame += t2 - t0
            if r:
                fr.append(t_frame)
    med = lambda x: round(1000 * float(np.median(x)), 3)  # noqa: E731
    mean = lambda x: round(1000 * float(np.mean(x)), 3)  # noqa: E731
    return {"code": os.environ.get("PYTHONPATH", ""), "frames": len(work), "repeat": repeat,
            "view_evidence_ms": med(ve), "skeleton_evidence_ms": med(se), "frame_ms": med(fr),
            "view_evidence_mean_ms": mean(ve), "skeleton_evidence_mean_ms": mean(se), "frame_mean_ms": mean(fr),
            "load": os.getloadavg()[0]}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path)
    p.add_argument("--scenes", type=int, default=None, help="the first N scenes (default all)")
    p.add_argument("--frames", type=int, default=6, help="frames 0..K-1 of each scene (those cached)")
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--time", action="store_true", help="time the evidence instead of comparing it")
    p.add_argument("--repeat", type=int, default=1)
    a = p.parse_args(argv)
    os.environ.setdefault("TENDRILKIT_PROGRESS", "0")
    scenes = _scenes(a.out, a.scenes)
    if a.time:
        print(json.dumps(time_frames(a.out, scenes, a.frames, a.repeat)))
        return 0
    jobs = [(a.out, s, a.frames) for s in scenes]
    if a.workers > 1:
        with ProcessPoolExecutor(a.workers) as pool:
            results = list(pool.map(check_scene, jobs))
    else:
        results = [check_scene(j) for j in jobs]
    lines = [x for r in results for x in r]
    bad = [x for x in lines if "DIFFERS" in x]
    for x in bad:
        print(x)
    print(f"{len(lines)} frames of {len(scenes)} scenes compared: {len(lines) - len(bad)} identical, {len(bad)} differ")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
