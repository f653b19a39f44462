"""The paper's Tables 1-3: reprojection error, projected PWC distance, PWC fit figures for chosen frames."""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

from tendrilkit.schema import REPROJECTION, SECTIONS, TABLE1, TABLE3
from tendrilkit.sequence._common import (SECTION_FRACTION, _checked, _default_frames, _split_curves, frame_status,
                                         resample_normalised)


def _chosen(available: np.ndarray, chosen: Sequence[int] | None, what: str) -> list[int]:
    avail = np.unique(np.asarray(available, dtype=int))
    if chosen is None:
        return _default_frames(avail)
    chosen = [int(f) for f in chosen]
    missing = [f for f in chosen if f not in set(avail.tolist())]
    if missing:
        raise ValueError(f"{what}: frame(s) {missing} not in the table (available {avail[:1].tolist()}..{avail[-1:].tolist()})")
    return chosen


def _error_table(rep: pd.DataFrame, chosen, frames, what, include_doubtful: bool = False) -> pd.DataFrame:
    r = _checked(rep, REPROJECTION.require("frame", "view", "section", "mean_px", "std_px"), what)
    if frames is not None:
        ok, _ = frame_status(frames, include_doubtful=include_doubtful)
        r = r[r["frame"].isin(ok)]
    fr = _chosen(r["frame"].to_numpy(), chosen, what)
    r = r[r["frame"].isin(fr)]
    r = r.assign(section=r["section"].astype(str))
    bad = set(r["section"]) - set(SECTIONS)
    if bad:
        raise ValueError(f"{what}: column section must be one of {SECTIONS}, got {sorted(bad)}")
    wide = r.pivot_table(index=["frame", "view"], columns="section", values=["mean_px", "std_px"], aggfunc="mean")
    out = pd.DataFrame(index=wide.index)
    for stat in ("mean", "std"):
        for sec in SECTIONS:
            key = (f"{stat}_px", sec)
            out[f"{stat}_{sec}_px"] = wide[key] if key in wide.columns else np.nan
    out = out.reset_index().sort_values(["frame", "view"], kind="stable").reset_index(drop=True)
    return out[list(TABLE1.columns)]


def table1(reprojection: pd.DataFrame, *, at_frames: Sequence[int] | None = None,
           frames: pd.DataFrame | None = None,
           include_doubtful: bool = False) -> pd.DataFrame:
    """Paper Table 1: reprojection error of the reconstruction per frame and view.

    Parameters
    ----------
    reprojection : DataFrame
        ``frame, view, section, mean_px, std_px`` (section base / tip / entire;
        e.g. ``reprojection.csv``, :data:`tendrilkit.schema.REPROJECTION`).
    at_frames : sequence of int, optional
        Frames to show; default the first, middle and last (ok) frame.
    frames : DataFrame, optional
        The run's ``frames`` table: only ok frames are eligible.

    Returns
    -------
    DataFrame
        ``frame, view, mean_base_px, mean_tip_px, mean_entire_px,
        std_base_px, std_tip_px, std_entire_px``.
    """
    return _error_table(reprojection, at_frames, frames, "reprojection", include_doubtful)


def projection_errors(curves: pd.DataFrame, other: pd.DataFrame, cameras: Sequence, *,
                      at_frames: Sequence[int] | None = None, n_s: int | None = None) -> pd.DataFrame:
    """Pixel distances between the projections of two curve tables (paper Table 2 input).

    Corresponding points are taken at equal normalised arc length. Sections:
    base = first quarter, tip = last quarter, entire.

    Parameters
    ----------
    curves, other : DataFrame
        ``curves`` and e.g. ``pwc_curves`` (same columns).
    cameras : sequence of :class:`tendrilkit.camera.Camera`
        In view order (views are reported 1-based).
    at_frames : sequence of int, optional
        Default: every frame present in both tables.

    Returns
    -------
    DataFrame
        ``frame, view, section, mean_px, std_px, max_px, n_points`` (the layout of
        ``reprojection.csv``, :data:`tendrilkit.schema.REPROJECTION`).
    """
    a = _split_curves(curves, None, "projection_errors")
    b = _split_curves(other, None, "projection_errors")
    common = sorted(set(a.frame.tolist()) & set(b.frame.tolist()))
    fr = common if at_frames is None else _chosen(np.asarray(common), at_frames, "projection_errors")
    rows = []
    for f in fr:
        P = a.points[int(np.flatnonzero(a.frame == f)[0])]
        Q = b.points[int(np.flatnonzero(b.frame == f)[0])]
        n = int(n_s) if n_s is not None else len(P)
        u = np.linspace(0.0, 1.0, n)
        Pu, Qu = resample_normalised(P, u), resample_normalised(Q, u)
        masks = {"base": u <= SECTION_FRACTION, "tip": u >= 1 - SECTION_FRACTION, "entire": np.ones(n, bool)}
        for v, cam in enumerate(cameras, start=1):
            d = np.linalg.norm(cam.project(Pu) - cam.project(Qu), axis=1)
            for sec in SECTIONS:
                dd = d[masks[sec]]
                rows.append((int(f), v, sec, float(np.nanmean(dd)), float(np.nanstd(dd)), float(np.nanmax(dd)),
                             int(np.isfinite(dd).sum())))
    return pd.DataFrame(rows, columns=list(REPROJECTION.columns))


def table2(pwc_errors: pd.DataFrame, *, at_frames: Sequence[int] | None = None,
           frames: pd.DataFrame | None = None,
           include_doubtful: bool = False) -> pd.DataFrame:
    """Paper Table 2: projected distance between the PWC curve and the reconstruction.

    ``pwc_errors`` has the ``reprojection`` layout, e.g. from
    :func:`projection_errors` ``(curves, pwc_curves, cameras)``; the result has
    the layout of :func:`table1`.
    """
    return _error_table(pwc_errors, at_frames, frames, "pwc_errors", include_doubtful)


def table3(fit_metrics: pd.DataFrame, *, at_frames: Sequence[int] | None = None,
           frames: pd.DataFrame | None = None,
           include_doubtful: bool = False) -> pd.DataFrame:
    """Paper Table 3: segments, R^2 and SSE of the PWC fit for chosen frames.

    Parameters
    ----------
    fit_metrics : DataFrame
        One row per frame (or per frame and penalty pair): ``frame`` and any
        of ``penalty_kappa, penalty_tau, n_kappa, n_tau, r2_entire, r2_base,
        r2_tip, sse_entire_mm2, sse_base_mm2, sse_tip_mm2`` (the names of
        ``pwc_metrics.csv``, :data:`tendrilkit.schema.PWC_METRICS`); rows whose
        ``status`` is not ``ok`` are dropped.
    at_frames : sequence of int, optional
        Default: first, middle and last (ok) frame.
    frames : DataFrame, optional
        The run's ``frames`` table: only ok frames are eligible.

    Returns
    -------
    DataFrame
        ``frame`` then the columns of :data:`tendrilkit.schema.TABLE3` present, in the paper's order;
        sorted by frame, rows of a frame in their input order (e.g. the
        penalty pairs of :func:`tendrilkit.pwc.penalty_table`).
    """
    m = _checked(fit_metrics, ("frame",), "fit_metrics")
    if "status" in m.columns:  # pwc_metrics.csv carries its own status per frame
        m = m[m["status"].astype(str).str.lower().eq("ok")]
    if frames is not None:
        ok, _ = frame_status(frames, include_doubtful=include_doubtful)
        m = m[m["frame"].isin(ok)]
    fr = _chosen(m["frame"].to_numpy(), at_frames, "fit_metrics")
    keep = [c for c in TABLE3.columns if c in m.columns]
    if len(keep) == 1:
        raise ValueError(f"fit_metrics: none of {', '.join(TABLE3.columns[1:])} found in "
                         f"{', '.join(map(str, fit_metrics.columns))}")
    out = m.loc[m["frame"].isin(fr), keep]
    return out.sort_values("frame", kind="stable").reset_index(drop=True)
