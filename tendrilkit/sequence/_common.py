"""What every analysis of :mod:`tendrilkit.sequence` shares: checked tables, kept frames, curves, laws.

Private to the package: the column checks (names from :mod:`tendrilkit.schema`),
the frame filter of the package notes ("Failed and doubtful frames"), the
curves of a table split per frame, resampling at normalised arc length and
the piece-wise linear laws evaluated at an arc length.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Iterable, Sequence

import numpy as np
import pandas as pd

from tendrilkit.schema import CURVES, PWC_SEGMENTS

#: Fraction of the normalised length in the base and tip sections (paper: one quarter).
SECTION_FRACTION = 0.25


def _checked(df: pd.DataFrame, required: Sequence[str], name: str) -> pd.DataFrame:
    """``df`` itself, once checked to be a DataFrame holding the ``required`` columns.

    The names are those of :mod:`tendrilkit.schema` (as tendrilkit writes
    them); a missing one is a ``ValueError`` naming the table, the missing
    and the present columns.
    """
    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"{name} must be a pandas DataFrame, got {type(df).__name__}")
    missing = [c for c in required if c not in df.columns]
    if missing:
        raise ValueError(f"{name}: missing column(s) {', '.join(missing)}; expected {', '.join(required)}, "
                         f"got {', '.join(map(str, df.columns))}")
    return df


def frame_status(frames: pd.DataFrame, *, include_doubtful: bool = False) -> tuple[np.ndarray, pd.DataFrame]:
    """Usable frame indices (sorted) and the table of the others (``frame, status, message``).

    Parameters
    ----------
    frames : DataFrame
        ``frame, status`` (``ok``, ``doubtful``, ``failed``), optional ``message``.
    include_doubtful : bool
        Also use ``doubtful`` frames (reconstructed, but a check against the
        views or the neighbouring frames failed); by default only ``ok`` ones.
    """
    f = _checked(frames, ("frame", "status"), "frames")
    status = f["status"].astype(str).str.lower()
    ok_mask = (status.eq("ok") | (status.eq("doubtful") & include_doubtful)).to_numpy()
    ok = np.sort(f.loc[ok_mask, "frame"].to_numpy(dtype=int))
    failed = f.loc[~ok_mask].copy()
    if "message" not in failed.columns:
        failed["message"] = ""
    failed["status"] = status[~ok_mask].to_numpy()
    failed = failed[["frame", "status", "message"]].sort_values("frame").reset_index(drop=True)
    return ok, failed


def _report(excluded: dict[int, str], what: str) -> list[int]:
    if excluded:
        items = ", ".join(f"{k} ({v})" if v else str(k) for k, v in sorted(excluded.items()))
        warnings.warn(f"{what}: {len(excluded)} frame(s) excluded: {items}", UserWarning, stacklevel=3)
    return sorted(excluded)


@dataclass(frozen=True, eq=False)


class _Curves:
    frame: np.ndarray      # (m,) int
    time_s: np.ndarray     # (m,) float
    points: list           # m arrays (n_i, 3) mm, base to tip
    excluded: dict         # frame -> reason


def _split_curves(curves: pd.DataFrame, frames: pd.DataFrame | None, what: str,
                  min_points: int = 2, include_doubtful: bool = False) -> _Curves:
    c = _checked(curves, CURVES.columns, "curves")
    ok_set, excluded = _frames_filter(frames, include_doubtful)
    c = c.sort_values(["frame", "point"], kind="stable")
    fr_out, t_out, pts_out = [], [], []
    for fr, g in c.groupby("frame", sort=True):
        fr = int(fr)
        if ok_set is not None and fr not in ok_set:
            excluded.setdefault(fr, "failed")
            continue
        P = g[["x_mm", "y_mm", "z_mm"]].to_numpy(dtype=float)
        if len(P) < min_points or not np.all(np.isfinite(P)):
            excluded[fr] = "non-finite coordinates" if len(P) >= min_points else f"{len(P)} point(s)"
            continue
        fr_out.append(fr)
        t_out.append(float(g["time_s"].iloc[0]))
        pts_out.append(P)
    if ok_set is not None:
        for fr in sorted(ok_set - set(fr_out) - set(excluded)):
            excluded[fr] = "ok in frames but absent from curves"
    _report(excluded, what)
    return _Curves(np.asarray(fr_out, dtype=int), np.asarray(t_out, dtype=float), pts_out, excluded)


def _arc_length(P: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(P, axis=0), axis=1))])


def resample_normalised(points_mm: np.ndarray, u: np.ndarray) -> np.ndarray:
    """Points at normalised arc lengths ``u`` (0 = base, 1 = tip) of a polyline.

    Parameters
    ----------
    points_mm : (n, 3) float array
        Ordered polyline, base to tip.
    u : (m,) float array
        Normalised arc lengths in [0, 1].

    Returns
    -------
    (m, 3) float array, linear interpolation along the polyline.
    """
    P = np.asarray(points_mm, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3 or len(P) < 2:
        raise ValueError(f"points_mm must have shape (n >= 2, 3), got {P.shape}")
    if not np.all(np.isfinite(P)):
        raise ValueError("points_mm must be finite (no NaN or inf)")
    s = _arc_length(P)
    if not s[-1] > 0:
        raise ValueError("points_mm has zero length")
    keep = np.concatenate([[True], np.diff(s) > 0])
    s, P = s[keep] / s[-1], P[keep]
    return np.stack([np.interp(u, s, P[:, k]) for k in range(3)], axis=1)


def _kabsch(A: np.ndarray, B: np.ndarray) -> np.ndarray:
    """``B`` moved rigidly onto ``A`` (least squares, proper rotation)."""
    ca, cb = A.mean(0), B.mean(0)
    H = (B - cb).T @ (A - ca)
    U, _, Vt = np.linalg.svd(H)
    d = np.sign(np.linalg.det(Vt.T @ U.T)) or 1.0
    R = Vt.T @ np.diag([1.0, 1.0, d]) @ U.T
    return (B - cb) @ R.T + ca


def _default_frames(ok: np.ndarray) -> list[int]:
    """First, middle and last ok frame (the paper's 1st, 100th, 200th)."""
    if len(ok) == 0:
        return []
    return sorted({int(ok[0]), int(ok[len(ok) // 2]), int(ok[-1])})


def _mark(df: pd.DataFrame, excluded: Iterable[int]) -> pd.DataFrame:
    df.attrs["excluded_frames"] = list(excluded)
    return df


def _segments(segments: pd.DataFrame) -> pd.DataFrame:
    s = _checked(segments, PWC_SEGMENTS.columns, "segments")
    kinds = set(s["kind"].astype(str).unique())
    bad = kinds - {"kappa", "tau"}
    if bad:
        raise ValueError(f"segments: column kind must be 'kappa' or 'tau', got {sorted(bad)}")
    s = s.copy()
    s["kind"] = s["kind"].astype(str)
    return s.sort_values(["frame", "kind", "s0_mm", "segment"], kind="stable").reset_index(drop=True)


def _eval_law(g: pd.DataFrame, s_mm: np.ndarray) -> np.ndarray:
    """Piece-wise linear law of one frame and kind at ``s_mm``."""
    s0 = g["s0_mm"].to_numpy(float)
    s1 = g["s1_mm"].to_numpy(float)
    v0 = g["value_s0"].to_numpy(float)
    v1 = g["value_s1"].to_numpy(float)
    i = np.clip(np.searchsorted(s0, s_mm, side="right") - 1, 0, len(s0) - 1)
    w = np.where(s1[i] > s0[i], (s_mm - s0[i]) / np.where(s1[i] > s0[i], s1[i] - s0[i], 1.0), 0.0)
    return v0[i] + np.clip(w, 0.0, 1.0) * (v1[i] - v0[i])


def _frames_filter(frames: pd.DataFrame | None, include_doubtful: bool = False) -> tuple[set | None, dict[int, str]]:
    if frames is None:
        return None, {}
    ok, failed = frame_status(frames, include_doubtful=include_doubtful)
    excluded = {int(f): (f"{st}: {m}" if isinstance(m, str) and m else st)
                for f, st, m in zip(failed["frame"], failed["status"], failed["message"])}
    return set(ok.tolist()), excluded
