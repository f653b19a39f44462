"""Composition of the stages for one frame; the only place that catches per-frame failures.

:func:`reconstruct_frame` composes, for one frame, the stages of the method
with the options of :func:`tendrilkit.options.stage_options`: per view
segmentation and base-to-tip ordering (2D stage), matching across views
(``correspondence.method``), triangulation, the gross-outlier filter
(:mod:`tendrilkit.outlier_filter`), the extension to the base marks
(:mod:`tendrilkit.base_extension`), resampling to ``points`` points base to
tip (uniform arc length), the nearly-straight check
(:mod:`tendrilkit.straightness`), the piece-wise clothoid fit, and the
quality figures (reprojection error per view and quarter against the
extracted skeletons, paper Table 1). The run over frames (chunks, workers,
resuming) is :mod:`tendrilkit.runner`, the tables :mod:`tendrilkit.assembly`,
the scores against ground truth :mod:`tendrilkit.evaluation`.

The result files of EXPERIMENT_FORMAT.md (see :data:`RESULT_FILES`), rows
sorted by frame (then point, view, ...), floats with 6 decimals:

   ========================  ==========================================================
   ``curves.csv``            ``frame, time_s, point, x_mm, y_mm, z_mm``: the centreline,
                             ``points`` points base (0) to tip, uniform arc length
   ``pwc_curves.csv``        same columns: the piece-wise clothoid registered onto it
   ``pwc_segments.csv``      the fitted laws: ``frame, kind (kappa|tau), segment, s0_mm,
                             s1_mm, value_s0, value_s1`` (1/mm), as ``tendrilkit fit``
   ``pwc_metrics.csv``       per frame R^2 and SSE (mm^2) of the fit, entire / base / tip
                             quarter, penalties and segment counts, as ``tendrilkit fit``
   ``frames.csv``            ``frame, time_s, status, message`` and the quality figures
                             of :func:`tendrilkit.schema.quality_columns`
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
    ``failed`` with the reason and the run goes on; a user's mistake
    (:class:`~tendrilkit.exceptions.ExperimentError`, although a
    ``ValueError``) is never a failed frame: it stops the run. A view whose 2D stage
    fails is left out when at least two views remain (the message says so).
    A failed piece-wise clothoid fit keeps the frame ``ok`` (the centreline
    stands) with no ``pwc_curves.csv`` rows and the reason in the message.
    A nearly straight centreline (within 1 % of its length of its chord) is
    ``ok`` with the note ``nearly straight ...: torsion undefined``.

Verification
    Every reconstructed frame is checked against every view's image
    (:func:`tendrilkit.verify.verify_curve` on
    :func:`tendrilkit.evidence.view_evidence`, inside the frame's worker) and,
    at assembly time over the ordered frames, against its neighbours in time
    (:func:`tendrilkit.assembly.with_temporal_checks`: the same whatever the chunks or workers).
    A frame failing a check is ``doubtful``, the failed checks first in its
    message; limits in the experiment's ``verification:`` section.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from tendrilkit.base_extension import base_from_marks
from tendrilkit.camera import Camera
from tendrilkit.correspondence import match_epipolar, match_frechet
from tendrilkit.exceptions import DegenerateCurveError, ExperimentError, FrameError
from tendrilkit.frenet import resample_curve
from tendrilkit import schema
from tendrilkit.outlier_filter import triangulation_inliers
from tendrilkit.options import stage_options
from tendrilkit.schema import quality_columns
from tendrilkit.segmentation import segment_view
from tendrilkit.skeleton import order_skeleton
from tendrilkit.straightness import straightness_note
from tendrilkit.triangulation import refine_to_curves, reprojection_table, triangulate

__all__ = ["FrameResult", "reconstruct_frame", "multiview_evidence", "quality_columns", "RESULT_FILES"]

#: The tables :func:`tendrilkit.runner.run_reconstruct` writes in ``DIR`` (besides ``cameras.json`` and ``frames/``).
RESULT_FILES = ("curves.csv", "pwc_curves.csv", "frames.csv", "reprojection.csv", "ordering.csv",
                "pwc_segments.csv", "pwc_metrics.csv", "calibration_markers.csv")

#: Numerical errors of a frame that become a ``failed`` row instead of a crash.
_NUMERICAL_ERRORS = (ValueError, FloatingPointError, np.linalg.LinAlgError, ZeroDivisionError, IndexError)



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
        Seconds per stage, for the benchmarks (``benchmarks/bench_reconstruct.py``,
        ``bench_throughput.py``); never written (the result files of the same
        input are the same bytes).
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


# ------------------------------------------------------------------ one frame
def _fit(points_mm: np.ndarray, exp, frame: int, time_s: float):
    """The piece-wise clothoid of one frame, by the ``fit`` command's own code (same options, same tables)."""
    from tendrilkit.fitting import fit_frame

    return fit_frame(points_mm, stage_options(exp, "fit"), frame=frame, time_s=time_s)




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
    seg_opts, order_opts = stage_options(exp, "segmentation"), stage_options(exp, "ordering")
    t_s = frame / exp.fps
    timings: dict[str, float] = {}
    centroids: list = [None] * V
    ncomp: list = [None] * V
    curves: list = [None] * V
    decisions: list = []
    notes: list[str] = []
    crossings: list = [None] * V
    labelled: list = [None] * V  # per view, the segmentation's labelled dark pixels (the verification reuses them)

    timings["segment"] = timings["order"] = 0.0  # the 2D stage, summed over the views
    for v in range(V):
        marks = exp.views[v]
        if images[v] is None:
            notes.append(f"view {v + 1}: {read_errors[v] or 'no image'}")
            continue
        try:
            t0 = time.perf_counter()
            seg = segment_view(images[v], roi=marks.roi, keep_out=marks.keep_out, base_point_xy=marks.base_point,
                               prev_centroid_xy=prev[v], **seg_opts)
            t1 = time.perf_counter()
            timings["segment"] += t1 - t0
            centroids[v] = [float(c) for c in seg.centroid_xy]
            ncomp[v] = int(seg.n_components)
            labelled[v] = seg.foreground
            oc = order_skeleton(seg.mask_roi, offset_xy=seg.roi_offset_xy, base_point_xy=marks.base_point,
                                frame=frame, view=v + 1, **order_opts)
            timings["order"] += time.perf_counter() - t1
            curves[v] = oc.points_xy
            crossings[v] = int(oc.n_crossings)
            decisions.extend(d.as_dict() for d in oc.decisions)
        except FrameError as e:
            notes.append(f"view {v + 1}: {type(e).__name__}: {e}")
        except ExperimentError:
            raise
        except _NUMERICAL_ERRORS as e:
            notes.append(f"view {v + 1}: unexpected {type(e).__name__} in the 2D stage: {e}")

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
                                     **stage_options(exp, "correspondence"))
        else:
            matched = match_frechet(cl, cams, reference=used.index(ref), k=k, marker_length_mm=exp.marker.length_mm)
        timings["match"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        tri = triangulate(matched, cams, **stage_options(exp, "triangulation"))
        good = triangulation_inliers(tri.points_mm, tri.reproj_err_px,
                                     max_distance_px=exp.correspondence.max_distance_px)
        timings["triangulate"] = time.perf_counter() - t0
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
            t0 = time.perf_counter()
            base = base_from_marks([m.base_point for m in exp.views], cameras, tri_pts,
                                   max_distance_px=exp.correspondence.max_distance_px)
            if base is not None:
                ext_mm = float(np.linalg.norm(tri_pts[0] - base))
                tri_pts = np.vstack([base, tri_pts])
                q_base = True
            timings["base"] = time.perf_counter() - t0
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
        checks = _verify(points, images, cameras, exp, seg_opts, q, labelled)
        timings["verify"] = time.perf_counter() - t0
    except FrameError as e:
        return failed("; ".join(notes + [f"{type(e).__name__}: {e}"]))
    except ExperimentError:
        raise
    except _NUMERICAL_ERRORS as e:
        return failed("; ".join(notes + [f"unexpected {type(e).__name__}: {e}"]))
    return FrameResult(frame=frame, time_s=t_s, status="doubtful" if checks else "ok",
                       message="; ".join(checks + notes), points_mm=points,
                       pwc_mm=pwc, quality=q, reprojection=reproj_rows, decisions=decisions,
                       centroids=centroids, n_components=ncomp, timings=timings,
                       pwc_segments=_plain(pwc_segments), pwc_metrics=_plain([pwc_row] if pwc_row else []),
                       checks=checks)


def _verify(points: np.ndarray, images: list, cameras: list[Camera], exp, seg_opts: dict, q: dict,
            labelled: list) -> list[str]:
    """Check the curve against every view's image (:mod:`tendrilkit.verify`); figures into ``q``, failed checks out.

    ``labelled``: per view the segmentation's labelled dark pixels
    (:class:`tendrilkit.segmentation.LabelledForeground`, same image and
    options) or None; the evidence reuses them instead of thresholding again.
    """
    from tendrilkit.evidence import view_evidence
    from tendrilkit.verify import Thresholds, verify_frame

    evidence = [None if img is None else
                view_evidence(img, roi=m.roi, keep_out=m.keep_out, base_point_xy=m.base_point, foreground=fg,
                              **seg_opts)
                for img, m, fg in zip(images, exp.views, labelled)]
    return verify_frame(points, cameras, evidence, q, Thresholds.from_params(exp.verification), images=images,
                        channel=seg_opts.get("channel", "blue"))


def _shape_and_fit(points: np.ndarray, q: dict, notes: list, exp, frame: int, t_s: float, fit: bool,
                   timings: dict):
    """The straightness note and the piece-wise clothoid fit of a centreline (fills ``q`` and ``notes``)."""
    # a (nearly) straight centreline has no normal: its torsion is undefined, whatever the fit says
    note = straightness_note(points, q["length_mm"])
    if note:
        notes.append(note)
    pwc, pwc_segments, pwc_row = None, [], None
    if fit:  # a failed fit leaves the reconstruction standing: the frame stays ok, without pwc
        t0 = time.perf_counter()
        try:
            pwc, pwc_segments, pwc_row = _fit(points, exp, frame, t_s)
        except ExperimentError:
            raise
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


def multiview_evidence(images, cameras: list[Camera], exp, *, read_errors=None) -> tuple[list, list, list[str]]:
    """The evidence of every view for ``reconstruction.method: multiview`` (what the method decides from).

    Parameters
    ----------
    images : list of (H, W, 3) uint8 arrays or None
        One per view (None: not read).
    cameras : list of Camera
    exp : Experiment
        Its marks and segmentation options are used.
    read_errors : list of str or None, optional
        Why a view's image is None.

    Returns
    -------
    views : list
        :func:`tendrilkit.evidence.view_evidence` per view (None where it failed); what the
        verification reads.
    evidence : list
        :func:`tendrilkit.mv_evidence.skeleton_evidence` per view (None where it failed).
    notes : list of str
        Why a view has no evidence (``view <i>: ...``, 1-based).
    """
    from tendrilkit.evidence import view_evidence
    from tendrilkit.mv_evidence import skeleton_evidence

    V = len(cameras)
    read_errors = list(read_errors) if read_errors is not None else [None] * V
    seg_opts = stage_options(exp, "segmentation")
    views: list = [None] * V
    evidence: list = [None] * V
    notes: list[str] = []
    for v in range(V):
        if images[v] is None:
            notes.append(f"view {v + 1}: {read_errors[v] or 'no image'}")
            continue
        m = exp.views[v]
        try:
            views[v] = view_evidence(images[v], roi=m.roi, keep_out=m.keep_out, base_point_xy=m.base_point, **seg_opts)
            evidence[v] = skeleton_evidence(views[v], cameras[v], image_bgr=images[v],  # the lines in front too
                                            front_line_contrast=exp.reconstruction.front_line_contrast)
        except FrameError as e:
            notes.append(f"view {v + 1}: {type(e).__name__}: {e}")
        except ExperimentError:
            raise
        except _NUMERICAL_ERRORS as e:
            notes.append(f"view {v + 1}: unexpected {type(e).__name__} in the evidence: {e}")
    return views, evidence, notes


def _multiview_frame(images, cameras: list[Camera], exp, *, frame: int, previous_mm, read_errors, fit: bool
                     ) -> FrameResult:
    """:func:`reconstruct_frame` by ``reconstruction.method: multiview`` (:mod:`tendrilkit.multiview`)."""
    from tendrilkit.multiview import base_point_from_marks, distance_table, reconstruct_multiview
    from tendrilkit.mv_evidence import attach_chroma
    from tendrilkit.verify import Thresholds, verify_frame

    V = len(cameras)
    t_s = frame / exp.fps
    timings: dict[str, float] = {}
    t0 = time.perf_counter()
    views, evidence, notes = multiview_evidence(images, cameras, exp, read_errors=read_errors)
    timings["evidence"] = time.perf_counter() - t0
    used = [v for v in range(V) if evidence[v] is not None]
    try:
        if len(used) < 2:
            raise DegenerateCurveError("fewer than two views have evidence of the tendril")
        t0 = time.perf_counter()
        B = base_point_from_marks([m.base_point for m in exp.views], cameras, max_px=exp.correspondence.max_distance_px)
        if exp.reconstruction.colour_px > 0:  # the colour of each view's skeleton pixels (the acquisition's)
            for v in used:
                attach_chroma(evidence[v], images[v])
        mv = reconstruct_multiview([evidence[v] for v in used], B, previous_mm=previous_mm,
                                   **stage_options(exp, "multiview"))
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
        checks = verify_frame(points, cameras, views, q, Thresholds.from_params(exp.verification), images=images,
                              channel=exp.segmentation.channel)
        timings["verify"] = time.perf_counter() - t0
    except FrameError as e:
        return FrameResult(frame=frame, time_s=t_s, status="failed", message="; ".join(notes + [f"{type(e).__name__}: {e}"]),
                           timings=timings)
    except ExperimentError:
        raise
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
