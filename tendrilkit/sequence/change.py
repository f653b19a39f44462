"""How the tendril's shape changed: against a reference frame, along its tip, per region.

Paper: "Analysis of Tip Motion" (Figure 9) and the Discussion's regions of
response (S1 = base ... S4 = tip).

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

"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.ndimage import median_filter

from tendrilkit.schema import REGION_RESPONSE, SHAPE_CHANGE, TIP_TRAJECTORY
from tendrilkit.sequence._common import (_arc_length, _checked, _eval_law, _kabsch, _mark, _segments, _split_curves,
                                         resample_normalised)


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


def tip_trajectory(curves: pd.DataFrame, *, frames: pd.DataFrame | None = None, include_doubtful: bool = False) -> pd.DataFrame:
    """The tip (last point) of every ok frame.

    Returns
    -------
    DataFrame
        ``frame, time_s, x_mm, y_mm, z_mm, step_mm`` (distance from the
        previous kept frame, 0 for the first), ``path_mm`` (cumulative) and
        ``displacement_mm`` (from the first kept frame).
    """
    cv = _split_curves(curves, frames, "tip_trajectory", min_points=1, include_doubtful=include_doubtful)
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
    t = _checked(trajectory, TIP_TRAJECTORY.require("x_mm", "y_mm", "z_mm"), "trajectory")
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
                 align: str = "none", frames: pd.DataFrame | None = None, include_doubtful: bool = False) -> pd.DataFrame:
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
    cv = _split_curves(curves, frames, "shape_change", include_doubtful=include_doubtful)
    cols = list(SHAPE_CHANGE.columns)
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
    cv = _split_curves(curves, frames, "region_response", include_doubtful=include_doubtful)
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
        s = _segments(segments)
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
    out = pd.DataFrame(rows, columns=list(REGION_RESPONSE.columns[:7]))
    tot = out["deformation_mm"].sum()
    out["share"] = out["deformation_mm"] / tot if tot > 0 else np.nan
    out["responsive"] = out["deformation_mm"] >= float(min_deformation_mm)
    out.attrs["frames"] = (int(cv.frame[ia]), int(cv.frame[ib]))
    return _mark(out, sorted(cv.excluded))
