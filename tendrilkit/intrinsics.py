"""Camera intrinsics from a video of a calibration board (``python -m tendrilkit intrinsics``).

The method:

1. :func:`select_views`: among the frames where the board was found
   (:func:`tendrilkit.boards.detect_board`), pick up to ``max_views`` that
   together cover the image: greedily the frame whose corners fall in the
   most cells of a 16 x 9 grid not yet covered, then the rest evenly;
2. :func:`calibrate_views`: ``cv2.calibrateCameraExtended`` (K and OpenCV's
   ``k1, k2, p1, p2, k3``); views whose RMS reprojection error is an outlier
   (above ``3 x`` the median and above 0.5 px, e.g. motion blur, a
   mis-ordered detection) are dropped and the camera is calibrated again
   (up to three rounds);
3. :func:`coverage`: where the detections fell: a 3 x 3 grid of cells, the
   four corner cells, and how near the edges the corners came;
4. :func:`verdict`: the result is ``ok`` only with enough good views, every
   cell of the 3 x 3 grid reached, and a focal length determined to 0.5 %
   (OpenCV's standard deviation of the estimate); otherwise one line per
   problem saying what to film.

The command (:func:`run_intrinsics`) reads frames with
:class:`tendrilkit.io.FrameSource`, prints the result and the ``cameras:``
entry to paste, and with ``--write`` fills it into a YAML file
(:func:`tendrilkit.templates.set_camera_entry`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from tendrilkit.boards import Board, detect_board, parse_board

__all__ = ["BoardDetection", "IntrinsicsResult", "select_views", "calibrate_views", "coverage", "verdict", "calibrate_source",
           "detect_in_frames", "run_intrinsics"]

#: Fewest good views for a calibration.
MIN_VIEWS = 8
#: Largest relative standard deviation of fx, fy for an ``ok`` result.
MAX_FOCAL_STD = 0.005


@dataclass(frozen=True, eq=False)
class BoardDetection:
    """The board in one frame: ``frame`` (0-based), ``ids`` (n,) int, ``corners_xy`` (n, 2) px."""

    frame: int
    ids: np.ndarray
    corners_xy: np.ndarray


@dataclass(frozen=True, eq=False)
class IntrinsicsResult:
    """A calibrated camera.

    Attributes
    ----------
    K : (3, 3) float array
        Pixels.
    dist : (5,) float array
        ``k1, k2, p1, p2, k3``.
    image_size : (int, int)
        Width, height, px.
    rms_px : float
        RMS reprojection error over every corner of the kept views, px.
    per_view_px : (n_views,) float array
        RMS error of each kept view, px.
    frames : (n_views,) int array
        The kept views' frames (0-based).
    rejected : list of (int, float)
        Frames dropped as outliers and their RMS error, px.
    std : (9,) float array
        Standard deviations of fx, fy, cx, cy, k1, k2, p1, p2, k3.
    n_detected : int
        Frames in which the board was found.
    n_sampled : int
        Frames looked at.
    """

    K: np.ndarray
    dist: np.ndarray
    image_size: tuple[int, int]
    rms_px: float
    per_view_px: np.ndarray
    frames: np.ndarray
    rejected: list
    std: np.ndarray
    n_detected: int = 0
    n_sampled: int = 0

    @property
    def focal_std_rel(self) -> float:
        """Largest relative standard deviation of fx and fy."""
        return float(max(self.std[0] / self.K[0, 0], self.std[1] / self.K[1, 1]))


def detect_in_frames(frames, board: Board) -> tuple[list[BoardDetection], int]:
    """Detect the board in ``(index, image)`` pairs; returns the detections and the frames seen."""
    out = []
    n = 0
    for idx, img in frames:
        n += 1
        d = detect_board(img, board)
        if d is not None:
            out.append(BoardDetection(int(idx), d[0], d[1]))
    return out, n


def _cells(xy: np.ndarray, size: tuple[int, int], nx: int, ny: int) -> np.ndarray:
    W, H = size
    cx = np.clip((xy[:, 0] / W * nx).astype(int), 0, nx - 1)
    cy = np.clip((xy[:, 1] / H * ny).astype(int), 0, ny - 1)
    return cy * nx + cx


def select_views(detections: list[BoardDetection], image_size: tuple[int, int], *, max_views: int = 40) -> list[BoardDetection]:
    """Up to ``max_views`` detections that cover the image (greedy on a 16 x 9 grid, then even spacing)."""
    if len(detections) <= max_views:
        return list(detections)
    cells = [set(_cells(d.corners_xy, image_size, 16, 9).tolist()) for d in detections]
    chosen: list[int] = []
    covered: set = set()
    while len(chosen) < max_views:
        gains = [(len(c - covered), len(detections[i].ids)) if i not in chosen else (-1, 0) for i, c in enumerate(cells)]
        best = max(range(len(cells)), key=lambda i: gains[i])
        if gains[best][0] <= 0:
            break
        chosen.append(best)
        covered |= cells[best]
    rest = [i for i in range(len(detections)) if i not in chosen]
    k = max_views - len(chosen)
    if k > 0 and rest:
        pick = np.unique(np.linspace(0, len(rest) - 1, min(k, len(rest))).round().astype(int))
        chosen += [rest[i] for i in pick]
    return [detections[i] for i in sorted(chosen)]


def calibrate_views(detections: list[BoardDetection], board: Board, image_size: tuple[int, int], *,
                    max_rounds: int = 3) -> IntrinsicsResult:
    """K and distortion from board detections, dropping outlier views.

    Parameters
    ----------
    detections : list of BoardDetection
    board : Board
    image_size : (width, height) px

    Raises
    ------
    ValueError
        Fewer than 4 usable detections (OpenCV cannot calibrate).
    """
    obj_all = board.object_points().astype(np.float32)
    views = [d for d in detections if len(d.ids) >= 6]
    if len(views) < 4:
        raise ValueError(f"detections: expected at least 4 views with 6 or more corners, got {len(views)}")
    rejected: list = []
    for _ in range(max_rounds):
        obj = [obj_all[d.ids] for d in views]
        img = [d.corners_xy.astype(np.float32).reshape(-1, 1, 2) for d in views]
        rms, K, dist, _, _, std_i, _, per_view = cv2.calibrateCameraExtended(
            obj, img, tuple(int(v) for v in image_size), None, None,
            criteria=(cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-12))
        per_view = np.asarray(per_view, float).ravel()
        med = float(np.median(per_view))
        bad = per_view > max(3.0 * med, 0.5)
        if not bad.any() or len(views) - bad.sum() < 4:
            break
        rejected += [(views[i].frame, float(per_view[i])) for i in np.flatnonzero(bad)]
        views = [v for v, b in zip(views, bad) if not b]
    std = np.asarray(std_i, float).ravel()[:9]
    return IntrinsicsResult(K=np.asarray(K, float), dist=np.asarray(dist, float).ravel()[:5], image_size=tuple(image_size),
                            rms_px=float(rms), per_view_px=per_view, frames=np.array([v.frame for v in views]),
                            rejected=sorted(rejected), std=std)


_THIRDS_X = ("left", "middle", "right")
_THIRDS_Y = ("top", "middle", "bottom")


def coverage(detections: list[BoardDetection], image_size: tuple[int, int]) -> dict:
    """Where the board's corners fell in the image.

    Returns
    -------
    dict
        ``grid`` (3, 3) int: corners per cell (row = top/middle/bottom third,
        column = left/middle/right); ``cells_hit`` (number of cells with at
        least one corner); ``corner_cells`` (hits of the four corner cells);
        ``reach`` (the fraction of the width/height from each edge the
        nearest corner stayed: ``left, right, top, bottom``).
    """
    W, H = image_size
    xy = np.concatenate([d.corners_xy for d in detections]) if detections else np.zeros((0, 2))
    grid = np.zeros((3, 3), int)
    if len(xy):
        c = _cells(xy, image_size, 3, 3)
        np.add.at(grid.ravel(), c, 1)
    reach = {"left": float(xy[:, 0].min() / W) if len(xy) else 1.0,
             "right": float(1 - xy[:, 0].max() / W) if len(xy) else 1.0,
             "top": float(xy[:, 1].min() / H) if len(xy) else 1.0,
             "bottom": float(1 - xy[:, 1].max() / H) if len(xy) else 1.0}
    return {"grid": grid, "cells_hit": int((grid > 0).sum()),
            "corner_cells": {"top-left": int(grid[0, 0]), "top-right": int(grid[0, 2]),
                             "bottom-left": int(grid[2, 0]), "bottom-right": int(grid[2, 2])},
            "reach": reach}


def verdict(result: IntrinsicsResult | None, cov: dict, n_views: int) -> list[str]:
    """What is wrong with a calibration, one line per problem, each saying what to film ([] = ok)."""
    problems = []
    if n_views < MIN_VIEWS:
        problems.append(f"the board was found in only {n_views} usable frame(s) (at least {MIN_VIEWS} needed): "
                        f"film the whole board, sharp and well lit, at 15-40 different positions and tilts")
    grid = cov["grid"]
    missing = []
    for r in range(3):
        for c in range(3):
            if grid[r, c] == 0:
                missing.append((r, c))
    cols_missing = [c for c in range(3) if all(grid[r, c] == 0 for r in range(3))]
    rows_missing = [r for r in range(3) if all(grid[r, c] == 0 for c in range(3))]
    for c in cols_missing:
        problems.append(f"the board never reached the image's {_THIRDS_X[c]} third; film it there too")
    for r in rows_missing:
        problems.append(f"the board never reached the image's {_THIRDS_Y[r]} third; film it there too")
    for r, c in missing:
        if c in cols_missing or r in rows_missing:
            continue
        where = "centre" if (r, c) == (1, 1) else (f"{_THIRDS_Y[r]}-{_THIRDS_X[c]} corner" if r != 1 and c != 1
                                                   else f"{(_THIRDS_Y[r] if r != 1 else _THIRDS_X[c])} edge")
        problems.append(f"no board corner in the image's {where}; film the board there too")
    if result is not None and n_views >= MIN_VIEWS and result.focal_std_rel > MAX_FOCAL_STD:
        problems.append(f"the focal length is uncertain ({100 * result.focal_std_rel:.2f} % standard deviation, "
                        f"at most {100 * MAX_FOCAL_STD:.1f} % wanted): tilt the board more (30-45 degrees, "
                        "towards and away from the camera, about both axes)")
    if result is not None and result.rms_px > 1.0:
        problems.append(f"the reprojection error is high ({result.rms_px:.2f} px RMS): the board may be bent, "
                        "blurred by motion or printed at another scale; film it flat, still and sharp")
    return problems


def summary_lines(result: IntrinsicsResult | None, cov: dict, board: Board) -> list[str]:
    """The report of a calibration, for the command line."""
    lines = []
    if result is not None:
        K, d = result.K, result.dist
        lines.append(f"board {board.text}: found in {result.n_detected} of {result.n_sampled} frames looked at; "
                     f"{len(result.frames)} used, {len(result.rejected)} rejected as outliers"
                     + (" (frames " + ", ".join(f"{f} {e:.2f} px" for f, e in result.rejected) + ")" if result.rejected else ""))
        lines.append(f"fx {K[0, 0]:.2f} fy {K[1, 1]:.2f} (+- {result.std[0]:.2f}, {result.std[1]:.2f}) px; "
                     f"cx {K[0, 2]:.2f} cy {K[1, 2]:.2f} (+- {result.std[2]:.2f}, {result.std[3]:.2f}) px")
        lines.append("dist (k1, k2, p1, p2, k3): " + ", ".join(f"{v:.5f}" for v in d))
        lines.append(f"reprojection error: {result.rms_px:.3f} px RMS (worst frame {result.per_view_px.max():.3f} px)")
    g = cov["grid"]
    lines.append("coverage (corners per third of the image, top to bottom): "
                 + " | ".join(" ".join(f"{v:4d}" for v in row) for row in g)
                 + f"; nearest the edges: left {100 * cov['reach']['left']:.0f} %, right {100 * cov['reach']['right']:.0f} %, "
                 f"top {100 * cov['reach']['top']:.0f} %, bottom {100 * cov['reach']['bottom']:.0f} % of the image away")
    return lines


def _sample_frames(src, n_samples: int):
    """``(index, image)`` of up to ``n_samples`` frames spread over a FrameSource."""
    from tendrilkit.exceptions import FrameReadError

    n = src.frame_count if src.frame_count and src.frame_count > 0 else n_samples
    idx = np.unique(np.linspace(0, n - 1, min(n, n_samples)).round().astype(int))
    for i in idx:
        try:
            yield int(i), src.read(int(i))
        except FrameReadError:
            continue


def calibrate_source(source: str | Path, board: Board, *, max_frames: int = 200,
                     max_views: int = 40) -> tuple[IntrinsicsResult | None, dict, list[str], tuple[int, int]]:
    """Detect, select, calibrate and judge one board video.

    Returns
    -------
    result : IntrinsicsResult or None
        None when fewer than 4 frames show the board.
    coverage : dict
        :func:`coverage` of the views used (of every detection when no result).
    problems : list of str
        :func:`verdict` ([] = ok).
    image_size : (width, height)
    """
    from tendrilkit.io import FrameSource

    with FrameSource(source) as src:
        size = (src.width, src.height)
        dets, n_seen = detect_in_frames(_sample_frames(src, max_frames), board)
    chosen = select_views(dets, size, max_views=max_views)
    result = None
    if len(chosen) >= 4:
        r = calibrate_views(chosen, board, size)
        result = IntrinsicsResult(**{**r.__dict__, "n_detected": len(dets), "n_sampled": n_seen})
        kept = set(result.frames.tolist())
        cov = coverage([d for d in chosen if d.frame in kept], size)
        problems = verdict(result, cov, len(result.frames))
    else:
        cov = coverage(dets, size)
        problems = verdict(None, cov, len(dets))
        problems.insert(0, f"board {board.text}: found in {len(dets)} of {n_seen} frames looked at "
                           "(is the --board right? squares and inner corners are counted as in its help)")
    return result, cov, problems, size


def run_intrinsics(source: str | Path, board_text: str, *, view: int = 1, write: str | Path | None = None,
                   max_frames: int = 200, max_views: int = 40) -> tuple[int, str]:
    """``python -m tendrilkit intrinsics``: calibrate one camera from a board video.

    Parameters
    ----------
    source : path
        A video or a folder of numbered images of the board.
    board_text : str
        See :func:`tendrilkit.boards.parse_board`.
    view : int, keyword-only
        The view (1-based) of the ``cameras:`` entry.
    write : path, optional, keyword-only
        A YAML file to fill the entry into: an experiment file (its other
        lines and comments are kept) or a new intrinsics file (created, for
        ``init --intrinsics``).
    max_frames : int, keyword-only
        Frames looked at, spread over the video.
    max_views : int, keyword-only
        Frames used in the calibration, chosen to cover the image.

    Returns
    -------
    (exit_code, report) : (int, str)
        0: calibrated, entry printed (and written); 1: too few or poorly
        spread detections (the report says what to film; nothing written).

    Raises
    ------
    ExperimentError
        Unreadable source, malformed board, a ``--write`` file that cannot be edited.
    """
    from tendrilkit.exceptions import ExperimentError
    from tendrilkit.io import read_text, write_text
    from tendrilkit.templates import camera_entry, set_camera_entry

    try:
        board = parse_board(board_text)
    except ValueError as e:
        raise ExperimentError(str(e)) from None
    if view < 1:
        raise ExperimentError(f"--view: expected a view number 1, 2, ..., got {view}")
    result, cov, problems, size = calibrate_source(source, board, max_frames=max_frames, max_views=max_views)
    lines = [f"{source}: {size[0]}x{size[1]}"] + summary_lines(result, cov, board)
    if problems:
        lines += [f"NOT OK: {p}" for p in problems]
        if result is not None:
            lines.append("the calibration below is doubtful; it is not written:")
            lines.append("# DOUBTFUL " + camera_entry(view, result.K, result.dist))
        return 1, "\n".join(lines)
    entry = camera_entry(view, result.K, result.dist)
    lines.append(f"OK: paste under cameras: (or use --write):\n{entry}")
    if write is not None:
        path = Path(write)
        old = read_text(path) if path.exists() else None
        note = (f"{size[0]}x{size[1]}, board {board.text}, {len(result.frames)} frames, "
                f"RMS {result.rms_px:.3f} px")
        write_text(set_camera_entry(old, view, result.K, result.dist, note=note, where=str(path)), path)
        lines.append(f"wrote the view {view} entry into {path}")
    return 0, "\n".join(lines)
