"""Accuracy and speed of the setup commands: intrinsics, marks, check.

    .venv/bin/python benchmarks/bench_setup.py [--seeds 0,1] [--frames 25]

Per seed (development seeds only, < 10000): a ChArUco board video per camera
of the phantom rig (:func:`tendrilkit.phantom.phantom_cameras`, 1920x1080,
lens distortion), rendered with :func:`tendrilkit.boards.render_board_frames`
and written as mp4v; ``intrinsics`` on each (error of fx, fy in %, of cx, cy
in px, RMS px, seconds); then an S3 phantom of 8 frames: ``marks``
suggestions against the hand-made marks (base point distance px, seconds)
and ``check`` (seconds, verdict). Wall-clock seconds on this machine; the
CPU seconds are printed too (the machine may be shared).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tendrilkit.boards import board_poses, parse_board, render_board_frames  # noqa: E402
from tendrilkit.intrinsics import calibrate_source  # noqa: E402
from tendrilkit.io import write_video  # noqa: E402
from tendrilkit.phantom import phantom_cameras, write_phantom_experiment  # noqa: E402


def _timed(fn, *a, **k):
    t, c = time.perf_counter(), time.process_time()
    out = fn(*a, **k)
    return out, time.perf_counter() - t, time.process_time() - c


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--frames", type=int, default=25)
    args = ap.parse_args()
    board = parse_board("charuco:9,6,40,30,DICT_5X5_100")
    for seed in [int(s) for s in args.seeds.split(",")]:
        if seed >= 10000:
            raise SystemExit("seeds >= 10000 are reserved for the final benchmark")
        with tempfile.TemporaryDirectory() as tmp:
            tmp = Path(tmp)
            for v, cam in enumerate(phantom_cameras(seed)):
                path = tmp / f"board{v + 1}.mp4"
                write_video(render_board_frames(board, cam, board_poses(board, cam, args.frames, seed=seed * 10 + v),
                                                seed=seed * 10 + v), path, fps=5)
                (res, cov, problems, _), wall, cpu = _timed(calibrate_source, path, board)
                K = res.K
                print(f"seed {seed} view {v + 1}: intrinsics fx {100 * (K[0, 0] / cam.K[0, 0] - 1):+.3f} % "
                      f"fy {100 * (K[1, 1] / cam.K[1, 1] - 1):+.3f} % cx {K[0, 2] - cam.K[0, 2]:+.2f} px "
                      f"cy {K[1, 2] - cam.K[1, 2]:+.2f} px RMS {res.rms_px:.3f} px "
                      f"{'ok' if not problems else problems}; {wall:.1f} s ({cpu:.1f} s CPU)")
            exp_path = write_phantom_experiment("S3", tmp / "S3", n_frames=8, seed=seed)
            from tendrilkit.marks import review_marks
            from tendrilkit.params import load_experiment
            from tendrilkit.preflight import run_check

            exp = load_experiment(exp_path, marks_optional=True)
            reviews, wall, cpu = _timed(review_marks, exp)
            for r in reviews:
                s = r.suggestion
                d = np.hypot(*(np.asarray(s.base_point) - r.user["base_point"])) if s and s.base_point else np.nan
                print(f"seed {seed} view {r.view}: suggested base point {d:.1f} px from the hand-made one; "
                      f"roi {s.roi if s else None} vs {r.user['roi']}; {r.line}")
            print(f"seed {seed}: marks {wall:.1f} s ({cpu:.1f} s CPU)")
            (code, report), wall, cpu = _timed(run_check, exp_path)
            print(f"seed {seed}: check exit {code}, {wall:.1f} s ({cpu:.1f} s CPU)")


if __name__ == "__main__":
    main()
