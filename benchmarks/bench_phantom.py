"""Phantom generation speed: the four default experiments, per stage.

    .venv/bin/python benchmarks/bench_phantom.py [--frames N] [--workers 2] [--sites S1,S3]

Per site: ``make_phantom`` (designs, constraint checks, scene, marks), the
static scene of one view (rendered once per view), one frame of one view
(tendril, blur, noise), and the whole ``write_phantom_experiment`` (three
mp4v videos and the ground truth) into a temporary folder. Then the total for
all sites, in sequence or over ``--workers`` processes. Wall and CPU seconds:
on a shared machine the wall time mostly says how busy it is.

Measured 2026-11-25 (2 cores shared with other jobs, load about 5), 60 frames:
CPU 29-35 s, wall 55-70 s for the four sites in sequence (about 8 s CPU each: 1 s make_phantom,
3 x 0.7 s static scene, 180 x ~25 ms frames with encoding).
"""

from __future__ import annotations

import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import cv2

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))


def _one(site: str, n_frames: int, out: str) -> tuple[str, float, float]:
    from tendrilkit.phantom import write_phantom_experiment

    cv2.setNumThreads(1)
    w0, c0 = time.perf_counter(), time.process_time()
    write_phantom_experiment(site, Path(out) / site, n_frames=n_frames)
    return site, time.perf_counter() - w0, time.process_time() - c0


def stages(sites: list[str], n_frames: int) -> None:
    from tendrilkit import phantom as P
    from tendrilkit.phantom.render import static_layers

    print(f"{'site':>4} {'make s':>7} {'static s':>8} {'frame ms':>8} {'write s':>8} {'cpu s':>6}")
    for site in sites:
        t0 = time.perf_counter()
        ph = P.make_phantom(site, n_frames=n_frames)
        t_make = time.perf_counter() - t0
        t0 = time.perf_counter()
        static_layers(ph, 1)
        t_static = time.perf_counter() - t0
        t0 = time.perf_counter()
        for f in range(min(5, ph.n_frames)):
            P.render_view(ph, f, 1)
        t_frame = (time.perf_counter() - t0) / min(5, ph.n_frames)
        del ph  # its static layers go with it
        with tempfile.TemporaryDirectory() as d:
            _, wall, cpu = _one(site, n_frames, d)
        print(f"{site:>4} {t_make:7.2f} {t_static:8.2f} {1000 * t_frame:8.1f} {wall:8.1f} {cpu:6.1f}")


def total(sites: list[str], n_frames: int, workers: int) -> None:
    with tempfile.TemporaryDirectory() as d:
        w0, c0 = time.perf_counter(), time.process_time()
        if workers <= 1:
            res = [_one(s, n_frames, d) for s in sites]
        else:
            with ProcessPoolExecutor(workers) as ex:
                res = list(ex.map(_one, sites, [n_frames] * len(sites), [d] * len(sites)))
        wall = time.perf_counter() - w0
    cpu = sum(r[2] for r in res)
    print(f"all of {','.join(sites)} ({n_frames} frames, {workers} process(es)): wall {wall:.1f} s, CPU {cpu:.1f} s")


if __name__ == "__main__":
    args = sys.argv[1:]

    def opt(name: str, default: str) -> str:
        return args[args.index(name) + 1] if name in args else default

    n = int(opt("--frames", "60"))
    sites = opt("--sites", "S1,S2,S3,S4").split(",")
    workers = int(opt("--workers", "1"))
    stages(sites, n)
    total(sites, n, workers)
