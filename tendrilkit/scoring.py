"""Scoring a reconstruction against a phantom's ground truth, per frame and per scene factor.

Used by ``benchmarks/bench_generalize.py`` (random scenes) and by tests: a
result folder (``curves.csv``, ``frames.csv``) is compared with the ground
truth written beside a phantom experiment (``ground_truth/``).

A frame is *within* the truth when its mean distance to the true centreline
is at most 0.5 mm, its largest distance at most 2 mm, and its base and tip
are within 2 mm of the true ends; and no true point lies farther than 2 mm
from it (``miss_mm``: a curve that cuts across a loop has every point on the
truth and both ends right; since 2026-12-02, no frame of the development
runs then changed). A frame is a *silent failure* when it is
reported ``ok`` but its mean distance exceeds 1.5 mm; a ``doubtful`` frame
that is wrong is counted apart (``flagged_wrong``): it was flagged.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

MEAN_OK_MM = 0.5
MAX_OK_MM = 2.0
ENDS_OK_MM = 2.0
WRONG_MM = 1.5

SCORE_COLUMNS = ["scene", "frame", "status", "mean_mm", "max_mm", "base_mm", "tip_mm", "miss_mm", "within_mean",
                 "within_max", "within_ends", "within", "silent", "flagged_wrong", "factors", "message"]


def score_frames(curves: pd.DataFrame, frames: pd.DataFrame, truth: pd.DataFrame, *, factors: list[str] = (),
                 scene: str = "") -> pd.DataFrame:
    """Per processed frame: distances to the truth, status, and the flags of the module docstring.

    Parameters
    ----------
    curves : DataFrame
        ``curves.csv`` of a run (``frame, point, x_mm, y_mm, z_mm``).
    frames : DataFrame
        ``frames.csv`` of the run (``frame, status, message``).
    truth : DataFrame
        True centrelines (``frame, point, x_mm, y_mm, z_mm``; a phantom's ``gt_curves.csv``).
    factors : list of str
        The scene's active factors (``gt_meta.json`` ``active_factors``), joined with ``;``.
    scene : str
        A label for the ``scene`` column.

    Returns
    -------
    DataFrame
        Columns :data:`SCORE_COLUMNS`, one row per row of ``frames``, sorted
        by frame; distances NaN (and every ``within`` False) where the frame
        has no curve.
    """
    from tendrilkit.evaluation import accuracy_against_truth

    acc = accuracy_against_truth(curves, truth) if len(curves) else pd.DataFrame(
        columns=["frame", "mean_mm", "max_mm", "base_mm", "tip_mm", "miss_mm"])
    fr = frames[["frame", "status", "message"]].copy()
    fr["frame"] = fr["frame"].astype(int)
    acc["frame"] = acc["frame"].astype(int)
    t = fr.merge(acc, on="frame", how="left").sort_values("frame").reset_index(drop=True)
    for c in ("mean_mm", "max_mm", "base_mm", "tip_mm", "miss_mm"):
        t[c] = t[c].astype(float)
    t.loc[t.status == "failed", ["mean_mm", "max_mm", "base_mm", "tip_mm", "miss_mm"]] = np.nan
    t["within_mean"] = t.mean_mm <= MEAN_OK_MM
    t["within_max"] = t.max_mm <= MAX_OK_MM
    t["within_ends"] = (t.base_mm <= ENDS_OK_MM) & (t.tip_mm <= ENDS_OK_MM)
    t["within"] = t.within_mean & t.within_max & t.within_ends & (t.miss_mm <= MAX_OK_MM)
    t["silent"] = (t.status == "ok") & (t.mean_mm > WRONG_MM)
    t["flagged_wrong"] = (t.status == "doubtful") & (t.mean_mm > WRONG_MM)
    t["factors"] = ";".join(factors)
    t["scene"] = scene
    t["message"] = ["" if pd.isna(m) else str(m) for m in t["message"]]
    return t[SCORE_COLUMNS]


def score_result(result_dir: str | Path, experiment_dir: str | Path, *, scene: str | None = None) -> pd.DataFrame:
    """:func:`score_frames` of a run folder against the ground truth of a phantom experiment.

    Parameters
    ----------
    result_dir : path
        Output of ``python -m tendrilkit reconstruct`` (``curves.csv``, ``frames.csv``).
    experiment_dir : path
        The phantom experiment folder (or its ``ground_truth`` folder).
    scene : str, optional
        Label of the ``scene`` column (default: the ground truth's ``name``).
    """
    from tendrilkit.io import read_csv
    from tendrilkit.phantom import read_ground_truth

    gt = read_ground_truth(experiment_dir)
    result_dir = Path(result_dir)
    curves = read_csv(result_dir / "curves.csv", required=("frame", "point", "x_mm", "y_mm", "z_mm"))
    frames = read_csv(result_dir / "frames.csv", required=("frame", "status", "message"))
    factors = gt.meta.get("active_factors", [f"site={gt.meta.get('site')}"])
    return score_frames(curves, frames, gt.curves_table(), factors=factors,
                        scene=scene if scene is not None else str(gt.meta.get("name", "")))


def summarise_scores(table: pd.DataFrame) -> pd.DataFrame:
    """Overall and per-factor figures of a :func:`score_frames` table (several scenes concatenated).

    Returns
    -------
    DataFrame
        One row ``all`` then one per factor (frames of the scenes that have
        it): ``scenes``, ``frames``, ``within_mean_pct``, ``within_max_pct``,
        ``within_ends_pct``, ``within_pct`` (all three), ``failed_pct``,
        ``silent`` (count), ``silent_pct``, ``flagged_wrong`` (count).
    """
    def row(name: str, t: pd.DataFrame) -> dict:
        n = len(t)
        pct = (lambda m: 100.0 * float(m.sum()) / n if n else float("nan"))
        return {"factor": name, "scenes": int(t.scene.nunique()), "frames": n,
                "within_mean_pct": pct(t.within_mean), "within_max_pct": pct(t.within_max),
                "within_ends_pct": pct(t.within_ends), "within_pct": pct(t.within),
                "failed_pct": pct(t.status == "failed"), "silent": int(t.silent.sum()), "silent_pct": pct(t.silent),
                "flagged_wrong": int(t.flagged_wrong.sum())}

    rows = [row("all", table)]
    fac = table.factors.str.split(";")
    names = sorted({f for fs in fac for f in fs if f})
    for name in names:
        rows.append(row(name, table[fac.apply(lambda fs, name=name: name in fs)]))
    return pd.DataFrame(rows)
