"""An experiment file's calibration options applied to frames and stored poses the caller has read.

:func:`tendrilkit.extrinsics.calibrate_experiment` reads the videos' first
processed frame (or the ``extrinsics`` files) and calls :func:`calibrate_views`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from tendrilkit.calibration.ijcv25 import calibration_from_ijcv25
from tendrilkit.calibration.bundle import _triangulate
from tendrilkit.calibration.rig import CalibrationResult, assess_rig, calibrate, check_calibration
from tendrilkit.camera import Camera

if TYPE_CHECKING:  # only for type hints: algorithm code never needs params
    from tendrilkit.params import Experiment

__all__ = ["calibrate_views", "experiment_intrinsics", "marks_volume"]


def experiment_intrinsics(exp: "Experiment", image_sizes: list[tuple[int, int]]) -> list[Camera]:
    """The experiment's cameras (K, dist; no pose) with each view's image size ``(width, height)`` px."""
    if len(image_sizes) != len(exp.cameras):
        raise ValueError(f"image_sizes: expected one per camera ({len(exp.cameras)}), got {len(image_sizes)}")
    cams = []
    for c, (w, h) in zip(exp.cameras, image_sizes):
        K = np.array([[c.fx, 0.0, c.cx], [0.0, c.fy, c.cy], [0.0, 0.0, 1.0]])
        cams.append(Camera(K=K, dist=np.asarray(c.dist, float), width=w, height=h))
    return cams


def calibrate_views(exp: "Experiment", *, image_sizes: list[tuple[int, int]], images: list | None = None,
                    extrinsics: list[dict[str, np.ndarray]] | None = None) -> CalibrationResult:
    """The rig of an experiment: from its stored poses, else from the markers of its first processed frame.

    With ``extrinsics: {format: ijcv25}`` (``extrinsics``: the files' tables,
    :func:`tendrilkit.io.read_ijcv25_extrinsics`) the stored poses of the row
    whose frame is ``frames.start`` (else the first row) are used
    (:func:`~tendrilkit.calibration.ijcv25.calibration_from_ijcv25`).
    Otherwise ``images`` (per view, frame ``frames.start``, BGR, or a list of
    it and the frames after it: ``calibration.average_frames``) go through
    :func:`~tendrilkit.calibration.rig.calibrate` with the experiment's
    ``marker``, ``calibration.bundle_adjust`` and ``calibration.corner_refine``.

    The result is then checked (:func:`check_calibration`): every view's
    marker corners must reproject within ``calibration.max_corner_rms_px``
    (unless ``null``) and no two cameras may sit at the same place. A rig
    from markers is then assessed on the volume the marks span
    (:func:`marks_volume`, :func:`~tendrilkit.calibration.rig.assess_rig`):
    a view it cannot pin to :data:`~tendrilkit.calibration.rig.RIG_LIMIT_PX`
    there is flagged (``result.flags``, a warning, the summary).

    Raises
    ------
    ExperimentError
        A view does not show the world marker, or the calibration failed its checks.
    """
    intr = experiment_intrinsics(exp, image_sizes)
    start = exp.frames.start
    if exp.extrinsics is not None:
        if extrinsics is None:
            raise ValueError("extrinsics: the experiment names stored poses (extrinsics:); pass their tables")
        result = calibration_from_ijcv25(extrinsics, intr, frame=start, length_mm=exp.marker.length_mm)
    else:
        if images is None:
            raise ValueError("images: expected frame frames.start (or a list of frames) of every view to calibrate from the markers")
        result = calibrate(images, intr, dictionary=exp.marker.dictionary, world_id=exp.marker.id,
                           length_mm=exp.marker.length_mm, bundle_adjust=exp.calibration.bundle_adjust, frame=start,
                           refine=exp.calibration.corner_refine)
    check_calibration(result, max_corner_rms_px=exp.calibration.max_corner_rms_px)
    if result.source != "ijcv25":
        volume = marks_volume(result.cameras, [m.base_point for m in exp.views], [m.roi for m in exp.views])
        result = assess_rig(result, volume, world_id=exp.marker.id, length_mm=exp.marker.length_mm)
    return result


def marks_volume(cameras: list[Camera], base_points_xy: list, rois: list, *, n: int = 13) -> np.ndarray:
    """Points (m, 3) mm where the tendril can be, from a user's marks on frame 0: the ROIs' visual hull.

    A cube of ``n^3`` points around the base point (``base_point`` of every
    view that has one, triangulated; without two, the world marker's origin),
    its half-side the largest ROI's half-diagonal in mm at the base's depth
    (``roi`` ``[x, y, w, h]`` px; 100 mm without ROIs); kept: the points in
    front of the board (``z >= 0``) that every view with a ROI sees inside
    it. Without any, the cube's centre.
    """
    obs = [None if b is None else np.asarray(b, float).reshape(1, 2) for b in base_points_xy]
    centre = np.zeros(3)
    if sum(o is not None for o in obs) >= 2:
        X = _triangulate(cameras, obs)[0]
        if np.all(np.isfinite(X)):
            centre = X
    half = []
    for cam, roi in zip(cameras, rois):
        if roi is None:
            continue
        depth = float((cam.R @ centre + cam.t_mm)[2])
        half.append(0.5 * np.hypot(roi[2], roi[3]) * depth / float(cam.K[0, 0]))
    h = max(half) if half else 100.0
    g = np.linspace(-1.0, 1.0, n)
    P = centre + h * np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    keep = P[:, 2] >= 0.0
    for cam, roi in zip(cameras, rois):
        if roi is None:
            continue
        xy = cam.project(P)
        keep &= ((xy[:, 0] >= roi[0]) & (xy[:, 0] <= roi[0] + roi[2]) & (xy[:, 1] >= roi[1])
                 & (xy[:, 1] <= roi[1] + roi[3]))
    return P[keep] if keep.any() else centre[None]
