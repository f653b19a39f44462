"""Speed of the whole reconstruction of one 3-view 1080p frame, on one core.

    .venv/bin/python benchmarks/bench_reconstruct.py               # synthetic views, the IJCV25 rig
    .venv/bin/python benchmarks/bench_reconstruct.py phantom [S3]  # a rendered phantom frame

Target: at most 0.2 s per frame (2D stage of three views, matching,
triangulation, resampling, Table 1, piece-wise clothoid fit); for
``reconstruction.method: multiview`` at most 0.15 s per frame, median (a
tracked frame, from the previous frame's curve), the worst case being an
acquisition (the first frame of a chunk, or tracking lost). One core:
``cv2.setNumThreads(1)`` and single-threaded BLAS; numbers on a machine shared
with other jobs are upper bounds. Prints the median of several repetitions,
total and per stage, for both correspondence methods, and the time to read
the three frames from the videos (phantom only).
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import cv2  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tendrilkit.phantom import render_tube_views  # noqa: E402
from tendrilkit.pipeline import reconstruct_frame  # noqa: E402

REPEATS = 7


def time_frame(images, cams, exp, *, previous_mm=None, clock=time.perf_counter, repeats: int = REPEATS):
    """Reconstruct frame 1 ``repeats`` times after a warm-up: (seconds per run, the last result, stage seconds per run)."""
    reconstruct_frame(images, cams, exp, frame=1, previous_mm=previous_mm)  # warm-up: compiled kernels, caches
    totals, stages = [], {}
    for _ in range(repeats):
        t0 = clock()
        r = reconstruct_frame(images, cams, exp, frame=1, previous_mm=previous_mm)
        totals.append(clock() - t0)
        for k, v in r.timings.items():
            stages.setdefault(k, []).append(v)
    return totals, r, stages


def synthetic_frame():
    """Three 1080p views of a curled 3D tube (9 px wide) through the IJCV25 rig; cameras; experiment."""
    s = np.linspace(0, 1, 3000)
    th = np.clip(s - 0.4, 0, None) * 6 * np.pi
    X = np.c_[-5 + 50 * s, 6 * np.sin(th), 20 + 6 * (1 - np.cos(th))]
    images, cams, exp = render_tube_views(X, width_px=9, margin_px=40, name="bench", fps=30)
    return images, cams, exp, None


def phantom_frame(site: str = "S3"):
    from tendrilkit.extrinsics import calibrate_experiment
    from tendrilkit.io import open_views
    from tendrilkit.params import load_experiment
    from tendrilkit.phantom import write_phantom_experiment

    tmp = Path(tempfile.mkdtemp(prefix="bench_reconstruct_"))
    path = write_phantom_experiment(site, tmp, n_frames=3, seed=0)
    exp = load_experiment(path)
    cams = calibrate_experiment(exp).cameras
    sources = open_views(list(exp.videos))
    t_read = []
    for _ in range(REPEATS):
        t0 = time.perf_counter()
        images = [s.read(1) for s in sources]
        t_read.append(time.perf_counter() - t0)
    for s in sources:
        s.close()
    return images, cams, exp, float(np.median(t_read))


def main(argv: list[str]) -> None:
    cv2.setNumThreads(1)
    if argv and argv[0] == "phantom":
        images, cams, exp, t_read = phantom_frame(argv[1] if len(argv) > 1 else "S3")
        what = f"phantom {argv[1] if len(argv) > 1 else 'S3'}"
    else:
        images, cams, exp, t_read = synthetic_frame()
        what = "synthetic"
    print(f"{what}: 3 views {images[0].shape[1]}x{images[0].shape[0]}, {exp.points} points, one core")
    if t_read is not None:
        print(f"  reading the 3 frames: {t_read * 1e3:.1f} ms (not counted below)")
    for method in ("epipolar", "frechet"):
        e = exp.model_copy(update={"correspondence": exp.correspondence.model_copy(update={"method": method})})
        totals, r, stages = time_frame(images, cams, e)
        split = ", ".join(f"{k} {np.median(v) * 1e3:.1f}" for k, v in stages.items())
        tot = np.median(totals)
        print(f"  {method:8s}: {tot * 1e3:6.1f} ms per frame [{'ok' if tot <= 0.2 else 'OVER'} vs 200 ms] "
              f"({r.status}{': ' + r.message if r.message else ''}); stages ms: {split}")
    e = exp.model_copy(update={"reconstruction": exp.reconstruction.model_copy(update={"method": "multiview"})})
    first = reconstruct_frame(images, cams, e, frame=1)  # the curve the tracked frames start from
    for mode, prev in (("acquired", None), ("tracked", first.points_mm)):
        totals, r, stages = time_frame(images, cams, e, previous_mm=prev)
        split = ", ".join(f"{k} {np.median(v) * 1e3:.1f}" for k, v in stages.items())
        tot = np.median(totals)
        print(f"  multiview {mode:8s}: median {tot * 1e3:6.1f} ms, worst {max(totals) * 1e3:6.1f} ms per frame "
              f"[{'ok' if tot <= 0.15 else 'OVER'} vs 150 ms] ({r.status}{': ' + r.message if r.message else ''}); "
              f"stages ms: {split}")


if __name__ == "__main__":
    main(sys.argv[1:])
