"""``python -m tendrilkit check EXPERIMENT.yaml``: a preflight in seconds.

One line per check, ``OK`` or ``FAIL`` with what to fix; exit 0 when every
check passes, 1 otherwise (2: the file itself cannot be read). The checks:

``videos``       every video opens; frame counts, sizes and container fps agree
                 (or the line says how they differ);
``intrinsics``   per view, the principal point near the image centre, fx and fy
                 alike, no placeholder left by ``init``;
``marker``       the world marker is found in every view on the frames the run
                 calibrates from (``calibration.average_frames`` from the first
                 processed frame, corners refined by ``calibration.corner_refine``
                 and averaged over the frames), with the corner RMS of its
                 single-marker pose;
``poses``        the rig (as the run calibrates it, from those corners,
                 ``calibration.bundle_adjust``): every camera on the board's front
                 side, 50 mm - 5 m from the marker; after the bundle
                 adjustment, the markers seen by several views reproject
                 within 1.5 px in every view; and the views' base points agree:
                 each view's base point lies within ``max(8 px,
                 correspondence.max_distance_px)`` of the point triangulated
                 from the other views (intrinsics off by a factor, a swapped
                 view or a wrong base point break this);
``marks``        per view: ROI, keep-out box and base point inside the image,
                 and a thin, elongated component (the tendril) at the base point
                 on the first frame;
``trial``        the first 2 selected frames reconstruct (no piece-wise fit),
                 each view's mean reprojection error within
                 ``correspondence.max_distance_px``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["run_check", "check_lines"]

_OK, _FAIL = "OK  ", "FAIL"


def _line(ok: bool, what: str, text: str) -> tuple[bool, str]:
    return ok, f"{_OK if ok else _FAIL} {what}: {text}"


def _videos(exp) -> tuple[list, list]:
    from tendrilkit.exceptions import ExperimentError
    from tendrilkit.io import FrameSource

    out, srcs = [], []
    for v, p in enumerate(exp.videos):
        try:
            srcs.append(FrameSource(p))
        except ExperimentError as e:
            srcs.append(None)
            out.append(_line(False, "videos", f"view {v + 1}: {e}"))
    ok = [s for s in srcs if s is not None]
    if len(ok) == len(srcs):
        sizes = [(s.width, s.height) for s in srcs]
        counts = [s.frame_count for s in srcs]
        fpss = [s.fps for s in srcs]
        diffs = []
        if len(set(sizes)) > 1:
            diffs.append("sizes " + ", ".join(f"view {v + 1} {w}x{h}" for v, (w, h) in enumerate(sizes)))
        if len(set(counts)) > 1:
            diffs.append("frame counts " + ", ".join(f"view {v + 1} {n}" for v, n in enumerate(counts))
                         + " (trim the videos to the same span, or the shorter view's last frames fail)")
        if len({round(f, 3) for f in fpss if f}) > 1:
            diffs.append("container fps " + ", ".join(f"view {v + 1} {f:g}" for v, f in enumerate(fpss) if f))
        if diffs:
            out.append(_line(False, "videos", "they differ: " + "; ".join(diffs)))
        else:
            f = f", {fpss[0]:g} fps in the files" if fpss[0] else ""
            out.append(_line(True, "videos", f"{len(srcs)} open, {sizes[0][0]}x{sizes[0][1]}, {counts[0]} frames each{f}"
                             f" (experiment fps {exp.fps:g})"))
    return out, srcs


def _intrinsics(exp, sizes) -> list:
    out = []
    bad = []
    for v, (c, (w, h)) in enumerate(zip(exp.cameras, sizes)):
        if c.fx == 1.0 and c.fy == 1.0:
            bad.append(f"view {v + 1}: placeholder intrinsics: run `python -m tendrilkit intrinsics BOARD_VIDEO "
                       f"--board ... --view {v + 1} --write {exp.source}`")
            continue
        if abs(c.cx - w / 2) > 0.25 * w or abs(c.cy - h / 2) > 0.25 * h:
            bad.append(f"view {v + 1}: principal point ({c.cx:g}, {c.cy:g}) is far from the {w}x{h} image's centre: "
                       "intrinsics of another resolution or camera?")
        if not 0.9 < c.fx / c.fy < 1.1:
            bad.append(f"view {v + 1}: fx {c.fx:g} and fy {c.fy:g} differ by more than 10 %: a typo?")
    if bad:
        return [_line(False, "intrinsics", b) for b in bad]
    return [_line(True, "intrinsics", f"{len(exp.cameras)} views: principal points near the centres, fx ~ fy")]


def check_lines(exp, *, n_trial: int = 2) -> list[tuple[bool, str]]:
    """Run every check of an experiment (loaded with ``marks_optional=True``); ``(ok, line)`` pairs."""
    from tendrilkit.calibration import average_detections, calibrate_from_observations, detect_markers
    from tendrilkit.calibration.poses import _pose_candidates
    from tendrilkit.extrinsics import calibration_frames
    from tendrilkit.camera import Camera
    from tendrilkit.exceptions import ExperimentError, FrameReadError

    lines, srcs = _videos(exp)
    if any(s is None for s in srcs):
        for s in srcs:
            if s is not None:
                s.close()
        return lines + [_line(False, "rest", "skipped until every video opens")]
    try:
        sizes = [(s.width, s.height) for s in srcs]
        lines += _intrinsics(exp, sizes)
        start = exp.frames.start
        images = []
        for v, s in enumerate(srcs):
            try:
                images.append(s.read(start))
            except FrameReadError as e:
                images.append(None)
                lines.append(_line(False, "videos", f"view {v + 1}: first processed frame {start}: {e}"))
        intr = [Camera(np.array([[c.fx, 0, c.cx], [0, c.fy, c.cy], [0, 0, 1.0]]), np.asarray(c.dist, float),
                       width=w, height=h) for c, (w, h) in zip(exp.cameras, sizes)]
        # ------------------------------------------------------------ marker
        # the run's calibration: the same frames (calibration.average_frames from frames.start), the same
        # corner refinement (calibration.corner_refine), the corners averaged over the frames
        mk, cal_opts = exp.marker, exp.calibration
        n_cal = cal_opts.average_frames
        observations: dict[int, dict] = {}
        found, marker_ok = [], True
        for v, (img, cam, src) in enumerate(zip(images, intr, srcs)):
            if img is None:
                marker_ok = False
                continue
            frames = calibration_frames(src, v, start, n_cal, first=img)
            obs = average_detections([detect_markers(f, mk.dictionary, refine=cal_opts.corner_refine, camera=cam)
                                      for f in frames])
            observations[v] = obs
            where = f"frame {start}" if len(frames) == 1 else f"any of frames {start}-{start + len(frames) - 1}"
            if mk.id not in obs:
                marker_ok = False
                others = ", ".join(str(m) for m in list(obs)[:6])
                lines.append(_line(False, "marker", f"view {v + 1}: world marker {mk.id} ({mk.dictionary}) not found on "
                                   f"{where}" + (f" (found {others}: is marker.id right?)" if obs else
                                                 " (no marker at all: is marker.dictionary right, the marker in view and sharp?)")))
                continue
            rms = _pose_candidates(obs[mk.id], cam, mk.length_mm)[0][2]
            found.append(f"view {v + 1} {rms:.2f} px")
            if rms > 1.0:
                marker_ok = False
                lines.append(_line(False, "marker", f"view {v + 1}: the marker's corners fit its pose only to {rms:.2f} px: "
                                   "wrong intrinsics (fx/fy, distortion) for this view?"))
        if marker_ok:
            lines.append(_line(True, "marker", f"world marker {mk.id} in every view; corner RMS " + ", ".join(found)))
        # ------------------------------------------------------------- poses
        cameras = None
        if marker_ok:
            import warnings

            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    cal = calibrate_from_observations(observations, intr, world_id=mk.id, length_mm=mk.length_mm,
                                                      bundle_adjust=cal_opts.bundle_adjust, frame=start,
                                                      dictionary=mk.dictionary)
                cameras = cal.cameras
            except (ExperimentError, ValueError, np.linalg.LinAlgError) as e:
                lines.append(_line(False, "poses", f"calibration failed: {e}"))
            if cameras is not None:
                lines += _poses(exp, cameras, cal)
        else:
            lines.append(_line(False, "poses", "skipped: the world marker must be found in every view first"))
        # ------------------------------------------------------------- marks
        marks_ok = True
        for v, (img, m) in enumerate(zip(images, exp.views)):
            w, h = sizes[v]
            if m.roi is None or m.base_point is None:
                marks_ok = False
                lines.append(_line(False, "marks", f"view {v + 1}: roi/base_point missing: run `python -m tendrilkit marks {exp.source}`"))
                continue
            x, y, bw, bh = m.roi
            if x < 0 or y < 0 or x + bw > w or y + bh > h:
                marks_ok = False
                lines.append(_line(False, "marks", f"view {v + 1}: roi {list(m.roi)} reaches outside the {w}x{h} image"))
                continue
            bx, by = m.base_point
            if not (0 <= bx < w and 0 <= by < h):
                marks_ok = False
                lines.append(_line(False, "marks", f"view {v + 1}: base_point {list(m.base_point)} is outside the {w}x{h} image"))
                continue
            if img is None:
                continue
            why = _tendril_at_base(img, m, exp)
            if why:
                marks_ok = False
                lines.append(_line(False, "marks", f"view {v + 1}: {why}; `python -m tendrilkit marks {exp.source}` suggests marks"))
        if marks_ok:
            lines.append(_line(True, "marks", "inside the images; a thin tendril at the base point in every view"))
        # ------------------------------------------------------------- trial
        if cameras is not None and marks_ok:
            lines += _trial(exp, cameras, srcs, n_trial)
        else:
            lines.append(_line(False, "trial", "skipped until the poses and marks checks pass"))
    finally:
        for s in srcs:
            s.close()
    return lines


def _poses(exp, cameras, cal) -> list:
    out, bad = [], []
    for v, c in enumerate(cameras):
        C = c.center_world
        d = float(np.linalg.norm(C))
        if C[2] <= 0:
            bad.append(f"view {v + 1}: the camera is behind the marker's board (z = {C[2]:.0f} mm): "
                       "wrong intrinsics or a mirrored marker print?")
        elif not 50 <= d <= 5000:
            bad.append(f"view {v + 1}: the camera is {d:.0f} mm from the marker (expected 50-5000): "
                       "fx off by a factor, or marker.length_mm wrong?")
    # the other markers: each view against what the other views triangulate (single-marker poses)
    obs = cal.observations
    V = len(cameras)
    shared = sorted(m for m in set().union(*[set(o) for o in obs.values()]) - {exp.marker.id}
                    if all(m in obs.get(v, {}) for v in range(V)))
    blamed = None
    if shared and V >= 3:
        P = np.stack([np.concatenate([obs[v][m] for m in shared]) for v in range(V)])
        errs, agree = _leave_one_out(P, cal.single_cameras)
        culprit = [v for v in range(V) if agree[v] <= 1.5 and errs[v] > 3.0]
        if len(culprit) == 1:
            blamed = culprit[0]
            others = " and ".join(str(u + 1) for u in range(V) if u != blamed)
            bad.append(f"view {blamed + 1}: the other markers, triangulated from views {others}, reproject "
                       f"{errs[blamed]:.1f} px off in view {blamed + 1} (views {others} agree within {agree[blamed]:.1f} px): "
                       f"view {blamed + 1}'s intrinsics are likely wrong (fx, fy off by a factor? distortion?)")
    t = cal.markers
    adj = t[t.stage == "adjusted"] if "stage" in t else t.iloc[:0]
    worse = [v for v in range(1, V + 1) if len(adj[adj.view == v]) and float(adj[adj.view == v].mean_px.max()) > 1.5]
    if worse and blamed is None:
        bad.append("markers seen by several views reproject " + ", ".join(
            f"{float(adj[adj.view == v].mean_px.max()):.1f} px in view {v}" for v in worse)
            + " after the joint adjustment (at most 1.5 px expected): some view's intrinsics are wrong")
    # the base points: each view's against the point triangulated from the others
    worst = None
    if all(m.base_point is not None for m in exp.views) and len(cameras) >= 3:
        tol = max(8.0, float(exp.correspondence.max_distance_px))
        pts = np.array([m.base_point for m in exp.views], float)
        errs, agree = _leave_one_out(pts[:, None, :], cameras)
        culprit = [v for v in range(len(cameras)) if agree[v] <= tol and errs[v] > tol]
        if len(culprit) == 1:
            v = culprit[0]
            others = " and ".join(str(u + 1) for u in range(len(cameras)) if u != v)
            bad.append(f"view {v + 1}: its base point lies {errs[v]:.0f} px from the point views {others} agree on "
                       f"(tolerance {tol:g} px): view {v + 1}'s base point, intrinsics or video (swapped?) is off")
        elif np.any(errs > tol):
            bad.append("the views' base points disagree: each lies " + ", ".join(f"{e:.0f}" for e in errs)
                       + f" px from the point the other views triangulate (tolerance {tol:g} px): a view's intrinsics "
                       "(fx off by a factor?), a swapped video or a wrong base point; the marks line says which view")
    if bad:
        return [_line(False, "poses", b) for b in bad]
    dist = ", ".join(f"view {v + 1} {np.linalg.norm(c.center_world):.0f} mm" for v, c in enumerate(cameras))
    return [_line(True, "poses", f"cameras in front of the board ({dist}); views agree on the base point")]


def _leave_one_out(points_xy: np.ndarray, cameras) -> tuple[np.ndarray, np.ndarray]:
    """Per view: median distance (px) of its points (V, k, 2) to those triangulated from the
    other views, and how well the other views agree among themselves (median reprojection, px)."""
    from tendrilkit.triangulation import triangulate

    V = len(cameras)
    errs, agree = np.full(V, np.inf), np.full(V, np.inf)
    for v in range(V):
        obs = np.array(points_xy, float)
        obs[v] = np.nan
        try:
            tri = triangulate(obs, cameras, refine=True)
        except (ValueError, np.linalg.LinAlgError):
            continue
        X = np.asarray(tri.points_mm, float)
        ok = np.all(np.isfinite(X), axis=1)
        if not ok.any():
            continue
        errs[v] = float(np.median(np.linalg.norm(cameras[v].project(X[ok]) - points_xy[v][ok], axis=1)))
        e = np.asarray(tri.reproj_err_px, float)
        agree[v] = float(np.nanmedian(np.delete(e, v, axis=0)[:, ok]))
    return errs, agree


def _tendril_at_base(img, m, exp) -> str:
    """Why no tendril is at the base point ('' if one is)."""
    import cv2

    from tendrilkit.exceptions import FrameError
    from tendrilkit.segmentation import segment_view

    from tendrilkit.options import stage_options

    try:
        s = segment_view(img, roi=m.roi, keep_out=m.keep_out, base_point_xy=m.base_point,
                         **stage_options(exp, "segmentation"))
    except FrameError as e:
        return f"no tendril in the roi ({e})"
    mask = s.mask_roi.astype(np.uint8)
    dt = cv2.distanceTransform(cv2.copyMakeBorder(mask, 1, 1, 1, 1, cv2.BORDER_CONSTANT, value=0), cv2.DIST_L2, 5)
    width = 2.0 * float(np.percentile(dt[dt > 0], 95)) if (dt > 0).any() else 0.0
    length = s.area_px / max(width, 1.0)
    ys, xs = np.nonzero(s.mask_roi)
    d = float(np.min(np.hypot(xs + s.roi_offset_xy[0] - m.base_point[0], ys + s.roi_offset_xy[1] - m.base_point[1])))
    reach = 4 * width + 10
    if m.keep_out is not None:
        reach = max(reach, 0.5 * float(np.hypot(m.keep_out[2], m.keep_out[3])) + 2 * width + 4)
    if d > reach:
        return (f"no tendril at base_point {list(m.base_point)}: the nearest component is {d:.0f} px away "
                f"(within {reach:.0f} px expected); put base_point where the tendril leaves the stem")
    if length < 8 * width:
        return (f"the component at base_point {list(m.base_point)} is not thin and long ({length:.0f} px long, "
                f"{width:.0f} px wide): a leaf, the stem or a marker? check base_point and keep_out")
    return ""


def _trial(exp, cameras, srcs, n_trial: int) -> list:
    from tendrilkit.pipeline import reconstruct_frame
    from tendrilkit.runner import _next_state, _read_views

    n = max(s.frame_count for s in srcs)
    fr = exp.frames
    stop = n if fr.stop is None else min(fr.stop, n)
    frames = list(range(fr.start, stop, fr.step))[:n_trial]
    state = [None] * len(cameras)
    parts, ok = [], True
    for f in frames:
        images, errors = _read_views(srcs, f)
        res = reconstruct_frame(images, cameras, exp, frame=f, prev_centroids=state, read_errors=errors, fit=False)
        state = _next_state(state, res)
        if res.status != "ok":
            ok = False
            parts.append(f"frame {f} {res.status}: {res.message}")
        else:
            means = [r["mean_px"] for r in res.reprojection if r.get("section") == "entire"]
            tol = float(exp.correspondence.max_distance_px)
            if means and max(means) > tol:
                ok = False
                parts.append(f"frame {f} reconstructed but reprojects {max(means):.1f} px off in its worst view "
                             f"(at most {tol:g} px expected): fix the calibration first")
            else:
                parts.append(f"frame {f} ok (reprojection {max(means):.1f} px worst view)" if means else f"frame {f} ok")
    return [_line(ok, "trial", "; ".join(parts) if parts else "no frame selected")]


def run_check(experiment_path: str | Path) -> tuple[int, str]:
    """``python -m tendrilkit check``: ``(exit code, report)``; 0 all OK, 1 some FAIL."""
    from tendrilkit.params import load_experiment

    exp = load_experiment(experiment_path, marks_optional=True)
    res = check_lines(exp)
    bad = sum(1 for ok, _ in res if not ok)
    tail = "all checks passed: run `python -m tendrilkit reconstruct`" if bad == 0 else f"{bad} check(s) failed"
    return (0 if bad == 0 else 1), "\n".join([line for _, line in res] + [tail])
