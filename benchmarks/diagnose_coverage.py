"""What the coverage check counts against a curve: overlays of the explained and the missed skeleton per view.

    .venv/bin/python benchmarks/diagnose_coverage.py OUT TAG SCENE FRAME [--png DIR]

``OUT`` a folder of ``benchmarks/rerun_multiview.py`` (its scenes and evidence cache). The scene is re-run (as
``rerun_multiview`` does, with this checkout's code) and, for frame ``FRAME``, each view's image is drawn cropped to
its ROI with the curve's projection (blue), the skeleton the curve explains (green) and the skeleton the coverage
counts as the tendril's, missed (red): ``DIR/SCENE-FRAME-v<i>.png``; each view's coverage is printed. Diagnosis
only (:func:`tendrilkit.verify_coverage.coverage_frac`'s ``parts``).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))


def main(argv: list[str] | None = None) -> int:
    import cv2

    import tendrilkit.pipeline as pipeline
    import tendrilkit.verify as V
    from tendrilkit.io import open_views
    from tendrilkit.params import load_experiment

    from rerun_multiview import rerun_scene

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path)
    p.add_argument("tag")
    p.add_argument("scene")
    p.add_argument("frame", type=int)
    p.add_argument("--png", type=Path, default=Path("/tmp/coverage"))
    a = p.parse_args(argv)
    calls = []  # (frame, evidence, projected curve, parts, figure) of every coverage figure
    original, reconstruct = V.coverage_frac, pipeline.reconstruct_frame
    now = {"frame": None}

    def recording(ev, dense, *args, **kw):
        parts: dict = {}
        value = original(ev, dense, *args, parts=parts, **kw)
        calls.append((now["frame"], ev, np.asarray(dense, float), parts, value))
        return value

    def tagged(*args, frame, **kw):
        now["frame"] = frame
        return reconstruct(*args, frame=frame, **kw)

    V.coverage_frac, pipeline.reconstruct_frame = recording, tagged
    folder = a.out / a.scene
    try:
        rerun_scene(folder, a.out / "evidence-cache", fit=False)
    finally:
        V.coverage_frac, pipeline.reconstruct_frame = original, reconstruct
    exp = load_experiment(folder / "scene" / "experiment.yaml")
    sources = open_views(list(exp.videos))
    images = [src.read(a.frame) for src in sources]
    for src in sources:
        src.close()
    # the frame's last verification: one figure per view that has a skeleton
    mine = [c[1:] for c in calls if c[0] == a.frame][-len(images):]
    if not mine:
        print(f"{a.scene} frame {a.frame}: no coverage figure (not processed, or failed)")
        return 1
    a.png.mkdir(parents=True, exist_ok=True)
    for v, (ev, dense, parts, value) in enumerate(mine):
        x0, y0 = (int(t) for t in ev.roi_offset_xy)
        h, w = ev.shape
        img = images[v][y0:y0 + h, x0:x0 + w].copy()
        for xy, colour in ((dense, (255, 0, 0)), (parts.get("explained_xy"), (0, 200, 0)),
                           (parts.get("missed_xy"), (0, 0, 255))):
            if xy is None or len(xy) == 0:
                continue
            c = np.clip(np.rint(xy - [x0, y0]).astype(int), 0, [w - 1, h - 1])
            img[c[:, 1], c[:, 0]] = colour
        path = a.png / f"{a.scene}-{a.frame}-v{v + 1}.png"
        cv2.imwrite(str(path), img)
        print(f"view {v + 1}: coverage {value:.3f}, missed {len(parts.get('missed_xy', []))} px -> {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
