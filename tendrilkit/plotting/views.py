"""2D views: frames with marks, masks, centrelines and reprojections drawn on them."""

from __future__ import annotations

from typing import Sequence

import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from tendrilkit.plotting.style import (
    DOUBLE_MM,
    OKABE_ITO,
    _letters,
    _size,
    _styled,
)


@_styled
def plot_reprojection_overlays(panels: list, *, crop_margin_px: int = 20) -> Figure:
    """The paper's reprojection figure: skeleton vs reprojected curve vs PWC, per view and frame.

    Parameters
    ----------
    panels : list of rows, each a list of dicts (one per view) with keys
        ``image`` ((h, w, 3) BGR or (h, w) grey), ``roi`` [x, y, w, h],
        ``skeleton_xy``, ``reprojected_xy``, ``pwc_xy`` ((n, 2) px or None)
        and ``label`` (e.g. "frame 0, view 1"). Rows are frames (first,
        middle, last), columns views. Each panel shows the ROI.
    """
    nr = max(len(panels), 1)
    nc = max((len(r) for r in panels), default=1)
    fig = Figure(figsize=_size("double", 58 * nr), layout="constrained")
    axes = np.atleast_2d(fig.subplots(nr, nc, squeeze=False))
    for i, row in enumerate(panels):
        for j, p in enumerate(row):
            ax = axes[i, j]
            img = np.asarray(p["image"])
            rgb = img[:, :, ::-1] if img.ndim == 3 else img
            x, y, w, h = (int(v) for v in p["roi"])
            x0, y0 = max(x - crop_margin_px, 0), max(y - crop_margin_px, 0)
            x1, y1 = min(x + w + crop_margin_px, img.shape[1]), min(y + h + crop_margin_px, img.shape[0])
            ax.imshow(rgb[y0:y1, x0:x1], extent=(x0 - 0.5, x1 - 0.5, y1 - 0.5, y0 - 0.5),
                      cmap=None if img.ndim == 3 else "gray", interpolation="nearest")
            for key, col, ls, lab in (("skeleton_xy", "black", "-", "skeleton"),
                                      ("reprojected_xy", OKABE_ITO["sky"], "-", "reconstruction reprojected"),
                                      ("pwc_xy", OKABE_ITO["orange"], "--", "PWC reprojected")):
                c = p.get(key)
                if c is not None and len(c):
                    c = np.asarray(c, float)
                    ax.plot(c[:, 0], c[:, 1], color=col, ls=ls, lw=0.9 if key == "skeleton_xy" else 0.8, label=lab)
            ax.set_xlim(x0 - 0.5, x1 - 0.5)
            ax.set_ylim(y1 - 0.5, y0 - 0.5)
            ax.set_xticks([])
            ax.set_yticks([])
            ax.grid(False)
            ax.set_title(p.get("label", ""), fontsize=7)
        for j in range(len(row), nc):
            axes[i, j].set_axis_off()
    handles, labels = axes[0, 0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncols=3)
    _letters(axes.ravel())
    return fig


@_styled
def plot_views(panels: list, *, width: str | float = "double") -> Figure:
    """Several views side by side (one panel each): image, ROI, keep-out box, base point, optional centreline.

    Parameters
    ----------
    panels : list of dicts with keys ``image``, ``roi``, ``keep_out``,
        ``base_point_xy``, optional ``centerline_xy`` ((n, 2) px, drawn base
        dark to tip bright), ``mask`` (a :class:`~tendrilkit.segmentation.TendrilMask`,
        magenta) and ``label``.
    """
    n = max(len(panels), 1)
    h0, w0 = np.asarray(panels[0]["image"]).shape[:2] if panels else (1, 1)
    fig = Figure(figsize=_size(width, DOUBLE_MM / n * h0 / w0 + 12), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, n))
    for ax, p in zip(axes, panels):
        img = np.asarray(p["image"])
        rgb = (img[:, :, ::-1] if img.ndim == 3 else np.repeat(img[:, :, None], 3, axis=2)).astype(float) / 255.0
        m = p.get("mask")
        if m is not None:
            mm = np.asarray(m.mask_roi, bool)
            xo, yo = (int(v) for v in m.roi_offset_xy)
            sub = rgb[yo:yo + mm.shape[0], xo:xo + mm.shape[1]]
            sub[mm] = 0.35 * sub[mm] + 0.65 * np.array([1.0, 0.0, 1.0])
        ax.imshow(rgb, interpolation="nearest")
        roi = p["roi"]
        ax.add_patch(Rectangle(tuple(roi[:2]), roi[2], roi[3], fill=False, ec=OKABE_ITO["green"], lw=0.8, label="ROI"))
        ko = p.get("keep_out")
        if ko is not None:
            ax.add_patch(Rectangle(tuple(ko[:2]), ko[2], ko[3], fill=False, ec=OKABE_ITO["vermillion"], lw=0.8,
                                   hatch="////", label="keep-out"))
        c = p.get("centerline_xy")
        if c is not None and len(c):
            c = np.asarray(c, float)
            ax.scatter(c[:, 0], c[:, 1], c=np.linspace(0, 1, len(c)), cmap="cividis", s=0.6, linewidths=0,
                       label="centreline (base dark)")
        b = p["base_point_xy"]
        ax.plot([b[0]], [b[1]], "*", color=OKABE_ITO["yellow"], mec="black", mew=0.4, ms=7, label="base point")
        ax.set_xlim(roi[0] - 40, roi[0] + roi[2] + 40)
        ax.set_ylim(roi[1] + roi[3] + 40, roi[1] - 40)
        ax.set_xticks([])
        ax.set_yticks([])
        ax.grid(False)
        ax.set_title(p.get("label", ""))
    handles, labels = axes[0].get_legend_handles_labels()
    if handles:
        fig.legend(handles, labels, loc="outside lower center", ncols=4)
    _letters(axes)
    return fig


@_styled
def plot_view_overlay(image_bgr: np.ndarray, *, roi: Sequence[float], keep_out: Sequence[float] | None,
                      base_point_xy: Sequence[float], centerline_xy: np.ndarray | None = None,
                      reprojected_xy: np.ndarray | None = None, title: str | None = None) -> Figure:
    """One frame of one view with what the user marked and what the method found.

    Parameters
    ----------
    image_bgr : (h, w, 3) uint8 array (BGR, as OpenCV reads it) or (h, w) grey
    roi, keep_out : [x, y, w, h] pixels
        The region of interest (green) and the keep-out box (red, hatched).
    base_point_xy : [x, y] pixels (yellow star)
    centerline_xy : (n, 2) float array, optional
        The ordered skeleton (black, as in paper Figure 4).
    reprojected_xy : (n, 2) float array, optional
        The reconstruction projected into the view (cyan).
    """
    img = np.asarray(image_bgr)
    if img.ndim == 3 and img.shape[2] == 3:
        rgb, cmap = img[:, :, ::-1], None
    elif img.ndim == 2:
        rgb, cmap = img, "gray"
    else:
        raise ValueError(f"image_bgr must have shape (h, w, 3) or (h, w), got {img.shape}")
    h, w = img.shape[:2]
    fig = Figure(figsize=(7.0, 7.0 * h / w + 0.4), layout="constrained")
    ax = fig.add_subplot()
    ax.imshow(rgb, cmap=cmap, interpolation="nearest")
    ax.add_patch(Rectangle(tuple(roi[:2]), roi[2], roi[3], fill=False, ec="lime", lw=1.2, label="ROI"))
    if keep_out is not None:
        ax.add_patch(Rectangle(tuple(keep_out[:2]), keep_out[2], keep_out[3], fill=False, ec="red", lw=1.0,
                               hatch="//", label="keep-out"))
    if centerline_xy is not None:
        c = np.asarray(centerline_xy, float)
        ax.plot(c[:, 0], c[:, 1], color="black", lw=1.2, label="skeleton")
    if reprojected_xy is not None:
        r = np.asarray(reprojected_xy, float)
        ax.plot(r[:, 0], r[:, 1], color="cyan", lw=1.0, label="reprojection")
    ax.plot([base_point_xy[0]], [base_point_xy[1]], "*", color="yellow", mec="black", ms=11, label="base point")
    ax.set_xlim(-0.5, w - 0.5)
    ax.set_ylim(h - 0.5, -0.5)
    ax.grid(False)
    ax.legend(loc="upper right", frameon=True)
    if title:
        ax.set_title(title)
    return fig


@_styled
def plot_marks(image_bgr: np.ndarray, *, roi: Sequence[float] | None, keep_out: Sequence[float] | None,
               base_point_xy: Sequence[float] | None, previous: dict | None = None,
               swept_mask: np.ndarray | None = None, title: str | None = None) -> Figure:
    """The marks of one view (``python -m tendrilkit marks``) on its first processed frame.

    Parameters
    ----------
    image_bgr : (h, w, 3) uint8 array
    roi, keep_out, base_point_xy
        The marks to show (as in :func:`plot_view_overlay`); None: missing.
    previous : dict, optional
        The user's marks (``roi``, ``keep_out``, ``base_point``) where
        suggestions replace them: drawn dashed (grey) for comparison.
    swept_mask : (h, w) bool array, optional
        The region the tendril swept over the sampled frames (magenta outline).
    """
    h, w = np.asarray(image_bgr).shape[:2]
    fig = plot_view_overlay(image_bgr, roi=roi if roi is not None else [0, 0, w, h], keep_out=keep_out,
                            base_point_xy=base_point_xy if base_point_xy is not None else [np.nan, np.nan],
                            title=title)
    ax = fig.axes[0]
    if swept_mask is not None and np.any(swept_mask):
        ax.contour(np.asarray(swept_mask, float), levels=[0.5], colors="magenta", linewidths=0.6)
        ax.plot([], [], color="magenta", lw=0.6, label="swept by the tendril")
    if previous:
        for key, colour in (("roi", "lime"), ("keep_out", "red")):
            b = previous.get(key)
            if b is not None:
                ax.add_patch(Rectangle(tuple(b[:2]), b[2], b[3], fill=False, ec=colour, ls="--", lw=0.8, alpha=0.7))
        bp = previous.get("base_point")
        if bp is not None:
            ax.plot([bp[0]], [bp[1]], "x", color="grey", ms=8, label="your base point")
        ax.plot([], [], color="grey", ls="--", label="your marks (dashed)")
    ax.legend(loc="upper right", frameon=True, fontsize=7)
    return fig


@_styled
def plot_mask_overlay(image_bgr: np.ndarray, tendril_mask, *, roi: Sequence[float], keep_out: Sequence[float] | None,
                      base_point_xy: Sequence[float], title: str | None = None) -> Figure:
    """The ROI crop of a frame with the tendril's mask (a :class:`~tendrilkit.segmentation.TendrilMask`) in magenta."""
    img = np.asarray(image_bgr)
    m = np.asarray(tendril_mask.mask_roi, bool)
    x0, y0 = (int(v) for v in tendril_mask.roi_offset_xy)
    crop = img[y0:y0 + m.shape[0], x0:x0 + m.shape[1]]
    rgb = (crop[:, :, ::-1] if crop.ndim == 3 else np.repeat(crop[:, :, None], 3, axis=2)).astype(float) / 255.0
    rgb[m] = 0.35 * rgb[m] + 0.65 * np.array([1.0, 0.0, 1.0])
    h, w = m.shape
    fig = Figure(figsize=(5.5, 5.5 * h / max(w, 1) + 0.4), layout="constrained")
    ax = fig.add_subplot()
    ax.imshow(rgb, extent=(x0 - 0.5, x0 + w - 0.5, y0 + h - 0.5, y0 - 0.5), interpolation="nearest")
    if keep_out is not None:
        ax.add_patch(Rectangle(tuple(keep_out[:2]), keep_out[2], keep_out[3], fill=False, ec="red", lw=1.0,
                               hatch="//", label="keep-out"))
    cx, cy = tendril_mask.centroid_xy
    ax.plot([cx], [cy], "+", color="black", ms=10, label="centroid")
    ax.plot([base_point_xy[0]], [base_point_xy[1]], "*", color="yellow", mec="black", ms=11, label="base point")
    ax.set_xlim(x0 - 0.5, x0 + w - 0.5)
    ax.set_ylim(y0 + h - 0.5, y0 - 0.5)
    ax.grid(False)
    ax.legend(loc="upper right", frameon=True)
    ax.set_title(title or f"mask: {tendril_mask.area_px} px")
    return fig
