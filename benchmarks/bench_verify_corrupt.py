"""Are corrupted frames caught? Site phantom frames with one view made wrong after rendering.

    .venv/bin/python benchmarks/bench_verify_corrupt.py [SITE] [--frames 0:60:6]

Needs ``data/phantoms/<SITE>/`` (``python -m tendrilkit phantom --site all --out data/phantoms``).
Per frame and corruption, :func:`tendrilkit.pipeline.reconstruct_frame` on the
frame's views (true cameras from ``cameras.json`` of a calibration), then the
status and the mean error against the truth:

* ``clean``: nothing changed (must be ok);
* ``fake_tip_v1``: view 1's tendril erased beyond 45 % of its length and a
  false dark continuation drawn at 60 degrees (a stem piece or a leaf's edge
  taken for the tendril);
* ``camera_6px_v1`` / ``camera_12px_v1``: view 1's principal point off by
  6 / 12 px (a bumped camera);
* ``shifted_v2``: view 2's image shifted by 10 px (the camera moved after the
  calibration).

A row is a silent failure when ok with mean error > 1.5 mm.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))

from test_verify_pipeline import _fake_continuation  # noqa: E402

from tendrilkit.extrinsics import calibrate_experiment  # noqa: E402
from tendrilkit.camera import Camera  # noqa: E402
from tendrilkit.io import read_frames  # noqa: E402
from tendrilkit.params import load_experiment  # noqa: E402
from tendrilkit.evaluation import accuracy_against_truth  # noqa: E402
from tendrilkit.pipeline import reconstruct_frame  # noqa: E402


def _shift_k(cam: Camera, dx: float) -> Camera:
    K = cam.K.copy()
    K[0, 2] += dx
    return Camera(K=K, dist=cam.dist, R=cam.R, t_mm=cam.t_mm, width=cam.width, height=cam.height)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("site", nargs="?", default="S3")
    ap.add_argument("--frames", default="0:60:6")
    a = ap.parse_args()
    d = ROOT / "data" / "phantoms" / a.site
    exp = load_experiment(d / "experiment.yaml")
    cams = calibrate_experiment(exp).cameras
    truth = pd.read_csv(d / "ground_truth" / "gt_curves.csv")
    proj = pd.read_csv(d / "ground_truth" / "gt_projections.csv")
    start, stop, step = (int(x) for x in a.frames.split(":"))
    rows = []
    for f in range(start, stop, step):
        images = read_frames(exp, f)
        p1 = proj[(proj.frame == f) & (proj.view == 1)].sort_values("point")[["x_px", "y_px"]].to_numpy()
        shifted = np.roll(images[1], 10, axis=1)
        cases = {
            "clean": (images, cams),
            "fake_tip_v1": ([_fake_continuation(images[0], p1)] + images[1:], cams),
            "camera_6px_v1": (images, [_shift_k(cams[0], 6.0)] + cams[1:]),
            "camera_12px_v1": (images, [_shift_k(cams[0], 12.0)] + cams[1:]),
            "shifted_v2": ([images[0], shifted, images[2]], cams),
        }
        for name, (imgs, cs) in cases.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r = reconstruct_frame(imgs, cs, exp, frame=f)
            err = np.nan
            if r.points_mm is not None:
                P = r.points_mm
                c = pd.DataFrame({"frame": f, "point": np.arange(len(P)), "x_mm": P[:, 0], "y_mm": P[:, 1], "z_mm": P[:, 2]})
                err = float(accuracy_against_truth(c, truth[truth.frame == f]).mean_mm.iloc[0])
            rows.append({"frame": f, "case": name, "status": r.status, "mean_mm": err,
                         "first_check": r.message.split("; ")[0] if r.status != "ok" else ""})
            print(f"frame {f:3d} {name:<15} {r.status:<9} {err:7.2f} mm  {rows[-1]['first_check'][:90]}", flush=True)
    t = pd.DataFrame(rows)
    print()
    summ = t.groupby("case").agg(frames=("status", "size"), ok=("status", lambda s: int((s == "ok").sum())),
                                 doubtful=("status", lambda s: int((s == "doubtful").sum())),
                                 failed=("status", lambda s: int((s == "failed").sum())),
                                 silent=("mean_mm", lambda e: int(((t.loc[e.index, "status"] == "ok") & (e > 1.5)).sum())),
                                 median_mm=("mean_mm", "median"))
    print(summ.to_string())


if __name__ == "__main__":
    main()
