"""Checks of an experiment against its videos, before anything is computed.

:func:`check_inputs` runs when ``reconstruct`` or ``calibrate`` opens the
videos; each mistake is one :class:`~tendrilkit.exceptions.ExperimentError`
line naming the view, the key, the value and what was expected (exit code 2):

- the intrinsics against the image size (principal point inside and near the
  centre, a plausible focal length; :func:`tendrilkit.params.check_against_images`),
- the marks against the image size and each other (base point inside the
  ROI, keep-out box overlapping the ROI at the base point without covering it),
- the marks against the first processed frame (:func:`check_marks_on_frame`):
  the base point must be on, or next to, a dark structure (stem or tendril),
- the videos' own frame rates against ``fps`` (:func:`check_video_fps`: a
  warning, not an error).
"""

from __future__ import annotations

import warnings

import numpy as np

from tendrilkit.exceptions import ExperimentError, FrameError, TendrilLostError
from tendrilkit.params import check_against_images, stage_options
from tendrilkit.segmentation import segment_view

__all__ = ["check_inputs", "check_marks_on_frame", "check_video_fps"]

#: A base point further than this from any dark structure (plus half the keep-out box's diagonal) is on the background.
BASE_POINT_REACH_PX = 10.0
#: A declared fps below this fraction of the container's is a time-lapse (the container's rate is for playback).
TIME_LAPSE_RATIO = 0.1


def check_inputs(exp, sources, *, marks_on_frame: bool = True) -> None:
    """Every check of the module docstring, on the opened frame sources (view order).

    Parameters
    ----------
    exp : tendrilkit.params.Experiment
    sources : list of tendrilkit.io.FrameSource
        The views, opened (``width``, ``height``, ``fps``, ``read``).
    marks_on_frame : bool, keyword-only
        Also check the marks against the first frame's content
        (``reconstruct``; ``calibrate`` does not use the marks).

    Raises
    ------
    ExperimentError
        The first mistake found, in one line.
    """
    check_against_images(exp, [(s.width, s.height) for s in sources])
    check_video_fps(exp, [s.fps for s in sources])
    if not marks_on_frame:
        return
    images = []
    for s in sources:
        try:
            images.append(s.read(exp.frames.start))
        except FrameError:
            images.append(None)  # the calibration (or the frame) reports it
    check_marks_on_frame(exp, images)


def check_video_fps(exp, container_fps: list[float | None]) -> None:
    """Warn when a video's container frame rate disagrees with the experiment's ``fps``.

    Times (``time_s``) always use the experiment's ``fps``. A rate within 1 %
    is the same; an experiment ``fps`` below a tenth of the container's is a
    time-lapse (the container's rate is for playback) and is not warned about.
    """
    for i, (path, fps) in enumerate(zip(exp.videos, container_fps)):
        if fps is None or not np.isfinite(fps) or fps <= 0:
            continue
        ratio = exp.fps / fps
        if abs(ratio - 1.0) > 0.01 and ratio >= TIME_LAPSE_RATIO:
            warnings.warn(f"videos[{i}]: {path.name} is stored at {fps:g} fps but the experiment file says fps: "
                          f"{exp.fps:g}; time_s uses {exp.fps:g}", stacklevel=2)


def check_marks_on_frame(exp, images: list[np.ndarray | None]) -> None:
    """Check each view's base point against the first processed frame.

    The ROI is segmented as :func:`tendrilkit.segmentation.segment_view` does
    (the experiment's ``segmentation`` options) but without the keep-out box,
    so that the stem counts: the base point must lie within
    :data:`BASE_POINT_REACH_PX` (plus half the keep-out box's diagonal) of a
    dark structure. A base point on the background would make the
    segmentation pick whatever lies nearest (a speck, a marker) as the tendril.

    Parameters
    ----------
    exp : tendrilkit.params.Experiment
    images : list of (H, W, 3) uint8 arrays or None
        The first processed frame of every view (None: not checked).

    Raises
    ------
    ExperimentError
        ``views[i].base_point: [x, y] is on the background of frame f ...``.
    """
    where = f"{exp.source}: " if exp.source is not None else ""
    seg = exp.segmentation
    for i, (marks, img) in enumerate(zip(exp.views, images)):
        if img is None:
            continue
        bp = np.asarray(marks.base_point, float)
        try:
            s = segment_view(img, roi=marks.roi, keep_out=None, base_point_xy=bp,
                             **{**stage_options(exp, "segmentation"), "opening_radius_px": 0})
        except TendrilLostError:
            raise ExperimentError(
                f"{where}views[{i}].roi: {list(marks.roi)} holds no dark structure in frame {exp.frames.start} of "
                f"view {marks.view} (segmentation channel {seg.channel!r}, threshold {seg.threshold!r}); expected the "
                f"tendril and its stem inside it") from None
        rows, cols = np.nonzero(s.mask_roi)
        d = float(np.hypot(cols + s.roi_offset_xy[0] - bp[0], rows + s.roi_offset_xy[1] - bp[1]).min())
        reach = BASE_POINT_REACH_PX
        if marks.keep_out is not None:
            reach += 0.5 * float(np.hypot(marks.keep_out[2], marks.keep_out[3]))
        if d > reach:
            raise ExperimentError(
                f"{where}views[{i}].base_point: {[round(float(c), 1) for c in bp]} is on the background of frame "
                f"{exp.frames.start} of view {marks.view} (the nearest dark structure is {d:.0f} px away); expected "
                f"the point where the tendril leaves the stem (within {reach:.0f} px)")
