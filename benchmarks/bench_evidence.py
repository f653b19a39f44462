"""Speed of the per-view evidence (:func:`tendrilkit.evidence.view_evidence`) and of its sampler.

    .venv/bin/python benchmarks/bench_evidence.py            # synthetic 1080p view (bench_2d's)
    .venv/bin/python benchmarks/bench_evidence.py phantom    # a rendered S3 phantom frame, three views
    .venv/bin/python benchmarks/bench_evidence.py masks [--scene pale] [--seeds 0:6] [--frames 6] [--out DIR]
    .venv/bin/python benchmarks/bench_evidence.py lines [--seeds 0:40] [--frames 6] [--out DIR]

``lines``: the ROI's foreground (:func:`tendrilkit.segmentation.label_foreground`,
every component) with the experiment's options, with light lines
(``line_width_px``), with joins across crossings (``bridge_gap_px``) and with
both, interleaved per view; per look (pale / other) and overall: the share of
the true centreline's projected points (inside the ROI, outside the keep-out
box) within 1.5 px of the foreground (``found``), the pixels each variant adds
farther than 2 px from the true tube, per view (``false_px``; a second
tendril's pixels count as false), and the median CPU ms per view.

Measured 2026-11-30 (shared machine, load 17-21; CPU times are upper bounds),
``lines --seeds 0:40`` (720 views; 360 of pale tendrils): centre line found,
pale 0.789 -> 0.907 with light lines (``line_width_px: 11``), 0.795 with
joins (``bridge_gap_px: 30``), 0.915 with both; other looks 1.000 in every
variant; false pixels per view 0.65 (pale) / 3.0 (other) with light lines, 1.3
/ 2.1 with joins; CPU per view 4.2 -> 9.0 ms (pale) and 3.3 -> 5.9 ms (other)
with light lines, 10.5 / 8.2 ms with joins. Untouched dev seeds (the 13 pale
scenes of 9100-9139, 234 views): 0.773 -> 0.913 (lines), 0.780 (joins), 0.920
(both); false pixels 2.1 / 0.8 / 2.9 per view.

``masks``: the segmentation's mask against the truth's projected tube, per
view, on random phantom scenes (:mod:`tendrilkit.phantom.scenes`; seeds
0-9999 only: 10000 and above are the held-out benchmark's), with the faint
pixels (:func:`tendrilkit.segmentation.faint_pixels`, the default),
without them (``local_contrast=0``: the global threshold alone) and with them
measured against the board beside darker objects (``local_exclude_dark``),
all in the same run, interleaved. Prints, per look (default, pale, brown) and overall,
the mean over views and frames of: centre recall (the share of the true
centreline's projected points, inside the ROI and outside the keep-out box,
within 1.5 px of the chosen component), tip recall (the same on the distal
fifth), foreground recall (the same for every dark pixel, any component),
pixel precision (the share of the component's pixels within 2 px of the
true tube) and the median CPU ms per view of ``segment_view``.

Measured 2026-11-30 (shared machine, load 17-23; CPU times are upper bounds),
``masks --seeds 5000:5020`` (360 views): pale tendrils (144 views) centre
recall 0.006 -> 0.513, tip 0.000 -> 0.214, foreground 0.018 -> 0.939,
precision 0.006 -> 0.884; default and brown tendrils identical with and
without (centre 0.583 / 0.806, precision 0.363 / 0.481; lost views are
contact and clutter, not contrast); ``segment_view`` 1.9 -> 4.9 ms CPU per
view. ``masks --scene pale --seeds 0:6``: centre recall 0.155 -> 0.988, tip
0.126 -> 0.959, precision 0.168 -> 1.000.

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


def _truth_tube(gt, f: int, v: int, offset, shape):
    """The true tube of frame ``f`` in view ``v`` drawn into the ROI crop; its centreline (n, 2) crop px and s."""
    cam = gt.cameras[v]
    look = gt.meta.get("realised", {}).get("look", {})
    d0 = float(look.get("diameter_base_mm", gt.meta.get("diameter_mm", 1.5)))
    d1 = float(look.get("diameter_tip_mm", d0))
    s = np.asarray(gt.s_mm, float)
    r_px = 0.5 * (d0 + (d1 - d0) * s / s[-1]) * cam.K[0, 0] / (gt.curves[f] @ cam.R.T + cam.t_mm)[:, 2]
    P = gt.projections[f, v] - np.asarray(offset, float)
    tube = np.zeros(shape, np.uint8)
    for i in range(len(P) - 1):
        if np.all(np.isfinite(P[i:i + 2])):
            a, b = (tuple(int(c) for c in np.round(q * 16)) for q in (P[i], P[i + 1]))
            cv2.line(tube, a, b, 255, max(1, int(round(2 * r_px[i]))), cv2.LINE_8, 4)
    return tube > 0, P, s / s[-1]


def mask_scores(seg, gt, f: int, v: int, keep_out) -> dict:
    """Centre / tip / foreground recall and pixel precision of one view's segmentation (see the module)."""
    off, shape = seg.roi_offset_xy, seg.mask_roi.shape
    tube, P, u = _truth_tube(gt, f, v, off, shape)
    ko = np.zeros(shape, bool)
    if keep_out is not None:
        kx, ky, kw, kh = (int(round(c)) for c in keep_out)
        ko[max(ky - off[1], 0):max(ky + kh - off[1], 0), max(kx - off[0], 0):max(kx + kw - off[0], 0)] = True
    Pi = np.round(P).astype(int)
    ok = np.all(np.isfinite(P), axis=1) & np.all((Pi >= 0) & (Pi < np.array(shape[::-1])), axis=1)
    ok[ok] = ~ko[Pi[ok, 1], Pi[ok, 0]]
    Pi, u = Pi[ok], u[ok]

    def near(mask):
        d = cv2.distanceTransform(np.where(mask, np.uint8(0), np.uint8(255)), cv2.DIST_L2, 5)
        return d[Pi[:, 1], Pi[:, 0]] <= 1.5

    on = near(seg.mask_roi)
    fg = near(seg.foreground.foreground > 0)
    tube2 = cv2.dilate(tube.view(np.uint8), np.ones((5, 5), np.uint8)) > 0
    nan = float("nan")
    return {"centre": float(on.mean()) if len(on) else nan, "tip": float(on[u > 0.8].mean()) if (u > 0.8).any() else nan,
            "fg": float(fg.mean()) if len(fg) else nan,
            "precision": float(tube2[seg.mask_roi].mean()) if seg.mask_roi.any() else nan}


def bench_masks(argv: list[str]) -> None:
    import argparse
    import tempfile
    import warnings

    import pandas as pd

    from tendrilkit.exceptions import FrameError
    from tendrilkit.io import read_frames
    from tendrilkit.options import stage_options
    from tendrilkit.params import load_experiment
    from tendrilkit.phantom import read_ground_truth, write_scene_experiment
    from tendrilkit.segmentation import segment_view

    p = argparse.ArgumentParser(prog="bench_evidence.py masks")
    p.add_argument("--scene", default="random")
    p.add_argument("--seeds", default="0:6")
    p.add_argument("--frames", type=int, default=6)
    p.add_argument("--out", default=None, help="scenes are written (or reused) here")
    a = p.parse_args(argv)
    start, stop = (int(x) for x in a.seeds.split(":"))
    if stop > 10000:
        p.error("--seeds: 10000 and above are the held-out benchmark's")
    out = Path(a.out) if a.out else Path(tempfile.mkdtemp(prefix="bench_masks_"))
    # each variant spelled out (the defaults now have the pale options on), light lines off as when measured
    variants = {"threshold only": {"local_contrast": 0.0, "line_width_px": 0},
                "with faint pixels": {"local_exclude_dark": False, "line_width_px": 0},
                "faint, beside dark (local_exclude_dark)": {"local_exclude_dark": True, "line_width_px": 0}}
    rows = []
    for seed in range(start, stop):
        folder = out / f"{a.scene}-{seed}" / "scene"
        try:
            exp = load_experiment(write_scene_experiment(folder, seed=seed, scene=a.scene, n_frames=a.frames))
        except Exception as e:  # noqa: BLE001 (a scene that cannot be made is reported and skipped)
            print(f"seed {seed}: not generated: {e}")
            continue
        gt = read_ground_truth(folder)
        look = gt.meta["factors"]["look"]
        opts = stage_options(exp, "segmentation")
        prev = {k: [None] * exp.n_views for k in variants}
        for f in range(len(gt.time_s)):
            images = read_frames(exp, f)
            for v, m in enumerate(exp.views):
                for name, extra in variants.items():
                    c0 = time.process_time()
                    try:
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            seg = segment_view(images[v], roi=m.roi, keep_out=m.keep_out, base_point_xy=m.base_point,
                                               prev_centroid_xy=prev[name][v], **{**opts, **extra})
                    except FrameError:
                        rows.append({"variant": name, "look": look, "centre": 0.0, "tip": 0.0, "fg": 0.0,
                                     "precision": float("nan"), "cpu_ms": 1e3 * (time.process_time() - c0)})
                        continue
                    cpu = 1e3 * (time.process_time() - c0)
                    prev[name][v] = seg.centroid_xy
                    rows.append({"variant": name, "look": look, **mask_scores(seg, gt, f, v, m.keep_out),
                                 "cpu_ms": cpu})
    t = pd.DataFrame(rows)
    t = pd.concat([t, t.assign(look="all")], ignore_index=True)
    table = t.groupby(["look", "variant"]).agg(views=("centre", "size"), centre=("centre", "mean"),
                                                tip=("tip", "mean"), fg=("fg", "mean"),
                                                precision=("precision", "mean"), cpu_ms=("cpu_ms", "median"))
    pd.set_option("display.width", 200)
    print(f"scene {a.scene} seeds {start}:{stop}, {a.frames} frames; scenes in {out}")
    print(table.reset_index().to_string(index=False, float_format=lambda x: f"{x:.3f}"))


LINE_VARIANTS = {"plain": {"line_width_px": 0}, "lines": {"line_width_px": 11},
                 "bridges": {"line_width_px": 0, "bridge_gap_px": 30},
                 "lines+bridges": {"line_width_px": 11, "bridge_gap_px": 30}}


def bench_lines(argv: list[str]) -> None:
    import argparse
    import tempfile

    import pandas as pd

    from tendrilkit.io import read_frames
    from tendrilkit.options import stage_options
    from tendrilkit.params import load_experiment
    from tendrilkit.phantom import read_ground_truth, write_scene_experiment
    from tendrilkit.segmentation import label_foreground

    p = argparse.ArgumentParser(prog="bench_evidence.py lines")
    p.add_argument("--seeds", default="0:40", help="START:STOP (stop exclusive) or a comma-separated list")
    p.add_argument("--frames", type=int, default=6)
    p.add_argument("--out", default=None, help="scenes are written (or reused) here, as random-SEED/")
    a = p.parse_args(argv)
    if ":" in a.seeds:
        start, stop = (int(x) for x in a.seeds.split(":"))
        seeds = list(range(start, stop))
    else:
        seeds = [int(x) for x in a.seeds.split(",")]
    if max(seeds) >= 10000:
        p.error("--seeds: 10000 and above are the held-out benchmark's")
    out = Path(a.out) if a.out else Path(tempfile.mkdtemp(prefix="bench_lines_"))
    rows = []
    for seed in seeds:
        folder = out / f"random-{seed}"
        exp = load_experiment(write_scene_experiment(folder, seed=seed, scene="random", n_frames=a.frames))
        gt = read_ground_truth(folder)
        look = "pale" if gt.meta["factors"]["look"] == "pale" else "other"
        opts = stage_options(exp, "segmentation")
        opts.pop("min_component_px")
        for f in range(len(gt.time_s)):
            images = read_frames(exp, f)
            for v, m in enumerate(exp.views):
                plain = None
                for name, extra in LINE_VARIANTS.items():
                    c0 = time.process_time()
                    lf = label_foreground(images[v], roi=m.roi, keep_out=m.keep_out, **{**opts, **extra})
                    cpu = 1e3 * (time.process_time() - c0)
                    fg = lf.foreground > 0
                    if plain is None:
                        plain = fg
                        tube, P, _ = _truth_tube(gt, f, v, lf.roi_offset_xy, fg.shape)
                        near_tube = cv2.dilate(tube.view(np.uint8), np.ones((5, 5), np.uint8)) > 0
                        Pi = np.round(P).astype(int)
                        ok = np.all(np.isfinite(P), axis=1) & np.all((Pi >= 0) & (Pi < np.array(fg.shape[::-1])), 1)
                        ko = np.zeros(fg.shape, bool)
                        if m.keep_out is not None:
                            kx, ky, kw, kh = (int(round(c)) for c in m.keep_out)
                            o = lf.roi_offset_xy
                            ko[max(ky - o[1], 0):max(ky + kh - o[1], 0), max(kx - o[0], 0):max(kx + kw - o[0], 0)] = 1
                        ok[ok] = ~ko[Pi[ok, 1], Pi[ok, 0]]
                        Pi = Pi[ok]
                    d = cv2.distanceTransform(np.where(fg, np.uint8(0), np.uint8(255)), cv2.DIST_L2, 5)
                    found = float((d[Pi[:, 1], Pi[:, 0]] <= 1.5).mean()) if len(Pi) else float("nan")
                    rows.append({"variant": name, "look": look, "found": found,
                                 "false_px": int((fg & ~plain & ~near_tube).sum()), "cpu_ms": cpu})
    t = pd.DataFrame(rows)
    t = pd.concat([t, t.assign(look="all")], ignore_index=True)
    table = t.groupby(["look", "variant"], sort=False).agg(views=("found", "size"), found=("found", "mean"),
                                                           false_px=("false_px", "mean"), cpu_ms=("cpu_ms", "median"))
    pd.set_option("display.width", 200)
    print(f"seeds {a.seeds}, {a.frames} frames; scenes in {out}")
    print(table.reset_index().to_string(index=False, float_format=lambda x: f"{x:.3f}"))


def main() -> None:
    cv2.setNumThreads(1)
    if len(sys.argv) > 1 and sys.argv[1] == "masks":
        bench_masks(sys.argv[2:])
    elif len(sys.argv) > 1 and sys.argv[1] == "lines":
        bench_lines(sys.argv[2:])
    elif len(sys.argv) > 1 and sys.argv[1] == "phantom":
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
