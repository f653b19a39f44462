"""Camera poses from ArUco markers, bundle adjustment, and the authors' stored poses.

Paper: "Experimental Setup" (markers on the panel define the world frame and
give the camera extrinsics); reference notes, stage 1.

The method in four steps:

1. :func:`detect_markers`: ArUco detection (OpenCV's class API) with the
   corners refined from the marker's edges: sub-pixel edge points along each
   side, undistorted, one straight line per side, corners where the lines
   meet; the black border's measured width removes the bias that a non-linear
   camera response puts on every edge (it would scale the whole rig); then
   (``refine="grid"``, the default, the experiment file's
   ``calibration.corner_refine``) one homography fitted to sub-pixel points
   on every black-white edge of the marker's cells, whose geometry the
   dictionary gives: a 7 x 7-cell marker has several times more edge than
   its four sides, and the corners it gives are the homography's. The rig is
   static, so with several frames per view (``calibration.average_frames``)
   each marker's corners are averaged over them (:func:`average_detections`).
2. :func:`marker_pose`: the world marker's pose in each view,
   ``cv2.solvePnP(..., SOLVEPNP_IPPE_SQUARE)`` with the lens distortion. This
   single-marker pose is what the paper uses as the camera pose.
3. :func:`bundle_adjust`: every other marker seen by two or more views is a
   square of unknown pose and side length; the camera poses and these squares
   are refined jointly on all corner observations, the world marker's corners
   held at :func:`tendrilkit.geometry.marker_corners` (which fixes the frame and the scale).
   Markers found to lie on the world marker's board are then held in its
   plane, which pins the world frame's tilt over the board's whole extent.
4. :func:`calibrate` (images) and :func:`calibrate_from_observations`
   (corners) compose them; :func:`calibrate_views` runs them on an
   experiment's first processed frames (read by the caller,
   :func:`tendrilkit.extrinsics.calibrate_experiment`), or takes the authors'
   stored poses (``extrinsics: ijcv25``, :mod:`.ijcv25`).

:func:`rig_agreement_px` measures a calibration against another (the truth of
a phantom) where it matters: on points of the tendril's working volume.
:func:`rig_uncertainty_px` predicts it from the calibration's own data (the
adjustment's covariance) and :func:`assess_rig` flags a view whose markers
cannot pin the rig to :data:`RIG_LIMIT_PX` there; :func:`calibrate_views`
assesses every rig from markers on the volume the marks span
(:func:`marks_volume`).

Why squares and not free 3D corners: a printed ArUco marker is a flat square,
so 7 unknowns (pose and side) instead of 12 describe it exactly; the four
corners then cannot absorb detection noise by bending the square, which both
tightens the camera poses and leaves a residual that says how well the
detections agree. The side is left free because the other markers need not be
printed at the world marker's size.

The sub-package does no I/O (the caller reads frames and files): ``markers``
(detection and corner refinement), ``poses`` (single-marker poses), ``bundle``
(bundle adjustment), ``rig`` (:class:`CalibrationResult`, :func:`calibrate`,
checks), ``ijcv25`` (the authors' stored poses and the paper's rig) and
``experiment`` (an experiment file's options applied to read frames);
``synthetic`` holds seeded scenes with exact truth for tests and benchmarks.
"""

from tendrilkit.calibration.bundle import BundleReport, bundle_adjust
from tendrilkit.calibration.experiment import calibrate_views, experiment_intrinsics, marks_volume
from tendrilkit.calibration.ijcv25 import RIG_DIR, calibration_from_ijcv25, cameras_from_ijcv25, ijcv25_rig
from tendrilkit.calibration.markers import REFINE_METHODS, average_detections, detect_markers
from tendrilkit.calibration.poses import marker_pose
from tendrilkit.calibration.rig import (
    MIN_BASELINE_FRACTION,
    RIG_FLOOR_PX,
    RIG_LIMIT_PX,
    RIG_LIMIT_SIGMAS,
    assess_rig,
    CalibrationResult,
    calibrate,
    calibrate_from_observations,
    check_calibration,
    corner_rms_px,
    rig_agreement_px,
    rig_uncertainty_px,
)

__all__ = [
    "MIN_BASELINE_FRACTION",
    "RIG_FLOOR_PX",
    "RIG_LIMIT_PX",
    "RIG_LIMIT_SIGMAS",
    "assess_rig",
    "average_detections",
    "marks_volume",
    "rig_uncertainty_px",
    "REFINE_METHODS",
    "RIG_DIR",
    "BundleReport",
    "CalibrationResult",
    "bundle_adjust",
    "calibrate",
    "calibrate_from_observations",
    "calibrate_views",
    "calibration_from_ijcv25",
    "cameras_from_ijcv25",
    "check_calibration",
    "corner_rms_px",
    "detect_markers",
    "experiment_intrinsics",
    "ijcv25_rig",
    "marker_pose",
    "rig_agreement_px",
]
