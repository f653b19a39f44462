"""The calibrated rig: :class:`CalibrationResult`, :func:`calibrate` composing detection, poses and bundle
adjustment, and the checks that refuse a calibration that cannot be right."""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from tendrilkit.calibration import bundle
from tendrilkit.calibration.bundle import BundleReport, _reprojection_rows
from tendrilkit.calibration.markers import average_detections, corner_sigma_px, detect_markers
from tendrilkit.calibration.poses import _choose_world_poses
from tendrilkit.camera import Camera, rotation_from_rvec
from tendrilkit.exceptions import ExperimentError
from tendrilkit.geometry import marker_corners

__all__ = ["MIN_BASELINE_FRACTION", "CalibrationResult", "calibrate", "calibrate_from_observations",
           "check_calibration", "corner_rms_px", "rig_agreement_px", "rig_uncertainty_px",
           "assess_rig", "RIG_FLOOR_PX", "RIG_LIMIT_PX", "RIG_LIMIT_SIGMAS"]


@dataclass(frozen=True, eq=False)
class CalibrationResult:
    """The calibrated rig of one experiment.

    Attributes
    ----------
    cameras : list of Camera
        Final cameras in view order (adjusted if bundle adjustment ran).
    single_cameras : list of Camera
        The single-marker (paper) poses.
    markers : pandas.DataFrame
        Corner reprojection errors, one row per (view, marker, stage):
        ``view`` (1-based), ``marker_id``, ``stage`` (``single`` | ``adjusted``),
        ``mean_px``, ``max_px``, ``n_corners``, and the marker's estimated
        geometry ``x_mm``, ``y_mm``, ``z_mm`` (centre, world) and ``length_mm``
        (NaN for a marker seen by one view only), sorted by stage, view, marker.
    observations : dict
        ``{view_index (0-based): {marker_id: corners (4, 2) px}}`` as detected.
    markers_world : dict[int, (4, 3) float array]
        Corners of every marker in the adjustment, world mm.
    frame : int or None
        The video frame the calibration comes from.
    source : str
        ``markers`` (detection, single marker), ``bundle`` (detection and
        bundle adjustment) or ``ijcv25`` (the authors' stored poses).
    bundle : BundleReport or None
        The adjustment's report (markers on the board plane, dropped
        observations, residuals) when it ran.
    uncertainty_px : (n_views,) float array or None
        The rig's spread on the working volume, px (:func:`assess_rig`), when assessed.
    flags : tuple of str
        One line per view the markers cannot pin to :data:`RIG_LIMIT_PX` on
        the working volume (:func:`assess_rig`): use such a rig knowing it.
    """

    cameras: list[Camera]
    single_cameras: list[Camera]
    markers: pd.DataFrame
    observations: dict[int, dict[int, np.ndarray]]
    markers_world: dict[int, np.ndarray]
    frame: int | None = None
    source: str = "markers"
    bundle: BundleReport | None = None
    uncertainty_px: np.ndarray | None = None
    flags: tuple[str, ...] = ()

    def view_quality(self) -> list[dict]:
        """Per view, the rig's assessment as ``cameras.json`` records it (README, "Result files").

        ``rig_spread_px``: the rig's 1-sigma spread on the marks' volume, px
        (None when not assessed: stored poses); ``rig_flagged``: the view is
        one of :attr:`flags` (its markers cannot pin the rig to
        :data:`RIG_LIMIT_PX` there).
        """
        u = self.uncertainty_px
        return [{"rig_spread_px": None if u is None or not np.isfinite(u[v]) else round(float(u[v]), 4),
                 "rig_flagged": u is not None and _pins_too_loosely(u[v])} for v in range(len(self.cameras))]

    def summary(self) -> str:
        """Per view: markers seen, mean corner error single -> adjusted."""
        t = self.markers
        lines = []
        for v in range(1, len(self.cameras) + 1):
            seen = len(self.observations.get(v - 1, {}))
            s = t[(t.view == v) & (t.stage == "single")]
            a = t[(t.view == v) & (t.stage == "adjusted")]
            used = len(a) if len(a) else len(s)
            line = f"view {v}: {seen} marker(s) seen, {used} used; corner error "
            if len(s):
                line += f"mean {_wmean(s):.3f} px (max {s.max_px.max():.3f})"
            if len(a):
                line += f" -> {_wmean(a):.3f} px (max {a.max_px.max():.3f}) after bundle adjustment"
            lines.append(line)
        if self.bundle is not None:
            b = self.bundle
            extra = f"adjusted markers: {', '.join(str(m) for m in sorted(b.markers_world))}"
            if b.on_plane:
                extra += f"; on the world marker's plane: {', '.join(str(m) for m in b.on_plane)}"
            if b.dropped:
                extra += "; dropped: " + ", ".join(f"view {v} marker {m}" for v, m in b.dropped)
            lines.append(extra + f"; rms {b.rms_before_px:.3f} -> {b.rms_after_px:.3f} px")
            if not b.converged:
                lines.append("the bundle adjustment did not converge: the single-marker poses are kept")
        if self.uncertainty_px is not None:
            lines.append("rig spread on the marks' volume (1 sigma, px): "
                         + ", ".join(f"view {v + 1} {u:.2f}" for v, u in enumerate(self.uncertainty_px)))
        lines += [f"FLAGGED: {f}" for f in self.flags]
        return "\n".join(lines)


def _wmean(rows: pd.DataFrame) -> float:
    return float((rows.mean_px * rows.n_corners).sum() / rows.n_corners.sum())


def _marker_table(rows: pd.DataFrame, markers_world: dict[int, np.ndarray],
                  markers_world_single: dict[int, np.ndarray] | None = None) -> pd.DataFrame:
    """The reprojection rows with each marker's centre and side (per stage)."""
    def geo(X):
        return (*X.mean(0), float(np.mean(np.linalg.norm(np.roll(X, -1, 0) - X, axis=1))))

    by_stage = {"adjusted": {m: geo(X) for m, X in markers_world.items()},
                "single": {m: geo(X) for m, X in (markers_world_single or markers_world).items()}}
    t = rows.copy()
    for j, col in enumerate(("x_mm", "y_mm", "z_mm", "length_mm")):
        t[col] = [by_stage[st][m][j] if m in by_stage[st] else np.nan for st, m in zip(t.stage, t.marker_id)]
    order = {"single": 0, "adjusted": 1}
    t = t.assign(_o=t.stage.map(order)).sort_values(["_o", "view", "marker_id"]).drop(columns="_o")
    return t.reset_index(drop=True)


def calibrate(images: list, intrinsics: list[Camera], *, dictionary: str, world_id: int,
              length_mm: float, bundle_adjust: bool = True, frame: int = 0,
              refine: str = "grid") -> CalibrationResult:
    """Camera poses from the markers in one or several frames of every view.

    The world marker's single-marker pose (:func:`marker_pose`) is each camera's
    initial pose, as in the paper; with ``bundle_adjust`` the rig is then
    refined with every marker two or more views see (:func:`bundle_adjust`).
    With several frames per view (the rig is static), each view's corners are
    the mean over the frames (:func:`~tendrilkit.calibration.markers.average_detections`),
    and a marker any frame shows is used.

    Parameters
    ----------
    images : list
        Per view, in view order: one BGR frame, a (height, width, 3) uint8
        array, or a list of such frames of the static rig.
    intrinsics : list of Camera
        One per view (K, dist, image size; poses ignored).
    dictionary, world_id, length_mm
        The world marker (experiment file's ``marker:``).
    bundle_adjust : bool, keyword-only
        Refine with the other markers (default True).
    frame : int, keyword-only
        The (first) frame's index in the videos, for messages only.
    refine : str, keyword-only
        Corner refinement of :func:`~tendrilkit.calibration.markers.detect_markers` (default ``grid``).

    Raises
    ------
    ExperimentError
        When a view does not show the world marker:
        ``view 2: world marker 815 (DICT_ARUCO_ORIGINAL) not found in frame 0``
        (``in any of 5 frames from frame 0`` for several).
    """
    if len(images) != len(intrinsics):
        raise ValueError(f"images: expected one per camera ({len(intrinsics)}), got {len(images)}")
    if len(images) < 1:
        raise ValueError("images: expected at least one view")
    observations: dict[int, dict[int, np.ndarray]] = {}
    for v, (img, cam) in enumerate(zip(images, intrinsics)):
        frames = list(img) if isinstance(img, (list, tuple)) else [img]
        if not frames:
            raise ValueError(f"images: expected at least one frame of view {v + 1}")
        observations[v] = average_detections([detect_markers(f, dictionary, refine=refine, camera=cam)
                                              for f in frames])
        if world_id not in observations[v]:
            where = f"frame {frame}" if len(frames) == 1 else f"any of {len(frames)} frames from frame {frame}"
            raise ExperimentError(f"view {v + 1}: world marker {world_id} ({dictionary}) not found in {where}")
    return calibrate_from_observations(observations, intrinsics, world_id=world_id, length_mm=length_mm,
                                       bundle_adjust=bundle_adjust, frame=frame)


def calibrate_from_observations(observations: dict[int, dict[int, np.ndarray]], intrinsics: list[Camera], *,
                                world_id: int, length_mm: float, bundle_adjust: bool = True,
                                frame: int | None = None, dictionary: str = "") -> CalibrationResult:
    """:func:`calibrate` from already detected corners ``{view_index: {id: (4, 2)}}``."""
    for v in range(len(intrinsics)):
        if world_id not in observations.get(v, {}):
            what = f" ({dictionary})" if dictionary else ""
            raise ExperimentError(f"view {v + 1}: world marker {world_id}{what} not found in frame {frame}")
    single = _choose_world_poses(observations, intrinsics, world_id, length_mm)
    W = marker_corners(length_mm)
    shared = [m for m in set().union(*[set(o) for o in observations.values()]) - {world_id}
              if sum(m in o for o in observations.values()) >= 2]
    if bundle_adjust and shared:
        cams, rep = bundle.bundle_adjust(single, observations, world_id=world_id, length_mm=length_mm)
        table = _marker_table(rep.table, rep.markers_world, rep.markers_world_single)
        return CalibrationResult(cameras=cams, single_cameras=single, markers=table, observations=observations,
                                 markers_world=rep.markers_world, frame=frame, source="bundle", bundle=rep)
    if bundle_adjust and len(intrinsics) > 1:
        warnings.warn("bundle adjustment skipped: no marker other than the world marker is seen by two views",
                      stacklevel=2)
    rows = pd.DataFrame(_reprojection_rows(single, observations, {world_id: W}, "single"),
                        columns=["view", "marker_id", "stage", "mean_px", "max_px", "n_corners"])
    return CalibrationResult(cameras=single, single_cameras=single, markers=_marker_table(rows, {world_id: W}),
                             observations=observations, markers_world={world_id: W}, frame=frame, source="markers")


def rig_agreement_px(cameras_a: list[Camera], cameras_b: list[Camera], points_world: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How far apart two rigs put the same world points, per view.

    Parameters
    ----------
    cameras_a, cameras_b : list of Camera
        Two calibrations of the same views (e.g. estimated and true).
    points_world : (n, 3) float array
        World points, mm (e.g. the tendril's working volume); NaN rows ignored.

    Returns
    -------
    max_px, mean_px : (n_views,) float arrays
        Largest and mean distance between the two projections of the points.
    """
    if len(cameras_a) != len(cameras_b):
        raise ValueError(f"cameras_b: expected {len(cameras_a)} cameras like cameras_a, got {len(cameras_b)}")
    X = np.asarray(points_world, float).reshape(-1, 3)
    X = X[np.all(np.isfinite(X), axis=1)]
    if len(X) == 0:
        raise ValueError("points_world: expected at least one finite point")
    d = np.array([np.linalg.norm(a.project(X) - b.project(X), axis=1) for a, b in zip(cameras_a, cameras_b)])
    return d.max(axis=1), d.mean(axis=1)


def _pose_jacobian(cam: Camera, X: np.ndarray) -> np.ndarray:
    """Jacobian (n, 2, 6) of the pixels of world points (n, 3) with respect to the camera's pose
    (Rodrigues vector, translation mm), central differences through the lens distortion."""
    p0 = np.r_[cam.rvec, cam.t_mm]
    J = np.empty((len(X), 2, 6))
    for i in range(6):
        h = 1e-6 if i < 3 else 1e-3
        e = np.zeros(6)
        e[i] = h
        a = cam.with_pose(rotation_from_rvec(p0[:3] + e[:3]), p0[3:] + e[3:]).project(X)
        b = cam.with_pose(rotation_from_rvec(p0[:3] - e[:3]), p0[3:] - e[3:]).project(X)
        J[:, :, i] = (a - b) / (2 * h)
    return J


def _single_covariance(result: "CalibrationResult", world_id: int, length_mm: float) -> tuple[float, np.ndarray]:
    """The world marker's corners alone: noise (px) from their residual (2 degrees of freedom per
    view), at least the detector's (:func:`~tendrilkit.calibration.markers.corner_sigma_px`, root mean
    square over the views), and each view's pose covariance (n_views, 6, 6)."""
    W = marker_corners(length_mm)
    res, Js, floor = [], [], []
    for v, cam in enumerate(result.cameras):
        res.append(cam.project(W) - result.observations[v][world_id])
        Js.append(_pose_jacobian(cam, W).reshape(-1, 6))
        floor.append(corner_sigma_px(result.observations[v][world_id]))
    r = np.concatenate(res).ravel()
    sigma = max(float(np.sqrt(np.mean(np.square(floor)))),
                float(np.sqrt(np.sum(r ** 2) / max(1, len(r) - 6 * len(Js)))))
    cov = []
    for J in Js:
        JtJ = J.T @ J
        cov.append(np.linalg.inv(JtJ) * sigma ** 2 if np.linalg.cond(JtJ) < 1e14 else np.full((6, 6), np.inf))
    return sigma, np.array(cov)


def rig_uncertainty_px(result: "CalibrationResult", points_world: np.ndarray, *, world_id: int | None = None,
                       length_mm: float | None = None) -> np.ndarray:
    """How far each view may put the given world points, from the calibration's own data, pixels.

    Per view, the largest over the points of the root-mean-square displacement
    of a point's projection that the camera pose's covariance implies (first
    order): from the bundle adjustment (:attr:`BundleReport.camera_cov`), else
    from the world marker's four corners alone (``world_id`` and ``length_mm``
    needed). It is the rig's one-sigma spread: a rig whose markers are few,
    small and far from the points shows a large value. The corner noise behind
    it is never below the detector's measured one
    (:func:`~tendrilkit.calibration.markers.corner_sigma_px`).

    Measured on random dev scenes (``bench_calibration.py scenes``, seeds
    0-69): the rig's true worst error on the tendril over this spread on the
    marks' volume, per view, has a median 0.81, 90th percentile 1.52, max 2.56
    (before the noise floor and per-marker noise: 0.94, 1.81, 3.47); with
    corners drawn from the noise model itself (the first-order covariance
    exact but for its linearisation) 0.81, 1.41, 2.02.

    Parameters
    ----------
    result : CalibrationResult
    points_world : (n, 3) float array
        The working volume, mm (NaN rows ignored).

    Returns
    -------
    (n_views,) float array
        Infinite for a view whose pose the markers do not determine; NaN when
        there is nothing to assess (stored poses, or a failed adjustment).
    """
    X = np.asarray(points_world, float).reshape(-1, 3)
    X = X[np.all(np.isfinite(X), axis=1)]
    if len(X) == 0:
        raise ValueError("points_world: expected at least one finite point")
    if result.bundle is not None:
        cov = result.bundle.camera_cov
    elif result.source == "markers" and world_id is not None and length_mm is not None:
        _, cov = _single_covariance(result, world_id, length_mm)
    else:
        cov = None
    if cov is None:
        return np.full(len(result.cameras), np.nan)
    out = []
    for cam, C in zip(result.cameras, cov):
        if not np.all(np.isfinite(C)):
            out.append(np.inf)
            continue
        J = _pose_jacobian(cam, X)
        out.append(float(np.sqrt(np.einsum("nij,jk,nik->n", J, C, J)).max()))
    return np.array(out)


#: The rig must map the working volume within this many px of the truth (issue 11) ...
RIG_LIMIT_PX = 0.5
#: ... bounded by this many sigmas of :func:`rig_uncertainty_px` over the marks' volume ...
RIG_LIMIT_SIGMAS = 2.0
#: ... plus this much (px) that no covariance shows: a view is flagged when
#: ``RIG_LIMIT_SIGMAS * spread + RIG_FLOOR_PX > RIG_LIMIT_PX`` (spread over 0.225 px). The rig's true worst
#: error on the tendril against its spread on the marks' volume (per view, ``bench_calibration.py scenes``,
#: grid x 5, dev seeds 3000-3039 and 4000-4039, 240 views, none over 0.5 px): the ratio true / spread reaches
#: 2.5, but only where the spread is small (max 2.5 under 0.1 px, 2.0 at 0.1-0.15, 1.47 at 0.15-0.2, 1.04
#: over 0.2): an error of a few hundredths of a pixel the corners' noise does not explain (their bias on
#: the rendered markers), not a spread too small by half. ``2 * spread`` alone was exceeded by 6 views (by
#: up to 0.03 px; a bound of 2.6 sigmas, exceeded by none, would flag 18 views instead of 11, all within
#: 0.5 px); ``2 * spread + 0.05`` by none, flagging 13 (all within 0.5 px; the worst unflagged 0.22 px).
#: Checked afterwards on dev seeds 0-39 (120 views, none over 0.5 px): ``2 * spread`` exceeded once (by 0.04
#: px, ratio 2.67 at a spread of 0.06), ``2.6 * spread`` once, ``2 * spread + 0.05`` never; 11 views flagged
#: (8 before). Site phantom S2 (spread 0.17-0.19 px, true 0.08-0.21 px) stays unflagged.
RIG_FLOOR_PX = 0.05


def _rig_bound_px(spread_px: float) -> float:
    """How far (px) a view whose rig spread (1 sigma) is ``spread_px`` may be off: ``RIG_LIMIT_SIGMAS *
    spread_px + RIG_FLOOR_PX``."""
    return RIG_LIMIT_SIGMAS * spread_px + RIG_FLOOR_PX


def _pins_too_loosely(spread_px: float) -> bool:
    """A view's rig spread (1 sigma, px) that :func:`assess_rig` flags: its bound (:func:`_rig_bound_px`) over
    :data:`RIG_LIMIT_PX`, or infinite (the markers do not constrain it); NaN (not assessed) is not."""
    return not np.isnan(spread_px) and not (_rig_bound_px(spread_px) <= RIG_LIMIT_PX)


def assess_rig(result: CalibrationResult, points_world: np.ndarray, *, world_id: int | None = None,
               length_mm: float | None = None) -> CalibrationResult:
    """The result with its spread on a working volume and a flag per view that the markers cannot pin.

    A view is flagged when :data:`RIG_LIMIT_SIGMAS` times its
    :func:`rig_uncertainty_px`, plus :data:`RIG_FLOOR_PX`, exceeds :data:`RIG_LIMIT_PX` (with a warning):
    its markers are too few, too small or too far from the volume for the rig
    to be trusted to half a pixel there. Returns a new result (``uncertainty_px``, ``flags``).
    """
    import dataclasses

    u = rig_uncertainty_px(result, points_world, world_id=world_id, length_mm=length_mm)
    flags = []
    for v, x in enumerate(u):
        if not _pins_too_loosely(x):
            continue
        seen = len(result.observations.get(v, {}))
        flags.append(f"view {v + 1}: the markers ({seen} seen) pin the rig only to "
                     f"{RIG_LIMIT_SIGMAS:g} x {x:.2f} + {RIG_FLOOR_PX:g} px on the working volume (limit {RIG_LIMIT_PX:g} px): "
                     "it needs more or larger markers near the tendril, seen by two or more views")
    if flags:
        warnings.warn("calibration: " + "; ".join(flags), stacklevel=2)
    return dataclasses.replace(result, uncertainty_px=u, flags=tuple(flags))


#: Two cameras closer than this fraction of their distance to the world marker cannot triangulate.
MIN_BASELINE_FRACTION = 0.02


def corner_rms_px(result: CalibrationResult) -> dict[int, float]:
    """Per view (1-based), the corner reprojection error of the final rig, pixels: the root mean
    square, over the markers, of each marker's mean corner error.

    Over every marker the view sees (the ``adjusted`` rows of
    :attr:`CalibrationResult.markers` when the bundle adjustment ran, else the
    ``single`` rows), dropped observations included.
    """
    t = result.markers
    stage = "adjusted" if (t.stage == "adjusted").any() else "single"
    t = t[t.stage == stage]
    out = {}
    for v, g in t.groupby("view"):
        # mean_px is a mean of distances: rms >= mean; the mean of the squares is bounded by max_px^2
        n = g.n_corners.to_numpy(float)
        out[int(v)] = float(np.sqrt((np.asarray(g.mean_px, float) ** 2 * n).sum() / n.sum()))
    return out


def check_calibration(result: CalibrationResult, *, max_corner_rms_px: float | None = 1.5) -> None:
    """Refuse a calibration that cannot be right.

    - A view whose marker corners reproject further than ``max_corner_rms_px``
      (:func:`corner_rms_px`): wrong intrinsics, intrinsics of another image
      size, a moved camera... (``None``: not checked; a warning is given).
    - Two cameras at the same place (closer than :data:`MIN_BASELINE_FRACTION`
      of their distance to the world marker): the same video given for two
      views; nothing can be triangulated.

    Raises
    ------
    ExperimentError
        ``calibration failed: view 1: marker corners reproject 6.27 px rms ...``
    """
    cams = result.cameras
    C = np.array([c.center_world for c in cams])
    depth = np.linalg.norm(C, axis=1)
    for i in range(len(cams)):
        for j in range(i):
            base = float(np.linalg.norm(C[i] - C[j]))
            if not base >= MIN_BASELINE_FRACTION * max(float(min(depth[i], depth[j])), 1e-9):
                raise ExperimentError(
                    f"calibration failed: views {j + 1} and {i + 1} are {base:.1f} mm apart at {depth[i]:.0f} mm from "
                    f"the world marker (at least {100 * MIN_BASELINE_FRACTION:g} % of it needed to triangulate); "
                    f"the same video given for two views?")
    rms = corner_rms_px(result)
    bad = {v: r for v, r in rms.items() if max_corner_rms_px is not None and not r <= max_corner_rms_px}
    if bad:
        v, r = max(bad.items(), key=lambda kv: kv[1])
        why = ""
        # a view whose intrinsics are wrong spreads its error over the others through the shared markers; the
        # adjustment tells which view disagrees: the one whose markers it dropped (when they are all one view's)
        dropped = {w for w, _ in result.bundle.dropped} if result.bundle is not None else set()
        if len(dropped) == 1 and next(iter(dropped)) in bad:
            v = next(iter(dropped))
            r = bad[v]
            why = "; the bundle adjustment dropped its markers as disagreeing with the other views"
        others = ", ".join(f"view {w}: {x:.2f} px" for w, x in sorted(bad.items()) if w != v)
        raise ExperimentError(
            f"calibration failed: view {v}: marker corners reproject {r:.2f} px off{why} (rms over markers; limit "
            f"calibration.max_corner_rms_px = {max_corner_rms_px:g} px{'; also ' + others if others else ''}); "
            f"check view {v}'s intrinsics (fx, fy, cx, cy, dist) and image size, or pass --accept-calibration")
    if max_corner_rms_px is None and rms:
        v, r = max(rms.items(), key=lambda kv: kv[1])
        if r > 1.5:
            warnings.warn(f"calibration accepted although view {v}'s marker corners reproject {r:.2f} px rms",
                          stacklevel=2)
