"""The reconstruction seen in the views: projections, crops, frame choice and video frames (no disk, no matplotlib).

What a user needs to trust a run is to *see* it: the reconstructed centreline
and its piece-wise clothoid projected back onto every view, around the
region of interest. This module prepares that:

* :func:`frame_overlays`: per view, the ROI crop (padded) of the image and
  the curve and the PWC projected into the crop's pixels;
* :func:`contact_frames`: which frames a contact sheet shows (every
  ``doubtful`` frame up to a limit, worst first, and a deterministic,
  evenly spaced sample of ``ok`` ones);
* :func:`draw_overlay_bgr`: one labelled video frame (views side by side,
  curve cyan, PWC magenta, status in the corner: green ok, orange
  doubtful, red failed), drawn with OpenCV for ``python -m tendrilkit
  overlay --video``.

Figures (the contact sheet) are drawn by
:func:`tendrilkit.plotting.plot_contact_sheet`; files are written by
:mod:`tendrilkit.qc` through :mod:`tendrilkit.io`.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import pandas as pd

__all__ = ["ViewOverlay", "frame_overlays", "contact_frames", "worst_frames", "draw_overlay_bgr", "STATUS_BGR"]

#: Colour of each status in the video frames (BGR).
STATUS_BGR = {"ok": (60, 170, 60), "doubtful": (0, 140, 255), "failed": (40, 40, 220)}


@dataclass(frozen=True, eq=False)
class ViewOverlay:
    """One view of one frame, cropped around the ROI.

    Attributes
    ----------
    crop_bgr : (h, w, 3) uint8 array or None
        The image around the ROI (None: the view could not be read).
    offset_xy : (2,) int array
        Full-image pixel of the crop's ``[0, 0]``.
    curve_xy, pwc_xy : (n, 2) float arrays or None
        The centreline and its PWC projected, crop pixels.
    base_xy : (2,) float array
        The base mark, crop pixels.
    """

    crop_bgr: np.ndarray | None
    offset_xy: np.ndarray
    curve_xy: np.ndarray | None
    pwc_xy: np.ndarray | None
    base_xy: np.ndarray


def _crop_box(roi, shape, pad_px: int) -> tuple[int, int, int, int]:
    H, W = shape[:2]
    x, y, w, h = (int(v) for v in roi)
    return max(x - pad_px, 0), max(y - pad_px, 0), min(x + w + pad_px, W), min(y + h + pad_px, H)


def frame_overlays(images: list, cameras: list, marks: list, points_mm: np.ndarray | None,
                   pwc_mm: np.ndarray | None = None, *, pad_px: int = 20) -> list[ViewOverlay]:
    """Per view, the crop around the ROI and the projections of the curve and its PWC.

    Parameters
    ----------
    images : list of (H, W, 3) uint8 arrays or None
        The frame of every view (None: unreadable).
    cameras : list of Camera
    marks : list
        Per view an object with ``roi`` and ``base_point`` (the experiment's
        ``views`` entries).
    points_mm, pwc_mm : (n, 3) float arrays or None
        The centreline and the PWC, world mm.
    pad_px : int
        Margin around the ROI, px.

    Returns
    -------
    list of ViewOverlay
    """
    out = []
    for img, cam, m in zip(images, cameras, marks):
        shape = (cam.height, cam.width) if img is None else img.shape
        x0, y0, x1, y1 = _crop_box(m.roi, shape, pad_px)
        off = np.array([x0, y0])
        crop = None if img is None else np.ascontiguousarray(img[y0:y1, x0:x1])

        def proj(X):
            return None if X is None else cam.project(np.asarray(X, float)) - off

        out.append(ViewOverlay(crop_bgr=crop, offset_xy=off, curve_xy=proj(points_mm), pwc_xy=proj(pwc_mm),
                               base_xy=np.asarray(m.base_point, float) - off))
    return out


def _badness(frames: pd.DataFrame) -> pd.Series:
    """Per row, the worst of the image figures (lower is worse): min over views of precision and coverage."""
    cols = [c for c in frames.columns if c.startswith(("on_tendril_frac_v", "coverage_frac_v"))]
    if not cols:
        return pd.Series(1.0, index=frames.index)
    return frames[cols].min(axis=1, skipna=True).fillna(1.0)


def contact_frames(frames: pd.DataFrame, *, max_doubtful: int = 8, n_ok: int = 4) -> list[int]:
    """The frames a contact sheet shows, in frame order.

    Parameters
    ----------
    frames : DataFrame
        ``frames.csv`` (``frame, status`` and the verification columns).
    max_doubtful : int
        At most this many ``doubtful`` frames: the worst by the lowest
        precision or coverage over the views (ties: the earlier frame).
    n_ok : int
        This many ``ok`` frames, evenly spaced over the ok frames (first and
        last included): deterministic, no random draw.

    Returns
    -------
    list of int
    """
    f = frames.reset_index(drop=True)
    d = f[f["status"] == "doubtful"].assign(_b=_badness(f[f["status"] == "doubtful"]))
    d = d.sort_values(["_b", "frame"], kind="stable").head(max(int(max_doubtful), 0))
    ok = f.loc[f["status"] == "ok", "frame"].to_numpy(int)
    pick: list[int] = []
    if len(ok) and n_ok > 0:
        idx = np.unique(np.rint(np.linspace(0, len(ok) - 1, min(int(n_ok), len(ok)))).astype(int))
        pick = ok[idx].tolist()
    return sorted(set(pick) | set(d["frame"].astype(int).tolist()))


def worst_frames(frames: pd.DataFrame, n: int = 3) -> list[int]:
    """The ``n`` reconstructed frames with the lowest precision or coverage over the views (ties: earlier first)."""
    f = frames[frames["status"] != "failed"].reset_index(drop=True)
    f = f.assign(_b=_badness(f)).sort_values(["_b", "frame"], kind="stable")
    return f["frame"].astype(int).head(max(int(n), 0)).tolist()


def _poly(img: np.ndarray, xy: np.ndarray | None, colour, scale: float, thickness: int) -> None:
    if xy is None:
        return
    p = np.asarray(xy, float) * scale
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p) >= 2:
        cv2.polylines(img, [np.round(p * 16).astype(np.int32)], False, colour, thickness, cv2.LINE_AA, 4)


def draw_overlay_bgr(views: list[ViewOverlay], *, status: str, label: str, height_px: int = 480) -> np.ndarray:
    """One video frame: the views' crops side by side, curve (cyan) and PWC (magenta) drawn, labelled.

    Parameters
    ----------
    views : list of ViewOverlay
    status : str
        ``ok``, ``doubtful`` or ``failed`` (colour of the label and border).
    label : str
        Text in the top-left corner (e.g. ``frame 12  3.0 min  doubtful``).
    height_px : int
        Height of every crop in the output (each scaled to it).

    Returns
    -------
    (height_px, W, 3) uint8 array
        W is the sum of the scaled crops' widths, rounded up to an even number
        (video encoders want even sizes).
    """
    tiles = []
    for v in views:
        if v.crop_bgr is None:
            tiles.append(np.full((height_px, height_px, 3), 40, np.uint8))
            continue
        h, w = v.crop_bgr.shape[:2]
        s = height_px / h
        tile = cv2.resize(v.crop_bgr, (max(int(round(w * s)), 1), height_px), interpolation=cv2.INTER_AREA)
        _poly(tile, v.pwc_xy, (255, 0, 255), s, 1)
        _poly(tile, v.curve_xy, (255, 255, 0), s, 1)
        b = np.round(v.base_xy * s).astype(int)
        cv2.drawMarker(tile, (int(b[0]), int(b[1])), (0, 220, 255), cv2.MARKER_STAR, 12, 1, cv2.LINE_AA)
        tiles.append(tile)
    img = np.hstack(tiles)
    if img.shape[1] % 2:
        img = np.hstack([img, np.zeros((height_px, 1, 3), np.uint8)])
    colour = STATUS_BGR.get(status, (200, 200, 200))
    cv2.rectangle(img, (0, 0), (img.shape[1] - 1, img.shape[0] - 1), colour, 4)
    cv2.rectangle(img, (0, 0), (12 + 9 * len(label), 26), (255, 255, 255), -1)
    cv2.putText(img, label, (6, 19), cv2.FONT_HERSHEY_SIMPLEX, 0.5, colour, 1, cv2.LINE_AA)
    return img
