"""Quality control a user can look at: contact sheets and overlay videos of a run.

Composition (like :mod:`tendrilkit.pipeline`): reads frames through
:mod:`tendrilkit.io`, projects with :mod:`tendrilkit.overlay`, draws with
:mod:`tendrilkit.plotting`, writes through :mod:`tendrilkit.io`.

* :func:`write_contact_sheet`: ``qc_contact_sheet.png`` in the results
  folder, written by ``reconstruct``: every ``doubtful`` frame (up to 8,
  the worst first) and 4 ``ok`` frames evenly spaced, each with its views
  cropped around the ROI and the centreline (cyan) and PWC (magenta)
  projected onto them.
* :func:`run_overlay`: ``python -m tendrilkit overlay EXPERIMENT.yaml
  RESULTS_DIR [--video OUT.mp4] [--sheet OUT.png]``: the labelled video of
  every processed frame (views side by side, status in the corner) and/or
  the contact sheet.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from tendrilkit.overlay import contact_frames, draw_overlay_bgr, frame_overlays

__all__ = ["CONTACT_SHEET", "frame_views", "write_contact_sheet", "overlay_video_frames", "run_overlay"]

#: File name of the contact sheet in a results folder.
CONTACT_SHEET = "qc_contact_sheet.png"


def _curve(table: pd.DataFrame | None, frame: int) -> np.ndarray | None:
    if table is None or not len(table):
        return None
    g = table[table["frame"] == frame]
    if g.empty:
        return None
    return g.sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy(float)


def _read(sources, frame: int) -> list:
    from tendrilkit.exceptions import FrameError

    out = []
    for s in sources:
        try:
            out.append(s.read(frame))
        except FrameError:
            out.append(None)
    return out


def frame_views(exp, results, frame: int, *, pad_px: int = 20) -> list:
    """The views of one frame of a finished run, cropped, with its centreline and PWC projected.

    Parameters
    ----------
    exp : tendrilkit.params.Experiment
    results : tendrilkit.io.Results
        :func:`tendrilkit.io.read_results` of the run (``cameras``, ``curves``, ``pwc_curves``).
    frame : int

    Returns
    -------
    list of tendrilkit.overlay.ViewOverlay
        For :func:`tendrilkit.plotting.plot_frame_overlay`.
    """
    from tendrilkit.io import open_views

    sources = open_views(list(exp.videos))
    try:
        images = _read(sources, frame)
    finally:
        for s in sources:
            s.close()
    return frame_overlays(images, results.cameras, exp.views, _curve(results.curves, frame),
                          _curve(results.pwc_curves, frame), pad_px=pad_px)


def write_contact_sheet(exp, cameras: list, frames: pd.DataFrame, curves: pd.DataFrame | None,
                        pwc: pd.DataFrame | None, path: str | Path, *, max_doubtful: int = 8,
                        n_ok: int = 4) -> list[int]:
    """Write the contact sheet PNG of a run; returns the frames shown (none: no file written).

    Parameters
    ----------
    exp : tendrilkit.params.Experiment
    cameras : list of Camera
    frames, curves, pwc : DataFrame
        ``frames.csv``, ``curves.csv``, ``pwc_curves.csv`` of the run.
    path : path
        The PNG to write (byte-stable).
    max_doubtful, n_ok : int
        See :func:`tendrilkit.overlay.contact_frames`.
    """
    from tendrilkit.io import open_views, save_figure
    from tendrilkit.plotting import plot_contact_sheet

    show = contact_frames(frames, max_doubtful=max_doubtful, n_ok=n_ok)
    if not show:
        return []
    status = dict(zip(frames["frame"].astype(int), frames["status"].astype(str)))
    message = dict(zip(frames["frame"].astype(int), frames["message"].fillna("").astype(str)))
    rows = []
    sources = open_views(list(exp.videos))
    try:
        for f in show:
            views = frame_overlays(_read(sources, f), cameras, exp.views, _curve(curves, f), _curve(pwc, f))
            rows.append((f, status[f], message[f], views))
    finally:
        for s in sources:
            s.close()
    fig = plot_contact_sheet(rows, title=f"{exp.name}: doubtful frames and a sample of ok ones "
                                         f"(cyan centreline, magenta PWC)")
    path = Path(path)
    save_figure(fig, path.with_suffix(""), formats=("png",), dpi=80)
    return show


def overlay_video_frames(exp, cameras: list, frames: pd.DataFrame, curves: pd.DataFrame | None,
                         pwc: pd.DataFrame | None, *, height_px: int = 480):
    """Yield one labelled BGR image per processed frame (see :func:`tendrilkit.overlay.draw_overlay_bgr`)."""
    from tendrilkit.io import open_views

    sources = open_views(list(exp.videos))
    try:
        for row in frames.sort_values("frame").itertuples():
            f = int(row.frame)
            views = frame_overlays(_read(sources, f), cameras, exp.views, _curve(curves, f), _curve(pwc, f))
            label = f"frame {f}  {float(row.time_s) / 60:.2f} min  {row.status}"
            yield draw_overlay_bgr(views, status=str(row.status), label=label, height_px=height_px)
    finally:
        for s in sources:
            s.close()


def run_overlay(experiment_path: str | Path, results_dir: str | Path, *, video: str | Path | None = None,
                sheet: str | Path | None = None, fps: float = 4.0, height_px: int = 480) -> str:
    """``python -m tendrilkit overlay``: an overlay video and/or a contact sheet of a finished run.

    Parameters
    ----------
    experiment_path : path
        The experiment file the run was made from.
    results_dir : path
        The run's folder (``frames.csv``, ``curves.csv``, ``cameras.json``).
    video : path, optional
        ``.mp4`` or ``.avi``: every processed frame, views side by side.
    sheet : path, optional
        A contact sheet PNG (default when neither is given:
        ``RESULTS_DIR/qc_contact_sheet.png``).
    fps : float
        Frame rate of the video (playback).
    height_px : int
        Height of each view in the video.

    Returns
    -------
    str
        What was written, one line per file (the command prints it).

    Raises
    ------
    ExperimentError
        The experiment or the results folder is unusable.
    """
    from tendrilkit.exceptions import ExperimentError
    from tendrilkit.io import read_results, write_video
    from tendrilkit.params import load_experiment

    exp = load_experiment(experiment_path)
    res = read_results(results_dir)
    if res.frames is None or res.cameras is None:
        raise ExperimentError(f"{results_dir}: frames.csv or cameras.json missing (run reconstruct first)")
    if len(res.cameras) != exp.n_views:
        raise ExperimentError(f"{results_dir}: cameras.json has {len(res.cameras)} views, "
                              f"the experiment {exp.n_views}")
    if video is None and sheet is None:
        sheet = Path(results_dir) / CONTACT_SHEET
    lines: list[str] = []
    if sheet is not None:
        shown = write_contact_sheet(exp, res.cameras, res.frames, res.curves, res.pwc_curves, sheet)
        lines.append(f"contact sheet: {sheet} ({len(shown)} frames)")
    if video is not None:
        n = write_video(overlay_video_frames(exp, res.cameras, res.frames, res.curves, res.pwc_curves,
                                             height_px=height_px), video, fps=fps)
        lines.append(f"overlay video: {video} ({n} frames)")
    return "\n".join(lines)
