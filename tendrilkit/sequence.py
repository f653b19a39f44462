"""Analyses over the frames of one experiment, and comparisons across sites.

Paper: "Reconstruction From a Sequence of Frames" and "Analysis of Tip
Motion" (Fan et al., IJCV 2025, Figures 7-9, Tables 1-3 and the Discussion's
response ~3 min / stable ~12 min). Pure functions on the result tables of the
pipeline (pandas DataFrames); no disk, no plotting.

Input tables (EXPERIMENT_FORMAT.md and the fit tables)
------------------------------------------------------
``curves`` (also ``pwc_curves``)
    ``frame, time_s, point, x_mm, y_mm, z_mm``: point 0 = base ... tip, world
    frame of the marker (mm).
``segments``
    ``frame, kind, segment, s0_mm, s1_mm, value_s0, value_s1``: the piece-wise
    linear laws of the fit, ``kind`` is ``kappa`` or ``tau``, values in 1/mm.
``frames``
    ``frame, time_s, status`` (``ok``/``doubtful``/``failed``), ``message``, quality columns.
``reprojection``
    ``frame, view, section`` (``base``/``tip``/``entire``), ``mean_px, std_px``.
``fit metrics``
    ``frame, r2_entire, r2_base, r2_tip, sse_entire_mm2, sse_base_mm2,
    sse_tip_mm2, n_kappa, n_tau, penalty_kappa, penalty_tau`` (see
    :data:`FIT_METRIC_ALIASES` for the other spellings accepted).

Every function taking a table also accepts ``columns=``, a mapping from the
canonical name above to the name used in the table, when a producer spells a
column differently.

Failed and doubtful frames
--------------------------
Frames are 0-based video frame indices. Every function that takes an optional
``frames`` table drops the frames whose status is not ``ok`` (``failed``, and
``doubtful``: reconstructed but a check of :mod:`tendrilkit.verify` failed);
with ``include_doubtful=True`` (the experiment's ``analysis:
{include_doubtful: true}``) it keeps the ``doubtful`` ones; frames with
missing or non-finite coordinates are dropped too. Nothing is interpolated:
dropped frames are listed in a :class:`UserWarning` and in
``result.attrs["excluded_frames"]`` of the returned table (maps keep a NaN
column for each of them, so a gap stays visible).

Definitions
-----------
Shape change (:func:`shape_change`)
    Points correspond at equal normalised arc length :math:`u \\in [0, 1]`:
    point :math:`i` to point :math:`i` when every frame has the same number of
    points (the pipeline's curves are uniform in arc length), otherwise after
    resampling. For frame :math:`i` and the reference frame :math:`r` (first
    ok frame), two distances in mm:

    .. math::

        D_i = \\frac{1}{n}\\sum_u \\lVert p_i(u) - p_r(u) \\rVert, \\qquad
        S_i = \\frac{1}{n}\\sum_u \\lVert R_i\\,p_i(u) + t_i - p_r(u) \\rVert

    with :math:`(R_i, t_i)` the rotation and translation minimising
    :math:`\\sum_u \\lVert R\\,p_i(u) + t - p_r(u) \\rVert^2` (Kabsch).
    ``mean_mm`` (:math:`D`) is the motion, without alignment: the base is
    attached to the stem and the world frame to the board, so every
    displacement is the tendril's (plus noise). ``shape_mm`` (:math:`S`) is
    the change of *shape*: a rigid swing of the whole tendril does not count.
    Response times use ``shape_mm`` by default, because a slight bend near
    the base swings the whole tendril through a lever arm: on the S1 phantom
    (a slight bend near the base) :math:`D` reaches 14 mm while :math:`S`
    stays at 0.6 mm; the paper reports no meaningful response for S1. Also
    reported: RMS and maximum of the unaligned distances, tip displacement
    :math:`\\lVert p_i(1) - p_r(1) \\rVert`, base shift and length.
    ``align="base"`` / ``"rigid"`` align before the ``mean/rms/max`` columns
    too (to check that a drift of the whole curve is not taken for motion).

Response times (:func:`response_times`)
    On a shape-change measure :math:`D(t)` of ok frames (default
    ``shape_mm``), median-filtered over ``median_frames`` frames
    (:math:`\\tilde D`; windows shrink at the ends):

    - de-biasing (``debias=True``): a mean of distances to a noisy
      reference never goes down to 0; noise adds in quadrature,
      :math:`D^2 \\approx S^2 + b^2` with :math:`b` the early level, so the
      analysis runs on :math:`\\operatorname{sign}(D^2 - b^2)\\sqrt{|D^2 - b^2|}`
      (small changes are otherwise compressed under the noise floor and the
      onset comes late: +22 s at 0.3 mm point noise on 20 s frames, -2..+3 s
      with de-biasing);
    - noise :math:`\\sigma`: robust standard deviation of the frame-to-frame
      noise, :math:`1.4826\\,\\mathrm{MAD}(\\Delta^2 D)/\\sqrt 6` (second
      differences remove a slow trend);
    - baseline :math:`b`: median of :math:`D` over frames 1..``baseline_frames``
      (frame 0 is the reference, 0 by construction);
    - plateau :math:`P`: median of :math:`\\tilde D` over the last
      ``plateau_frames`` frames; amplitude :math:`A = P - b`;
    - responded: :math:`A \\ge` ``min_amplitude_mm`` (default 2 mm) and
      :math:`A > k\\sigma` (``noise_k`` = 3); otherwise both times are NaN;
    - onset: first time :math:`\\tilde D` exceeds
      :math:`b + \\max(f_{on} A, k\\sigma)`, linearly interpolated between the
      two frames around the crossing;
    - stabilisation: first time after which :math:`|\\tilde D - P|` stays
      within :math:`\\max((1 - f_{st}) A, k\\sigma)` until the end of the
      sequence (interpolated likewise). NaN, with a warning, if the last frame
      is still outside the band.

    Times are ``time_s - stimulus_s`` (``stimulus_s`` = 0: the video starts at
    the stimulus).

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
from typing import Iterable, Mapping, Sequence

import numpy as np
import pandas as pd
from scipy.ndimage import median_filter

CURVE_COLUMNS = ("frame", "time_s", "point", "x_mm", "y_mm", "z_mm")
SEGMENT_COLUMNS = ("frame", "kind", "segment", "s0_mm", "s1_mm", "value_s0", "value_s1")
REPROJECTION_COLUMNS = ("frame", "view", "section", "mean_px", "std_px")
FIT_METRIC_COLUMNS = (
    "frame", "penalty_kappa", "penalty_tau", "n_kappa", "n_tau",
    "r2_entire", "r2_base", "r2_tip", "sse_entire_mm2", "sse_base_mm2", "sse_tip_mm2",
)
#: Other spellings accepted for the fit-metric columns (canonical -> candidates).
FIT_METRIC_ALIASES: dict[str, tuple[str, ...]] = {
    "penalty_kappa": ("penalty_kappa", "eps_kappa", "epsilon_kappa", "pen_kappa", "kappa_penalty"),
    "penalty_tau": ("penalty_tau", "eps_tau", "epsilon_tau", "pen_tau", "tau_penalty"),
    "n_kappa": ("n_kappa", "n_segments_kappa", "segments_kappa", "kappa_segments", "n_seg_kappa"),
    "n_tau": ("n_tau", "n_segments_tau", "segments_tau", "tau_segments", "n_seg_tau"),
    "r2_entire": ("r2_entire", "r2", "pwc_r2", "r2_all"),
    "r2_base": ("r2_base",),
    "r2_tip": ("r2_tip",),
    "sse_entire_mm2": ("sse_entire_mm2", "sse_entire", "sse_mm2", "sse", "pwc_sse_mm2"),
    "sse_base_mm2": ("sse_base_mm2", "sse_base"),
    "sse_tip_mm2": ("sse_tip_mm2", "sse_tip"),
}
SECTIONS = ("base", "tip", "entire")
#: Fraction of the normalised length in the base and tip sections (paper: one quarter).
SECTION_FRACTION = 0.25


# ------------------------------------------------------------------ helpers
def _canonical(df: pd.DataFrame, required: Sequence[str], name: str,
               columns: Mapping[str, str] | None = None,
               aliases: Mapping[str, Sequence[str]] | None = None,
               optional: Sequence[str] = ()) -> pd.DataFrame:
    """Rename ``df``'s columns to the canonical names and check the required ones."""
    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"{name} must be a pandas DataFrame, got {type(df).__name__}")
    rename: dict[str, str] = {}
    for canon, actual in (columns or {}).items():
        if actual in df.columns and actual != canon:
            rename[actual] = canon
    present = set(df.columns) | set(rename.values())
    for canon in list(required) + list(optional):
        if canon in present:
            continue
        for cand in (aliases or {}).get(canon, ()):
            if cand in df.columns and cand not in rename:
                rename[cand] = canon
                present.add(canon)
                break
    out = df.rename(columns=rename)
    missing = [c for c in required if c not in out.columns]
    if missing:
        raise ValueError(
            f"{name}: missing column(s) {', '.join(missing)}; expected {', '.join(required)}, "
            f"got {', '.join(map(str, df.columns))} (pass columns={{canonical: actual}})")
    return out


def frame_status(frames: pd.DataFrame, *, columns: Mapping[str, str] | None = None,
                 include_doubtful: bool = False) -> tuple[np.ndarray, pd.DataFrame]:
    """Usable frame indices (sorted) and the table of the others (``frame, status, message``).

    Parameters
    ----------
    frames : DataFrame
        ``frame, status`` (``ok``, ``doubtful``, ``failed``), optional ``message``.
    include_doubtful : bool
        Also use ``doubtful`` frames (reconstructed, but a check against the
        views or the neighbouring frames failed); by default only ``ok`` ones.
    """
    f = _canonical(frames, ("frame", "status"), "frames", columns)
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


def _split_curves(curves: pd.DataFrame, frames: pd.DataFrame | None, columns, what: str,
                  min_points: int = 2, include_doubtful: bool = False) -> _Curves:
    c = _canonical(curves, CURVE_COLUMNS, "curves", columns)
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


# ---------------------------------------------------------------- laws
def _segments(segments: pd.DataFrame, columns) -> pd.DataFrame:
    s = _canonical(segments, SEGMENT_COLUMNS, "segments", columns)
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


def split_points(segments: pd.DataFrame, *, frames: pd.DataFrame | None = None, include_doubtful: bool = False, points: int | None = None,
                 columns: Mapping[str, str] | None = None) -> pd.DataFrame:
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
    s = _segments(segments, columns)
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
    out = pd.DataFrame(rows, columns=["frame", "kind", "s_mm", "s_norm"])
    out["frame"] = out["frame"].astype(int)
    if frames is not None:
        f = _canonical(frames, ("frame",), "frames")
        if "time_s" in f.columns:
            out = out.merge(f[["frame", "time_s"]].drop_duplicates("frame"), on="frame", how="left")
    if points is not None:
        if int(points) < 2:
            raise ValueError(f"points must be >= 2, got {points}")
        out["point"] = np.rint(out["s_norm"].to_numpy() * (int(points) - 1)).astype(int)
    out = out.sort_values(["frame", "kind", "s_mm"], kind="stable").reset_index(drop=True)
    return _mark(out, _report(excluded, "split_points"))


def segment_counts(segments: pd.DataFrame, *, columns: Mapping[str, str] | None = None) -> pd.DataFrame:
    """Number of curvature and torsion segments per frame: ``frame, n_kappa, n_tau``."""
    s = _segments(segments, columns)
    n = s.groupby(["frame", "kind"]).size().unstack("kind").reindex(columns=["kappa", "tau"]).fillna(0).astype(int)
    n.columns = ["n_kappa", "n_tau"]
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
    columns: Mapping[str, str] | None = None,
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
        source = "laws" if "kind" in data.columns or (columns and "kind" in columns) else "frenet"
    u = np.linspace(0.0, 1.0, n_s)
    cols_k, cols_t, fr_list, t_list, L_list = [], [], [], [], []
    if source == "laws":
        s = _segments(data, columns)
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
            f = _canonical(frames, ("frame",), "frames")
            if "time_s" in f.columns:
                tmap = dict(zip(f["frame"].astype(int), f["time_s"].astype(float)))
        if "time_s" in data.columns:
            tmap.update(dict(zip(data["frame"].astype(int), data["time_s"].astype(float))))
        t_list = [tmap.get(fr, np.nan) for fr in fr_list]
        excluded_list = _report(excluded, "curvature_torsion_maps")
    elif source == "frenet":
        from tendrilkit.frenet import frenet_frames  # lazy: only the raw estimates need it

        cv = _split_curves(data, frames, columns, "curvature_torsion_maps", min_points=5, include_doubtful=include_doubtful)
        excluded = dict(cv.excluded)
        for fr, t, P in zip(cv.frame, cv.time_s, cv.points):
            try:
                ff = frenet_frames(P, smoothing_length_mm=smoothing_length_mm)
            except Exception as e:  # a degenerate frame is reported, not filled
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
        f = _canonical(frames, ("frame",), "frames")
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


# ---------------------------------------------------------------- tip
@dataclass(frozen=True, eq=False)
class TipPathStats:
    """Summary of the tip's path (paper Figure 9).

    Attributes
    ----------
    path_length_mm : float
        Sum of the frame-to-frame steps (includes reconstruction noise; see
        ``median_frames`` of :func:`tip_path_stats`).
    net_displacement_mm : float
        Distance between first and last tip positions.
    straightness : float
        ``net / path`` in [0, 1]: 1 = straight path (S2-like), small for a
        wandering (S1-like) or curling (S3/S4-like) path.
    extent_mm : (3,) float array
        Range of x, y, z (max - min).
    bbox_min_mm, bbox_max_mm : (3,) float arrays
    radius_of_gyration_mm : float
        RMS distance of the tip positions to their mean (the volume spanned).
    n_frames : int
    """

    path_length_mm: float
    net_displacement_mm: float
    straightness: float
    extent_mm: np.ndarray
    bbox_min_mm: np.ndarray
    bbox_max_mm: np.ndarray
    radius_of_gyration_mm: float
    n_frames: int


def tip_trajectory(curves: pd.DataFrame, *, frames: pd.DataFrame | None = None, include_doubtful: bool = False,
                   columns: Mapping[str, str] | None = None) -> pd.DataFrame:
    """The tip (last point) of every ok frame.

    Returns
    -------
    DataFrame
        ``frame, time_s, x_mm, y_mm, z_mm, step_mm`` (distance from the
        previous kept frame, 0 for the first), ``path_mm`` (cumulative) and
        ``displacement_mm`` (from the first kept frame).
    """
    cv = _split_curves(curves, frames, columns, "tip_trajectory", min_points=1, include_doubtful=include_doubtful)
    tips = np.array([P[-1] for P in cv.points]).reshape(-1, 3)
    step = np.concatenate([[0.0], np.linalg.norm(np.diff(tips, axis=0), axis=1)]) if len(tips) else np.zeros(0)
    out = pd.DataFrame({
        "frame": cv.frame, "time_s": cv.time_s,
        "x_mm": tips[:, 0], "y_mm": tips[:, 1], "z_mm": tips[:, 2],
        "step_mm": step, "path_mm": np.cumsum(step),
        "displacement_mm": np.linalg.norm(tips - tips[:1], axis=1) if len(tips) else np.zeros(0),
    })
    return _mark(out, sorted(cv.excluded))


def tip_path_stats(trajectory: pd.DataFrame, *, median_frames: int = 1) -> TipPathStats:
    """Path length, extent and straightness of a :func:`tip_trajectory`.

    ``median_frames`` > 1 median-filters each coordinate over that many frames
    first, so that reconstruction noise does not inflate the path length.
    """
    t = _canonical(trajectory, ("x_mm", "y_mm", "z_mm"), "trajectory")
    P = t[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
    if len(P) == 0:
        nan3 = np.full(3, np.nan)
        return TipPathStats(np.nan, np.nan, np.nan, nan3, nan3, nan3, np.nan, 0)
    if median_frames > 1:
        P = median_filter(P, size=(int(median_frames), 1), mode="nearest")
    path = float(np.linalg.norm(np.diff(P, axis=0), axis=1).sum())
    net = float(np.linalg.norm(P[-1] - P[0]))
    lo, hi = P.min(0), P.max(0)
    rg = float(np.sqrt(np.mean(np.sum((P - P.mean(0)) ** 2, axis=1))))
    return TipPathStats(path, net, net / path if path > 0 else np.nan, hi - lo, lo, hi, rg, len(P))


# ---------------------------------------------------------------- shape change
def shape_change(curves: pd.DataFrame, *, reference_frame: int | None = None, n_s: int | None = None,
                 align: str = "none", frames: pd.DataFrame | None = None, include_doubtful: bool = False,
                 columns: Mapping[str, str] | None = None) -> pd.DataFrame:
    """How far every frame's curve is from the reference frame's (module notes).

    Parameters
    ----------
    curves : DataFrame
        ``frame, time_s, point, x_mm, y_mm, z_mm``.
    reference_frame : int, optional
        Default: the first kept frame.
    n_s : int, optional
        Resample every curve at ``n_s`` equal steps of normalised arc length.
        Default: when every frame has the same number of points (as the
        pipeline writes them, uniform in arc length), point ``i`` corresponds
        to point ``i``; otherwise curves are resampled at the reference's
        point count.
    align : {"none", "base", "rigid"}
        ``none`` (default; the base is attached to the stem, the world frame
        to the board), ``base`` (translate so the bases coincide), ``rigid``
        (best rotation + translation of the whole curve).
    frames : DataFrame, optional
        The run's ``frames`` table (failed frames are dropped and reported).

    Returns
    -------
    DataFrame
        ``frame, time_s, mean_mm, rms_mm, max_mm, shape_mm,
        tip_displacement_mm, base_shift_mm, length_mm``; sorted by frame.
        ``mean/rms/max``: distances after ``align``; ``shape_mm``: mean
        distance after the best rigid alignment (module notes).
    """
    if align not in ("none", "base", "rigid"):
        raise ValueError(f"align must be 'none', 'base' or 'rigid', got {align!r}")
    cv = _split_curves(curves, frames, columns, "shape_change", include_doubtful=include_doubtful)
    cols = ["frame", "time_s", "mean_mm", "rms_mm", "max_mm", "shape_mm", "tip_displacement_mm", "base_shift_mm",
            "length_mm"]
    if len(cv.frame) == 0:
        return _mark(pd.DataFrame(columns=cols), sorted(cv.excluded))
    if reference_frame is None:
        ri = 0
    else:
        hits = np.flatnonzero(cv.frame == int(reference_frame))
        if hits.size == 0:
            raise ValueError(f"reference_frame {reference_frame} is not a kept frame "
                             f"(kept: {cv.frame[0]}..{cv.frame[-1]}, excluded: {sorted(cv.excluded)})")
        ri = int(hits[0])
    n_ref = len(cv.points[ri])
    by_index = n_s is None and all(len(P) == n_ref for P in cv.points)
    n = n_ref if n_s is None else int(n_s)
    u = np.linspace(0.0, 1.0, max(n, 2))

    def corresponding(P):
        # same point count: point i <-> point i (the pipeline writes curves resampled at uniform
        # arc length); re-parametrising a noisy polyline by its own length would let noise slide
        # the points along the curve
        return np.asarray(P, float) if by_index else resample_normalised(P, u)

    ref = corresponding(cv.points[ri])
    rows = []
    for fr, t, P in zip(cv.frame, cv.time_s, cv.points):
        Q = corresponding(P)
        if align == "base":
            Q = Q - Q[0] + ref[0]
        elif align == "rigid":
            Q = _kabsch(ref, Q)
        d = np.linalg.norm(Q - ref, axis=1)
        Q0 = corresponding(P)
        shape = float(np.linalg.norm(_kabsch(ref, Q0) - ref, axis=1).mean())
        rows.append((int(fr), float(t), float(d.mean()), float(np.sqrt(np.mean(d ** 2))), float(d.max()), shape,
                     float(np.linalg.norm(Q0[-1] - ref[-1])), float(np.linalg.norm(P[0] - cv.points[ri][0])),
                     float(_arc_length(P)[-1])))
    out = pd.DataFrame(rows, columns=cols)
    out.attrs["reference_frame"] = int(cv.frame[ri])
    return _mark(out, sorted(cv.excluded))


@dataclass(frozen=True, eq=False)
class ResponseTimes:
    """When and how much a tendril responded (module notes, "Response times").

    Attributes
    ----------
    responded : bool
    onset_s, stable_s : float
        Response onset and stabilisation, s after ``stimulus_s``; NaN when not
        responded (``stable_s`` also NaN when the sequence ends unsettled).
    amplitude_mm : float
        Plateau minus baseline of the (de-biased) measure, mm: with
        ``debias``, an estimate of the noise-free final change.
    baseline_mm, plateau_mm, peak_mm : float
        Early level, final level and maximum of the measure as given
        (smoothed), mm: the levels to draw over it.
    noise_mm : float
        Robust frame-to-frame noise (standard deviation) of the (de-biased) measure, mm.
    onset_frame, stable_frame : int
        First frame beyond the onset threshold / first frame of the final band (-1 if none).
    measure : str
        Column of the shape-change table used.
    note : str
        Why not responded, or a caveat ("" otherwise).
    """

    responded: bool
    onset_s: float
    stable_s: float
    amplitude_mm: float
    baseline_mm: float
    plateau_mm: float
    peak_mm: float
    noise_mm: float
    onset_frame: int = -1
    stable_frame: int = -1
    measure: str = "shape_mm"
    note: str = ""


def running_median(y: np.ndarray, width: int) -> np.ndarray:
    """Median over ``width`` samples centred on each sample; the window shrinks at the ends.

    The first and last samples take the median of the three end samples.
    Unlike padding with the end values, a single outlier in the last (or
    first) sample does not survive the filter.
    """
    y = np.asarray(y, dtype=float)
    h = int(width) // 2
    if h < 1 or y.size < 3:
        return y.copy()
    out = median_filter(y, size=2 * h + 1, mode="nearest")
    n = y.size
    for i in sorted(set(range(min(h, n))) | set(range(max(n - h, 0), n))):
        k = min(i, n - 1 - i, h)
        if k > 0:
            out[i] = np.median(y[i - k:i + k + 1])
        else:  # the first / last sample: median of the three end samples
            out[i] = np.median(y[:3]) if i == 0 else np.median(y[-3:])
    return out


def _crossing(t0, t1, y0, y1, level):
    if not np.isfinite(y0) or y1 == y0:
        return float(t1)
    w = float(np.clip((level - y0) / (y1 - y0), 0.0, 1.0))
    return float(t0 + w * (t1 - t0))


def response_times(
    change: pd.DataFrame,
    *,
    measure: str = "shape_mm",
    onset_fraction: float = 0.1,
    stable_fraction: float = 0.9,
    median_frames: int | None = None,
    baseline_frames: int | None = None,
    plateau_frames: int | None = None,
    noise_k: float = 3.0,
    min_amplitude_mm: float = 2.0,
    stimulus_s: float = 0.0,
    debias: bool = True,
) -> ResponseTimes:
    """Response onset and stabilisation times from a :func:`shape_change` table.

    Parameters
    ----------
    change : DataFrame
        ``time_s`` and the ``measure`` column (mm), one row per kept frame;
        NaN rows are dropped.
    measure : str
        ``shape_mm`` (default: change of shape, rigid motion removed),
        ``mean_mm`` (motion), ``tip_displacement_mm``, ...
    onset_fraction : float
        Fraction of the amplitude that marks the onset (default 0.1).
    stable_fraction : float
        The measure is stable once it stays within ``(1 - stable_fraction)``
        of the amplitude around the plateau (default 0.9: within 10 %).
    median_frames : int, optional
        Width of the median filter (frames; 1 = none). Default: 5, at most a
        quarter of the sequence (odd).
    baseline_frames, plateau_frames : int, optional
        Frames used for the baseline (after the reference frame) and the
        plateau. Default: 5, at most an eighth of the sequence (at least 1),
        so that a short sequence is not all baseline and plateau.
    noise_k : float
        Thresholds are at least ``noise_k`` noise standard deviations.
    min_amplitude_mm : float
        Below this amplitude the tendril is reported as not responding
        (default 2 mm, about a tenth of a tendril's typical bending
        displacement, several times the reconstruction noise).
    stimulus_s : float
        Time of the stimulus on the ``time_s`` axis.
    debias : bool
        Remove the noise floor in quadrature before anything else (module
        notes); False: use the measure as it is.

    Returns
    -------
    ResponseTimes
    """
    for name, v in (("onset_fraction", onset_fraction), ("stable_fraction", stable_fraction)):
        if not 0 < v < 1:
            raise ValueError(f"{name} must be in (0, 1), got {v}")
    for name, v in (("median_frames", median_frames), ("baseline_frames", baseline_frames),
                    ("plateau_frames", plateau_frames)):
        if v is not None and int(v) < 1:
            raise ValueError(f"{name} must be >= 1, got {v}")
    c = _canonical(change, ("time_s", measure), "change")
    c = c[np.isfinite(c[measure].to_numpy(float)) & np.isfinite(c["time_s"].to_numpy(float))]
    c = c.sort_values("time_s", kind="stable")
    t = c["time_s"].to_numpy(float) - float(stimulus_s)
    y = c[measure].to_numpy(float)
    fr = c["frame"].to_numpy(int) if "frame" in c.columns else np.arange(len(c))
    n = len(y)
    nan = float("nan")
    if n < 3:
        return ResponseTimes(False, nan, nan, nan, nan, nan, nan, nan, measure=measure,
                             note=f"only {n} frame(s)")
    if median_frames is None:
        median_frames = max(1, min(5, n // 4) | 1)
    if baseline_frames is None:
        baseline_frames = max(1, min(5, n // 8))
    if plateau_frames is None:
        plateau_frames = max(1, min(5, n // 8))
    raw_baseline = float(np.median(y[1:1 + int(baseline_frames)]))
    raw_smooth = running_median(y, int(median_frames))
    raw_plateau = float(np.median(raw_smooth[-int(plateau_frames):]))
    raw_peak = float(raw_smooth.max())
    if debias and raw_baseline > 0:
        # noise adds in quadrature to a mean of distances: D^2 ~ S^2 + b^2
        q = y * y - raw_baseline ** 2
        y = np.where(y == 0, 0.0, np.sign(q) * np.sqrt(np.abs(q)))
    ys = running_median(y, int(median_frames))
    d2 = np.diff(y, 2)
    noise = float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0)) if d2.size else 0.0
    baseline = float(np.median(y[1:1 + int(baseline_frames)]))
    plateau = float(np.median(ys[-int(plateau_frames):]))
    amplitude = plateau - baseline
    peak = float(ys.max())
    floor = noise_k * noise
    if not (amplitude >= min_amplitude_mm and amplitude > floor):
        why = (f"amplitude {amplitude:.3g} mm below the floor max({min_amplitude_mm:g} mm, "
               f"{noise_k:g} x noise {noise:.3g} mm)")
        if peak - baseline >= min_amplitude_mm and peak - baseline > floor:
            why += f"; transient change up to {peak - baseline:.3g} mm that did not last"
        return ResponseTimes(False, nan, nan, amplitude, raw_baseline, raw_plateau, raw_peak, noise,
                             measure=measure, note=why)
    on_level = baseline + max(onset_fraction * amplitude, floor)
    above = np.flatnonzero(ys > on_level)
    i = int(above[0])
    onset = float(t[0]) if i == 0 else _crossing(t[i - 1], t[i], ys[i - 1], ys[i], on_level)
    tol = max((1.0 - stable_fraction) * amplitude, floor)
    outside = np.flatnonzero(np.abs(ys - plateau) > tol)
    note = ""
    if outside.size == 0:
        j, stable = 0, float(t[0])
    elif outside[-1] == n - 1:
        j, stable = -1, nan
        note = "the sequence ends before the change settles"
        warnings.warn(f"response_times: {note}", UserWarning, stacklevel=2)
    else:
        k = int(outside[-1])
        j = k + 1
        level = plateau + tol if ys[k] > plateau else plateau - tol
        stable = _crossing(t[k], t[j], ys[k], ys[j], level)
    if j >= 0 and j >= n - int(plateau_frames):
        note = "stabilises within the plateau window: the sequence may be too short"
        warnings.warn(f"response_times: {note}", UserWarning, stacklevel=2)
    return ResponseTimes(True, onset, stable, amplitude, raw_baseline, raw_plateau, raw_peak, noise,
                         onset_frame=int(fr[i]), stable_frame=int(fr[j]) if j >= 0 else -1,
                         measure=measure, note=note)


# ---------------------------------------------------------------- regions
def _site_names(n_regions: int) -> list[str]:
    return [f"S{k + 1}" if n_regions == 4 else f"R{k + 1}" for k in range(n_regions)]


def region_response(
    curves: pd.DataFrame,
    *,
    n_regions: int = 4,
    segments: pd.DataFrame | None = None,
    first_frame: int | None = None,
    last_frame: int | None = None,
    n_s: int | None = None,
    min_deformation_mm: float = 1.0,
    frames: pd.DataFrame | None = None,
    include_doubtful: bool = False,
    columns: Mapping[str, str] | None = None,
) -> pd.DataFrame:
    """Which regions of the tendril changed between two frames, and how much.

    The normalised length is cut into ``n_regions`` equal zones (4: the
    stimulation sites S1 = base ... S4 = tip). Between ``first_frame`` and
    ``last_frame`` (default: first and last kept frames):

    - ``displacement_mm``: mean distance of the zone's points, world frame (no
      alignment). It accumulates along the tendril: a bend near the base moves
      every zone beyond it, so it says where the tendril moved, not where it bent;
    - ``deformation_mm``: RMS distance after the best rigid alignment of the
      zone alone; rigid motion carried from upstream cancels, only the zone's
      own bending and twisting remain. The most responsive zone is the one
      with the largest deformation;
    - ``dkappa_per_mm``, ``dtau_per_mm``: mean absolute change of curvature
      and torsion over the zone, from the fitted laws when ``segments`` is
      given (NaN otherwise);
    - ``share``: the zone's fraction of the summed deformation;
    - ``responsive``: ``deformation_mm >= min_deformation_mm`` (default
      1 mm; the RMS of reconstruction noise after alignment is about
      :math:`\\sqrt{2}` times the per-point noise, so raise it for noisy data).

    Points correspond by index when both frames have the same count and
    ``n_s`` is None, otherwise at ``n_s`` equal steps of normalised arc length.

    Returns
    -------
    DataFrame
        ``region, u0, u1, displacement_mm, deformation_mm, dkappa_per_mm,
        dtau_per_mm, share, responsive``; ``attrs["frames"]`` = the two frames.
    """
    if n_regions < 1:
        raise ValueError(f"n_regions must be >= 1, got {n_regions}")
    cv = _split_curves(curves, frames, columns, "region_response", include_doubtful=include_doubtful)
    if len(cv.frame) < 2:
        raise ValueError(f"curves: region_response needs two kept frames, got {len(cv.frame)}")

    def pick(fr, default):
        if fr is None:
            return default
        hits = np.flatnonzero(cv.frame == int(fr))
        if hits.size == 0:
            raise ValueError(f"frame {fr} is not a kept frame (excluded: {sorted(cv.excluded)})")
        return int(hits[0])

    ia, ib = pick(first_frame, 0), pick(last_frame, len(cv.frame) - 1)
    Pa, Pb = cv.points[ia], cv.points[ib]
    if n_s is None and len(Pa) == len(Pb):  # point i <-> point i (see shape_change)
        A, B = np.asarray(Pa, float), np.asarray(Pb, float)
        u = np.linspace(0.0, 1.0, len(A))
    else:
        u = np.linspace(0.0, 1.0, int(n_s) if n_s is not None else len(Pa))
        A, B = resample_normalised(Pa, u), resample_normalised(Pb, u)
    dk = dt = None
    if segments is not None:
        s = _segments(segments, columns)
        laws = {}
        for (f, kind), g in s.groupby(["frame", "kind"]):
            laws[(int(f), kind)] = g
        fa, fb = int(cv.frame[ia]), int(cv.frame[ib])
        have = all((f, k) in laws for f in (fa, fb) for k in ("kappa", "tau"))
        if have:
            ev = {(f, k): _eval_law(laws[(f, k)], u * float(laws[(f, k)]["s1_mm"].max()))
                  for f in (fa, fb) for k in ("kappa", "tau")}
            dk = np.abs(ev[(fb, "kappa")] - ev[(fa, "kappa")])
            dt = np.abs(ev[(fb, "tau")] - ev[(fa, "tau")])
        else:
            warnings.warn(f"region_response: no laws for frame {fa} or {fb} in segments", UserWarning, stacklevel=2)
    rows = []
    edges = np.linspace(0.0, 1.0, n_regions + 1)
    for k, name in enumerate(_site_names(n_regions)):
        m = (u >= edges[k] - 1e-12) & (u <= edges[k + 1] + 1e-12)
        disp = float(np.linalg.norm(B[m] - A[m], axis=1).mean())
        deform = float(np.sqrt(np.mean(np.sum((_kabsch(A[m], B[m]) - A[m]) ** 2, axis=1)))) if m.sum() >= 3 else np.nan
        rows.append((name, edges[k], edges[k + 1], disp, deform,
                     float(dk[m].mean()) if dk is not None else np.nan,
                     float(dt[m].mean()) if dt is not None else np.nan))
    out = pd.DataFrame(rows, columns=["region", "u0", "u1", "displacement_mm", "deformation_mm",
                                      "dkappa_per_mm", "dtau_per_mm"])
    tot = out["deformation_mm"].sum()
    out["share"] = out["deformation_mm"] / tot if tot > 0 else np.nan
    out["responsive"] = out["deformation_mm"] >= float(min_deformation_mm)
    out.attrs["frames"] = (int(cv.frame[ia]), int(cv.frame[ib]))
    return _mark(out, sorted(cv.excluded))


# ---------------------------------------------------------------- experiment summary, sites
@dataclass(frozen=True, eq=False)
class ExperimentSummary:
    """Everything the cross-site comparison needs from one experiment.

    Attributes
    ----------
    name : str
    site : str
        ``S1`` .. ``S4`` or "" when unknown.
    response : ResponseTimes
    regions : DataFrame
        :func:`region_response`.
    tip : TipPathStats
    change : DataFrame
        :func:`shape_change`.
    n_frames_ok : int
    failed_frames : tuple of int
    """

    name: str
    site: str
    response: ResponseTimes
    regions: pd.DataFrame
    tip: TipPathStats
    change: pd.DataFrame
    n_frames_ok: int
    failed_frames: tuple = ()


def summarize_experiment(curves: pd.DataFrame, *, name: str = "", site: str = "",
                         segments: pd.DataFrame | None = None, frames: pd.DataFrame | None = None,
                         include_doubtful: bool = False,
                         response_kwargs: Mapping | None = None, tip_median_frames: int = 1,
                         columns: Mapping[str, str] | None = None) -> ExperimentSummary:
    """Shape change, response times, region response and tip path of one experiment."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        change = shape_change(curves, frames=frames, columns=columns, include_doubtful=include_doubtful)
        resp = response_times(change, **dict(response_kwargs or {}))
        regions = region_response(curves, segments=segments, frames=frames, columns=columns, include_doubtful=include_doubtful)
        tip = tip_path_stats(tip_trajectory(curves, frames=frames, columns=columns, include_doubtful=include_doubtful), median_frames=tip_median_frames)
    seen = set()
    for w in caught:  # report each distinct warning once
        if str(w.message) not in seen:
            seen.add(str(w.message))
            warnings.warn(f"{name or 'experiment'}: {w.message}", w.category, stacklevel=2)
    failed = tuple(change.attrs.get("excluded_frames", ()))
    return ExperimentSummary(name=name, site=site, response=resp, regions=regions, tip=tip,
                             change=change, n_frames_ok=len(change), failed_frames=failed)


SITE_COMPARISON_COLUMNS = (
    "experiment", "site", "responded", "onset_s", "stable_s", "amplitude_mm", "tip_displacement_mm",
    "most_responsive_region", "max_deformation_mm", "tip_path_mm", "tip_straightness",
    "n_frames_ok", "n_frames_excluded",
)


def compare_sites(results: Mapping[str, ExperimentSummary | Mapping]) -> pd.DataFrame:
    """The cross-site comparison table, one row per experiment.

    Parameters
    ----------
    results : mapping name -> ExperimentSummary
        (or a mapping with the keys of :data:`SITE_COMPARISON_COLUMNS`,
        taken as is).

    Returns
    -------
    DataFrame
        Columns :data:`SITE_COMPARISON_COLUMNS`, sorted by site then experiment.
        ``tip_displacement_mm`` is the final shape change at the tip.
    """
    rows = []
    for name, r in results.items():
        if isinstance(r, ExperimentSummary):
            reg = r.regions
            if len(reg) and reg["deformation_mm"].notna().any():
                best = reg.loc[reg["deformation_mm"].idxmax()]
                most, dmax = str(best["region"]), float(best["deformation_mm"])
            else:
                most, dmax = "", np.nan
            tipd = float(r.change["tip_displacement_mm"].iloc[-1]) if len(r.change) else np.nan
            rows.append({
                "experiment": str(name), "site": r.site or "", "responded": bool(r.response.responded),
                "onset_s": r.response.onset_s, "stable_s": r.response.stable_s,
                "amplitude_mm": r.response.amplitude_mm, "tip_displacement_mm": tipd,
                "most_responsive_region": most, "max_deformation_mm": dmax,
                "tip_path_mm": r.tip.path_length_mm, "tip_straightness": r.tip.straightness,
                "n_frames_ok": int(r.n_frames_ok), "n_frames_excluded": len(r.failed_frames),
            })
        elif isinstance(r, Mapping):
            row = {c: r.get(c, np.nan) for c in SITE_COMPARISON_COLUMNS}
            row["experiment"] = str(r.get("experiment", name))
            rows.append(row)
        else:
            raise TypeError(f"results[{name!r}] must be an ExperimentSummary or a mapping, got {type(r).__name__}")
    out = pd.DataFrame(rows, columns=list(SITE_COMPARISON_COLUMNS))
    return out.sort_values(["site", "experiment"], kind="stable").reset_index(drop=True)


# ---------------------------------------------------------------- tables 1-3
def _chosen(available: np.ndarray, chosen: Sequence[int] | None, what: str) -> list[int]:
    avail = np.unique(np.asarray(available, dtype=int))
    if chosen is None:
        return _default_frames(avail)
    chosen = [int(f) for f in chosen]
    missing = [f for f in chosen if f not in set(avail.tolist())]
    if missing:
        raise ValueError(f"{what}: frame(s) {missing} not in the table (available {avail[:1].tolist()}..{avail[-1:].tolist()})")
    return chosen


def _error_table(rep: pd.DataFrame, chosen, frames, columns, what, include_doubtful: bool = False) -> pd.DataFrame:
    r = _canonical(rep, REPROJECTION_COLUMNS, what, columns)
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
    return out.reset_index().sort_values(["frame", "view"], kind="stable").reset_index(drop=True)


def table1(reprojection: pd.DataFrame, *, at_frames: Sequence[int] | None = None,
           frames: pd.DataFrame | None = None, columns: Mapping[str, str] | None = None,
           include_doubtful: bool = False) -> pd.DataFrame:
    """Paper Table 1: reprojection error of the reconstruction per frame and view.

    Parameters
    ----------
    reprojection : DataFrame
        ``frame, view, section, mean_px, std_px`` (section base / tip / entire).
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
    return _error_table(reprojection, at_frames, frames, columns, "reprojection", include_doubtful)


def projection_errors(curves: pd.DataFrame, other: pd.DataFrame, cameras: Sequence, *,
                      at_frames: Sequence[int] | None = None, n_s: int | None = None,
                      columns: Mapping[str, str] | None = None) -> pd.DataFrame:
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
        ``frame, view, section, mean_px, std_px`` (same layout as ``reprojection``).
    """
    a = _split_curves(curves, None, columns, "projection_errors")
    b = _split_curves(other, None, columns, "projection_errors")
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
                rows.append((int(f), v, sec, float(np.nanmean(dd)), float(np.nanstd(dd))))
    return pd.DataFrame(rows, columns=list(REPROJECTION_COLUMNS))


def table2(pwc_errors: pd.DataFrame, *, at_frames: Sequence[int] | None = None,
           frames: pd.DataFrame | None = None, columns: Mapping[str, str] | None = None,
           include_doubtful: bool = False) -> pd.DataFrame:
    """Paper Table 2: projected distance between the PWC curve and the reconstruction.

    ``pwc_errors`` has the ``reprojection`` layout, e.g. from
    :func:`projection_errors` ``(curves, pwc_curves, cameras)``; the result has
    the layout of :func:`table1`.
    """
    return _error_table(pwc_errors, at_frames, frames, columns, "pwc_errors", include_doubtful)


def table3(fit_metrics: pd.DataFrame, *, at_frames: Sequence[int] | None = None,
           frames: pd.DataFrame | None = None, columns: Mapping[str, str] | None = None,
           include_doubtful: bool = False) -> pd.DataFrame:
    """Paper Table 3: segments, R^2 and SSE of the PWC fit for chosen frames.

    Parameters
    ----------
    fit_metrics : DataFrame
        One row per frame (or per frame and penalty pair): ``frame`` and any
        of ``penalty_kappa, penalty_tau, n_kappa, n_tau, r2_entire, r2_base,
        r2_tip, sse_entire_mm2, sse_base_mm2, sse_tip_mm2`` (spellings in
        :data:`FIT_METRIC_ALIASES` are recognised; ``columns`` maps others),
        e.g. ``pwc_metrics.csv``; rows whose ``status`` is not ``ok`` are dropped.
    at_frames : sequence of int, optional
        Default: first, middle and last (ok) frame.
    frames : DataFrame, optional
        The run's ``frames`` table: only ok frames are eligible.

    Returns
    -------
    DataFrame
        ``frame`` then the canonical columns present, in the paper's order;
        sorted by frame, rows of a frame in their input order (e.g. the
        penalty pairs of :func:`tendrilkit.pwc.penalty_table`).
    """
    m = _canonical(fit_metrics, ("frame",), "fit_metrics", columns, FIT_METRIC_ALIASES,
                   optional=FIT_METRIC_COLUMNS[1:])
    if "status" in m.columns:  # pwc_metrics.csv carries its own status per frame
        m = m[m["status"].astype(str).str.lower().eq("ok")]
    if frames is not None:
        ok, _ = frame_status(frames, include_doubtful=include_doubtful)
        m = m[m["frame"].isin(ok)]
    fr = _chosen(m["frame"].to_numpy(), at_frames, "fit_metrics")
    keep = [c for c in FIT_METRIC_COLUMNS if c in m.columns]
    if len(keep) == 1:
        raise ValueError(f"fit_metrics: none of {', '.join(FIT_METRIC_COLUMNS[1:])} found in "
                         f"{', '.join(map(str, fit_metrics.columns))}")
    out = m.loc[m["frame"].isin(fr), keep]
    return out.sort_values("frame", kind="stable").reset_index(drop=True)
