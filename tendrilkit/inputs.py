"""Checks of an experiment against its videos, before anything is computed.

:func:`check_inputs` runs when ``reconstruct`` or ``calibrate`` opens the
videos; each mistake is one :class:`~tendrilkit.exceptions.ExperimentError`
line naming the view, the key, the value and what was expected (exit code 2):

- the intrinsics against the image size (principal point inside and near the
  centre, a plausible focal length; :func:`check_against_images`),
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

from tendrilkit import limits as L
from tendrilkit.exceptions import ExperimentError, FrameError, TendrilLostError
from tendrilkit.options import stage_options
from tendrilkit.segmentation import segment_view

__all__ = ["check_against_images", "check_inputs", "check_marks_on_frame", "check_video_fps"]

#: A base point further than this from any dark structure (plus half the keep-out box's diagonal) is on the background.
BASE_POINT_REACH_PX = 10.0
#: A declared fps below this fraction of the container's is a time-lapse (the container's rate is for playback).
TIME_LAPSE_RATIO = 0.1


def check_against_images(exp, sizes_wh: list[tuple[int, int]]) -> None:
    """Check the intrinsics and the per-view marks against the views' image sizes (width, height) px.

    Raises :class:`ExperimentError` naming the view and key when:

    - the principal point lies outside the image or further than a quarter
      of its width (height) from its centre, or a focal length is not between
      0.2 and 40 times the image width, or ``fy / fx`` is not between 1/2 and
      2 (intrinsics made for another image size, or a typo);
    - an ROI, a keep-out box or a base point lies outside its image, or the
      ROI is too small to hold a tendril;
    - the base point lies outside the ROI; the keep-out box does not overlap
      the ROI, covers half of it or more, or lies away from the base point
      (further than its own diagonal, at least 20 px).

    The marks against the first frame's content are checked by
    :func:`tendrilkit.inputs.check_marks_on_frame`.
    """
    where = f"{exp.source}: " if exp.source is not None else ""
    if len(sizes_wh) != exp.n_views:
        raise ExperimentError(f"{where}videos: expected {exp.n_views} readable videos, got {len(sizes_wh)}")
    for i, (cam, (w, h)) in enumerate(zip(exp.cameras, sizes_wh)):
        key = f"{where}cameras[{i}]"
        if not (0 <= cam.cx <= w and 0 <= cam.cy <= h):
            raise ExperimentError(f"{key}: principal point ({cam.cx:g}, {cam.cy:g}) is outside the {w}x{h} image of "
                                  f"view {cam.view}; intrinsics made for another image size?")
        if abs(cam.cx - w / 2) > L.MAX_PRINCIPAL_OFFSET * w or abs(cam.cy - h / 2) > L.MAX_PRINCIPAL_OFFSET * h:
            raise ExperimentError(f"{key}: principal point ({cam.cx:g}, {cam.cy:g}) is far from the centre "
                                  f"({w / 2:g}, {h / 2:g}) of the {w}x{h} image of view {cam.view} (expected within "
                                  f"{L.MAX_PRINCIPAL_OFFSET:g} of its width and height); intrinsics made for another "
                                  f"image size?")
        for name, f in (("fx", cam.fx), ("fy", cam.fy)):
            if not L.MIN_FOCAL_PER_WIDTH * w <= f <= L.MAX_FOCAL_PER_WIDTH * w:
                raise ExperimentError(f"{key}.{name}: {f:g} px is not a plausible focal length for the {w}x{h} image "
                                      f"of view {cam.view} (expected {L.MIN_FOCAL_PER_WIDTH:g} to "
                                      f"{L.MAX_FOCAL_PER_WIDTH:g} times the width)")
        if not 1 / L.MAX_ASPECT <= cam.fy / cam.fx <= L.MAX_ASPECT:
            raise ExperimentError(f"{key}: fy / fx = {cam.fy / cam.fx:.3g}; expected square-ish pixels "
                                  f"(1/{L.MAX_ASPECT:g} to {L.MAX_ASPECT:g})")
    for i, (marks, (w, h)) in enumerate(zip(exp.views, sizes_wh)):
        x, y, bw, bh = marks.roi
        if x < 0 or y < 0 or x + bw > w or y + bh > h:
            raise ExperimentError(f"{where}views[{i}].roi: {list(marks.roi)} reaches outside the {w}x{h} image of view {marks.view}")
        if bw < 8 or bh < 8:
            raise ExperimentError(f"{where}views[{i}].roi: {list(marks.roi)} is too small (at least 8x8 px)")
        if marks.keep_out is not None:
            kx, ky, kw, kh = marks.keep_out
            if kx < 0 or ky < 0 or kx + kw > w or ky + kh > h:
                raise ExperimentError(f"{where}views[{i}].keep_out: {list(marks.keep_out)} reaches outside the {w}x{h} image of view {marks.view}")
        bx, by = marks.base_point
        if not (0 <= bx < w and 0 <= by < h):
            raise ExperimentError(f"{where}views[{i}].base_point: {list(marks.base_point)} is outside the {w}x{h} image of view {marks.view}")
        if not (x <= bx <= x + bw and y <= by <= y + bh):
            raise ExperimentError(f"{where}views[{i}].base_point: {list(marks.base_point)} is outside the roi {list(marks.roi)} of view {marks.view}")
        if marks.keep_out is not None:
            kx, ky, kw, kh = marks.keep_out
            ox = max(0, min(x + bw, kx + kw) - max(x, kx))
            oy = max(0, min(y + bh, ky + kh) - max(y, ky))
            if ox * oy == 0:
                raise ExperimentError(f"{where}views[{i}].keep_out: {list(marks.keep_out)} does not overlap the roi "
                                      f"{list(marks.roi)} of view {marks.view}; expected a box between tendril and stem, at the base point")
            if ox * oy >= 0.5 * bw * bh:
                raise ExperimentError(f"{where}views[{i}].keep_out: {list(marks.keep_out)} covers "
                                      f"{100 * ox * oy / (bw * bh):.0f} % of the roi {list(marks.roi)} of view {marks.view}; "
                                      f"expected a small box between tendril and stem, at the base point")
            gap = float(np.hypot(max(kx - bx, 0, bx - (kx + kw)), max(ky - by, 0, by - (ky + kh))))
            reach = max(20.0, float(np.hypot(kw, kh)))
            if gap > reach:
                raise ExperimentError(f"{where}views[{i}].keep_out: {list(marks.keep_out)} is {gap:.0f} px from the "
                                      f"base point {list(marks.base_point)} of view {marks.view}; expected the box "
                                      f"between tendril and stem, at the base point (within {reach:.0f} px)")


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
