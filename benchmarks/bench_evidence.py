"""Speed of the per-view evidence (:func:`tendrilkit.evidence.view_evidence`) and of its sampler.

    .venv/bin/python benchmarks/bench_evidence.py            # synthetic 1080p view (bench_2d's)
    .venv/bin/python benchmarks/bench_evidence.py phantom    # a rendered S3 phantom frame, three views

One core (``cv2.setNumThreads(1)``); numbers on a busy machine are upper
bounds: the CPU time (``process_time``) is printed beside the wall-clock
median. Target: under 5 ms per 1080p view without the skeleton.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_2d import synthetic_view  # noqa: E402

from tendrilkit.evidence import sample_distance, view_evidence  # noqa: E402


def time_it(fn, repeat: int = 30) -> tuple[float, float]:
    fn()
    wall, cpu = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return 1e3 * float(np.median(wall)), 1e3 * float(np.median(cpu))


def report(label: str, img, roi, keep_out, base) -> None:
    for sk in (False, True):
        w, c = time_it(lambda: view_evidence(img, roi=roi, keep_out=keep_out, base_point_xy=base, skeleton=sk))
        print(f"{label:<22} skeleton={sk!s:<5}  median {w:6.2f} ms  cpu {c:6.2f} ms")
    ev = view_evidence(img, roi=roi, keep_out=keep_out, base_point_xy=base, skeleton=False)
    xy = np.random.default_rng(0).uniform([roi[0], roi[1]], [roi[0] + roi[2], roi[1] + roi[3]], (1000, 2))
    w, c = time_it(lambda: sample_distance(ev, xy), repeat=200)
    print(f"{label:<22} sample_distance of 1000 points: {1e3 * w:7.1f} us")


def main() -> None:
    cv2.setNumThreads(1)
    if len(sys.argv) > 1 and sys.argv[1] == "phantom":
        from tendrilkit.phantom import make_phantom, render_view

        ph = make_phantom("S3", n_frames=12)
        for v in range(3):
            m = ph.views[v]
            report(f"phantom S3 view {v + 1}", render_view(ph, 11, v), m["roi"], m["keep_out"], m["base_point"])
    else:
        img, roi, keep_out, base = synthetic_view()
        report("synthetic 1080p", img, roi, keep_out, base)


if __name__ == "__main__":
    main()
