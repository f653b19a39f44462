"""Speed of the whole reconstruction of one 3-view 1080p frame, on one core.

    .venv/bin/python benchmarks/bench_reconstruct.py               # synthetic views, the IJCV25 rig
    .venv/bin/python benchmarks/bench_reconstruct.py phantom [S3]  # a rendered phantom frame
    .venv/bin/python benchmarks/bench_reconstruct.py scenes 0:10 [DIR]  # multiview over random dev scenes

Target: at most 0.2 s per frame (2D stage of three views, matching,
triangulation, resampling, Table 1, piece-wise clothoid fit); for
``reconstruction.method: multiview`` at most 0.15 s per frame, median (a
tracked frame, from the previous frame's curve), the worst case being an
acquisition (the first frame of a chunk, or tracking lost). One core:
``cv2.setNumThreads(1)`` and single-threaded BLAS; numbers on a machine shared
with other jobs are upper bounds. Prints the median of several repetitions,
total and per stage, for both correspondence methods, and the time to read
the three frames from the videos (phantom only).

``scenes START:STOP``: ``reconstruction.method: multiview`` on every frame
(6 per scene) of the random dev scenes of :mod:`tendrilkit.phantom.scenes`
(seeds 0-9999 only; kept in DIR, default a temporary folder), in order,
each frame tracked from the previous one when that one is ``ok`` and
acquired otherwise, as ``tendrilkit reconstruct`` does: prints the median
and the worst ms per frame over all of them (acquisitions included), wall
and CPU (``time.process_time``), and the median per mode.

Measured (2026-12-02, issue 12): the acquisition's beam search
(:func:`tendrilkit.mv_acquire.grow_curve`) with its hypotheses in arrays
instead of a tuple each and each step's arithmetic in a few compiled calls
(per view one call: the ends' and midpoints' costs, ``advance``, the new
evidence and the colour; then the step's costs, the self-return check on the
nodes that can be near only, the junctions' siblings, the claims projected
and marked at once), the rotations and products numpy's as before. The same
curves: ``rerun_multiview.py --no-fit`` on dev seeds 1040-1079 (240 frames,
``line_width_px`` 11), curves and CSV byte for byte after each of the three
commits; tests pin every kernel and the whole search to d0679b9's numpy.
Old (d0679b9) and new checkouts alternated, 3 rounds, one core, load 3.0-5.0
on the 2 cores (other jobs): medians of the rounds.

- ``grow_curve`` alone (the 45 acquisitions of dev scenes 1040-1047, their
  inputs captured and replayed, each call's median of 3): mean 95.0 -> 58.4
  ms CPU per acquisition (rounds 95.0 / 97.1 / 91.8 -> 58.4 / 61.5 / 47.2).
- ``scenes 0:10`` (60 frames, 51 acquired, the default options): median
  333 -> 285 ms CPU per frame (333 / 344 / 327 -> 285 / 293 / 276), worst
  769 -> 521 (769 / 916 / 688 -> 583 / 521 / 514); acquired frames 348 ->
  293; tracked ones (9, code unchanged) 186 -> 222, the machine's noise. The
  issue's 150 ms median is not reached on this machine under this load.
- ``/work/runs/scr/profmv.py 1040 1048`` (48 frames with the fit, under
  cProfile): 368 -> 334 ms CPU per frame (386 / 368 / 353 -> 324 / 373 /
  334); its multiview stage 200 -> 160 ms mean (287 / 200 / 183 -> 160 /
  175 / 140).

What is left in ``grow_curve`` (line profile of the replay, 58 ms per
acquisition): each view's compiled step 41 % (within it the nearest skeleton
pixel search 57 %, the line distances 19 %, the projection 6 %; the
rotations before it numpy's), the look-ahead of steps fewer than two views see
6 %, the seeds 6 %, the claims 5 %, numpy's products (the cone's directions,
the turn, the cells' and siblings' directions) 3 % each.
Tried and not kept: (a) the products and rotations compiled as loops
(``np.einsum`` "ij,ij->i" and "hij,cj->hci", ``@ R.T``): numpy's einsum and
OpenBLAS use fused multiply-adds, the loops' last bits differ (on nearly
every one of about 300 random sizes); (b) the steps' ends rotated once for both their costs and
``advance`` (the rows of ``vstack([ends, mids]) @ R.T``): BLAS gave the same
rows in 3000 random trials but for single rows (numpy's gemv), no guarantee
across BLAS kernels, for about 2 ms per acquisition; (c) the nearest-pixel
search over the pixels' coordinates sorted by cell (a row of a ring one
contiguous span): the same rows on 2304 captured calls, the search 15 %
faster, about 2 ms per acquisition: not worth a second copy of
:mod:`tendrilkit.mv_evidence`'s search.
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
from tendrilkit.params import with_overrides  # noqa: E402
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


def scenes_frames(seeds: str, folder: str | None = None, n_frames: int = 6) -> None:
    """Time multiview on every frame of random dev scenes (see the module's docstring)."""
    from tendrilkit.extrinsics import calibrate_experiment
    from tendrilkit.io import open_views
    from tendrilkit.params import load_experiment
    from tendrilkit.phantom import write_scene_experiment

    start, stop = (int(x) for x in seeds.split(":"))
    if stop > 10000:
        raise SystemExit("seeds 10000 and above are reserved for the final benchmark")
    root = Path(folder) if folder else Path(tempfile.mkdtemp(prefix="bench_reconstruct_scenes_"))
    wall, cpu, modes = [], [], []
    for seed in range(start, stop):
        exp = load_experiment(write_scene_experiment(root / f"random-{seed}" / "scene", seed=seed, n_frames=n_frames))
        exp = exp.model_copy(update={"reconstruction": exp.reconstruction.model_copy(update={"method": "multiview"})})
        cams = calibrate_experiment(exp).cameras
        sources = open_views(list(exp.videos))
        images = [[s.read(f) for s in sources] for f in range(n_frames)]
        for s in sources:
            s.close()
        reconstruct_frame(images[0], cams, exp, frame=0, fit=True)  # warm-up
        state = None
        for f in range(n_frames):
            w0, c0 = time.perf_counter(), time.process_time()
            r = reconstruct_frame(images[f], cams, exp, frame=f, previous_mm=state)
            wall.append(time.perf_counter() - w0)
            cpu.append(time.process_time() - c0)
            modes.append("tracked" if state is not None else "acquired")
            state = r.points_mm if r.status == "ok" else None
    w, c, m = np.array(wall) * 1e3, np.array(cpu) * 1e3, np.array(modes)
    print(f"multiview, random dev scenes {seeds} x {n_frames} frames ({len(w)} frames, {int((m == 'acquired').sum())} "
          f"acquired), one core, load {os.getloadavg()[0]:.1f}:")
    print(f"  per frame: median {np.median(w):6.1f} ms wall, {np.median(c):6.1f} ms cpu; worst {w.max():6.1f} ms wall, "
          f"{c.max():6.1f} ms cpu [{'ok' if np.median(c) <= 150 else 'OVER'} vs 150 ms median]")
    for mode in ("acquired", "tracked"):
        if (m == mode).any():
            print(f"  {mode:8s}: median {np.median(w[m == mode]):6.1f} ms wall, {np.median(c[m == mode]):6.1f} ms cpu "
                  f"({int((m == mode).sum())} frames)")


def main(argv: list[str]) -> None:
    cv2.setNumThreads(1)
    if argv and argv[0] == "scenes":
        scenes_frames(argv[1] if len(argv) > 1 else "0:5", argv[2] if len(argv) > 2 else None)
        return
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
        e = with_overrides(exp, {"reconstruction": {"method": "chain"}, "correspondence": {"method": method}})
        totals, r, stages = time_frame(images, cams, e)
        split = ", ".join(f"{k} {np.median(v) * 1e3:.1f}" for k, v in stages.items())
        tot = np.median(totals)
        print(f"  chain, {method:8s}: {tot * 1e3:6.1f} ms per frame [{'ok' if tot <= 0.2 else 'OVER'} vs 200 ms] "
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
