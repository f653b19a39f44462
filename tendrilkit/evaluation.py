"""Evaluation of reconstructions against ground truth (phantoms) and between correspondence methods.

:func:`accuracy_against_truth` scores a ``curves.csv`` against the true
centrelines (a phantom's ``gt_curves.csv``); :func:`compare_correspondence`
reconstructs an experiment once per correspondence method and tabulates
both (``benchmarks/correspondence_comparison.ipynb``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["accuracy_against_truth", "compare_correspondence"]


def accuracy_against_truth(curves: pd.DataFrame, truth: pd.DataFrame) -> pd.DataFrame:
    """Per frame: distance of a reconstruction to the true 3D centreline (phantoms).

    Parameters
    ----------
    curves : pandas.DataFrame
        ``curves.csv`` (``frame, point, x_mm, y_mm, z_mm``).
    truth : pandas.DataFrame
        The true centrelines, same columns (e.g. a phantom's ``gt_curves.csv``).

    Returns
    -------
    pandas.DataFrame
        ``frame``, ``mean_mm`` and ``max_mm`` (distance of each reconstructed
        point to the true polyline), ``base_mm`` and ``tip_mm`` (distance of
        the first and last points to the true ends), ``miss_mm`` (the other
        way: the largest distance of a true point to the reconstructed
        polyline; a curve that cuts across a loop, every point of it on the
        truth, misses the loop), sorted by frame.
    """
    from scipy.spatial import cKDTree

    from tendrilkit.geometry import resample_polyline

    def dense(Y: np.ndarray) -> np.ndarray:
        """The polyline ``Y`` every 0.02 mm (itself when it has no length: a single point)."""
        length = float(np.linalg.norm(np.diff(Y, axis=0), axis=1).sum()) if len(Y) > 1 else 0.0
        return resample_polyline(Y, max(2, int(np.ceil(length / 0.02)))) if length > 0 else Y

    rows = []
    for frame, g in curves.groupby("frame", sort=True):
        t = truth[truth.frame == frame].sort_values("point")
        if t.empty:
            continue
        X = t[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
        P = g.sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
        d, _ = cKDTree(dense(X)).query(P)  # each reconstructed point to the true polyline
        miss, _ = cKDTree(dense(P)).query(X)  # and each true point to the reconstructed one
        rows.append({"frame": int(frame), "mean_mm": float(d.mean()), "max_mm": float(d.max()),
                     "base_mm": float(np.linalg.norm(P[0] - X[0])), "tip_mm": float(np.linalg.norm(P[-1] - X[-1])),
                     "miss_mm": float(miss.max())})
    return pd.DataFrame(rows, columns=["frame", "mean_mm", "max_mm", "base_mm", "tip_mm", "miss_mm"])


def compare_correspondence(experiment_path: str | Path, out_dir: str | Path, *, truth: pd.DataFrame | None = None,
                           methods: tuple[str, ...] = ("epipolar", "frechet"), workers: int | None = None,
                           fit: bool = False) -> pd.DataFrame:
    """Reconstruct an experiment once per correspondence method and tabulate the figures per frame.

    Each method runs into ``out_dir/<method>/`` (resumable like any run), with
    ``reconstruction.method: chain`` (the correspondence method is a step of
    the chain; the multi-view method matches no 2D curves).

    Parameters
    ----------
    experiment_path, out_dir : path
    truth : pandas.DataFrame, optional
        True centrelines (``frame, point, x_mm, y_mm, z_mm``; a phantom's
        ``gt_curves.csv``): adds the columns of :func:`accuracy_against_truth`.
    methods : tuple of str
    workers : int, optional
    fit : bool
        Also fit the piece-wise clothoid (slower; not needed to compare).

    Returns
    -------
    pandas.DataFrame
        One row per method and frame: ``method``, ``frame``, ``status``, the
        reprojection columns ``reproj_mean_px_v<i>`` and, with ``truth``,
        ``mean_mm, max_mm, base_mm, tip_mm``.
    """
    from tendrilkit.io import read_csv
    from tendrilkit.runner import run_reconstruct

    out = Path(out_dir)
    parts = []
    for m in methods:
        run_reconstruct(experiment_path, out / m, workers=workers, progress=False, fit=fit,
                        overrides={"reconstruction": {"method": "chain"}, "correspondence": {"method": m}})
        f = read_csv(out / m / "frames.csv")
        cols = ["frame", "status"] + [c for c in f.columns if c.startswith("reproj_mean_px_v")]
        t = f[cols].copy()
        if truth is not None:
            acc = accuracy_against_truth(read_csv(out / m / "curves.csv"), truth)
            t = t.merge(acc, on="frame", how="left")
        t.insert(0, "method", m)
        parts.append(t)
    return pd.concat(parts, ignore_index=True)
