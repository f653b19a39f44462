"""Census of the ``tip off`` frames of a re-run: where the curve left the tendril and what the views show of its tail.

    .venv/bin/python benchmarks/diagnose_tipoff.py OUT TAG [--seeds 1040:1080] [--csv census.csv]

``OUT`` and ``TAG`` as :mod:`benchmarks.rerun_multiview` (run it with ``--keep-curves``: the curves are read from
``OUT/curves-TAG/``, the rows from ``OUT/rerun-TAG.csv``, each view's evidence from ``OUT/evidence-cache``). Per
frame whose cause is ``tip off``:

``tip_off_mm``
    the tip's distance to the true centreline.
``tail_mm``
    the curve's length beyond its last node within 2 mm of the truth (the wrong tail).
``left_at``
    ``past tip`` where that node lies within 3 mm of the true tip (it ran past the tendril's end onto something),
    else ``mid`` (it left the tendril at a crossing or contact and followed the other object); ``short_mm`` is the
    true length beyond the departure.
``mode``
    ``tracked`` when the previous processed frame of the scene was ``ok`` (the run tracks from it), else
    ``acquired``.
per view ``on_v`` / ``covered_v`` / ``unseen_v`` / ``board_v``
    the share of the tail (nodes every 0.5 mm) on the view's skeleton (within ``ON_PX``), covered (a leaf, the stem),
    outside the ROI or in the keep-out box, on the board (the view contradicts it).
``tail_views``
    how many views see the tail on their skeletons over half its length or more.
``runs_out``
    the tip ends where two views stop seeing (the ROIs' edge).
``objects``
    the scene's factors that put an object near the tendril (``tip_leaf``, ``second_tendril``, ...).

Diagnosis only; the figures that count are ``bench_generalize``'s.
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

OBJECTS = ("tip_leaf", "second_tendril", "over_leaf", "occluding_leaf", "alongside", "over_stem", "shape")


def _nearest_on(P: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n,) distance of each point of P to the polyline Q and its arc length along Q."""
    a, b = Q[:-1], Q[1:]
    ab = b - a
    sq = np.r_[0.0, np.cumsum(np.linalg.norm(ab, axis=1))]
    t = np.einsum("nkd,kd->nk", P[:, None, :] - a[None], ab) / np.maximum((ab ** 2).sum(1), 1e-12)
    t = np.clip(t, 0.0, 1.0)
    c = a[None] + t[..., None] * ab[None]
    dist = np.linalg.norm(P[:, None, :] - c, axis=2)
    k = dist.argmin(axis=1)
    r = np.arange(len(P))
    return dist[r, k], sq[k] + t[r, k] * np.linalg.norm(ab[k], axis=1)


def census(out: Path, tag: str, seeds: tuple[int, int] | None = None) -> pd.DataFrame:
    from tendrilkit.geometry import arc_length, resample_polyline
    from tendrilkit.mv_acquire import ON_PX, point_costs, runs_out
    from tendrilkit.phantom import read_ground_truth

    t = pd.read_csv(out / f"rerun-{tag}.csv", keep_default_na=False, na_values=[""])
    t["seed"] = t.scene.str.rsplit("-", n=1).str[1].astype(int)
    if seeds:
        t = t[(t.seed >= seeds[0]) & (t.seed < seeds[1])]
    rows = []
    for scene, g in t.groupby("scene", sort=False):
        g = g.sort_values("frame")
        off = g[g.cause == "tip off"]
        if off.empty:
            continue
        folder = out / scene
        gt = read_ground_truth(folder / "scene")
        meta = json.loads((folder / "scene" / "ground_truth" / "gt_meta.json").read_text())
        objects = [k for k in OBJECTS if meta["factors"].get(k) not in (False, None, "none", "plain")]
        objects = [f"{k}={meta['factors'][k]}" if k == "shape" else k for k in objects]
        cv = pd.read_csv(out / f"curves-{tag}" / f"{scene}.csv")
        status = dict(zip(g.frame, g.status))
        frames = list(g.frame)
        for r in off.itertuples():
            rec = cv[cv.frame == r.frame][["x_mm", "y_mm", "z_mm"]].to_numpy(float)
            true = np.asarray(gt.curves[int(r.frame)], float)
            L = float(arc_length(true)[-1])
            s = arc_length(rec)
            d, along = _nearest_on(rec, true)
            good = np.flatnonzero(d <= 2.0)
            j = int(good[-1]) if len(good) else 0
            tail = resample_polyline(rec[j:], step=0.5) if s[-1] - s[j] > 0.5 else rec[j:]
            cached = pickle.loads((out / "evidence-cache" / f"{scene}-{r.frame}.pkl").read_bytes())[1]
            views = [v for v, e in enumerate(cached) if e is not None]  # the columns keep the views' own numbers
            ev = [cached[v] for v in views]
            dd, seen, near, bg, cov = point_costs(ev, tail, nearest=True, covered=True)
            i = frames.index(r.frame)
            row = {"scene": scene, "frame": int(r.frame), "status": r.status,
                   "mode": "tracked" if i > 0 and status[frames[i - 1]] == "ok" else "acquired",
                   "tip_off_mm": round(float(d[-1]), 1), "tail_mm": round(float(s[-1] - s[j]), 1),
                   "left_at": "past tip" if L - along[j] <= 3.0 else "mid", "short_mm": round(L - along[j], 1),
                   "length_mm": round(float(s[-1]), 1), "true_mm": round(L, 1), "mean_mm": r.mean_mm}
            for k, v in enumerate(views):
                row[f"on_{v + 1}"] = round(float(np.mean(seen[k] & (dd[k] <= ON_PX))), 2)
                row[f"covered_{v + 1}"] = round(float(np.mean(cov[k])), 2)
                row[f"unseen_{v + 1}"] = round(float(np.mean(~seen[k] & ~cov[k])), 2)
                row[f"board_{v + 1}"] = round(float(np.mean(bg[k])), 2)
            row["tail_views"] = int(sum(row.get(f"on_{v + 1}", 0) >= 0.5 for v in views))
            row["runs_out"] = bool(runs_out(ev, [rec], 2.0)[0])
            row["objects"] = ";".join(objects)
            rows.append(row)
    return pd.DataFrame(rows)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path)
    p.add_argument("tag")
    p.add_argument("--seeds", default=None, help="START:STOP")
    p.add_argument("--csv", type=Path, default=None)
    a = p.parse_args(argv)
    seeds = tuple(int(x) for x in a.seeds.split(":")) if a.seeds else None
    c = census(a.out, a.tag, seeds)
    if a.csv:
        c.to_csv(a.csv, index=False)
    if c.empty:
        print("no tip off frame")
        return 0
    pd.set_option("display.width", 250)
    pd.set_option("display.max_rows", 500)
    print(c.drop(columns=[k for k in c.columns if k.startswith(("covered_", "unseen_", "board_"))]).to_string())
    print(f"\n{len(c)} tip off frames: status {c.status.value_counts().to_dict()}, mode {c['mode'].value_counts().to_dict()}")
    for key, grp in c.groupby("left_at"):
        print(f"{key}: {len(grp)} frames; tail median {grp.tail_mm.median():.1f} mm (max {grp.tail_mm.max():.1f}), "
              f"tip off median {grp.tip_off_mm.median():.1f} mm; views on the tail "
              f"{grp.tail_views.value_counts().sort_index().to_dict()}; runs out {int(grp.runs_out.sum())}; "
              f"mode {grp['mode'].value_counts().to_dict()}")
    objs = c.objects.str.split(";").explode()
    print("objects (factor, frames):", objs.value_counts().to_dict())
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
