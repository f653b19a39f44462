"""Where a curve that ends wrong stopped, and what each view's evidence shows of the tendril beyond.

    .venv/bin/python benchmarks/diagnose_beyond.py OUT

``OUT`` is the ``--out`` folder of ``benchmarks/bench_generalize.py --method
multiview`` (its ``scores.csv`` and, per scene, ``scene/`` and
``result-multiview/``). For every reconstructed frame whose tip lies more than
2 mm from the true tip: the arc length along the truth (``s_stop_mm``) where
the curve last lies within 2 mm of it (``left_truth``: the curve went on off
the truth after that), and, for the true centreline beyond that point, per
view ``<v>`` (1-based) the fraction that

* ``on<v>``: lies within :data:`tendrilkit.mv_acquire.ON_PX` of the view's
  thin skeleton (:mod:`tendrilkit.mv_evidence`) and is seen;
* ``fg<v>``: lies on the view's dark pixels (the segmentation found it);
* ``seen<v>``: the view can see (inside its ROI, outside the keep-out box);
* ``cov<v>``: is covered (deep inside a dark region wider than a tendril: a
  leaf or the stem over or under it);

and ``ok2_frac``, the fraction where two views or more have it on their
skeleton, covered or unseen (what the multi-view growth can follow), with
``first_gap_mm``, how far beyond the stop the first place is where fewer than
two do. Reading it: ``fg`` low in a view means the segmentation misses the
tendril there; ``cov`` high means the tendril passes a leaf or the stem; ``on``
high in every view means the evidence is there and the search stopped.

Writes ``OUT/beyond.csv`` and prints it. Each frame's evidence is cached in
``OUT/evidence-cache/`` (as :mod:`benchmarks.rerun_multiview`; delete the folder
when the evidence code changes). Seeds 0-9999 only (``bench_generalize``'s
rule): diagnosis of development scenes, never of held-out ones.

First used 2026-11-30 on dev seeds 9980-9999 (89 frames): a pale tendril over the
stem stopped at it in every frame although every view had 93 % of the rest on
its skeleton (seed 9981); tendrils over leaves stopped where the rest is
covered in one or two views; pale tendrils stopped where one view's dark
pixels hold 6-40 % of the rest.
"""

from __future__ import annotations

import argparse
import pickle
import sys
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

#: A curve point within this of the truth (mm) is on it; a tip farther than this from the true tip is wrong.
ON_TRUTH_MM = 2.0


def _evidence(folder: Path, frame: int, exp, cameras, cache: Path, sources: list):
    """The frame's (views, skeleton evidence, notes) as the multi-view method reads them, cached."""
    import tendrilkit.pipeline as pipeline
    from tendrilkit.io import open_views
    from tendrilkit.runner import _read_views

    path = cache / f"{folder.name}-{frame}.pkl"
    if path.is_file():
        return pickle.loads(path.read_bytes())
    if not sources:
        sources.extend(open_views(list(exp.videos)))
    images, errors = _read_views(sources, frame)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        evidence = pipeline.multiview_evidence(images, cameras, exp, read_errors=errors)
    path.write_bytes(pickle.dumps(evidence))
    return evidence


def beyond_rows(out: Path) -> list[dict]:
    """One row per reconstructed frame of ``out`` whose tip is wrong (see the module)."""
    from tendrilkit.geometry import arc_length
    from tendrilkit.io import read_cameras
    from tendrilkit.mv_acquire import ON_PX
    from tendrilkit.mv_evidence import skeleton_distance
    from tendrilkit.params import load_experiment
    from tendrilkit.phantom import read_ground_truth

    cache = out / "evidence-cache"
    cache.mkdir(exist_ok=True)
    scores = pd.read_csv(out / "scores.csv")
    rows = []
    for scene, g in scores.groupby("scene"):
        folder = out / scene
        res = folder / "result-multiview"
        curves = pd.read_csv(res / "curves.csv")
        truth = read_ground_truth(folder / "scene").curves_table()
        exp = load_experiment(folder / "scene" / "experiment.yaml")
        cameras = read_cameras(res / "cameras.json")
        sources: list = []
        try:
            for _, x in g.iterrows():
                f = int(x.frame)
                if x.status == "failed" or not x.tip_mm > ON_TRUTH_MM:
                    continue
                C = curves[curves.frame == f][["x_mm", "y_mm", "z_mm"]].to_numpy()
                T = truth[truth.frame == f][["x_mm", "y_mm", "z_mm"]].to_numpy()
                sT = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(T, axis=0), axis=1))]
                dC = np.linalg.norm(C[:, None, :] - T[None, :, :], axis=2).min(axis=1)
                off = np.flatnonzero(dC > ON_TRUTH_MM)
                last = (off[0] if len(off) else len(C)) - 1
                s_stop = sT[np.argmin(np.linalg.norm(T - C[max(last, 0)], axis=1))]
                rest = sT > s_stop + 1.0
                if rest.sum() < 2:
                    continue
                _, evidence, _ = _evidence(folder, f, exp, cameras, cache, sources)
                row = {"scene": scene, "frame": f, "status": x.status, "mean_mm": x.mean_mm, "tip_mm": x.tip_mm,
                       "length_true_mm": sT[-1], "length_curve_mm": arc_length(C)[-1], "s_stop_mm": s_stop,
                       "left_truth": bool(len(off))}
                follow = []
                for v, ev in enumerate(evidence):
                    if ev is None:
                        continue
                    xy = ev.camera.project(T[rest])
                    d, _, seen, _, _, covered = skeleton_distance(ev, xy, outside_px=10.0, index=True)
                    h, w = ev.foreground.shape
                    ix = np.clip(np.rint(xy[:, 0] - ev.offset_xy[0]).astype(int), 0, w - 1)
                    iy = np.clip(np.rint(xy[:, 1] - ev.offset_xy[1]).astype(int), 0, h - 1)
                    on = (d <= ON_PX) & seen
                    row.update({f"on{v + 1}": on.mean(), f"fg{v + 1}": (ev.foreground[iy, ix] & seen).mean(),
                                f"seen{v + 1}": seen.mean(), f"cov{v + 1}": covered.mean()})
                    follow.append(on | covered | ~seen)
                ok2 = np.sum(follow, axis=0) >= 2
                gaps = np.flatnonzero(~ok2)
                row["ok2_frac"] = ok2.mean()
                row["first_gap_mm"] = (sT[rest] - s_stop)[gaps[0]] if len(gaps) else np.nan
                row["factors"] = x.factors
                rows.append(row)
        finally:
            for src in sources:
                src.close()
    return rows


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out", help="a bench_generalize --method multiview output folder")
    a = ap.parse_args(argv)
    out = Path(a.out)
    if not (out / "scores.csv").is_file():
        print(f"error: {out} has no scores.csv (run bench_generalize.py --method multiview --out {out})", file=sys.stderr)
        return 2
    table = pd.DataFrame(beyond_rows(out))
    table.to_csv(out / "beyond.csv", index=False)
    with pd.option_context("display.width", 250, "display.max_rows", 500):
        print(table.drop(columns=["factors"], errors="ignore").round(2).to_string())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
