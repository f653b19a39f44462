"""Composition of the stages; the only place that catches per-frame failures.

``python -m tendrilkit reconstruct EXPERIMENT.yaml --out DIR`` is
:func:`run_reconstruct`:

1. load and check the experiment; calibrate the rig once
   (:func:`tendrilkit.calibration.calibrate_experiment`); write
   ``DIR/cameras.json`` and ``DIR/calibration_markers.csv``;
2. for every selected frame (``frames: {start, stop, step}``; ``stop: null``
   is the longest video's length: a frame that a shorter video lacks is read
   as missing in that view, see Failures), :func:`reconstruct_frame`: per view
   segmentation and base-to-tip ordering (2D stage), matching across views
   (``correspondence.method``), triangulation (``triangulation.refine``),
   resampling to ``points`` points base to tip (uniform arc length), the
   piece-wise clothoid fit, and the quality figures (reprojection error per
   view and quarter against the extracted skeletons, paper Table 1);
3. write the result files of EXPERIMENT_FORMAT.md (see :data:`RESULT_FILES`),
   rows sorted by frame (then point, view, ...), floats with 6 decimals:

   ========================  ==========================================================
   ``curves.csv``            ``frame, time_s, point, x_mm, y_mm, z_mm``: the centreline,
                             ``points`` points base (0) to tip, uniform arc length
   ``pwc_curves.csv``        same columns: the piece-wise clothoid registered onto it
   ``pwc_segments.csv``      the fitted laws: ``frame, kind (kappa|tau), segment, s0_mm,
                             s1_mm, value_s0, value_s1`` (1/mm), as ``tendrilkit fit``
   ``pwc_metrics.csv``       per frame R^2 and SSE (mm^2) of the fit, entire / base / tip
                             quarter, penalties and segment counts, as ``tendrilkit fit``
   ``frames.csv``            ``frame, time_s, status, message`` and the quality figures
                             of :func:`quality_columns`
   ``reprojection.csv``      ``frame, view, section, mean_px, std_px, max_px, n_points``:
                             the paper's Table 1 for every frame (section ``base`` /
                             ``tip`` quarters of the 3D arc length, ``entire``)
   ``ordering.csv``          the 2D stage's decisions at crossings: ``frame, view,
                             junction, junction_x_px, junction_y_px, candidates``
                             (JSON ``[[branch, angle_deg], ...]``), ``chosen, method``
   ``calibration_markers.csv``  :attr:`tendrilkit.calibration.CalibrationResult.markers`
   ``cameras.json``          the calibrated rig (EXPERIMENT_FORMAT.md)
   ``qc_contact_sheet.png``  doubtful frames and a sample of ok ones, the reconstruction
                             drawn on every view (:func:`tendrilkit.qc.write_contact_sheet`)
   ``frames/``               one JSON file per finished frame (resuming, below)
   ========================  ==========================================================

Failures
    A frame whose 2D stage, matching or triangulation raises a
    :class:`~tendrilkit.exceptions.FrameError` (or meets an unexpected
    numerical error: ``ValueError``, ``FloatingPointError``,
    ``LinAlgError``, ``ZeroDivisionError``, ``IndexError``) is recorded as
    ``failed`` with the reason and the run goes on. A view whose 2D stage
    fails is left out when at least two views remain (the message says so).
    A failed piece-wise clothoid fit keeps the frame ``ok`` (the centreline
    stands) with no ``pwc_curves.csv`` rows and the reason in the message.
    A nearly straight centreline (within 1 % of its length of its chord) is
    ``ok`` with the note ``nearly straight ...: torsion undefined``.

Tracking and workers
    Segmentation takes, in every view, the component nearest the previous
    frame's centroid (the paper's tracking), so a frame depends on the frames
    before it. Frames are processed in chunks of consecutive frames, in
    parallel processes (``cv2.setNumThreads(1)`` in each); a chunk starts
    without a previous centroid and is accepted only if that cannot change
    the result: in every view, the chunk's first frame has a single
    component (the choice does not depend on the previous centroid), or the
    true previous centroid is also none, or the segmentation of that frame
    from the true previous centroid (run again in the parent process: a few
    milliseconds) picks the component of the same centroid, hence the same
    mask. Otherwise the chunk is recomputed from the true previous
    centroids, frame by frame, until both computations carry the same
    tracking state; from there on the chunk's own results had the same
    inputs and are kept. The results are therefore identical, byte for byte,
    whatever the number of workers.

    With ``reconstruction.method: multiview`` the tracking state is the
    previous frame's 3D curve (:mod:`tendrilkit.multiview`; none after a
    frame that is not ``ok``). The frames are cut into fixed chunks of
    ``reconstruction.chunk_frames`` processed frames, independent of the
    number of workers; each chunk starts by acquiring the curve from the
    base, then tracks it frame by frame, so the results are identical
    whatever the number of workers (a resumed run starts a chunk's remaining
    frames from the curve of the last finished one).

Resuming
    Every finished frame is written atomically to
    ``DIR/frames/frame_000123.json`` with a fingerprint of the run (resolved
    experiment including ``frames`` start and step, since tracking depends on
    the frames seen; each video's size, modification time and a hash of 16
    blocks spread over it; cameras; tendrilkit's version and source code), its
    frame number and a checksum of its content (:func:`tendrilkit.io.write_frame_record`).
    Running the same command again reuses the calibration it wrote
    (``cameras.json``, stamped in ``frames/calibration_stamp.json``), skips
    the frames whose file verifies (same fingerprint, same frame, checksum;
    an edited, truncated or copied file is recomputed) and assembles the
    tables from the per-frame files; an interrupted run (Ctrl-C, SIGTERM)
    keeps its finished frames.

Exit code
    0 if every frame is ``ok``, 1 if some are ``doubtful`` or ``failed`` (the
    run still completes and writes every table); user mistakes raise
    :class:`~tendrilkit.exceptions.ExperimentError` (exit code 2 in the CLI);
    Ctrl-C propagates ``KeyboardInterrupt`` (exit code 130 in the CLI; SIGTERM
    143) after the finished frames are on disk; a result file that cannot be
    written raises :class:`~tendrilkit.exceptions.OutputWriteError` (exit
    code 74), the finished frames kept. The last line printed is
    ``N frames: X ok, Y doubtful, Z failed``.

Verification
    Every reconstructed frame is checked against every view's image
    (:func:`tendrilkit.verify.verify_curve` on
    :func:`tendrilkit.evidence.view_evidence`, inside the frame's worker) and,
    at assembly time over the ordered frames, against its neighbours in time
    (:func:`with_temporal_checks`: the same whatever the chunks or workers).
    A frame failing a check is ``doubtful``, the failed checks first in its
    message; limits in the experiment's ``verification:`` section.
"""

from __future__ import annotations

import concurrent.futures
import contextlib
import hashlib
import json
import math
import multiprocessing as mp
import os
import signal
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from tendrilkit.camera import Camera
from tendrilkit.correspondence import match_epipolar, match_frechet
from tendrilkit.exceptions import DegenerateCurveError, ExperimentError, FrameError, FrameReadError
from tendrilkit.frenet import resample_curve
from tendrilkit.pwc import fit_piecewise_clothoid
from tendrilkit.segmentation import segment_view
from tendrilkit.skeleton import order_skeleton
from tendrilkit.triangulation import refine_to_curves, reprojection_table, triangulate

__all__ = ["FrameResult", "reconstruct_frame", "run_reconstruct", "frame_fingerprint", "accuracy_against_truth", "compare_correspondence", "RESULT_FILES"]

#: The tables :func:`run_reconstruct` writes in ``DIR`` (besides ``cameras.json`` and ``frames/``).
RESULT_FILES = ("curves.csv", "pwc_curves.csv", "frames.csv", "reprojection.csv", "ordering.csv",
                "pwc_segments.csv", "pwc_metrics.csv", "calibration_markers.csv")

#: Numerical errors of a frame that become a ``failed`` row instead of a crash.
_NUMERICAL_ERRORS = (ValueError, FloatingPointError, np.linalg.LinAlgError, ZeroDivisionError, IndexError)

_FORMAT_VERSION = 1
_MAX_CHUNK = 16


@dataclass(frozen=True, eq=False)
class FrameResult:
    """The reconstruction of one frame.

    Attributes
    ----------
    frame : int
        0-based frame index.
    time_s : float
        ``frame / fps``.
    status : str
        ``ok``, ``doubtful`` (reconstructed, but a check of
        :mod:`tendrilkit.verify` failed) or ``failed``.
    message : str
        Why it failed or which checks it failed (with the figure and the
        limit), then notes (a view left out); empty otherwise.
    points_mm : (n, 3) float array or None
        The centreline, ``points`` points base to tip, uniform arc length, mm.
    pwc_mm : (n, 3) float array or None
        The piece-wise clothoid registered onto it, mm.
    quality : dict
        Figures of the frame (see :data:`QUALITY_COLUMNS`).
    reprojection : list of dict
        Rows of the paper's Table 1 (``view, section, mean_px, std_px, max_px, n_points``).
    decisions : list of dict
        The 2D stage's ordering decisions (:meth:`tendrilkit.skeleton.Decision.as_dict`).
    centroids : list of (2,) list or None
        Per view, the tendril's mask centroid (the next frame's tracking point).
    n_components : list of int or None
        Per view, the components the segmentation could choose from.
    timings : dict
        Seconds per stage (not written to the result files).
    checks : list of str
        The checks against the views it failed (:mod:`tendrilkit.verify`);
        ``message`` starts with them.
    """

    frame: int
    time_s: float
    status: str
    message: str
    points_mm: np.ndarray | None = None
    pwc_mm: np.ndarray | None = None
    quality: dict = field(default_factory=dict)
    reprojection: list = field(default_factory=list)
    decisions: list = field(default_factory=list)
    centroids: list = field(default_factory=list)
    n_components: list = field(default_factory=list)
    timings: dict = field(default_factory=dict)
    pwc_segments: list = field(default_factory=list)
    pwc_metrics: list = field(default_factory=list)
    checks: list = field(default_factory=list)

    def to_json(self) -> dict:
        def arr(a):
            return None if a is None else np.asarray(a, float).tolist()

        return {
            "frame": int(self.frame), "time_s": float(self.time_s), "status": self.status,
            "message": self.message, "points_mm": arr(self.points_mm), "pwc_mm": arr(self.pwc_mm),
            "quality": self.quality, "reprojection": self.reprojection, "decisions": self.decisions,
            "centroids": self.centroids, "n_components": self.n_components,
            "pwc_segments": self.pwc_segments, "pwc_metrics": self.pwc_metrics, "checks": self.checks,
        }

    @classmethod
    def from_json(cls, d: dict) -> "FrameResult":
        def arr(a):
            return None if a is None else np.asarray(a, float).reshape(-1, 3)

        return cls(frame=int(d["frame"]), time_s=float(d["time_s"]), status=d["status"], message=d["message"],
                   points_mm=arr(d["points_mm"]), pwc_mm=arr(d["pwc_mm"]), quality=d["quality"],
                   reprojection=d["reprojection"], decisions=d["decisions"], centroids=d["centroids"],
                   n_components=d["n_components"], pwc_segments=d.get("pwc_segments", []),
                   pwc_metrics=d.get("pwc_metrics", []), checks=d.get("checks", []))


def quality_columns(n_views: int) -> list[str]:
    """The quality columns of ``frames.csv``, in order, for ``n_views`` views.

    ``views_used`` (views whose 2D stage succeeded), ``n_matched`` (reference
    points matched and triangulated), ``base_extended`` (the curve was
    extended to the triangulated base marks), ``length_mm`` (centreline length),
    ``reproj_mean_px_v<i>`` / ``reproj_std_px_v<i>`` / ``reproj_max_px_v<i>``
    (distance of the projected centreline to view i's skeleton, entire
    tendril), ``tri_err_px_v<i>`` (mean reprojection error of the matched
    points at triangulation), ``pwc_r2``, ``pwc_sse_mm2``, ``pwc_rmse_mm``,
    ``pwc_segments_kappa``, ``pwc_segments_tau``, ``n_crossings_v<i>``; then
    the checks of :mod:`tendrilkit.verify`: ``views_checked``,
    ``length_change_pct``, ``shape_change_mm``, ``dt_prev_s`` and per view
    ``on_tendril_frac_v<i>``, ``off_tendril_max_px_v<i>``,
    ``skeleton_mean_px_v<i>``, ``coverage_frac_v<i>``, ``base_px_v<i>``.
    """
    cols = ["views_used", "n_matched", "base_extended", "length_mm"]
    for v in range(1, n_views + 1):
        cols += [f"reproj_mean_px_v{v}", f"reproj_std_px_v{v}", f"reproj_max_px_v{v}"]
    cols += [f"tri_err_px_v{v}" for v in range(1, n_views + 1)]
    cols += ["pwc_r2", "pwc_sse_mm2", "pwc_rmse_mm", "pwc_segments_kappa", "pwc_segments_tau"]
    cols += [f"n_crossings_v{v}" for v in range(1, n_views + 1)]
    from tendrilkit.verify import VERIFY_COLUMNS_FRAME, view_columns

    cols += list(VERIFY_COLUMNS_FRAME) + view_columns(n_views)  # the checks of tendrilkit.verify
    return cols


# ------------------------------------------------------------------ one frame
def _options(exp) -> tuple[dict, dict]:
    """Keyword options of segment_view and order_skeleton from the experiment's sections.

    The 2D stage is :func:`tendrilkit.skeleton.process_view` taken apart (the
    pipeline needs the number of components the segmentation chose from, for
    the tracking across workers); each function gets the fields it accepts.
    """
    import inspect

    fields = {**exp.segmentation.model_dump(), **exp.skeleton.model_dump(), **exp.ordering.model_dump()}
    seg_keys = set(inspect.signature(segment_view).parameters)
    order_keys = set(inspect.signature(order_skeleton).parameters)
    skip = {"image_bgr", "mask_roi", "roi", "keep_out", "base_point_xy", "prev_centroid_xy", "offset_xy", "frame", "view"}
    seg = {k: v for k, v in fields.items() if k in seg_keys and k not in skip}
    order = {k: v for k, v in fields.items() if k in order_keys and k not in skip}
    return seg, order


def _fit(points_mm: np.ndarray, exp, frame: int, time_s: float):
    """The piece-wise clothoid of one frame, by the ``fit`` command's own code (same options, same tables)."""
    from tendrilkit.fitting import FitOptions, fit_frame

    return fit_frame(points_mm, FitOptions.from_params(exp.fit, exp.smoothing), frame=frame, time_s=time_s)


_BASE_MAX_MM = 10.0
#: A centreline within this fraction of its length of its chord is straight: torsion undefined (a note).
_STRAIGHT_FRACTION = 0.01


def _base_from_marks(exp, cameras: list[Camera], points_mm: np.ndarray) -> np.ndarray | None:
    """The triangulated ``base_point`` marks (3,), if they agree and continue the curve, else None."""
    marks = np.array([[m.base_point] for m in exp.views], dtype=float)  # (V, 1, 2)
    tri = triangulate(marks, cameras)
    B = tri.points_mm[0]
    if not np.all(np.isfinite(B)) or np.nanmax(tri.reproj_err_px) > exp.correspondence.max_distance_px:
        return None
    d = points_mm[0] - B
    gap = float(np.linalg.norm(d))
    if gap > _BASE_MAX_MM:
        return None
    if gap < 1e-6:
        return None
    # no folding back: the gap must go on in the direction of the curve's first millimetres
    # (the hidden part may bend: on the phantoms the angle reaches 70 degrees)
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points_mm, axis=0), axis=1))])
    j = int(np.searchsorted(s, min(3.0, s[-1] / 4)))
    t = points_mm[max(j, 1)] - points_mm[0]
    if np.dot(d, t) <= 0.0:  # the gap turns back against the curve
        return None
    return B


def reconstruct_frame(images: list[np.ndarray | None], cameras: list[Camera], exp, *, frame: int = 0,
                      prev_centroids: list | None = None, read_errors: list[str | None] | None = None,
                      fit: bool = True, previous_mm: np.ndarray | None = None) -> FrameResult:
    """Reconstruct one frame from its views; failures become a ``failed`` result.

    Parameters
    ----------
    images : list of (H, W, 3) uint8 arrays or None
        The frame of every view, BGR (None: the view could not be read).
    cameras : list of Camera
        The calibrated rig, view order.
    exp : tendrilkit.params.Experiment
        Options: ``segmentation``, ``skeleton``, ``ordering``,
        ``correspondence``, ``triangulation``, ``points``, ``smoothing``,
        ``fit``, ``views`` (marks), ``reference_view``, ``fps``.
    frame : int, keyword-only
        0-based frame index (recorded, selects ordering overrides).
    prev_centroids : list of (2,) or None, optional
        The previous frame's mask centroid per view (tracking).
    read_errors : list of str or None, optional
        Why a view's image is None.
    fit : bool
        Run the piece-wise clothoid fit.
    previous_mm : (k, 3) float array, optional
        ``reconstruction.method: multiview`` only: the previous processed
        frame's curve (tracking); None: the curve is acquired from the base.

    Returns
    -------
    FrameResult
    """
    if exp.reconstruction.method == "multiview":
        return _multiview_frame(images, cameras, exp, frame=frame, previous_mm=previous_mm, read_errors=read_errors,
                                fit=fit)
    V = len(cameras)
    prev = list(prev_centroids) if prev_centroids is not None else [None] * V
    read_errors = list(read_errors) if read_errors is not None else [None] * V
    seg_opts, order_opts = _options(exp)
    t_s = frame / exp.fps
    timings: dict[str, float] = {}
    centroids: list = [None] * V
    ncomp: list = [None] * V
    curves: list = [None] * V
    decisions: list = []
    notes: list[str] = []
    crossings: list = [None] * V

    t0 = time.perf_counter()
    for v in range(V):
        marks = exp.views[v]
        if images[v] is None:
            notes.append(f"view {v + 1}: {read_errors[v] or 'no image'}")
            continue
        try:
            seg = segment_view(images[v], roi=marks.roi, keep_out=marks.keep_out, base_point_xy=marks.base_point,
                               prev_centroid_xy=prev[v], **seg_opts)
            centroids[v] = [float(c) for c in seg.centroid_xy]
            ncomp[v] = int(seg.n_components)
            oc = order_skeleton(seg.mask_roi, offset_xy=seg.roi_offset_xy, base_point_xy=marks.base_point,
                                frame=frame, view=v + 1, **order_opts)
            curves[v] = oc.points_xy
            crossings[v] = int(oc.n_crossings)
            decisions.extend(d.as_dict() for d in oc.decisions)
        except FrameError as e:
            notes.append(f"view {v + 1}: {type(e).__name__}: {e}")
        except _NUMERICAL_ERRORS as e:
            notes.append(f"view {v + 1}: unexpected {type(e).__name__} in the 2D stage: {e}")
    timings["2d"] = time.perf_counter() - t0

    def failed(msg: str) -> FrameResult:
        return FrameResult(frame=frame, time_s=t_s, status="failed", message=msg, decisions=decisions,
                           centroids=centroids, n_components=ncomp, timings=timings)

    used = [v for v in range(V) if curves[v] is not None and len(curves[v]) >= 2]
    if len(used) < 2:
        return failed("; ".join(notes) or "fewer than two views have a centreline")
    try:
        ref = exp.reference_view - 1
        if ref not in used:
            notes.append(f"reference view {ref + 1} unavailable, view {used[0] + 1} used instead")
            ref = used[0]
        cams = [cameras[v] for v in used]
        cl = [curves[v] for v in used]
        k = exp.points
        t0 = time.perf_counter()
        if exp.correspondence.method == "epipolar":
            matched = match_epipolar(cl, cams, reference=used.index(ref), k=k,
                                     max_cost_px=exp.correspondence.max_distance_px,
                                     smooth=exp.correspondence.depth_smoothing)
        else:
            matched = match_frechet(cl, cams, reference=used.index(ref), k=k, marker_length_mm=exp.marker.length_mm)
        timings["match"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        tri = triangulate(matched, cams, refine=exp.triangulation.refine)
        timings["triangulate"] = time.perf_counter() - t0
        good = np.all(np.isfinite(tri.points_mm), axis=1)
        # gross outliers (a wrong match triangulates anywhere): more than 3x the match tolerance
        with np.errstate(invalid="ignore"):
            worst = np.nanmax(np.where(np.isfinite(tri.reproj_err_px), tri.reproj_err_px, -1.0), axis=0)
        good &= worst <= 3.0 * exp.correspondence.max_distance_px
        if good.sum() < max(10, k // 10):
            raise DegenerateCurveError(f"only {int(good.sum())} of {k} points could be triangulated")
        tri_pts = tri.points_mm[good]
        if exp.triangulation.to_curves:
            t0 = time.perf_counter()
            tri_pts = refine_to_curves(tri_pts, [curves[v] for v in used], cams)
            timings["to_curves"] = time.perf_counter() - t0
        q_base = False
        ext_mm = 0.0
        if exp.triangulation.base_from_marks:
            base = _base_from_marks(exp, cameras, tri_pts)
            if base is not None:
                ext_mm = float(np.linalg.norm(tri_pts[0] - base))
                tri_pts = np.vstack([base, tri_pts])
                q_base = True
        t0 = time.perf_counter()
        points = resample_curve(tri_pts, k)
        timings["resample"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        # Table 1 measures what the views see: not the extension to the base marks
        s_pts = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])
        table = reprojection_table(points, [curves[v] for v in range(V)], cameras, measured=s_pts >= ext_mm - 1e-9)
        timings["reprojection"] = time.perf_counter() - t0
        q: dict = {c: None for c in quality_columns(V)}
        q["views_used"] = len(used)
        q["base_extended"] = q_base
        q["n_matched"] = int(good.sum())
        q["length_mm"] = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
        for row in table.itertuples():
            if row.section == "entire":
                q[f"reproj_mean_px_v{row.view}"] = float(row.mean_px)
                q[f"reproj_std_px_v{row.view}"] = float(row.std_px)
                q[f"reproj_max_px_v{row.view}"] = float(row.max_px)
        for i, v in enumerate(used):
            e = tri.reproj_err_px[i][good]
            e = e[np.isfinite(e)]
            q[f"tri_err_px_v{v + 1}"] = float(e.mean()) if e.size else None
            q[f"n_crossings_v{v + 1}"] = crossings[v]
        pwc, pwc_segments, pwc_row = _shape_and_fit(points, q, notes, exp, frame, t_s, fit, timings)
        reproj_rows = [{k_: (v_.item() if hasattr(v_, "item") else v_) for k_, v_ in r.items()}
                       for r in table.to_dict("records")]
        t0 = time.perf_counter()
        checks = _verify(points, images, cameras, exp, seg_opts, q)
        timings["verify"] = time.perf_counter() - t0
    except FrameError as e:
        return failed("; ".join(notes + [f"{type(e).__name__}: {e}"]))
    except _NUMERICAL_ERRORS as e:
        return failed("; ".join(notes + [f"unexpected {type(e).__name__}: {e}"]))
    return FrameResult(frame=frame, time_s=t_s, status="doubtful" if checks else "ok",
                       message="; ".join(checks + notes), points_mm=points,
                       pwc_mm=pwc, quality=q, reprojection=reproj_rows, decisions=decisions,
                       centroids=centroids, n_components=ncomp, timings=timings,
                       pwc_segments=_plain(pwc_segments), pwc_metrics=_plain([pwc_row] if pwc_row else []),
                       checks=checks)


def _verify(points: np.ndarray, images: list, cameras: list[Camera], exp, seg_opts: dict, q: dict) -> list[str]:
    """Check the curve against every view's image (:mod:`tendrilkit.verify`); figures into ``q``, failed checks out."""
    from tendrilkit.evidence import view_evidence
    from tendrilkit.verify import Thresholds, image_check_messages, verify_curve

    th = Thresholds.from_params(exp.verification)
    evidence = [None if img is None else
                view_evidence(img, roi=m.roi, keep_out=m.keep_out, base_point_xy=m.base_point, **seg_opts)
                for img, m in zip(images, exp.views)]
    q.update(verify_curve(points, cameras, evidence, tolerance_px=th.tolerance_px,
                          coverage_tolerance_px=th.coverage_tolerance_px))
    return image_check_messages(q, len(cameras), th)


def _shape_and_fit(points: np.ndarray, q: dict, notes: list, exp, frame: int, t_s: float, fit: bool,
                   timings: dict):
    """The straightness note and the piece-wise clothoid fit of a centreline (fills ``q`` and ``notes``)."""
    # a (nearly) straight centreline has no normal: its torsion is undefined, whatever the fit says
    chord = points[-1] - points[0]
    if np.linalg.norm(chord) > 0:
        rel = points - points[0]
        chord = chord / np.linalg.norm(chord)
        dev = float(np.linalg.norm(rel - np.outer(rel @ chord, chord), axis=1).max())
        if dev <= _STRAIGHT_FRACTION * q["length_mm"]:
            notes.append(f"nearly straight (at most {dev:.2f} mm from its chord over {q['length_mm']:.1f} mm): "
                         f"torsion undefined")
    pwc, pwc_segments, pwc_row = None, [], None
    if fit:  # a failed fit leaves the reconstruction standing: the frame stays ok, without pwc
        t0 = time.perf_counter()
        try:
            pwc, pwc_segments, pwc_row = _fit(points, exp, frame, t_s)
        except (FrameError, *_NUMERICAL_ERRORS) as e:
            pwc, pwc_segments = None, []
            pwc_row = {"frame": frame, "time_s": t_s, "status": "failed", "message": f"{type(e).__name__}: {e}"}
        timings["pwc"] = time.perf_counter() - t0
        if pwc is None:
            notes.append(f"piece-wise clothoid fit failed: {pwc_row.get('message', '')}")
        else:
            q["pwc_r2"] = float(pwc_row["r2_entire"])
            q["pwc_sse_mm2"] = float(pwc_row["sse_entire_mm2"])
            q["pwc_rmse_mm"] = float(pwc_row["rmse_mm"])
            q["pwc_segments_kappa"] = int(pwc_row["n_kappa"])
            q["pwc_segments_tau"] = int(pwc_row["n_tau"])
    return pwc, pwc_segments, pwc_row


def _multiview_frame(images, cameras: list[Camera], exp, *, frame: int, previous_mm, read_errors, fit: bool
                     ) -> FrameResult:
    """:func:`reconstruct_frame` by ``reconstruction.method: multiview`` (:mod:`tendrilkit.multiview`)."""
    from tendrilkit.evidence import view_evidence
    from tendrilkit.multiview import base_point_from_marks, distance_table, reconstruct_multiview
    from tendrilkit.mv_evidence import skeleton_evidence
    from tendrilkit.verify import Thresholds, image_check_messages, verify_curve

    V = len(cameras)
    read_errors = list(read_errors) if read_errors is not None else [None] * V
    seg_opts, _ = _options(exp)
    t_s = frame / exp.fps
    timings: dict[str, float] = {}
    notes: list[str] = []
    views: list = [None] * V  # tendrilkit.evidence per view (also what the verification reads)
    evidence: list = [None] * V
    t0 = time.perf_counter()
    for v in range(V):
        if images[v] is None:
            notes.append(f"view {v + 1}: {read_errors[v] or 'no image'}")
            continue
        m = exp.views[v]
        try:
            views[v] = view_evidence(images[v], roi=m.roi, keep_out=m.keep_out, base_point_xy=m.base_point, **seg_opts)
            evidence[v] = skeleton_evidence(views[v], cameras[v])
        except FrameError as e:
            notes.append(f"view {v + 1}: {type(e).__name__}: {e}")
        except _NUMERICAL_ERRORS as e:
            notes.append(f"view {v + 1}: unexpected {type(e).__name__} in the evidence: {e}")
    timings["evidence"] = time.perf_counter() - t0
    used = [v for v in range(V) if evidence[v] is not None]
    try:
        if len(used) < 2:
            raise DegenerateCurveError("fewer than two views have evidence of the tendril")
        t0 = time.perf_counter()
        B = base_point_from_marks([m.base_point for m in exp.views], cameras, max_px=exp.correspondence.max_distance_px)
        mv = reconstruct_multiview([evidence[v] for v in used], B, previous_mm=previous_mm,
                                   segment_mm=exp.reconstruction.segment_mm)
        timings["multiview"] = time.perf_counter() - t0
        if mv.note:
            notes.append(mv.note)
        points = resample_curve(mv.nodes_mm, exp.points)
        q: dict = {c: None for c in quality_columns(V)}
        q["views_used"] = len(used)
        q["base_extended"] = True
        q["length_mm"] = float(np.linalg.norm(np.diff(points, axis=0), axis=1).sum())
        rows = distance_table(points, evidence)
        for row in rows:
            if row["section"] == "entire":
                for k_ in ("mean", "std", "max"):
                    q[f"reproj_{k_}_px_v{row['view']}"] = row[f"{k_}_px"]
        pwc, pwc_segments, pwc_row = _shape_and_fit(points, q, notes, exp, frame, t_s, fit, timings)
        t0 = time.perf_counter()
        th = Thresholds.from_params(exp.verification)
        q.update(verify_curve(points, cameras, views, tolerance_px=th.tolerance_px,
                              coverage_tolerance_px=th.coverage_tolerance_px))
        checks = image_check_messages(q, V, th)
        timings["verify"] = time.perf_counter() - t0
    except FrameError as e:
        return FrameResult(frame=frame, time_s=t_s, status="failed", message="; ".join(notes + [f"{type(e).__name__}: {e}"]),
                           timings=timings)
    except _NUMERICAL_ERRORS as e:
        return FrameResult(frame=frame, time_s=t_s, status="failed",
                           message="; ".join(notes + [f"unexpected {type(e).__name__}: {e}"]), timings=timings)
    return FrameResult(frame=frame, time_s=t_s, status="doubtful" if checks else "ok", message="; ".join(checks + notes),
                       points_mm=points, pwc_mm=pwc, quality=q, reprojection=_plain(rows), timings=timings,
                       pwc_segments=_plain(pwc_segments), pwc_metrics=_plain([pwc_row] if pwc_row else []),
                       checks=checks)


def _plain(rows: list[dict]) -> list[dict]:
    """JSON-ready rows (numpy scalars to Python, NaN to None)."""
    out = []
    for r in rows:
        d = {}
        for k, v in r.items():
            v = v.item() if hasattr(v, "item") else v
            d[k] = None if isinstance(v, float) and not math.isfinite(v) else v
        out.append(d)
    return out


# ------------------------------------------------------------------ chunks
def _read_views(sources, frame: int):
    images, errors = [], []
    for src in sources:
        try:
            images.append(src.read(frame))
            errors.append(None)
        except FrameError as e:
            images.append(None)
            errors.append(f"{type(e).__name__}: {e}")
    return images, errors


def _next_state(state: list, res: FrameResult) -> list:
    """Tracking state after a frame: per view, its centroid if segmented, else the previous one."""
    return [c if c is not None else s for s, c in zip(state, res.centroids or [None] * len(state))]


def _run_chunk(args) -> list[FrameResult]:
    """Process consecutive frames from a tracking state (in a worker); see :func:`_iter_chunk`."""
    return list(_iter_chunk(*args))


def _worker_init() -> None:
    import cv2

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # and SIGTERM; Pool.terminate() ends the workers with it
    cv2.setNumThreads(1)


def _local_pool(workers: int, fit: bool):
    """tendrilkit's process pool of ``workers`` processes (fork where it exists: the compiled kernels inherited)."""
    if "fork" in mp.get_all_start_methods():
        ctx = mp.get_context("fork")
        _warm_up(fit)  # compile once here; the forked workers inherit the compiled kernels
    else:
        ctx = mp.get_context("spawn")
    return ctx.Pool(workers, initializer=_worker_init)


class _PoolExecutor(concurrent.futures.Executor):
    """The :class:`concurrent.futures.Executor` interface over a :class:`multiprocessing.pool.Pool`."""

    def __init__(self, pool) -> None:
        self._pool = pool

    def submit(self, fn, /, *args, **kwargs) -> concurrent.futures.Future:
        fut: concurrent.futures.Future = concurrent.futures.Future()
        fut.set_running_or_notify_cancel()
        self._pool.apply_async(fn, args, kwargs, callback=fut.set_result, error_callback=fut.set_exception)
        return fut


def _speculation_holds(true_state: list, first: FrameResult, exp=None, sources=None) -> bool:
    """Whether a chunk computed from no previous centroid equals the one from ``true_state``.

    It does if, in every view, the chunk's first frame had one component to
    choose from or no true previous centroid exists; otherwise (given the
    frame's ``sources``) the segmentation of that view is run again from the
    true previous centroid: the same centroid means the same component, the
    same mask and the same results.
    """
    n_comp = first.n_components or [None] * len(true_state)
    doubtful = [v for v, (st, n) in enumerate(zip(true_state, n_comp)) if st is not None and n != 1]
    if not doubtful:
        return True
    if exp is None or sources is None:
        return False
    seg_opts, _ = _options(exp)
    for v in doubtful:
        try:
            img = sources[v].read(first.frame)
        except FrameError:
            return False
        marks = exp.views[v]
        try:
            seg = segment_view(img, roi=marks.roi, keep_out=marks.keep_out, base_point_xy=marks.base_point,
                               prev_centroid_xy=true_state[v], **seg_opts)
            c = [float(x) for x in seg.centroid_xy]
        except FrameError:
            c = None
        if c != (first.centroids[v] if first.centroids else None):
            return False
    return True


# ------------------------------------------------------------------ the run
def frame_fingerprint(exp, cameras: list[Camera], video_info: list[dict]) -> str:
    """SHA-256 of what determines a frame's result: resolved parameters, videos, cameras, code."""
    from tendrilkit import __version__ as version
    from tendrilkit.params import experiment_to_dict

    payload = {
        "format": _FORMAT_VERSION,
        "version": version,
        "code": _code_digest(),
        # frames: start and step change the tracking (the frames seen); stop does not change a frame's result
        "experiment": {k: v for k, v in experiment_to_dict(exp).items() if k not in ("frames", "name")},
        "frames": {"start": exp.frames.start, "step": exp.frames.step},
        "videos": video_info,
        "cameras": [c.to_dict(i + 1) for i, c in enumerate(cameras)],
    }
    text = json.dumps(payload, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _code_digest() -> str:
    """SHA-256 of tendrilkit's own source files: a changed algorithm recomputes the frames."""
    h = hashlib.sha256()
    for p in sorted(Path(__file__).resolve().parent.glob("*.py")):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()


def _calibration_stamp(exp, video_info: list[dict]) -> str:
    """SHA-256 of what the calibration depends on: intrinsics, marker, extrinsics files, first frame, videos."""
    from tendrilkit import __version__ as version
    from tendrilkit.params import experiment_to_dict

    d = experiment_to_dict(exp)
    payload = {"version": version, "code": _code_digest(), "videos": video_info, "start": exp.frames.start,
               **{k: d.get(k) for k in ("cameras", "marker", "extrinsics", "calibration")}}
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()


def _frame_path(out: Path, frame: int) -> Path:
    return out / "frames" / f"frame_{frame:06d}.json"


def _load_done(out: Path, frames: list[int], fp: str) -> dict[int, FrameResult]:
    """The finished frames whose file verifies (:func:`tendrilkit.io.read_frame_record`); the others are recomputed."""
    from tendrilkit.io import read_frame_record

    done = {}
    for f in frames:
        d = read_frame_record(_frame_path(out, f), fp, f)
        if d is None:
            continue
        try:
            done[f] = FrameResult.from_json(d)
        except (KeyError, TypeError, ValueError, AttributeError):
            continue
    return done


def _assemble(results: list[FrameResult], n_views: int, n_points: int) -> dict[str, pd.DataFrame]:
    from tendrilkit.fitting import SEGMENT_COLUMNS, metrics_table

    cur, pwc, rows, rep, dec, segs, mets = [], [], [], [], [], [], []
    qcols = quality_columns(n_views)
    for r in sorted(results, key=lambda r: r.frame):
        row = {"frame": r.frame, "time_s": r.time_s, "status": r.status, "message": r.message}
        row.update({c: (r.quality.get(c) if r.quality else None) for c in qcols})
        rows.append(row)
        for arr, dest in ((r.points_mm, cur), (r.pwc_mm, pwc)):
            if arr is not None:
                n = len(arr)
                dest.append(pd.DataFrame({"frame": r.frame, "time_s": r.time_s, "point": np.arange(n),
                                          "x_mm": arr[:, 0], "y_mm": arr[:, 1], "z_mm": arr[:, 2]}))
        for t in r.reprojection:
            rep.append({"frame": r.frame, **t})
        for d in r.decisions:
            dec.append({**d, "candidates": json.dumps(d.get("candidates"))})
        segs.extend(r.pwc_segments)
        mets.extend(r.pwc_metrics)
    ccols = ["frame", "time_s", "point", "x_mm", "y_mm", "z_mm"]

    def cat(parts):
        return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=ccols)

    frames = pd.DataFrame(rows, columns=["frame", "time_s", "status", "message"] + qcols)
    for c in qcols:
        frames[c] = pd.to_numeric(frames[c], errors="coerce")
    frames["base_extended"] = frames["base_extended"].astype("boolean")
    for c in ["views_used", "views_checked", "n_matched", "pwc_segments_kappa", "pwc_segments_tau"] + [f"n_crossings_v{v}" for v in range(1, n_views + 1)]:
        frames[c] = frames[c].astype("Int64")
    rcols = ["frame", "view", "section", "mean_px", "std_px", "max_px", "n_points"]
    reproj = pd.DataFrame(rep, columns=rcols)
    if len(reproj):
        order = {"base": 0, "tip": 1, "entire": 2}
        reproj = reproj.assign(_o=reproj.section.map(order)).sort_values(["frame", "view", "_o"]).drop(columns="_o")
    dcols = ["frame", "view", "junction", "junction_x_px", "junction_y_px", "candidates", "chosen", "method"]
    ordering = pd.DataFrame(dec, columns=dcols)
    if len(ordering):
        ordering = ordering.sort_values(["frame", "view", "junction"], kind="stable")
    return {"curves.csv": cat(cur), "pwc_curves.csv": cat(pwc), "frames.csv": frames,
            "reprojection.csv": reproj.reset_index(drop=True), "ordering.csv": ordering.reset_index(drop=True),
            "pwc_segments.csv": pd.DataFrame(segs, columns=list(SEGMENT_COLUMNS)),
            "pwc_metrics.csv": metrics_table(mets)}


def _chunks(frames: list[int], workers: int) -> list[list[int]]:
    if workers <= 1:
        return [frames] if frames else []
    # small chunks: progress and Ctrl-C lose at most a chunk per worker; a chunk boundary costs nothing
    # unless the speculation fails there (several components in the first frame)
    size = min(_MAX_CHUNK, max(2, math.ceil(len(frames) / (4 * workers))))
    return [frames[i:i + size] for i in range(0, len(frames), size)]


def _with_overrides(exp, overrides: dict | None):
    """The experiment with some optional sections changed, validated again."""
    if not overrides:
        return exp
    from tendrilkit.params import Experiment

    data = exp.model_dump()
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    try:
        new = Experiment.model_validate(data)
    except Exception as e:  # pydantic's ValidationError: a programming mistake of the caller
        raise ValueError(f"overrides {overrides!r} do not validate: {e}") from None
    return new.model_copy(update={"source": exp.source})


def run_reconstruct(experiment_path: str | Path, out_dir: str | Path, *, workers: int | None = None,
                    progress: bool = True, fit: bool = True, overrides: dict | None = None,
                    contact_sheet: bool = True, executor=None) -> int:
    """``python -m tendrilkit reconstruct``: every selected frame of an experiment.

    Parameters
    ----------
    experiment_path : str or Path
        The experiment YAML file.
    out_dir : str or Path
        Output folder (created): the tables of :data:`RESULT_FILES`,
        ``cameras.json`` and ``frames/`` (one JSON file per finished frame).
    workers : int, optional
        Processes for frames (default: every core). The results do not
        depend on it.
    progress : bool
        Progress bar on a terminal (:func:`tendrilkit.progress.progress`).
    fit : bool
        Fit the piece-wise clothoid (``pwc_curves.csv``).
    overrides : dict, optional
        Optional sections of the experiment to change for this run, e.g.
        ``{"correspondence": {"method": "frechet"}}`` (they enter the
        fingerprint).
    contact_sheet : bool
        Write ``qc_contact_sheet.png`` (:func:`tendrilkit.qc.write_contact_sheet`):
        the doubtful frames and a sample of ok ones, the reconstruction
        projected onto every view.
    executor : concurrent.futures.Executor, optional
        Where the chunks run (e.g. a Dask cluster's,
        :class:`tendrilkit.distributed.Cluster`); ``workers`` is then its
        number of workers. Default: tendrilkit's process pool (in-process for
        one worker). The results do not depend on it.

    Returns
    -------
    int
        0 if every frame is ``ok``, 1 if some are ``doubtful`` or ``failed``.
        The last line printed is ``N frames: X ok, Y doubtful, Z failed``.

    Raises
    ------
    ExperimentError
        The experiment file, a video or the output folder is unusable, or the
        calibration fails.
    """
    from tendrilkit.calibration import calibrate_experiment
    from tendrilkit.inputs import check_inputs
    from tendrilkit.io import (check_writable_dir, file_stamp, open_views, read_cameras, write_cameras, write_csv,
                               write_frame_record, write_json)
    from tendrilkit.params import load_experiment
    from tendrilkit.progress import progress as progress_bar

    exp = _with_overrides(load_experiment(experiment_path), overrides)
    out = check_writable_dir(out_dir)
    sources = open_views(list(exp.videos))
    try:
        sizes = [(s.width, s.height) for s in sources]
        counts = [s.frame_count for s in sources]
        video_info = [{"path": str(p), **file_stamp(p), "frames": n, "width": w, "height": h}
                      for p, n, (w, h) in zip(exp.videos, counts, sizes)]
        check_inputs(exp, sources)
    finally:
        for s in sources:
            s.close()
    n_video = max(counts)  # a shorter view's missing frames fail in that view only (FrameReadError)
    fr = exp.frames
    stop = n_video if fr.stop is None else min(fr.stop, n_video)
    frames = list(range(fr.start, stop, fr.step))
    if not frames:
        raise ExperimentError(f"{exp.source}: frames: no frame selected (start {fr.start}, stop {fr.stop}, "
                              f"step {fr.step}; the longest video has {n_video} frames)")

    # calibrate once per experiment and videos: a rerun reuses the rig it wrote
    cal_stamp = _calibration_stamp(exp, video_info)
    stamp_path = out / "frames" / "calibration_stamp.json"
    cameras = None
    if stamp_path.is_file() and (out / "cameras.json").is_file() and (out / "calibration_markers.csv").is_file():
        try:
            if json.loads(stamp_path.read_text(encoding="utf-8")).get("stamp") == cal_stamp:
                cameras = read_cameras(out / "cameras.json")
        except (OSError, json.JSONDecodeError, ExperimentError):
            cameras = None
    if cameras is None:
        calib = calibrate_experiment(exp)
        cameras = calib.cameras
        write_cameras(cameras, out / "cameras.json")
        write_csv(calib.markers, out / "calibration_markers.csv")
        write_json({"stamp": cal_stamp}, stamp_path)

    fp = frame_fingerprint(exp, cameras, video_info)
    done = _load_done(out, frames, fp)
    todo = [f for f in frames if f not in done]
    workers = max(1, int(workers) if workers is not None else (os.cpu_count() or 1))
    workers = min(workers, max(1, len(todo)))
    V = exp.n_views

    def save(res: FrameResult) -> None:
        write_frame_record(_frame_path(out, res.frame), fp, res.frame, res.to_json())
        done[res.frame] = res

    # runs of consecutive to-do frames (done frames between them carry the tracking state)
    runs: list[list[int]] = []
    pos = {f: i for i, f in enumerate(frames)}
    for f in todo:
        if runs and pos[f] == pos[runs[-1][-1]] + 1:
            runs[-1].append(f)
        else:
            runs.append([f])
    multiview = exp.reconstruction.method == "multiview"
    if multiview:  # fixed chunks (acquired afresh at each start): the same results for any number of workers
        size = exp.reconstruction.chunk_frames
        chunks = [[f for f in r if pos[f] // size == k] for r in runs for k in sorted({pos[f] // size for f in r})]
    else:
        chunks = [c for r in runs for c in _chunks(r, workers)]

    def state_before(f: int):
        if multiview:  # the previous frame's curve within the chunk (done frames: a resumed run)
            i = pos[f]
            return None if i % exp.reconstruction.chunk_frames == 0 else _next_curve(done[frames[i - 1]])
        st: list = [None] * V
        for g in frames[: pos[f]]:
            st = _next_state(st, done[g])
        return st

    import cv2

    def produce():
        """Finished frames in frame order, each already tracked from the true previous centroids."""
        if workers == 1 and executor is None:
            for chunk in chunks:
                yield from _iter_chunk(chunk, state_before(chunk[0]), exp, cameras, fit)
            return
        with (_local_pool(workers, fit) if executor is None else contextlib.nullcontext()) as pool, \
                _Sources(exp) as sources:
            ex = executor if executor is not None else _PoolExecutor(pool)
            jobs = [ex.submit(_run_chunk, (c, state_before(c[0]) if multiview else [None] * V, exp, cameras, fit))
                    for c in chunks]
            for chunk, job in zip(chunks, jobs):
                results = job.result()
                state = state_before(chunk[0]) if not multiview else None
                if not multiview and not _speculation_holds(state, results[0], exp, sources):
                    # recompute from the true state until both chains carry the same tracking state:
                    # from there on the speculative results had the same inputs
                    spec_states, st = [], [None] * V
                    for res in results:
                        st = _next_state(st, res)
                        spec_states.append(st)
                    fixed = []
                    for i, f in enumerate(chunk):
                        res = ex.submit(_run_chunk, ([f], state, exp, cameras, fit)).result()[0]
                        fixed.append(res)
                        state = _next_state(state, res)
                        if state == spec_states[i]:
                            break
                    results = fixed + results[len(fixed):]
                for res in results:
                    yield res

    old_threads = cv2.getNumThreads()
    cv2.setNumThreads(1)  # the same single-threaded OpenCV in-process as in the workers
    try:
        for res in progress_bar(produce(), total=len(todo), desc=exp.name, enabled=None if progress else False):
            save(res)
    finally:
        cv2.setNumThreads(old_threads)

    results = with_temporal_checks([done[f] for f in frames], exp.verification)
    tables = _assemble(results, V, exp.points)
    for name, df in tables.items():
        write_csv(df, out / name)
    if contact_sheet:
        from tendrilkit.qc import CONTACT_SHEET, write_contact_sheet

        write_contact_sheet(exp, cameras, tables["frames.csv"], tables["curves.csv"], tables["pwc_curves.csv"],
                            out / CONTACT_SHEET)
    n_ok = sum(r.status == "ok" for r in results)
    n_doubtful = sum(r.status == "doubtful" for r in results)
    n_failed = len(results) - n_ok - n_doubtful
    print(f"{len(results)} frames: {n_ok} ok, {n_doubtful} doubtful, {n_failed} failed")  # the command's summary line
    return 0 if n_ok == len(results) else 1


def with_temporal_checks(results: list[FrameResult], verification=None) -> list[FrameResult]:
    """The results with the checks against neighbouring frames applied (:func:`tendrilkit.verify.temporal_checks`).

    Run at assembly time over the ordered results (so that it does not depend
    on chunks or workers): fills ``length_change_pct``, ``shape_change_mm``
    and ``dt_prev_s`` and turns an ``ok`` frame that jumps into ``doubtful``.
    """
    from dataclasses import replace

    from tendrilkit.verify import Thresholds, temporal_checks

    th = Thresholds.from_params(verification) if verification is not None else Thresholds()
    results = sorted(results, key=lambda r: r.frame)
    figs, msgs = temporal_checks([r.frame for r in results], [r.time_s for r in results],
                                 [r.points_mm if r.status != "failed" else None for r in results],
                                 [r.status == "ok" for r in results], th)
    out = []
    for r, fig, msg in zip(results, figs, msgs):
        if r.status == "failed":
            out.append(r)
            continue
        status = "doubtful" if (msg or r.status == "doubtful") else "ok"
        notes = r.message.split("; ")[len(r.checks):] if r.message else []
        message = "; ".join(list(r.checks) + list(msg) + notes)  # the failed checks first, then the notes
        out.append(replace(r, status=status, message=message, quality={**r.quality, **fig}))
    return out


class _Sources:
    """The views' frame sources, opened lazily (the parent checks speculative chunks with them)."""

    def __init__(self, exp) -> None:
        self.exp = exp
        self._src = None

    def __getitem__(self, v: int):
        if self._src is None:
            from tendrilkit.io import open_views

            self._src = open_views(list(self.exp.videos))
        return self._src[v]

    def __enter__(self) -> "_Sources":
        return self

    def __exit__(self, *exc) -> None:
        for s in self._src or []:
            s.close()


def _warm_up(fit: bool) -> None:
    """Run the compiled kernels once on a small synthetic curve (numba compiles or loads its cache)."""
    from tendrilkit.correspondence import discrete_frechet

    s = np.linspace(0.0, 1.0, 60)
    X = np.c_[30 * s, 5 * np.sin(4 * s), 200 + 5 * np.cos(4 * s)]
    cams = [Camera(K=np.array([[1000.0, 0, 500], [0, 1000, 500], [0, 0, 1]]), t_mm=np.array([tx, 0.0, 0.0]))
            for tx in (-40.0, 0.0, 40.0)]
    curves = [c.project(X) for c in cams]
    try:
        m = match_epipolar(curves, cams, reference=1, k=20)
        tri = triangulate(m, cams)
        reprojection_table(np.nan_to_num(tri.points_mm), curves, cams)
        discrete_frechet(curves[0], curves[1])
        if fit:
            _fit_defaults(X)
    except Exception:  # noqa: BLE001 - a warm-up only; the real frames report their own errors
        pass


def _fit_defaults(points_mm: np.ndarray) -> None:
    fit_piecewise_clothoid(points_mm)


def _next_curve(res: FrameResult) -> np.ndarray | None:
    """Multiview tracking state after a frame: its curve if it is ``ok``, else None (acquire)."""
    return res.points_mm if res.status == "ok" else None


def _iter_chunk(frames, state, exp, cameras, fit):
    """Process consecutive frames from a tracking state, yielding each frame as it finishes.

    The state is the previous frame's centroids per view (chain) or curve (multiview).
    """
    multiview = exp.reconstruction.method == "multiview"
    sources = [_open_or_unreadable(p) for p in exp.videos]
    try:
        for f in frames:
            images, errors = _read_views(sources, f)
            if multiview:
                res = reconstruct_frame(images, cameras, exp, frame=f, previous_mm=state, read_errors=errors, fit=fit)
                state = _next_curve(res)
            else:
                res = reconstruct_frame(images, cameras, exp, frame=f, prev_centroids=state, read_errors=errors,
                                        fit=fit)
                state = _next_state(state, res)
            yield res
    finally:
        for s in sources:
            s.close()


class _Unreadable:
    """A view whose video this process cannot open: every frame read fails with the reason."""

    def __init__(self, reason: str) -> None:
        self.reason = reason

    def read(self, frame: int):
        raise FrameReadError(f"cannot open the video here ({self.reason})")

    def close(self) -> None:
        pass


def _open_or_unreadable(path):
    """The view's frame source, or (e.g. a cluster worker that does not see the file) an :class:`_Unreadable`."""
    from tendrilkit.io import FrameSource

    try:
        return FrameSource(path)
    except ExperimentError as e:
        return _Unreadable(str(e))


# ------------------------------------------------------------------ accuracy
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
        the first and last points to the true ends), sorted by frame.
    """
    from scipy.spatial import cKDTree

    rows = []
    for frame, g in curves.groupby("frame", sort=True):
        t = truth[truth.frame == frame].sort_values("point")
        if t.empty:
            continue
        X = t[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
        P = g.sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
        seg = np.linalg.norm(np.diff(X, axis=0), axis=1)
        n = max(2, int(np.ceil(seg.sum() / 0.02)))  # the true polyline every 0.02 mm
        Xd = _resample_linear(X, n)
        d, _ = cKDTree(Xd).query(P)
        rows.append({"frame": int(frame), "mean_mm": float(d.mean()), "max_mm": float(d.max()),
                     "base_mm": float(np.linalg.norm(P[0] - X[0])), "tip_mm": float(np.linalg.norm(P[-1] - X[-1]))})
    return pd.DataFrame(rows, columns=["frame", "mean_mm", "max_mm", "base_mm", "tip_mm"])


def _resample_linear(X: np.ndarray, n: int) -> np.ndarray:
    from tendrilkit.correspondence import resample_by_arclength

    return resample_by_arclength(X, n)


def compare_correspondence(experiment_path: str | Path, out_dir: str | Path, *, truth: pd.DataFrame | None = None,
                           methods: tuple[str, ...] = ("epipolar", "frechet"), workers: int | None = None,
                           fit: bool = False) -> pd.DataFrame:
    """Reconstruct an experiment once per correspondence method and tabulate the figures per frame.

    Each method runs into ``out_dir/<method>/`` (resumable like any run).

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

    out = Path(out_dir)
    parts = []
    for m in methods:
        run_reconstruct(experiment_path, out / m, workers=workers, progress=False, fit=fit,
                        overrides={"correspondence": {"method": m}})
        f = read_csv(out / m / "frames.csv")
        cols = ["frame", "status"] + [c for c in f.columns if c.startswith("reproj_mean_px_v")]
        t = f[cols].copy()
        if truth is not None:
            acc = accuracy_against_truth(read_csv(out / m / "curves.csv"), truth)
            t = t.merge(acc, on="frame", how="left")
        t.insert(0, "method", m)
        parts.append(t)
    return pd.concat(parts, ignore_index=True)
