"""The multi-view evidence against the truth: how much of the tendril each view's skeleton sees, and what else.

    .venv/bin/python benchmarks/bench_evidence_truth.py OUT --seeds 9340:9380 [--frames 6] \
        [--variant NAME:key=value,key=value ...]

``OUT`` holds random phantom scenes as ``benchmarks/bench_generalize.py`` writes
them (``OUT/random-SEED/scene``; seeds 0-9999 only). For every frame and view,
each variant's evidence (:func:`tendrilkit.pipeline.multiview_evidence`'s route:
:func:`tendrilkit.evidence.view_evidence` with the experiment's segmentation
options and the variant's, then :func:`tendrilkit.mv_evidence.skeleton_evidence`,
the thin structures' skeleton the multi-view fit reads) is compared with the
true centreline projected by the true camera (``gt_projections.csv``), inside
the ROI and outside the keep-out box:

* ``recall``: the share of the true centreline's projected points within
  2 px of the thin skeleton; ``tip``: the same on the distal fifth;
  ``on_obj``: the same on the points in front of (or behind) a darker object
  (more than 40 % of the pixels 3-8 px around the tube, the tube left out,
  darker than Otsu's threshold of the ROI: a leaf, the stem, a marker);
  ``on_board``: on the other points;
* ``precision``: the share of the thin skeleton's pixels within 2 px of the
  true tube (the tube drawn at the tendril's radius); everything else counts
  as false (a second tendril, a side shoot, a leaf's edge, a shadow), so it
  is low on cluttered scenes whatever the variant;
* ``false_px``: per view, thin skeleton pixels farther than 2 px from the
  tube; ``added_false``: those the variant has and the first variant has not
  (farther than 2 px from any of the first's);
* ``ms``: the median CPU time of the evidence per view (one core).

Rows: every view (``all``) and the views of scenes with a factor (``pale``,
``over_leaf``, ``over_stem``, ``shadow``, ``pale+over_leaf``,
``pale+over_stem``, ``not pale``); the skeleton of a view that lost the tendril
altogether counts as recall 0.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import warnings
from pathlib import Path

import cv2
import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_evidence import _truth_tube  # noqa: E402

NEAR_PX = 2.0
GROUPS = ("all", "pale", "not pale", "over_leaf", "over_stem", "pale+over_leaf", "pale+over_stem", "shadow")


def parse_variant(text: str) -> tuple[str, dict]:
    """``NAME:key=value,key=value`` -> (NAME, {key: value}) (ints, floats, true/false)."""
    name, _, rest = text.partition(":")
    opts = {}
    for item in filter(None, rest.split(",")):
        k, _, v = item.partition("=")
        low = v.strip().lower()
        if low in ("true", "false"):
            opts[k.strip()] = low == "true"
        else:
            try:
                opts[k.strip()] = int(v)
            except ValueError:
                opts[k.strip()] = float(v)
    return name, opts


def _over_object(grey: np.ndarray, tube: np.ndarray, Pi: np.ndarray) -> np.ndarray:
    """(n,) bool: the points ``Pi`` (n, 2) crop xy lie on a darker object (see the module)."""
    _, dark = cv2.threshold(grey, 0, 1, cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU)
    inner = cv2.dilate(tube.view(np.uint8), np.ones((7, 7), np.uint8))
    ring = cv2.dilate(tube.view(np.uint8), np.ones((17, 17), np.uint8)) & (1 - inner)
    num = cv2.boxFilter((dark & ring).astype(np.float32), -1, (17, 17), normalize=False)
    den = cv2.boxFilter(ring.astype(np.float32), -1, (17, 17), normalize=False)
    frac = num[Pi[:, 1], Pi[:, 0]] / np.maximum(den[Pi[:, 1], Pi[:, 0]], 1.0)
    return frac > 0.4


def view_scores(sk, gt, f: int, v: int, m, grey, first_skel) -> tuple[dict, np.ndarray]:
    """One view's figures for one variant's thin skeleton ``sk`` ((k, 2) full-image xy or None)."""
    h, w = grey.shape
    off = np.array([max(int(m.roi[0]), 0), max(int(m.roi[1]), 0)])
    tube, P, u = _truth_tube(gt, f, v, off, (h, w))
    Pi = np.round(P).astype(int)
    ok = np.all(np.isfinite(P), axis=1) & np.all((Pi >= 0) & (Pi < np.array([w, h])), axis=1)
    if m.keep_out is not None:
        kx, ky, kw, kh = (int(round(c)) for c in m.keep_out)
        ko = np.zeros((h, w), bool)
        ko[max(ky - off[1], 0):max(ky + kh - off[1], 0), max(kx - off[0], 0):max(kx + kw - off[0], 0)] = True
        ok[ok] = ~ko[Pi[ok, 1], Pi[ok, 0]]
    Pi, u = Pi[ok], u[ok]
    obj = _over_object(grey, tube, Pi) if len(Pi) else np.zeros(0, bool)
    skel = np.zeros((h, w), np.uint8)
    if sk is not None and len(sk):
        q = np.round(np.asarray(sk) - off).astype(int)
        q = q[(q[:, 0] >= 0) & (q[:, 1] >= 0) & (q[:, 0] < w) & (q[:, 1] < h)]
        skel[q[:, 1], q[:, 0]] = 1
    d = cv2.distanceTransform(1 - skel, cv2.DIST_L2, 5)
    hit = d[Pi[:, 1], Pi[:, 0]] <= NEAR_PX
    dt = cv2.distanceTransform(1 - tube.view(np.uint8), cv2.DIST_L2, 5)
    on = skel > 0
    false = on & (dt > NEAR_PX)
    added = false
    if first_skel is not None:
        d0 = cv2.distanceTransform(1 - first_skel, cv2.DIST_L2, 5)
        added = false & (d0 > NEAR_PX)
    nan = float("nan")
    mean = lambda a: float(a.mean()) if len(a) else nan  # noqa: E731
    return {"recall": mean(hit), "tip": mean(hit[u > 0.8]), "on_obj": mean(hit[obj]), "on_board": mean(hit[~obj]),
            "n_obj": int(obj.sum()), "precision": float((on & (dt <= NEAR_PX)).sum() / on.sum()) if on.any() else nan,
            "false_px": int(false.sum()), "added_false": int(added.sum())}, skel


def main(argv: list[str] | None = None) -> int:
    from tendrilkit.evidence import view_evidence
    from tendrilkit.exceptions import FrameError
    from tendrilkit.io import read_frames
    from tendrilkit.mv_evidence import skeleton_evidence
    from tendrilkit.options import stage_options
    from tendrilkit.params import load_experiment
    from tendrilkit.phantom import read_ground_truth
    from tendrilkit.segmentation import grey_image

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path)
    p.add_argument("--seeds", required=True, help="START:STOP (stop exclusive)")
    p.add_argument("--frames", type=int, default=6, help="the first N frames of each scene")
    p.add_argument("--variant", action="append", default=[], help="NAME:key=value,...; the first is the reference")
    p.add_argument("--csv", type=Path, default=None, help="write the per-view rows here")
    a = p.parse_args(argv)
    start, stop = (int(x) for x in a.seeds.split(":"))
    if stop > 10000:
        p.error("--seeds: 10000 and above are the held-out benchmark's")
    variants = [parse_variant(t) for t in a.variant] or [("default", {})]
    cv2.setNumThreads(1)
    rows = []
    for seed in range(start, stop):
        folder = a.out / f"random-{seed}" / "scene"
        if not folder.is_dir():
            continue
        exp = load_experiment(folder / "experiment.yaml")
        gt = read_ground_truth(folder)
        meta = json.loads((folder / "ground_truth" / "gt_meta.json").read_text())
        active = set(meta.get("active_factors", []))
        pale = meta["factors"]["look"] == "pale"
        tags = {"all", "pale" if pale else "not pale"} | ({"shadow"} & active)
        for k in ("over_leaf", "over_stem"):
            if k in active:
                tags |= {k, f"pale+{k}"} if pale else {k}
        opts = stage_options(exp, "segmentation")
        for f in range(min(a.frames, len(gt.time_s))):
            images = read_frames(exp, f)
            for v, m in enumerate(exp.views):
                x0, y0 = max(int(m.roi[0]), 0), max(int(m.roi[1]), 0)
                grey = grey_image(images[v][y0:y0 + int(m.roi[3]) + min(int(m.roi[1]), 0),
                                            x0:x0 + int(m.roi[2]) + min(int(m.roi[0]), 0)], channel=opts["channel"])
                first = None
                for name, extra in variants:
                    c0 = time.process_time()
                    sk = None
                    try:
                        with warnings.catch_warnings():
                            warnings.simplefilter("ignore")
                            ev = view_evidence(images[v], roi=m.roi, keep_out=m.keep_out, base_point_xy=m.base_point,
                                               **{**opts, **extra})
                            sk = skeleton_evidence(ev, gt.cameras[v]).skeleton_xy
                    except FrameError:
                        pass
                    ms = 1e3 * (time.process_time() - c0)
                    sc, skel = view_scores(sk, gt, f, v, m, grey, first)
                    if first is None:
                        first = skel
                    rows.append({"seed": seed, "frame": f, "view": v, "variant": name, "tags": ";".join(sorted(tags)),
                                 **sc, "ms": ms})
        print(f"seed {seed} done", file=sys.stderr, flush=True)
    t = pd.DataFrame(rows)
    if a.csv:
        t.to_csv(a.csv, index=False)
    out = []
    for g in GROUPS:
        sub = t[t.tags.str.split(";").apply(lambda s, g=g: all(x in s for x in g.split("+")) if g != "not pale"
                                            else "not pale" in s)]
        if sub.empty:
            continue
        for name, _ in variants:
            s = sub[sub.variant == name]
            out.append({"group": g, "variant": name, "views": len(s), "recall": s.recall.mean(), "tip": s.tip.mean(),
                        "on_obj": s.on_obj.mean(), "on_board": s.on_board.mean(), "precision": s.precision.mean(),
                        "false_px": s.false_px.mean(), "added_false": s.added_false.mean(), "ms": s.ms.median()})
    pd.set_option("display.width", 200)
    print(f"seeds {a.seeds}, {a.frames} frames, {len(t) // max(len(variants), 1)} views; near = {NEAR_PX} px")
    print(pd.DataFrame(out).to_string(index=False, float_format=lambda x: f"{x:.3f}"))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
