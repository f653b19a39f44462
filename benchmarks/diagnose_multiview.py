"""Why the frames of a generalisation run are wrong: one primary cause per frame, overall and per factor.

    .venv/bin/python benchmarks/diagnose_multiview.py OUT [--method multiview] [--factors tip_leaf,pale]

``OUT`` is the ``--out`` folder of ``benchmarks/bench_generalize.py`` (its
``scores.csv`` and, per scene, ``scene/`` and ``result-<method>/``). Every
frame that is not *within* the truth (:mod:`tendrilkit.scoring`) gets the
first cause that applies, in this order:

``failed``
    no curve.
``wrong start``
    a point of the first 10 mm of the curve lies more than 2 mm from the
    true centreline (another object at the base: stem, petiole).
``tip off``
    the curve's tip lies more than 2 mm from the true centreline (it ran
    onto a leaf, a second tendril, a petiole, or over the board).
``too long``
    the tip is on the tendril but the curve is over 1.1 times the true
    length (out and back, or past the tip along it).
``stops short``
    the tip is on the tendril, more than 2 mm short of the true tip.
``excursion``
    ends right, but a point mid-curve more than 2 mm off (a crossing).
``other``
    ends and every point within 2 mm, mean over 0.5 mm.

Also prints the silent frames (``ok``, mean over 1.5 mm: must not grow).
Diagnosis only: the figures that count are bench_generalize's.

Measured 2026-11-30, seeds 0:40, 6 frames, ``--method multiview`` (240
frames), before (7b6296e) / after the thin-skeleton evidence, the runs-out
undo and the tracked length cap (b7ba57a): wrong start 14 / 9, tip off
72 / 65, too long 1 / 1, stops short 58 / 72, excursion 10 / 7, failed 0 / 0;
silent 0 / 0.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

CAUSES = ("failed", "wrong start", "tip off", "too long", "stops short", "excursion", "other")


def _dist_to_polyline(P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """(n,) distance of each point of P (n, 3) to the polyline Q (m, 3)."""
    a, b = Q[:-1], Q[1:]
    ab = b - a
    t = np.einsum("nkd,kd->nk", P[:, None, :] - a[None], ab) / np.maximum((ab ** 2).sum(1), 1e-12)
    t = np.clip(t, 0.0, 1.0)
    c = a[None] + t[..., None] * ab[None]
    return np.linalg.norm(P[:, None, :] - c, axis=2).min(axis=1)


def frame_cause(rec: np.ndarray | None, true: np.ndarray, row) -> str:
    """The primary cause (:data:`CAUSES`) of a frame that is not within the truth."""
    if rec is None or len(rec) < 2 or row.status == "failed":
        return "failed"
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(rec, axis=0), axis=1))]
    L_true = float(np.linalg.norm(np.diff(true, axis=0), axis=1).sum())
    d = _dist_to_polyline(rec, true)
    if np.any(d[s <= 10.0] > 2.0):
        return "wrong start"
    if d[-1] > 2.0:
        return "tip off"
    if s[-1] > 1.1 * L_true:
        return "too long"
    if row.tip_mm > 2.0:
        return "stops short"
    if np.any(d > 2.0) or row.max_mm > 2.0:
        return "excursion"
    return "other"


def diagnose(out: Path, method: str = "multiview") -> pd.DataFrame:
    """The scores table of ``out`` with ``cause`` (empty for frames within), ``length_ratio`` and ``pale``."""
    from tendrilkit.io import read_csv
    from tendrilkit.phantom import read_ground_truth

    scores = pd.read_csv(out / "scores.csv", keep_default_na=False, na_values=[""])
    causes, ratios = [], []
    cache: dict = {}
    for row in scores.itertuples():
        folder = out / row.scene
        if row.scene not in cache:
            gt = read_ground_truth(folder / "scene")
            res = folder / f"result-{method}"
            cv = read_csv(res / "curves.csv", required=("frame", "point", "x_mm", "y_mm", "z_mm")) \
                if (res / "curves.csv").is_file() else pd.DataFrame(columns=["frame", "point", "x_mm", "y_mm", "z_mm"])
            cache = {row.scene: (gt, {int(f): g.sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
                                      for f, g in cv.groupby("frame")})}
        gt, curves = cache[row.scene]
        rec = curves.get(int(row.frame))
        true = np.asarray(gt.curves[int(row.frame)], float)
        L_true = float(np.linalg.norm(np.diff(true, axis=0), axis=1).sum())
        ratios.append(float(np.linalg.norm(np.diff(rec, axis=0), axis=1).sum()) / L_true if rec is not None else np.nan)
        causes.append("" if bool(row.within) else frame_cause(rec, true, row))
    scores["cause"] = causes
    scores["length_ratio"] = ratios
    scores["pale"] = scores.factors.fillna("").str.contains("look=pale")
    return scores


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("out", type=Path)
    p.add_argument("--method", default="multiview")
    p.add_argument("--factors", default="tip_leaf,look=pale,second_tendril,petiole,over_leaf,careless_marks",
                   help="factors to break the causes down by, comma separated")
    a = p.parse_args(argv)
    t = diagnose(a.out, a.method)
    t.to_csv(a.out / "causes.csv", index=False, float_format="%.4f")
    wrong = t[t.cause != ""]
    print(f"{len(t)} frames, {int(t.within.sum())} within, {len(wrong)} wrong; "
          f"silent (ok, mean > 1.5 mm): {int(t.silent.sum())}")
    rows = []
    for c in CAUSES:
        w = wrong[wrong.cause == c]
        rows.append({"cause": c, "frames": len(w), "pale": int(w.pale.sum()),
                     "silent": int(w.silent.sum()),
                     "median_length_ratio": float(w.length_ratio.median()) if len(w) else np.nan})
    print(pd.DataFrame(rows).to_string(index=False, float_format=lambda x: f"{x:.2f}"))
    fac = t.factors.fillna("").str.split(";")
    print()
    cols = ["factor", "frames", "within"] + list(CAUSES)
    out = []
    for name in [f for f in a.factors.split(",") if f]:
        sel = t[fac.apply(lambda fs, name=name: name in fs)]
        out.append([name, len(sel), int(sel.within.sum())] + [int((sel.cause == c).sum()) for c in CAUSES])
    print(pd.DataFrame(out, columns=cols).to_string(index=False))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
