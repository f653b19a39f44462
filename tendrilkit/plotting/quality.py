"""Quality control: reprojection bars, per-frame status over time, frame overlays, the contact sheet and
the multi-view decision figure."""

from __future__ import annotations

import textwrap
from typing import Sequence

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from tendrilkit.plotting.style import (
    FRAME_SHADES,
    OKABE_ITO,
    STATUS_COLORS,
    _check,
    _letters,
    _size,
    _status_bands,
    _styled,
    _time_axis,
)


@_styled
def plot_reprojection_bars(table: pd.DataFrame, *, title: str | None = None, width: str | float = "double",
                           ylabel: str = "error (px)") -> Figure:
    """Bar plot of a Table 1/2 (mean error with its standard deviation), frames shaded (paper Figures 5-6).

    Error bars are clipped at 0 (an error is never negative).

    Parameters
    ----------
    table : DataFrame
        :func:`tendrilkit.sequence.table1` or ``table2``: ``frame, view,
        mean_{base,tip,entire}_px, std_{base,tip,entire}_px``.
    """
    sections = ("base", "tip", "entire")
    _check(table, ("frame", "view") + tuple(f"mean_{s}_px" for s in sections), "table")
    t = table.sort_values(["frame", "view"], kind="stable").reset_index(drop=True)
    frames = list(dict.fromkeys(t["frame"].tolist()))
    views = sorted(t["view"].unique().tolist())
    fig = Figure(figsize=_size(width, 55), layout="constrained")
    axes = fig.subplots(1, 3, sharey=True)
    width_ = 0.8 / max(len(views), 1)
    palette = [OKABE_ITO[k] for k in ("blue", "orange", "green", "purple", "sky")]
    for ax, sec in zip(axes, sections):
        for k, f in enumerate(frames):
            ax.axvspan(k - 0.5, k + 0.5, color=FRAME_SHADES[k % len(FRAME_SHADES)], zorder=0, lw=0)
        for vi, v in enumerate(views):
            d = t[t["view"] == v].set_index("frame").reindex(frames)
            pos = np.arange(len(frames)) - 0.4 + width_ * (vi + 0.5)
            mean = d[f"mean_{sec}_px"].to_numpy(float)
            std = d.get(f"std_{sec}_px")
            yerr = None if std is None else np.vstack([np.minimum(std.to_numpy(float), mean), std.to_numpy(float)])
            ax.bar(pos, mean, width=width_ * 0.9, color=palette[vi % len(palette)], yerr=yerr, capsize=1.5,
                   error_kw={"lw": 0.6}, label=f"view {v}", zorder=2)
        ax.set_xticks(range(len(frames)), [f"frame {f}" for f in frames])
        ax.set_xlim(-0.5, len(frames) - 0.5)
        ax.set_ylim(bottom=0)
        ax.set_title({"base": "base quarter", "tip": "tip quarter", "entire": "entire tendril"}[sec])
        ax.grid(axis="x", visible=False)
    axes[0].set_ylabel(ylabel)
    axes[-1].legend(loc="upper left")
    _letters(axes)
    if title:
        fig.suptitle(title)
    return fig


@_styled
def plot_multiview_decision(evidence: Sequence, result, *, truth_mm: np.ndarray | None = None,
                            title: str | None = None) -> Figure:
    """How ``reconstruction.method: multiview`` decided a frame: every view's evidence and the 3D curves tried.

    Parameters
    ----------
    evidence : list of tendrilkit.mv_evidence.SkeletonEvidence
        The views' evidence (foreground grey, skeleton black).
    result : tendrilkit.multiview.MultiviewResult
        Made with ``keep_candidates=True``: each candidate curve (tracked
        from the previous frame: orange dashed; acquired from the base: blue
        dotted) and the curve kept (cyan) are projected into every view; the
        titles give each view's precision and coverage of the kept curve (a
        view whose skeleton crosses itself is ambiguous alone; the curve is
        the one all views explain).
    truth_mm : (n, 3) float array, optional
        The true centreline (phantoms), green.
    """
    n = len(evidence)
    fig = Figure(figsize=(4.2 * n, 4.6), layout="constrained")
    styles = {"tracked": dict(color="tab:orange", ls="--", lw=1.0), "acquired": dict(color="tab:blue", ls=":", lw=1.2)}
    for v, ev in enumerate(evidence):
        ax = fig.add_subplot(1, n, v + 1)
        h, w = ev.foreground.shape
        x0, y0 = ev.offset_xy
        ax.imshow(np.where(ev.foreground, 0.75, 1.0), cmap="gray", vmin=0, vmax=1, interpolation="nearest",
                  extent=(x0 - 0.5, x0 + w - 0.5, y0 + h - 0.5, y0 - 0.5))
        sk = ev.skeleton_xy
        ax.plot(sk[:, 0], sk[:, 1], ",", color="black")
        for c in result.candidates:
            u = ev.camera.project(c["nodes_mm"])
            ax.plot(u[:, 0], u[:, 1], label=f"{c['mode']} (score {c['score']:.2f})", **styles.get(c["mode"], {}))
        u = ev.camera.project(result.nodes_mm)
        ax.plot(u[:, 0], u[:, 1], color="cyan", lw=1.6, alpha=0.8, label=f"kept: {result.mode}")
        ax.plot(u[:1, 0], u[:1, 1], "*", color="yellow", mec="black", ms=10)
        if truth_mm is not None:
            t = ev.camera.project(np.asarray(truth_mm, float))
            ax.plot(t[:, 0], t[:, 1], color="green", lw=0.8, label="truth")
        ax.set_xlim(x0 - 0.5, x0 + w - 0.5)
        ax.set_ylim(y0 + h - 0.5, y0 - 0.5)
        ax.set_aspect("equal")
        ax.grid(False)
        ax.set_title(f"view {v + 1}: precision {result.precision[v]:.2f}, coverage {result.coverage[v]:.2f}")
        if v == 0:
            ax.legend(loc="lower left", frameon=True)
    if title:
        fig.suptitle(title)
    return fig


@_styled
def plot_quality_over_time(frames: pd.DataFrame, *, thresholds=None, title: str | None = None) -> Figure:
    """Per-frame verification figures over time, one line per view, non-ok frames shaded.

    Parameters
    ----------
    frames : DataFrame
        ``frames.csv``: ``frame, time_s, status`` and the columns of
        :mod:`tendrilkit.verify` (``on_tendril_frac_v<i>``,
        ``skeleton_mean_px_v<i>``, ``coverage_frac_v<i>``, ``base_px_v<i>``,
        ``length_change_pct``).
    thresholds : tendrilkit.verify.Thresholds, optional
        Draws the limits (dashed).
    """
    _check(frames, ("frame", "status"), "frames")
    f = frames.sort_values("frame")
    x, xlabel = _time_axis(f)
    views = sorted(int(c.rsplit("_v", 1)[1]) for c in f.columns if c.startswith("on_tendril_frac_v"))
    panels = [("on_tendril_frac_v{}", "precision (on tendril)", "min_on_tendril_frac", 1.0),
              ("skeleton_mean_px_v{}", "off the middle (px)", "max_skeleton_mean_px", None),
              ("coverage_frac_v{}", "coverage", "min_coverage_frac", 1.0),
              ("base_px_v{}", "base to mark (px)", "max_base_px", None)]
    fig = Figure(figsize=(7.5, 8.5), layout="constrained")
    axes = fig.subplots(5, 1, sharex=True)
    for ax, (pat, ylabel, key, _) in zip(axes, panels):
        for v in views:
            col = pat.format(v)
            if col in f.columns:
                ax.plot(x, f[col].to_numpy(float), ".-", ms=3, lw=0.8, label=f"view {v}")
        if thresholds is not None:
            ax.axhline(getattr(thresholds, key), color="black", ls="--", lw=0.7, label="limit")
        ax.set_ylabel(ylabel)
    ax = axes[4]
    if "length_change_pct" in f.columns:
        ax.plot(x, f["length_change_pct"].to_numpy(float), ".-", color="black", ms=3, lw=0.8,
                label="length change (%)")
    ax.set_ylabel("length change to\nprevious frame (%)")
    ax.set_xlabel(xlabel)
    for a in axes:
        _status_bands(a, f, x_time=xlabel.startswith("time"))
    axes[0].legend(loc="lower left", ncol=5)
    counts = f["status"].value_counts()
    fig.suptitle((title + ": " if title else "") + ", ".join(f"{int(counts.get(k, 0))} {k}" for k in STATUS_COLORS))
    return fig


def _draw_views(axes, views, *, status: str, header: str | None = None, note: str | None = None) -> None:
    for k, (ax, v) in enumerate(zip(axes, views)):
        ax.grid(False)
        ax.set_xticks([])
        ax.set_yticks([])
        for sp in ax.spines.values():
            sp.set_color(STATUS_COLORS.get(status, "black"))
            sp.set_linewidth(2.0)
        if v.crop_bgr is None:
            ax.text(0.5, 0.5, "no image", ha="center", va="center", transform=ax.transAxes)
            continue
        h, w = v.crop_bgr.shape[:2]
        ax.imshow(v.crop_bgr[:, :, ::-1], interpolation="bilinear")
        if v.pwc_xy is not None:
            ax.plot(v.pwc_xy[:, 0], v.pwc_xy[:, 1], color="magenta", lw=0.8, label="PWC")
        if v.curve_xy is not None:
            ax.plot(v.curve_xy[:, 0], v.curve_xy[:, 1], color="cyan", lw=0.8, label="centreline")
        ax.plot([v.base_xy[0]], [v.base_xy[1]], "*", color="yellow", mec="black", ms=7)
        ax.set_xlim(-0.5, w - 0.5)
        ax.set_ylim(h - 0.5, -0.5)
        if k == 0 and header:
            ax.set_ylabel(header, color=STATUS_COLORS.get(status, "black"), fontsize=8)
        ax.set_title(f"view {k + 1}", fontsize=8)
    if note:
        axes[-1].text(1.02, 0.5, note, transform=axes[-1].transAxes, fontsize=6, va="center", wrap=True)


@_styled
def plot_frame_overlay(views, *, status: str = "ok", title: str | None = None) -> Figure:
    """One frame: the centreline (cyan) and its PWC (magenta) projected onto every view, around the ROI.

    Parameters
    ----------
    views : list of tendrilkit.overlay.ViewOverlay
        :func:`tendrilkit.overlay.frame_overlays`.
    status : str
        Colours the frame of each panel (ok green, doubtful orange, failed red).
    """
    fig = Figure(figsize=(3.0 * len(views), 3.3), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, len(views)))
    _draw_views(axes, views, status=status)
    if title:
        fig.suptitle(title, color=STATUS_COLORS.get(status, "black"))
    return fig


@_styled
def plot_contact_sheet(rows, *, title: str | None = None) -> Figure:
    """A contact sheet: one row per frame (its views side by side), reconstruction overlaid.

    Parameters
    ----------
    rows : list of (frame, status, message, list of ViewOverlay)
        E.g. the doubtful frames and a sample of ok ones
        (:func:`tendrilkit.overlay.contact_frames`); the message's first
        failed check is printed beside the row.
    """
    rows = list(rows)
    n_views = max((len(r[3]) for r in rows), default=1)
    fig = Figure(figsize=(2.6 * n_views + 1.8, 2.5 * max(len(rows), 1) + 0.4), layout="constrained")
    if not rows:
        fig.text(0.5, 0.5, "no reconstructed frame", ha="center")
        return fig
    axes = np.atleast_2d(fig.subplots(len(rows), n_views))
    for ax_row, (frame, status, message, views) in zip(axes, rows):
        note = None
        if status != "ok" and message:
            first = str(message).split("; ")[0]
            note = "\n".join(textwrap.wrap(first, 30)[:6])
        _draw_views(ax_row, views, status=status, header=f"frame {frame}: {status}", note=note)
    fig.suptitle(title or "reconstruction projected onto the views (cyan centreline, magenta PWC)")
    return fig
