"""Figures of the paper from result tables: the only module importing matplotlib and plotly.

Every ``plot_*`` function takes tables or results of :mod:`tendrilkit.sequence`
and returns a figure (``matplotlib.figure.Figure`` or ``plotly.graph_objects.Figure``);
nothing here saves (see :func:`tendrilkit.io.save_figure`) or computes more
than what is drawn.

Matplotlib figures are made as plain ``Figure`` objects, not through pyplot:
they are not kept in pyplot's global list, are not shown twice in a notebook,
and are garbage-collected like any object. Importing this module selects the
non-interactive ``Agg`` backend only when no backend is set (a notebook's
inline backend, or ``MPLBACKEND``, is left alone); it also imports pyplot so
that IPython registers its display of figures.

Determinism: every figure is built under :data:`STYLE` (fixed fonts, sizes,
colours, ``svg.hashsalt``); no timestamps or random ids. Colours follow the
paper: first frame black, last red; tip path black with its XY, YZ, XZ
projections orange, green, blue; skeleton black, reprojection cyan.
"""

from __future__ import annotations

import functools
import os
import textwrap
from typing import Sequence

import matplotlib
import numpy as np
import pandas as pd


def _backend_unset() -> bool:
    if os.environ.get("MPLBACKEND"):
        return False
    getter = getattr(matplotlib.rcParams, "_get_backend_or_none", None)
    try:
        return getter() is None if getter is not None else False
    except Exception:  # pragma: no cover - private API changed
        return False


if _backend_unset():
    matplotlib.use("Agg")

import matplotlib.pyplot as _plt  # noqa: E402,F401  (resolves the backend; IPython display hooks)
from matplotlib.colors import TwoSlopeNorm  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

#: rcParams every figure is built under (and io.save_figure saves under).
STYLE: dict = {
    "font.family": "DejaVu Sans",
    "font.size": 9.0,
    "axes.titlesize": 10.0,
    "axes.labelsize": 9.0,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "legend.fontsize": 8.0,
    "legend.frameon": False,
    "lines.linewidth": 1.2,
    "image.cmap": "viridis",
    "figure.dpi": 100.0,
    "savefig.dpi": 150.0,
    "savefig.bbox": None,
    "svg.hashsalt": "tendrilkit",
    "svg.fonttype": "path",
    "pdf.fonttype": 42,
    "path.simplify": True,
    "axes.prop_cycle": matplotlib.cycler(color=["#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
                                                "#8c564b", "#e377c2", "#7f7f7f"]),
}
FIRST_COLOR, LAST_COLOR = "black", "red"
PROJECTION_COLORS = {"XY": "orange", "YZ": "green", "XZ": "blue"}
FRAME_SHADES = ("white", "#dcecf7", "#e6e6e6")   # the paper's bar plots: white, light blue, grey


def _styled(fn):
    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with matplotlib.rc_context(STYLE):
            return fn(*args, **kwargs)
    return wrapper


def _check(df, cols: Sequence[str], name: str) -> None:
    if not isinstance(df, pd.DataFrame):
        raise TypeError(f"{name} must be a pandas DataFrame, got {type(df).__name__}")
    missing = [c for c in cols if c not in df.columns]
    if missing:
        raise ValueError(f"{name}: missing column(s) {', '.join(missing)}; expected {', '.join(cols)}")


def _time_axis(df: pd.DataFrame) -> tuple[np.ndarray, str]:
    if "time_s" in df.columns and df["time_s"].notna().all():
        return df["time_s"].to_numpy(float) / 60.0, "time (min)"
    return df["frame"].to_numpy(float), "frame"


def _equal_3d(ax, P: np.ndarray) -> None:
    lo, hi = np.nanmin(P, axis=0), np.nanmax(P, axis=0)
    c, r = (lo + hi) / 2, max(float(np.max(hi - lo)) / 2, 1e-6)
    ax.set_xlim(c[0] - r, c[0] + r)
    ax.set_ylim(c[1] - r, c[1] + r)
    ax.set_zlim(c[2] - r, c[2] + r)
    ax.set_box_aspect((1, 1, 1))


def _pick_frames(all_frames: np.ndarray, frames: Sequence[int] | None, max_frames: int) -> list[int]:
    fr = np.unique(np.asarray(all_frames, dtype=int))
    if frames is not None:
        return [int(f) for f in frames if f in set(fr.tolist())]
    if len(fr) <= max_frames:
        return fr.tolist()
    idx = np.unique(np.rint(np.linspace(0, len(fr) - 1, max_frames)).astype(int))
    return fr[idx].tolist()


def _frame_colors(n: int, cmap: str = "viridis") -> list:
    """First black, last red, the others along ``cmap``."""
    if n == 1:
        return [FIRST_COLOR]
    cm = matplotlib.colormaps[cmap]
    cols = [cm(0.15 + 0.7 * i / max(n - 2, 1)) for i in range(n)]
    cols[0], cols[-1] = FIRST_COLOR, LAST_COLOR
    return cols


# ------------------------------------------------------------------ sequence figures
@_styled
def plot_split_points(split: pd.DataFrame, *, y: str = "s_norm", title: str | None = None,
                      frames: pd.DataFrame | None = None) -> Figure:
    """Breakpoints of the curvature (top) and torsion (bottom) laws over frames (paper Figure 7).

    Parameters
    ----------
    split : DataFrame
        :func:`tendrilkit.sequence.split_points` (``frame, kind, s_mm, s_norm``, optional ``point``).
    y : {"s_norm", "s_mm", "point"}
        Position along the tendril shown on the vertical axis.
    frames : DataFrame, optional
        ``frames.csv``: doubtful (orange, hatched) and failed (grey) frames shaded.
    """
    _check(split, ("frame", "kind", y), "split")
    fig = Figure(figsize=(6.4, 5.0), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    labels = {"s_norm": "normalised length (0 base, 1 tip)", "s_mm": "arc length (mm)", "point": "point index"}
    for ax, kind, name in zip(axes, ("kappa", "tau"), ("curvature", "torsion")):
        d = split[split["kind"] == kind]
        ax.scatter(d["frame"], d[y], s=4, color="#1f77b4" if kind == "kappa" else "#d62728", linewidths=0)
        ax.set_ylabel(labels.get(y, y))
        ax.set_title(f"{name} split points")
        if y == "s_norm":
            ax.set_ylim(0, 1)
        _status_bands(ax, frames, x_time=False)
    axes[-1].set_xlabel("frame")
    if title:
        fig.suptitle(title)
    return fig


@_styled
def plot_kt_maps(maps, *, title: str | None = None) -> Figure:
    """Normalised curvature and torsion along the normalised length over time (paper Figure 8).

    Parameters
    ----------
    maps : :class:`tendrilkit.sequence.KTMaps`
        NaN columns (excluded frames) are drawn blank.
    """
    s, K, T = np.asarray(maps.s_norm), np.asarray(maps.kappa), np.asarray(maps.tau)
    t = np.asarray(maps.time_s, dtype=float)
    if t.size and np.all(np.isfinite(t)):
        x, xlabel = t / 60.0, "time (min)"
    else:
        x, xlabel = np.asarray(maps.frame, dtype=float), "frame"
    fig = Figure(figsize=(7.0, 5.0), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    kmin = np.nanmin(K) if np.isfinite(K).any() else 0.0
    for ax, M, name, scale in ((axes[0], K, "curvature", maps.kappa_scale), (axes[1], T, "torsion", maps.tau_scale)):
        signed = name == "torsion" or kmin < 0
        kw = dict(cmap="RdBu_r", norm=TwoSlopeNorm(0.0, -1.0, 1.0)) if signed else dict(cmap="viridis", vmin=0, vmax=1)
        if M.shape[1] == 0:
            ax.set_title(f"{name}: no frames")
            continue
        mesh = ax.pcolormesh(x, s, np.ma.masked_invalid(M), shading="nearest", rasterized=False, **kw)
        ax.grid(False)
        cb = fig.colorbar(mesh, ax=ax)
        cb.set_label(f"normalised {name}")
        ax.set_ylabel("normalised length")
        ax.set_title(f"{name} / {scale:.4g} mm$^{{-1}}$ ({maps.source})")
    axes[-1].set_xlabel(xlabel)
    if title:
        fig.suptitle(title)
    return fig


@_styled
def plot_tip_trajectory(traj: pd.DataFrame, *, title: str | None = None) -> Figure:
    """The tip's 3D path (black) and its XY, YZ, XZ projections (orange, green, blue; paper Figure 9)."""
    _check(traj, ("x_mm", "y_mm", "z_mm"), "traj")
    P = traj[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
    fig = Figure(figsize=(8.0, 7.0), layout="constrained")
    ax3 = fig.add_subplot(2, 2, 1, projection="3d")
    ax3.plot(P[:, 0], P[:, 1], P[:, 2], color="black")
    if len(P):
        ax3.scatter(*P[0], color=FIRST_COLOR, marker="o", s=12)
        ax3.scatter(*P[-1], color=LAST_COLOR, marker="o", s=12)
        _equal_3d(ax3, P)
    ax3.set_xlabel("x (mm)")
    ax3.set_ylabel("y (mm)")
    ax3.set_zlabel("z (mm)")
    ax3.set_title("tip path")
    for k, (name, (i, j)) in enumerate((("XY", (0, 1)), ("YZ", (1, 2)), ("XZ", (0, 2)))):
        ax = fig.add_subplot(2, 2, k + 2)
        ax.plot(P[:, i], P[:, j], color=PROJECTION_COLORS[name])
        if len(P):
            ax.plot(P[0, i], P[0, j], "o", color=FIRST_COLOR, ms=3)
            ax.plot(P[-1, i], P[-1, j], "o", color=LAST_COLOR, ms=3)
        ax.set_xlabel(f"{'xyz'[i]} (mm)")
        ax.set_ylabel(f"{'xyz'[j]} (mm)")
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title(f"{name} projection")
    if title:
        fig.suptitle(title)
    return fig


@_styled
def plot_shape_evolution(curves: pd.DataFrame, *, frames: Sequence[int] | None = None, max_frames: int = 12,
                         title: str | None = None) -> Figure:
    """Centrelines of a few frames in 3D: first black, last red, between along viridis (Figure 8 top)."""
    _check(curves, ("frame", "point", "x_mm", "y_mm", "z_mm"), "curves")
    show = _pick_frames(curves["frame"].to_numpy(), frames, max_frames)
    fig = Figure(figsize=(6.0, 6.0), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    allP = []
    for f, col in zip(show, _frame_colors(len(show))):
        P = curves[curves["frame"] == f].sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
        allP.append(P)
        lw = 2.0 if col in (FIRST_COLOR, LAST_COLOR) else 0.9
        ax.plot(P[:, 0], P[:, 1], P[:, 2], color=col, lw=lw, label=f"frame {f}" if col in (FIRST_COLOR, LAST_COLOR) else None)
    if allP:
        _equal_3d(ax, np.vstack(allP))
        ax.legend(loc="upper left")
    ax.set_xlabel("x (mm, gravity)")
    ax.set_ylabel("y (mm)")
    ax.set_zlabel("z (mm)")
    ax.set_title(title or "shape evolution")
    return fig


@_styled
def plot_shape_change(change: pd.DataFrame, response=None, *, measure: str | None = None,
                      title: str | None = None, frames: pd.DataFrame | None = None) -> Figure:
    """Shape change over time with the response onset and stabilisation marked.

    Parameters
    ----------
    change : DataFrame
        :func:`tendrilkit.sequence.shape_change`.
    response : :class:`tendrilkit.sequence.ResponseTimes`, optional
        Adds the baseline and plateau (dotted), onset (dashed) and
        stabilisation (dotted) lines. Its times are drawn on the table's time
        axis: pass the same ``stimulus_s`` (0 by default).
    measure : str, optional
        Column drawn in black; default the response's measure, else ``shape_mm``.
        The motion (``mean_mm``) and the tip displacement are drawn in grey.
    frames : DataFrame, optional
        ``frames.csv``: its ``doubtful`` (orange, hatched) and ``failed``
        (grey) frames are shaded, and the lines break there instead of
        bridging them.
    """
    measure = measure or (response.measure if response is not None else "shape_mm")
    _check(change, ("frame", measure), "change")
    x, xlabel = _time_axis(change)
    scale = 60.0 if xlabel.startswith("time") else None
    names = {"shape_mm": "shape change (rigid motion removed)", "mean_mm": "motion (mean distance)",
             "tip_displacement_mm": "tip displacement"}
    fig = Figure(figsize=(7.0, 3.6), layout="constrained")
    ax = fig.add_subplot()
    all_frames = None if frames is None else frames["frame"].to_numpy(int)
    kept = change["frame"].to_numpy(int)
    for col, color in (("mean_mm", "#9a9a9a"), ("tip_displacement_mm", "#c8c8c8")):
        if col in change.columns and col != measure:
            ax.plot(*_gapped(x, change[col].to_numpy(float), all_frames, kept), color=color, lw=0.8, label=names[col])
    ax.plot(*_gapped(x, change[measure].to_numpy(float), all_frames, kept), ".-", color="black", ms=3, lw=0.9,
            label=names.get(measure, measure))
    _status_bands(ax, frames, x_time=xlabel.startswith("time"))
    if response is not None:
        for level in (response.baseline_mm, response.plateau_mm):
            if np.isfinite(level):
                ax.axhline(level, color="#1f77b4", lw=0.6, ls=":")
        if response.responded and scale is not None:
            if np.isfinite(response.onset_s):
                ax.axvline(response.onset_s / scale, color="#ff7f0e", ls="--",
                           label=f"onset {response.onset_s / 60:.1f} min")
            if np.isfinite(response.stable_s):
                ax.axvline(response.stable_s / scale, color="#2ca02c", ls=":",
                           label=f"stable {response.stable_s / 60:.1f} min")
        elif not response.responded:
            ax.text(0.98, 0.05, "no response", transform=ax.transAxes, color="#d62728", ha="right")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("distance to the first frame (mm)")
    ax.legend(loc="upper left")
    if title:
        ax.set_title(title)
    return fig


@_styled
def plot_reprojection_bars(table: pd.DataFrame, *, title: str | None = None) -> Figure:
    """Bar plot of a Table 1/2 (mean error with its standard deviation), frames shaded (paper Figures 5-6).

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
    fig = Figure(figsize=(9.0, 3.4), layout="constrained")
    axes = fig.subplots(1, 3, sharey=True)
    width = 0.8 / max(len(views), 1)
    cm = matplotlib.colormaps["tab10"]
    for ax, sec in zip(axes, sections):
        for k, f in enumerate(frames):
            ax.axvspan(k - 0.5, k + 0.5, color=FRAME_SHADES[k % len(FRAME_SHADES)], zorder=0, lw=0)
        for vi, v in enumerate(views):
            d = t[t["view"] == v].set_index("frame").reindex(frames)
            pos = np.arange(len(frames)) - 0.4 + width * (vi + 0.5)
            std = d.get(f"std_{sec}_px")
            ax.bar(pos, d[f"mean_{sec}_px"], width=width * 0.9, color=cm(vi),
                   yerr=None if std is None else std.to_numpy(float), capsize=2,
                   error_kw={"lw": 0.8}, label=f"view {v}", zorder=2)
        ax.set_xticks(range(len(frames)), [f"frame {f}" for f in frames])
        ax.set_xlim(-0.5, len(frames) - 0.5)
        ax.set_title({"base": "base section", "tip": "tip section", "entire": "entire"}[sec])
        ax.grid(axis="x", visible=False)
    axes[0].set_ylabel("error (px)")
    axes[-1].legend(loc="upper left")
    if title:
        fig.suptitle(title)
    return fig


@_styled
def plot_site_comparison(table: pd.DataFrame, *, title: str | None = None) -> Figure:
    """The cross-site table (:func:`tendrilkit.sequence.compare_sites`) as three panels.

    Amplitude of the shape change (hatched: no response), onset and
    stabilisation times, and tip path length, one bar per experiment,
    labelled ``site`` (and name when a site has several).
    """
    _check(table, ("experiment", "site", "responded", "onset_s", "stable_s", "amplitude_mm", "tip_path_mm"), "table")
    t = table.reset_index(drop=True)
    dup = t["site"].duplicated(keep=False) | (t["site"].astype(str) == "")
    labels = [f"{s}\n{e}" if d else str(s) for s, e, d in zip(t["site"], t["experiment"], dup)]
    x = np.arange(len(t))
    fig = Figure(figsize=(9.0, 3.4), layout="constrained")
    a1, a2, a3 = fig.subplots(1, 3)
    resp = t["responded"].astype(bool).to_numpy()
    bars = a1.bar(x, t["amplitude_mm"].astype(float), color=np.where(resp, "#2ca02c", "#bbbbbb"))
    for b, r in zip(bars, resp):
        if not r:
            b.set_hatch("//")
    a1.set_ylabel("shape change amplitude (mm)")
    a1.set_title("amplitude (grey: no response)")
    a2.bar(x - 0.2, t["onset_s"].astype(float) / 60.0, width=0.4, color="#ff7f0e", label="onset")
    a2.bar(x + 0.2, t["stable_s"].astype(float) / 60.0, width=0.4, color="#1f77b4", label="stable")
    a2.set_ylabel("time after stimulus (min)")
    a2.set_title("response times")
    a2.legend(loc="upper left")
    a3.bar(x, t["tip_path_mm"].astype(float), color="black")
    a3.set_ylabel("tip path length (mm)")
    a3.set_title("tip path")
    for ax in (a1, a2, a3):
        ax.set_xticks(x, labels)
        ax.grid(axis="x", visible=False)
    if title:
        fig.suptitle(title)
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


# ------------------------------------------------------------------ quality control (tendrilkit.verify)
STATUS_COLORS = {"ok": "#2ca02c", "doubtful": "#ff7f0e", "failed": "#d62728"}


def _status_bands(ax, frames: pd.DataFrame | None, *, x_time: bool) -> None:
    """Shade the frames that are not ``ok``: doubtful orange hatched, failed grey, half a frame each side.

    Nothing is bridged: the caller breaks its lines at these frames.
    """
    if frames is None or "status" not in frames.columns or not len(frames):
        return
    f = frames.sort_values("frame")
    x = f["time_s"].to_numpy(float) / 60.0 if (x_time and "time_s" in f.columns) else f["frame"].to_numpy(float)
    half = 0.5 * (float(np.median(np.diff(x))) if len(x) > 1 else 1.0)
    labelled = set()
    for xi, st in zip(x, f["status"].astype(str)):
        if st == "ok":
            continue
        style = ({"color": STATUS_COLORS["doubtful"], "alpha": 0.25, "hatch": "///"} if st == "doubtful"
                 else {"color": "#7f7f7f", "alpha": 0.35})
        ax.axvspan(xi - half, xi + half, lw=0, label=None if st in labelled else f"{st} frame", **style)
        labelled.add(st)


def _gapped(x: np.ndarray, y: np.ndarray, frames_all: np.ndarray | None, frames_kept: np.ndarray) -> tuple:
    """``x, y`` with a NaN inserted wherever a frame between two kept frames is missing (lines are not bridged)."""
    if frames_all is None or len(frames_kept) < 2:
        return x, y
    pos = np.searchsorted(np.sort(frames_all), frames_kept)
    gap = np.nonzero(np.diff(pos) > 1)[0]
    if not len(gap):
        return x, y
    return (np.insert(np.asarray(x, float), gap + 1, np.nan), np.insert(np.asarray(y, float), gap + 1, np.nan))


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


# ------------------------------------------------------------------ plotly (interactive, HTML)
def _go():
    import plotly.graph_objects as go

    return go


def _plotly_layout(fig, title: str | None):
    fig.update_layout(template="plotly_white", title=title, margin=dict(l=0, r=0, t=40 if title else 10, b=0),
                      scene=dict(aspectmode="data", xaxis_title="x (mm)", yaxis_title="y (mm)", zaxis_title="z (mm)"),
                      legend=dict(itemsizing="constant"))
    return fig


def plot_tip_trajectory_3d_interactive(traj: pd.DataFrame, *, title: str | None = None):
    """Interactive tip path (plotly): black path, XY / YZ / XZ projections on the box walls."""
    _check(traj, ("x_mm", "y_mm", "z_mm"), "traj")
    go = _go()
    P = traj[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
    text = [f"frame {f}" for f in traj["frame"]] if "frame" in traj.columns else None
    fig = go.Figure()
    fig.add_trace(go.Scatter3d(x=P[:, 0], y=P[:, 1], z=P[:, 2], mode="lines+markers", name="tip",
                               line=dict(color="black", width=4), marker=dict(size=2, color="black"), text=text))
    if len(P):
        lo = P.min(axis=0)
        walls = {"XY": (P[:, 0], P[:, 1], np.full(len(P), lo[2])),
                 "YZ": (np.full(len(P), lo[0]), P[:, 1], P[:, 2]),
                 "XZ": (P[:, 0], np.full(len(P), lo[1]), P[:, 2])}
        for name, (x, y, z) in walls.items():
            fig.add_trace(go.Scatter3d(x=x, y=y, z=z, mode="lines", name=name,
                                       line=dict(color=PROJECTION_COLORS[name], width=2)))
        for i, col, name in ((0, FIRST_COLOR, "first"), (-1, LAST_COLOR, "last")):
            fig.add_trace(go.Scatter3d(x=[P[i, 0]], y=[P[i, 1]], z=[P[i, 2]], mode="markers", name=name,
                                       marker=dict(size=5, color=col)))
    return _plotly_layout(fig, title)


def plot_curves_3d_interactive(curves: pd.DataFrame, pwc: pd.DataFrame | None = None, *,
                               frames: Sequence[int] | None = None, max_frames: int = 12,
                               title: str | None = None):
    """Interactive centrelines (plotly): first frame black, last red (Figure 8 top); PWC curves dashed."""
    _check(curves, ("frame", "point", "x_mm", "y_mm", "z_mm"), "curves")
    go = _go()
    show = _pick_frames(curves["frame"].to_numpy(), frames, max_frames)
    cols = [matplotlib.colors.to_hex(c) for c in _frame_colors(len(show))]
    fig = go.Figure()
    for f, col in zip(show, cols):
        P = curves[curves["frame"] == f].sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
        fig.add_trace(go.Scatter3d(x=P[:, 0], y=P[:, 1], z=P[:, 2], mode="lines", name=f"frame {f}",
                                   line=dict(color=col, width=5 if col in ("#000000", "#ff0000") else 3)))
        if pwc is not None:
            Q = pwc[pwc["frame"] == f].sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
            if len(Q):
                fig.add_trace(go.Scatter3d(x=Q[:, 0], y=Q[:, 1], z=Q[:, 2], mode="lines", name=f"PWC {f}",
                                           line=dict(color=col, width=2, dash="dash")))
    return _plotly_layout(fig, title)


__all__ = [
    "STYLE", "plot_split_points", "plot_kt_maps", "plot_tip_trajectory", "plot_tip_trajectory_3d_interactive",
    "plot_curves_3d_interactive", "plot_shape_evolution", "plot_shape_change", "plot_reprojection_bars",
    "plot_site_comparison", "plot_view_overlay",
]


# ------------------------------------------------------------------ stage figures (notebooks)
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


@_styled
def plot_pwc_fit(fit, *, title: str | None = None) -> Figure:
    """Measured curvature and torsion against arc length with the fitted laws (a :class:`~tendrilkit.pwc.PWCFit`).

    Torsion samples where it is undefined (curvature near zero) are drawn hollow;
    knots are vertical ticks.
    """
    fr = fit.frames
    s = np.asarray(fit.s_mm)
    fig = Figure(figsize=(7.0, 5.0), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    for ax, kind, meas, law, fitted in ((axes[0], "curvature κ (1/mm)", fr.kappa, fit.kappa_law, fit.kappa_fit),
                                        (axes[1], "torsion τ (1/mm)", fr.tau, fit.tau_law, fit.tau_fit)):
        ok = np.ones(len(s), bool) if ax is axes[0] else np.asarray(fr.tau_defined, bool)
        ax.plot(s[ok], np.asarray(meas)[ok], ".", color="0.55", ms=2.5, label="measured")
        if (~ok).any():
            ax.plot(s[~ok], np.asarray(meas)[~ok], ".", color="0.8", ms=2.5, label="undefined")
        ax.plot(s, fitted, color="red", lw=1.4, label=f"piece-wise linear ({law.n_segments} segments)")
        for k in np.asarray(law.knots_mm)[1:-1]:
            ax.axvline(k, color="red", lw=0.6, alpha=0.4)
        ax.set_ylabel(kind)
        ax.legend(loc="upper left")
    axes[1].set_xlabel("arc length s (mm)")
    fig.suptitle(title or f"R² = {fit.r2:.5f}, SSE = {fit.sse_mm2:.3g} mm²")
    return fig


@_styled
def plot_grid_search(grid) -> Figure:
    """The paper's penalty grid search (Figure 11): R² over each level's grid, the chosen cell marked."""
    levels = list(grid.levels)
    n = max(len(levels), 1)
    fig = Figure(figsize=(3.2 * n, 3.2), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, n))
    for ax, lev in zip(axes, levels):
        pk, pt, r2 = np.asarray(lev.penalty_kappa), np.asarray(lev.penalty_tau), np.asarray(lev.r2)
        im = ax.pcolormesh(pt, pk, r2, shading="nearest", cmap="viridis", vmin=max(float(np.nanmin(r2)), 0.9), vmax=1.0)
        i, j = lev.best
        ax.plot([pt[j]], [pk[i]], "s", mfc="none", mec="red", ms=9)
        ax.set_xlabel("ε_τ")
        ax.set_ylabel("ε_κ")
        ax.grid(False)
    fig.colorbar(im, ax=list(axes), label="R²", shrink=0.85)
    fig.suptitle(f"grid search: ε_κ = {grid.penalty_kappa:.3g}, ε_τ = {grid.penalty_tau:.3g}"
                 + ("" if grid.converged else " (not converged)"))
    return fig


def show_interactive(fig):
    """Display a plotly figure in a notebook as self-contained HTML with a stable element id.

    plotly.js comes from its CDN (a saved notebook stays small; the figures
    saved by :func:`tendrilkit.io.save_figure` embed it for offline use) and the notebook is the
    same at every run (plotly's default output carries a random id).
    """
    from IPython.display import HTML

    title = fig.layout.title.text if fig.layout.title and fig.layout.title.text else "figure"
    div_id = "tk-" + "".join(c if c.isalnum() else "-" for c in title.lower())[:40]
    return HTML(fig.to_html(include_plotlyjs="cdn", full_html=False, div_id=div_id))
