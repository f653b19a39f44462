"""Speed of the per-view 2D stage: segmentation + skeleton + ordering of one 1080p view.

    .venv/bin/python benchmarks/bench_2d.py                 # synthetic 1080p views
    .venv/bin/python benchmarks/bench_2d.py phantom [SITES] # rendered phantom views (last frame of 12)

One core (``cv2.setNumThreads(1)``, and the process should not share its core:
numbers on a busy machine are upper bounds). The target is 20 ms per view.
Wall-clock medians, the best run and the median CPU time (``process_time``,
less sensitive to other processes on the machine) are printed. The synthetic
views are a dark tube 9 px wide on a white board with a
self-crossing (an off-plane curl), drawn into a 1920 x 1080 frame with a 700 x
700 px ROI; the stage timings split the total into segmentation, thinning,
the skan graph and the walk; the segmentation's CPU time is also given
without its faint pixels (``local_contrast=0``, the global threshold alone),
timed interleaved with the default.
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import cv2
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tendrilkit.segmentation import segment_view  # noqa: E402
from tendrilkit.skeleton import order_skeleton, process_view  # noqa: E402


def synthetic_view(kind: str = "crossing", width: int = 9, seed: int = 0):
    """A 1080p BGR view with one tendril; returns image, roi, keep_out, base_point_xy."""
    rng = np.random.default_rng(seed)
    img = np.full((1080, 1920, 3), 235, np.uint8)
    img = np.clip(img + rng.normal(0, 3, img.shape), 0, 255).astype(np.uint8)
    # lead-in from the base, then (crossing) a prolate-trochoid curl, then the tip
    lead = np.c_[np.linspace(700, 900, 300), np.linspace(300, 420, 300)]
    d = (lead[-1] - lead[-2]) / np.hypot(*(lead[-1] - lead[-2]))
    ph = np.linspace(0, 2 * np.pi, 800) if kind == "crossing" else np.zeros(1)
    a, r = 35.0, 110.0
    u, v = a * ph + r * np.sin(ph), r * (1 - np.cos(ph))  # along d, across d
    curl = lead[-1] + u[:, None] * d + v[:, None] * np.array([-d[1], d[0]])
    d2 = d if len(curl) < 2 else (curl[-1] - curl[-2]) / np.hypot(*(curl[-1] - curl[-2]))
    tail = curl[-1] + np.linspace(0, 250, 300)[:, None] * d2
    pts = np.vstack([lead, curl[1:], tail[1:]])
    x, y = pts[:, 0], pts[:, 1]
    # stem: a thick vertical bar at the base, separated by the keep-out box
    cv2.line(img, (680, 150), (680, 600), (60, 120, 70), 14)
    cv2.polylines(img, [np.round(np.vstack([[680, y[0]], pts]) * 16).astype(np.int32)], False, (40, 150, 90), width, cv2.LINE_AA, 4)
    roi = (660, 150, 700, 700)
    keep_out = (670, int(y[0]) - 20, 25, 40)
    base = (float(x[0]), float(y[0]))
    return img, roi, keep_out, base


def time_view(img, roi, keep_out, base, repeat: int = 30, **options) -> dict:
    process_view(img, roi=roi, keep_out=keep_out, base_point_xy=base, ordering=options)  # warm-up (numba, caches)
    tot, seg_t, ord_t, cpu, seg_cpu, thr_cpu = [], [], [], [], [], []
    for _ in range(repeat):
        c0 = time.process_time()  # the segmentation without and with its faint pixels, interleaved (CPU time)
        segment_view(img, roi=roi, keep_out=keep_out, base_point_xy=base, local_contrast=0.0, line_width_px=0)
        c1 = time.process_time()
        segment_view(img, roi=roi, keep_out=keep_out, base_point_xy=base)
        thr_cpu.append(c1 - c0)
        seg_cpu.append(time.process_time() - c1)
        t0 = time.perf_counter()
        seg = segment_view(img, roi=roi, keep_out=keep_out, base_point_xy=base)
        t1 = time.perf_counter()
        order_skeleton(seg.mask_roi, offset_xy=seg.roi_offset_xy, base_point_xy=base, **options)
        t2 = time.perf_counter()
        seg_t.append(t1 - t0)
        ord_t.append(t2 - t1)
        t0, c0 = time.perf_counter(), time.process_time()
        process_view(img, roi=roi, keep_out=keep_out, base_point_xy=base, ordering=options)
        tot.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    ms = lambda v: 1000 * float(np.median(v))  # noqa: E731
    return {"total_ms": ms(tot), "segment_ms": ms(seg_t), "skeleton_order_ms": ms(ord_t),
            "best_total_ms": 1000 * min(tot), "cpu_ms": ms(cpu), "segment_cpu_ms": ms(seg_cpu),
            "threshold_only_cpu_ms": ms(thr_cpu)}


def bench_synthetic() -> None:
    for kind in ("plain", "crossing"):
        img, roi, keep_out, base = synthetic_view(kind)
        r = time_view(img, roi, keep_out, base)
        print(f"synthetic {kind:9s} total {r['total_ms']:6.2f} ms (best {r['best_total_ms']:.2f}, cpu {r['cpu_ms']:.2f})  "
              f"segment {r['segment_ms']:.2f}  skeleton+order {r['skeleton_order_ms']:.2f}  "
              f"segment cpu {r['segment_cpu_ms']:.2f} (threshold only {r['threshold_only_cpu_ms']:.2f})")


def bench_phantom(sites: list[str]) -> None:
    from tendrilkit.phantom import make_phantom, render_view

    for site in sites:
        ph = make_phantom(site, n_frames=12, seed=0)
        for v in range(len(ph.cameras)):
            img = render_view(ph, 11, v)  # the last, most curled frame
            marks = ph.views[v]
            r = time_view(img, marks["roi"], marks["keep_out"], marks["base_point"], repeat=15)
            print(f"phantom {site} view {v + 1} (roi {marks['roi'][2]}x{marks['roi'][3]}): total {r['total_ms']:6.2f} ms "
                  f"(best {r['best_total_ms']:.2f}, cpu {r['cpu_ms']:.2f})  segment {r['segment_ms']:.2f}  "
                  f"skeleton+order {r['skeleton_order_ms']:.2f}  segment cpu {r['segment_cpu_ms']:.2f} "
                  f"(threshold only {r['threshold_only_cpu_ms']:.2f})")


if __name__ == "__main__":
    cv2.setNumThreads(1)
    args = sys.argv[1:]
    if args and args[0] == "phantom":
        bench_phantom(args[1:] or ["S1", "S2", "S3", "S4"])
    else:
        bench_synthetic()
