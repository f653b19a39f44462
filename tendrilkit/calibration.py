"""Camera poses from the world ArUco marker, and the authors' stored poses.

Paper: "Experimental Setup" (markers define the world frame); reference notes,
stage 1.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from tendrilkit.camera import Camera

RIG_DIR = Path(__file__).resolve().parent / "data" / "ijcv25_rig"


def marker_object_corners(length_mm: float) -> np.ndarray:
    """The world marker's corners (4, 3) mm, OpenCV ArUco order and frame.

    Top-left, top-right, bottom-right, bottom-left: ``(-L/2, L/2, 0), (L/2, L/2, 0),
    (L/2, -L/2, 0), (-L/2, -L/2, 0)``.
    """
    h = float(length_mm) / 2.0
    return np.array([[-h, h, 0.0], [h, h, 0.0], [h, -h, 0.0], [-h, -h, 0.0]])


def cameras_from_ijcv25(files: list[Path], intrinsics: list[Camera], *, row: int = 0) -> list[Camera]:
    """Cameras whose poses are the authors' stored marker poses (one file per view).

    ``row`` selects the stored video frame (0: the first row of each file).
    """
    from tendrilkit.io import read_ijcv25_extrinsics

    out = []
    for f, cam in zip(files, intrinsics):
        ext = read_ijcv25_extrinsics(f)
        r = min(row, len(ext["frame"]) - 1)
        out.append(cam.with_pose(ext["R"][r], ext["t_mm"][r]))
    return out


def ijcv25_rig() -> list[Camera]:
    """The real three-camera rig of the paper (intrinsics and first stored poses)."""
    from tendrilkit.io import read_ijcv25_intrinsics

    meta = read_ijcv25_intrinsics(RIG_DIR / "intrinsics.yaml")
    w, h = meta["image_size"]
    intr = [
        Camera(K=np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1.0]]), width=w, height=h)
        for c in meta["cameras"]
    ]
    files = [RIG_DIR / f"CamExtrPara_Corners{i + 1}.csv" for i in range(len(intr))]
    return cameras_from_ijcv25(files, intr)
