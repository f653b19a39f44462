"""Split points and normalised curvature/torsion maps over the frames (paper Figures 7 and 8).

Normalised curvature/torsion maps (:func:`curvature_torsion_maps`)
    :math:`\\kappa(u, t) / \\kappa_{ref}` with
    :math:`\\kappa_{ref} = \\max_{u,t} |\\kappa|` over the whole sequence (or a
    percentile of it, ``scale_percentile``), likewise torsion: values in
    [-1, 1] (curvature in [0, 1] when it is non-negative); the scales are
    returned so maps can be turned back into 1/mm.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from tendrilkit.exceptions import DegenerateCurveError
from tendrilkit.schema import SEGMENT_COUNTS, SPLIT_POINTS
from tendrilkit.sequence._common import _checked, _eval_law, _frames_filter, _mark, _report, _segments, _split_curves


def split_points(segments: pd.DataFrame, *, frames: pd.DataFrame | None = None, include_doubtful: bool = False, points: int | None = None) -> pd.DataFrame:
    """Interior breakpoints of the curvature and torsion laws of every frame (paper Figure 7).

    Parameters
    ----------
    segments : DataFrame
        ``frame, kind, segment, s0_mm, s1_mm, value_s0, value_s1``.
    frames : DataFrame, optional
        The run's ``frames`` table: failed frames are dropped (and reported),
        ``time_s`` is added.
    points : int, optional
        Points per curve; adds ``point``, the nearest point index of each
        breakpoint (the paper's axis, 0 ... points - 1).

    Returns
    -------
    DataFrame
        ``frame, kind, s_mm, s_norm`` (+ ``time_s``, ``point``): one row per
        interior breakpoint (the start of every segment but the first),
        ``s_norm = s_mm / L`` with ``L`` the end of the last segment of that
        frame and kind. Sorted by frame, kind, s_mm.

    Examples
    --------
    >>> seg = pd.DataFrame({"frame": [0, 0, 0], "kind": ["kappa"] * 3, "segment": [0, 1, 2],
    ...     "s0_mm": [0.0, 40.0, 90.0], "s1_mm": [40.0, 90.0, 100.0],
    ...     "value_s0": [0.0] * 3, "value_s1": [0.0] * 3})
    >>> split_points(seg)[["s_mm", "s_norm"]].to_numpy().tolist()
    [[40.0, 0.4], [90.0, 0.9]]
    """
    s = _segments(segments)
    ok_set, excluded = _frames_filter(frames, include_doubtful)
    rows = []
    for (fr, kind), g in s.groupby(["frame", "kind"], sort=True):
        fr = int(fr)
        if ok_set is not None and fr not in ok_set:
            excluded.setdefault(fr, "failed")
            continue
        L = float(g["s1_mm"].max())
        for s0 in g["s0_mm"].to_numpy(float)[1:]:
            rows.append((fr, kind, s0, s0 / L if L > 0 else np.nan))
    out = pd.DataFrame(rows, columns=list(SPLIT_POINTS.columns))
    out["frame"] = out["frame"].astype(int)
    if frames is not None:
        f = _checked(frames, ("frame",), "frames")
        if "time_s" in f.columns:
            out = out.merge(f[["frame", "time_s"]].drop_duplicates("frame"), on="frame", how="left")
    if points is not None:
        if int(points) < 2:
            raise ValueError(f"points must be >= 2, got {points}")
        out["point"] = np.rint(out["s_norm"].to_numpy() * (int(points) - 1)).astype(int)
    out = out.sort_values(["frame", "kind", "s_mm"], kind="stable").reset_index(drop=True)
    return _mark(out, _report(excluded, "split_points"))


def segment_counts(segments: pd.DataFrame) -> pd.DataFrame:
    """Number of curvature and torsion segments per frame: ``frame, n_kappa, n_tau``."""
    s = _segments(segments)
    n = s.groupby(["frame", "kind"]).size().unstack("kind").reindex(columns=["kappa", "tau"]).fillna(0).astype(int)
    n.columns = list(SEGMENT_COUNTS.columns[1:])
    return n.reset_index()


# ---------------------------------------------------------------- maps
@dataclass(frozen=True, eq=False)


class KTMaps:
    """Normalised curvature and torsion along the normalised length over time (Figure 8).

    Unpacks as ``s_norm, time_s, kappa, tau``.

    Attributes
    ----------
    s_norm : (n_s,) float array
        Normalised arc length, 0 = base, 1 = tip.
    frame : (m,) int array
        Frame of each column.
    time_s : (m,) float array
        Time of each column, s.
    kappa, tau : (n_s, m) float arrays
        Curvature and torsion divided by ``kappa_scale`` / ``tau_scale``
        (NaN columns for excluded frames).
    kappa_scale, tau_scale : float
        The normalisers, 1/mm: the ``scale_percentile`` percentile of the
        absolute values over the whole sequence (100 = maximum).
    source : str
        ``"laws"`` (fitted piece-wise linear laws) or ``"frenet"`` (raw estimates).
    length_mm : (m,) float array
        Curve length of each column, mm.
    """

    s_norm: np.ndarray
    frame: np.ndarray
    time_s: np.ndarray
    kappa: np.ndarray
    tau: np.ndarray
    kappa_scale: float
    tau_scale: float
    source: str
    length_mm: np.ndarray = field(default_factory=lambda: np.zeros(0))
    excluded_frames: tuple = ()

    def __iter__(self):
        return iter((self.s_norm, self.time_s, self.kappa, self.tau))


def _scale(a: np.ndarray, pct: float) -> float:
    v = np.abs(a[np.isfinite(a)])
    if v.size == 0:
        return 1.0
    sc = float(np.percentile(v, pct)) if pct < 100 else float(v.max())
    return sc if sc > 0 else 1.0


def curvature_torsion_maps(
    data: pd.DataFrame,
    *,
    n_s: int = 100,
    frames: pd.DataFrame | None = None,
    include_doubtful: bool = False,
    source: str = "auto",
    scale_percentile: float = 100.0,
    smoothing_length_mm: float | None = None,
) -> KTMaps:
    """Normalised curvature and torsion maps, length x time (paper Figure 8).

    Parameters
    ----------
    data : DataFrame
        A ``segments`` table (the fitted laws, evaluated exactly) or a
        ``curves`` table (raw Frenet estimates by :func:`tendrilkit.frenet.frenet_frames`).
    n_s : int
        Samples along the normalised length.
    frames : DataFrame, optional
        The run's ``frames`` table: failed frames become NaN columns at their time.
    source : {"auto", "laws", "frenet"}
        ``auto`` picks from the columns of ``data``.
    scale_percentile : float
        Percentile of the absolute values used as normaliser (100: the
        maximum; e.g. 99 to ignore spikes of raw torsion; values beyond the
        scale are then clipped to +-1).
    smoothing_length_mm : float, optional
        Frenet source only: half-gain wavelength of the smoother, mm
        (default: :func:`tendrilkit.frenet.frenet_frames`' choice per curve).

    Returns
    -------
    KTMaps
    """
    if n_s < 2:
        raise ValueError(f"n_s must be >= 2, got {n_s}")
    if not 0 < scale_percentile <= 100:
        raise ValueError(f"scale_percentile must be in (0, 100], got {scale_percentile}")
    if source == "auto":
        source = "laws" if "kind" in data.columns else "frenet"
    u = np.linspace(0.0, 1.0, n_s)
    cols_k, cols_t, fr_list, t_list, L_list = [], [], [], [], []
    if source == "laws":
        s = _segments(data)
        ok_set, excluded = _frames_filter(frames, include_doubtful)
        for fr, g in s.groupby("frame", sort=True):
            fr = int(fr)
            if ok_set is not None and fr not in ok_set:
                excluded.setdefault(fr, "failed")
                continue
            gk, gt = g[g["kind"] == "kappa"], g[g["kind"] == "tau"]
            if gk.empty or gt.empty:
                excluded[fr] = "no kappa or no tau law"
                continue
            L = float(g["s1_mm"].max())
            cols_k.append(_eval_law(gk, u * float(gk["s1_mm"].max())))
            cols_t.append(_eval_law(gt, u * float(gt["s1_mm"].max())))
            fr_list.append(fr)
            L_list.append(L)
            t_list.append(np.nan)
        if ok_set is not None:
            for fr in sorted(ok_set - set(fr_list) - set(excluded)):
                excluded[fr] = "ok in frames but absent from segments"
        tmap = {}
        if frames is not None:
            f = _checked(frames, ("frame",), "frames")
            if "time_s" in f.columns:
                tmap = dict(zip(f["frame"].astype(int), f["time_s"].astype(float)))
        if "time_s" in data.columns:
            tmap.update(dict(zip(data["frame"].astype(int), data["time_s"].astype(float))))
        t_list = [tmap.get(fr, np.nan) for fr in fr_list]
        excluded_list = _report(excluded, "curvature_torsion_maps")
    elif source == "frenet":
        from tendrilkit.frenet import frenet_frames  # lazy: only the raw estimates need it

        cv = _split_curves(data, frames, "curvature_torsion_maps", min_points=5, include_doubtful=include_doubtful)
        excluded = dict(cv.excluded)
        for fr, t, P in zip(cv.frame, cv.time_s, cv.points):
            try:
                ff = frenet_frames(P, smoothing_length_mm=smoothing_length_mm)
            except (DegenerateCurveError, ValueError, np.linalg.LinAlgError, FloatingPointError) as e:
                # a degenerate frame is reported, not filled
                excluded[int(fr)] = f"frenet: {e}"
                warnings.warn(f"curvature_torsion_maps: frame {fr} excluded ({e})", UserWarning, stacklevel=2)
                continue
            sn = ff.s_mm / ff.s_mm[-1]
            cols_k.append(np.interp(u, sn, ff.kappa))
            cols_t.append(np.interp(u, sn, ff.tau))
            fr_list.append(int(fr))
            t_list.append(float(t))
            L_list.append(float(ff.s_mm[-1]))
        excluded_list = sorted(excluded)
    else:
        raise ValueError(f"source must be 'auto', 'laws' or 'frenet', got {source!r}")
    # excluded frames with a known time become NaN columns, in time order
    if frames is not None:
        f = _checked(frames, ("frame",), "frames")
        tm = dict(zip(f["frame"].astype(int), f["time_s"].astype(float))) if "time_s" in f.columns else {}
        for fr in excluded_list:
            if fr not in fr_list:
                fr_list.append(fr)
                t_list.append(tm.get(fr, np.nan))
                L_list.append(np.nan)
                cols_k.append(np.full(n_s, np.nan))
                cols_t.append(np.full(n_s, np.nan))
    order = np.argsort(np.asarray(fr_list, dtype=int), kind="stable")
    K = np.stack(cols_k, axis=1)[:, order] if cols_k else np.zeros((n_s, 0))
    T = np.stack(cols_t, axis=1)[:, order] if cols_t else np.zeros((n_s, 0))
    ks, ts = _scale(K, scale_percentile), _scale(T, scale_percentile)
    Kn, Tn = K / ks, T / ts
    if scale_percentile < 100:
        Kn, Tn = np.clip(Kn, -1, 1), np.clip(Tn, -1, 1)
    return KTMaps(s_norm=u, frame=np.asarray(fr_list, dtype=int)[order],
                  time_s=np.asarray(t_list, dtype=float)[order], kappa=Kn, tau=Tn,
                  kappa_scale=ks, tau_scale=ts, source=source,
                  length_mm=np.asarray(L_list, dtype=float)[order], excluded_frames=tuple(excluded_list))
