"""The authors' stored marker poses (``extrinsics: {format: ijcv25}``) and the paper's three-camera rig.

The stored files (``CamExtrPara_Corners*.csv``, one per view) are read by
:func:`tendrilkit.io.read_ijcv25_extrinsics`; the functions here take what it
returns. :func:`ijcv25_rig` is the rig of the paper: the intrinsics of
``tendrilkit/data/ijcv25_rig/intrinsics.yaml`` and the first stored pose of
each view, held here as numbers (tests/test_calibration.py checks them
against the files).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from tendrilkit.calibration.bundle import _reprojection_rows
from tendrilkit.calibration.rig import CalibrationResult, _marker_table
from tendrilkit.camera import Camera
from tendrilkit.geometry import marker_corners

__all__ = ["RIG_DIR", "calibration_from_ijcv25", "cameras_from_ijcv25", "ijcv25_rig"]

#: The stored files of the paper's rig (intrinsics.yaml, CamExtrPara_Corners{1,2,3}.csv, README.md).
RIG_DIR = Path(__file__).resolve().parent.parent / "data" / "ijcv25_rig"

# intrinsics.yaml: image size and (fx, fy, cx, cy) per view
_RIG_SIZE = (1920, 1080)
_RIG_INTRINSICS = (
    (1756.278855719401, 1755.414209871876, 981.9760611747568, 502.6336668977876),
    (1746.03418315378, 1743.897159523071, 989.7610371275571, 516.8615018982824),
    (1766.976985094071, 1763.953084472804, 980.5866647001145, 521.8461347969713),
)
# CamExtrPara_Corners{1,2,3}.csv, first row, columns 10-21: the stored translation (m, 3) and matrix (3 x 3,
# row-major), converted as tendrilkit.io.read_ijcv25_extrinsics does (R = matrix transposed, t_mm = -1000 t)
_RIG_STORED_POSES = (
    (-0.0372909809729585, 0.07543446270933231, -0.3447450413040325, 0.04469606566025397, 0.9989980324541833,
     -0.002278786335925459, 0.927238325536296, -0.040636319527659115, 0.3722603621014353, 0.3717947678103337,
     -0.018751551613574252, -0.9281255464326706),
    (-0.01921568285864925, 0.07381098858004073, -0.3607961372092236, 0.06304834759804667, 0.9964259358952461,
     0.0562161910879727, 0.9890455941136009, -0.06991580697554134, 0.13000227959321953, 0.13346804347719604,
     0.047403947201075915, -0.9899187578585058),
    (0.006217939313710566, 0.06980081027497981, -0.37133665271439387, 0.08367386792362086, 0.9964896474131356,
     -0.002658274843759051, 0.9869367648696793, -0.08323969511135587, -0.13793830253537193, -0.13767536444575593,
     0.008918282133519181, -0.9904372560987976),
)


def _row(table: dict[str, np.ndarray], frame: int | None, row: int = 0) -> int:
    """The row of a stored table: the one whose frame is ``frame`` if any, else ``row`` (clipped)."""
    r = min(row, len(table["frame"]) - 1)
    if frame is not None and np.any(table["frame"] == frame):
        r = int(np.flatnonzero(table["frame"] == frame)[0])
    return r


def cameras_from_ijcv25(tables: list[dict[str, np.ndarray]], intrinsics: list[Camera], *, row: int = 0,
                        frame: int | None = None) -> list[Camera]:
    """Cameras whose poses are the authors' stored marker poses (one table per view).

    Parameters
    ----------
    tables : list of dict
        Per view, what :func:`tendrilkit.io.read_ijcv25_extrinsics` returns
        (``frame`` (n,), ``marker_id`` (n,), ``corners_xy`` (n, 4, 2) px,
        ``R`` (n, 3, 3), ``t_mm`` (n, 3)).
    intrinsics : list of Camera
        One per view (poses ignored).
    row : int, keyword-only
        The stored row to use (0: the first); clipped to the table.
    frame : int, optional, keyword-only
        With it, the row whose stored frame index equals it, if any.

    Returns
    -------
    list of Camera
    """
    if len(tables) != len(intrinsics):
        raise ValueError(f"tables: expected one per camera ({len(intrinsics)}), got {len(tables)}")
    out = []
    for ext, cam in zip(tables, intrinsics):
        r = _row(ext, frame, row)
        out.append(cam.with_pose(ext["R"][r], ext["t_mm"][r]))
    return out


def calibration_from_ijcv25(tables: list[dict[str, np.ndarray]], intrinsics: list[Camera], *, frame: int,
                            length_mm: float) -> CalibrationResult:
    """The rig of the stored poses of ``frame`` (else the first row), with the stored corners' errors.

    ``markers`` holds the reprojection errors of each view's stored corners
    (stage ``single``); ``frame`` of the result is the stored frame used.
    """
    cams = cameras_from_ijcv25(tables, intrinsics, frame=frame)
    obs: dict[int, dict[int, np.ndarray]] = {}
    frame_used = None
    for v, ext in enumerate(tables):
        hit = np.flatnonzero(ext["frame"] == frame)
        r = int(hit[0]) if hit.size else 0
        frame_used = int(ext["frame"][r])
        obs[v] = {int(ext["marker_id"][r]): ext["corners_xy"][r]}
    mw = {mid: marker_corners(length_mm) for o in obs.values() for mid in o}
    rows = pd.DataFrame(_reprojection_rows(cams, obs, mw, "single"),
                        columns=["view", "marker_id", "stage", "mean_px", "max_px", "n_corners"])
    return CalibrationResult(cameras=cams, single_cameras=cams, markers=_marker_table(rows, mw),
                             observations=obs, markers_world=mw, frame=frame_used, source="ijcv25")


def ijcv25_rig() -> list[Camera]:
    """The real three-camera rig of the paper (intrinsics and first stored poses), no distortion.

    Examples
    --------
    >>> rig = ijcv25_rig()
    >>> len(rig), rig[0].width, rig[0].height
    (3, 1920, 1080)
    """
    w, h = _RIG_SIZE
    out = []
    for (fx, fy, cx, cy), stored in zip(_RIG_INTRINSICS, _RIG_STORED_POSES):
        cam = Camera(K=np.array([[fx, 0, cx], [0, fy, cy], [0, 0, 1.0]]), width=w, height=h)
        a = np.array(stored)
        out.append(cam.with_pose(a[3:12].reshape(3, 3).T, -a[0:3] * 1000.0))
    return out
