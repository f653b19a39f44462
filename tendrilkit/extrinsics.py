"""Camera poses of an experiment (``python -m tendrilkit calibrate``, and the pipeline's calibration).

Reads what :mod:`tendrilkit.calibration` needs (each video's image size and
first processed frame, or the stored ``extrinsics`` files) through
:mod:`tendrilkit.io`, calibrates (:func:`tendrilkit.calibration.calibrate_views`)
and, for the command, writes ``cameras.json`` and the marker table.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from tendrilkit.calibration import CalibrationResult, calibrate_views
from tendrilkit.exceptions import ExperimentError, FrameReadError
from tendrilkit.io import FrameSource, read_ijcv25_extrinsics

if TYPE_CHECKING:
    from tendrilkit.params import Experiment

__all__ = ["calibrate_experiment", "calibrate_to_dir", "calibration_frames"]


def calibration_frames(src: FrameSource, view: int, start: int, n: int, *, first=None) -> list:
    """The frames of one view the calibration averages: ``start`` and the ``n - 1`` after it.

    As many as the video has (a frame that cannot be read ends the list), so
    the run (:func:`calibrate_experiment`) and the preflight
    (:mod:`tendrilkit.preflight`) calibrate from the same frames.

    Parameters
    ----------
    src : FrameSource
        The view's open video.
    view : int
        0-based, for the message.
    start : int
        The first processed frame (``frames.start``).
    n : int
        ``calibration.average_frames``.
    first : (height, width, 3) uint8 array, optional, keyword-only
        Frame ``start`` when the caller has read it already.

    Returns
    -------
    list of (height, width, 3) uint8 arrays
        BGR, at least one.

    Raises
    ------
    ExperimentError
        Frame ``start`` cannot be read.
    """
    if first is not None:
        frames = [first]
    else:
        try:
            frames = [src.read(start)]
        except FrameReadError as e:
            raise ExperimentError(f"view {view + 1}: cannot read the first processed frame {start} for calibration "
                                  f"({e})") from None
    for f in range(start + 1, start + n):
        if src.frame_count and f >= src.frame_count:
            break
        try:
            frames.append(src.read(f))
        except FrameReadError:  # the video ends (or a frame is damaged): average the frames read
            break
    return frames


def calibrate_experiment(exp: "Experiment") -> CalibrationResult:
    """The rig of an experiment: from its ``extrinsics`` files, else from markers.

    With ``extrinsics: {format: ijcv25}`` the stored poses of the row whose frame
    is ``frames.start`` (else the first row) are used, and the table holds the
    stored corners' reprojection errors. Otherwise the first processed frame of
    every view and the ``calibration.average_frames - 1`` video frames after it
    (as many as the video has) are read and :func:`tendrilkit.calibration.calibrate`
    runs with the experiment's ``marker`` and ``calibration`` options, the
    corners averaged over the frames.

    The result is then checked (:func:`tendrilkit.calibration.check_calibration`):
    every view's marker corners must reproject within
    ``calibration.max_corner_rms_px`` (unless ``null``) and no two cameras may
    sit at the same place.

    Raises
    ------
    ExperimentError
        A video cannot be read, a view does not show the world marker, or the
        calibration failed its checks.
    """
    sizes = []
    for video in exp.videos:
        with FrameSource(video) as src:
            sizes.append((src.width, src.height))
    start = exp.frames.start
    if exp.extrinsics is not None:
        tables = [read_ijcv25_extrinsics(f) for f in exp.extrinsics.files]
        return calibrate_views(exp, image_sizes=sizes, extrinsics=tables)
    images = []
    for v, video in enumerate(exp.videos):
        with FrameSource(video) as src:
            images.append(calibration_frames(src, v, start, exp.calibration.average_frames))
    return calibrate_views(exp, image_sizes=sizes, images=images)


def calibrate_to_dir(experiment_path: str | Path, out_dir: str | Path, *, overrides: dict | None = None) -> str:
    """``python -m tendrilkit calibrate``: write ``cameras.json`` and the marker table.

    Writes ``out_dir/cameras.json`` (EXPERIMENT_FORMAT.md) and
    ``out_dir/calibration_markers.csv`` (:attr:`CalibrationResult.markers`);
    returns a short summary, one line per view. ``overrides`` replace keys
    of the experiment's sections, e.g. ``{"calibration": {"max_corner_rms_px":
    None}}`` (the command line's ``--accept-calibration``).
    """
    from tendrilkit.inputs import check_inputs
    from tendrilkit.io import check_writable_dir, open_views, write_cameras, write_csv
    from tendrilkit.params import load_experiment

    exp = load_experiment(experiment_path)
    if overrides:
        exp = exp.model_copy(update={k: getattr(exp, k).model_copy(update=v) for k, v in overrides.items()})
    out = check_writable_dir(out_dir)
    sources = open_views(list(exp.videos))
    try:
        check_inputs(exp, sources, marks_on_frame=False)  # the marks' geometry only: calibrating does not use them
    finally:
        for s in sources:
            s.close()
    res = calibrate_experiment(exp)
    write_cameras(res.cameras, out / "cameras.json", quality=res.view_quality())
    write_csv(res.markers, out / "calibration_markers.csv")
    how = {"ijcv25": "the authors' stored poses (ijcv25)",
           "bundle": "the world marker and bundle adjustment over the markers two or more views see",
           "markers": "the world marker alone"}[res.source]
    head = (f"{exp.name}: {len(res.cameras)} views calibrated from {how}, frame {res.frame} "
            f"(marker {exp.marker.id}, {exp.marker.dictionary}, {exp.marker.length_mm:g} mm)")
    tail = f"wrote {out / 'cameras.json'} and {out / 'calibration_markers.csv'}"
    return "\n".join([head, res.summary(), tail])
