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
paper: first frame blue and solid (circle), last vermillion and dashed (square),
the others along cividis; tip path black with its XY, YZ, XZ projections
orange, green, sky blue (Okabe-Ito, colour-blind safe); skeleton black,
reprojection sky blue, piece-wise clothoid orange dashed.

Journal sizes: widths :data:`SINGLE_MM` (85 mm) or :data:`DOUBLE_MM`
(180 mm), text 6.5-8 pt at that size, panel letters (a, b, ...), no baked-in
titles unless ``title=`` is given; :func:`tendrilkit.io.save_figure` writes
300 dpi PNG with vector PDF and SVG. Time axes are in minutes.
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

import matplotlib.pyplot as _plt  # noqa: E402,F401  (IPython display hooks)

try:  # load the backend now: the inline backend registers IPython's display of figures when it is imported
    _plt.switch_backend(matplotlib.rcParams["backend"])
except Exception:  # pragma: no cover - a broken backend setting: matplotlib will say so when drawing
    pass
from matplotlib.colors import TwoSlopeNorm  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from matplotlib.patches import Rectangle  # noqa: E402

#: rcParams every figure is built under (and io.save_figure saves under).
STYLE: dict = {
    "font.family": "DejaVu Sans",
    "font.size": 7.0,
    "axes.titlesize": 8.0,
    "axes.labelsize": 7.0,
    "xtick.labelsize": 6.5,
    "ytick.labelsize": 6.5,
    "axes.linewidth": 0.6,
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.4,
    "legend.fontsize": 6.5,
    "legend.frameon": False,
    "lines.linewidth": 1.0,
    "lines.markersize": 3.0,
    "image.cmap": "viridis",
    "figure.dpi": 150.0,
    "savefig.dpi": 300.0,
    "savefig.bbox": None,
    "svg.hashsalt": "tendrilkit",
    "svg.fonttype": "path",
    "pdf.fonttype": 42,
    "path.simplify": True,
    "axes.prop_cycle": matplotlib.cycler(color=["#0072B2", "#E69F00", "#009E73", "#D55E00", "#CC79A7",
                                                "#56B4E9", "#F0E442", "#000000"]),
}
#: Journal column widths (mm): single and double column.
SINGLE_MM, DOUBLE_MM = 85.0, 180.0
MM = 1.0 / 25.4
#: Okabe-Ito colours (colour-blind safe). First and last frame differ by colour, line style and marker.
OKABE_ITO = {"blue": "#0072B2", "orange": "#E69F00", "green": "#009E73", "vermillion": "#D55E00",
             "purple": "#CC79A7", "sky": "#56B4E9", "yellow": "#F0E442", "black": "#000000"}
FIRST_COLOR, LAST_COLOR = OKABE_ITO["blue"], OKABE_ITO["vermillion"]
FIRST_STYLE = dict(color=FIRST_COLOR, ls="-", marker="o")
LAST_STYLE = dict(color=LAST_COLOR, ls="--", marker="s")
PROJECTION_COLORS = {"XY": OKABE_ITO["orange"], "YZ": OKABE_ITO["green"], "XZ": OKABE_ITO["sky"]}
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


def _frame_colors(n: int, cmap: str = "cividis") -> list:
    """First blue, last vermillion, the others along ``cmap``."""
    if n == 1:
        return [FIRST_COLOR]
    cm = matplotlib.colormaps[cmap]
    cols = [cm(0.25 + 0.6 * i / max(n - 2, 1)) for i in range(n)]
    cols[0], cols[-1] = FIRST_COLOR, LAST_COLOR
    return cols


def _size(width: str | float = "double", height_mm: float = 60.0) -> tuple[float, float]:
    """Figure size (inches) for a journal column: ``"single"`` (85 mm), ``"double"`` (180 mm) or mm."""
    w = {"single": SINGLE_MM, "double": DOUBLE_MM}.get(width, width) if isinstance(width, str) else float(width)
    if isinstance(w, str):
        raise ValueError(f"width must be 'single', 'double' or a number of mm, got {width!r}")
    return w * MM, float(height_mm) * MM


def _letters(axes, *, start: int = 0) -> None:
    """Panel letters a, b, c ... in bold at the top left of each axes."""
    for k, ax in enumerate(axes):
        letter = "abcdefghijklmnopqrstuvwxyz"[(start + k) % 26]
        if hasattr(ax, "text2D"):  # 3D axes
            ax.text2D(0.0, 1.0, letter, transform=ax.transAxes, fontsize=9, fontweight="bold", ha="left", va="top")
        else:
            ax.text(-0.02, 1.02, letter, transform=ax.transAxes, fontsize=9, fontweight="bold", ha="right", va="bottom")


def _minutes(df: pd.DataFrame) -> tuple[np.ndarray, str]:
    if "time_s" in df.columns and df["time_s"].notna().all():
        return df["time_s"].to_numpy(float) / 60.0, "time after stimulus (min)"
    return df["frame"].to_numpy(float), "frame"


# ------------------------------------------------------------------ sequence figures
@_styled
def plot_split_points(split: pd.DataFrame, *, y: str = "s_norm", title: str | None = None, ax_pair=None,
                      width: str | float = "single", frames: pd.DataFrame | None = None) -> Figure:
    """Breakpoints of the curvature (top) and torsion (bottom) laws over time (paper Figure 7).

    Parameters
    ----------
    split : DataFrame
        :func:`tendrilkit.sequence.split_points` (``frame, kind, s_mm, s_norm``, optional ``time_s``, ``point``).
        The time axis is in minutes when ``time_s`` is present, else frames.
    y : {"s_norm", "s_mm", "point"}
        Position along the tendril shown on the vertical axis.
    frames : DataFrame, optional
        ``frames.csv``: doubtful (orange, hatched) and failed (grey) frames shaded.
    """
    _check(split, ("frame", "kind", y), "split")
    fig = Figure(figsize=_size(width, 70), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    _draw_split(axes, split, y)
    for ax in axes:
        _status_bands(ax, frames, x_time="time_s" in split.columns and bool(split["time_s"].notna().all()))
    _letters(axes)
    if title:
        fig.suptitle(title)
    return fig


def _draw_split(axes, split: pd.DataFrame, y: str, *, labels: bool = True) -> None:
    names = {"s_norm": "(0 base, 1 tip)", "s_mm": "(mm)", "point": "(point)"}
    for ax, kind, name, col in zip(axes, ("kappa", "tau"), ("κ", "τ"), (OKABE_ITO["blue"], OKABE_ITO["vermillion"])):
        d = split[split["kind"] == kind]
        x, xlabel = _minutes(d)
        ax.scatter(x, d[y], s=3, color=col, linewidths=0)
        if labels:
            ax.set_ylabel(f"{name} split points\n{names.get(y, y)}")
        if y == "s_norm":
            ax.set_ylim(0, 1)
    axes[-1].set_xlabel(xlabel if len(split) else "time after stimulus (min)")


def _map_limits(maps_list, percentile: float) -> tuple[float, float]:
    K = np.concatenate([np.abs(np.asarray(m.kappa) * m.kappa_scale).ravel() for m in maps_list])
    T = np.concatenate([np.abs(np.asarray(m.tau) * m.tau_scale).ravel() for m in maps_list])
    K, T = K[np.isfinite(K)], T[np.isfinite(T)]
    kv = float(np.percentile(K, percentile)) if K.size else 1.0
    tv = float(np.percentile(T, percentile)) if T.size else 1.0
    return (kv if kv > 0 else 1.0), (tv if tv > 0 else 1.0)


def _draw_maps(axes, maps, kv: float, tv: float, *, undefined_fraction: float, fig, colorbars: bool, labels: bool):
    s = np.asarray(maps.s_norm)
    K = np.asarray(maps.kappa) * maps.kappa_scale
    T = np.asarray(maps.tau) * maps.tau_scale
    t = np.asarray(maps.time_s, dtype=float)
    x, xlabel = (t / 60.0, "time after stimulus (min)") if t.size and np.all(np.isfinite(t)) else \
        (np.asarray(maps.frame, float), "frame")
    T = np.where(np.abs(K) < undefined_fraction * kv, np.nan, T)  # torsion undefined where the curve is straight
    signed_k = np.nanmin(K) < 0 if np.isfinite(K).any() else False
    meshes = []
    for ax, M, name, v, signed in ((axes[0], K, "curvature κ (1/mm)", kv, signed_k),
                                   (axes[1], T, "torsion τ (1/mm)", tv, True)):
        ax.set_facecolor("#d9d9d9")  # masked (undefined or excluded) cells show grey
        if M.shape[1] == 0:
            continue
        kw = dict(cmap="RdBu_r", vmin=-v, vmax=v) if signed else dict(cmap="viridis", vmin=0, vmax=v)
        mesh = ax.pcolormesh(x, s, np.ma.masked_invalid(M), shading="nearest", rasterized=True, **kw)
        ax.grid(False)
        meshes.append(mesh)
        if colorbars:
            cb = fig.colorbar(mesh, ax=ax, extend="both" if signed else "max", pad=0.01)
            cb.set_label(name)
        if labels:
            ax.set_ylabel("position (0 base, 1 tip)")
    axes[-1].set_xlabel(xlabel)
    return meshes


@_styled
def plot_kt_maps(maps, *, title: str | None = None, percentile: float = 99.0, limits: tuple | None = None,
                 undefined_fraction: float = 0.05, width: str | float = "single") -> Figure:
    """Curvature and torsion along the normalised length over time (paper Figure 8).

    Parameters
    ----------
    maps : :class:`tendrilkit.sequence.KTMaps`
        Drawn in 1/mm (``kappa * kappa_scale``); NaN columns (excluded frames) grey.
    percentile : float
        Colour limits at this percentile of the absolute values (robust to
        one-frame spikes); values beyond saturate (``extend`` arrows).
    limits : (float, float), optional
        Colour limits (κ, τ) in 1/mm, e.g. shared across sites.
    undefined_fraction : float
        Torsion is masked (grey) where |κ| is below this fraction of the κ limit:
        a nearly straight stretch has no defined torsion.
    """
    kv, tv = limits if limits is not None else _map_limits([maps], percentile)
    fig = Figure(figsize=_size(width, 75), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    _draw_maps(axes, maps, kv, tv, undefined_fraction=undefined_fraction, fig=fig, colorbars=True, labels=True)
    _letters(axes)
    if title:
        fig.suptitle(title)
    return fig


def _draw_tip(fig, spec, P: np.ndarray, *, label_axes: bool = False):
    ax3 = fig.add_subplot(spec, projection="3d")
    ax3.plot(P[:, 0], P[:, 1], P[:, 2], color="black", lw=0.9)
    if len(P):
        lo = P.min(axis=0)
        for name, (x, y, z) in {"XY": (P[:, 0], P[:, 1], np.full(len(P), lo[2])),
                                "YZ": (np.full(len(P), lo[0]), P[:, 1], P[:, 2]),
                                "XZ": (P[:, 0], np.full(len(P), lo[1]), P[:, 2])}.items():
            ax3.plot(x, y, z, color=PROJECTION_COLORS[name], lw=0.7, label=f"{name} projection")
        ax3.scatter(*P[0], color=FIRST_COLOR, marker="o", s=10, label="first")
        ax3.scatter(*P[-1], color=LAST_COLOR, marker="s", s=10, label="last")
        _equal_3d(ax3, P)
    if label_axes:
        ax3.set_xlabel("x (mm)", labelpad=-6)
        ax3.set_ylabel("y (mm)", labelpad=-6)
        ax3.set_zlabel("z (mm)", labelpad=-6)
    else:  # the labels of a small 3D panel collide with its neighbours: one line under it instead
        ax3.text2D(0.5, -0.02, "x, y, z (mm)", transform=ax3.transAxes, ha="center", va="top", fontsize=6.5)
    ax3.tick_params(pad=-2)
    return ax3


@_styled
def plot_tip_trajectory(traj: pd.DataFrame, *, title: str | None = None, width: str | float = "double") -> Figure:
    """The tip's 3D path (black) with its XY, YZ, XZ projections (paper Figure 9).

    First position: blue circle; last: vermillion square.
    """
    _check(traj, ("x_mm", "y_mm", "z_mm"), "traj")
    P = traj[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
    fig = Figure(figsize=_size(width, 55), layout="constrained")
    fig.get_layout_engine().set(wspace=0.06)
    gs = fig.add_gridspec(1, 4, width_ratios=(1.35, 1.0, 1.0, 1.0))
    ax3 = _draw_tip(fig, gs[0, 0], P)
    axes = [ax3]
    for k, (name, (i, j)) in enumerate((("XY", (0, 1)), ("YZ", (1, 2)), ("XZ", (0, 2)))):
        ax = fig.add_subplot(gs[0, k + 1])
        ax.plot(P[:, i], P[:, j], color=PROJECTION_COLORS[name])
        if len(P):
            ax.plot(P[0, i], P[0, j], "o", color=FIRST_COLOR, ms=3, label="first")
            ax.plot(P[-1, i], P[-1, j], "s", color=LAST_COLOR, ms=3, label="last")
        ax.set_xlabel(f"{'xyz'[i]} (mm)")
        ax.set_ylabel(f"{'xyz'[j]} (mm)")
        ax.set_aspect("equal", adjustable="datalim")
        axes.append(ax)
    axes[1].legend(loc="best")
    _letters(axes)
    if title:
        fig.suptitle(title)
    return fig


def _draw_evolution(ax, curves: pd.DataFrame, show: list[int]) -> None:
    allP = []
    for f, col in zip(show, _frame_colors(len(show))):
        P = curves[curves["frame"] == f].sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
        allP.append(P)
        end = f == show[0] or f == show[-1]
        t = curves.loc[curves["frame"] == f, "time_s"].iloc[0] / 60.0 if "time_s" in curves.columns else np.nan
        lab = (f"{t:.1f} min" if np.isfinite(t) else f"frame {f}") if end else None
        ax.plot(P[:, 0], P[:, 1], P[:, 2], color=col, lw=1.6 if end else 0.6, ls="--" if f == show[-1] and len(show) > 1 else "-",
                label=lab)
    if allP:
        _equal_3d(ax, np.vstack(allP))
    ax.tick_params(pad=-2)


@_styled
def plot_shape_evolution(curves: pd.DataFrame, *, frames: Sequence[int] | None = None, max_frames: int = 12,
                         title: str | None = None, width: str | float = "single") -> Figure:
    """Centrelines of a few frames in 3D (Figure 8 top): first blue solid, last vermillion dashed, between cividis."""
    _check(curves, ("frame", "point", "x_mm", "y_mm", "z_mm"), "curves")
    show = _pick_frames(curves["frame"].to_numpy(), frames, max_frames)
    fig = Figure(figsize=_size(width, 75), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    _draw_evolution(ax, curves, show)
    if show:
        ax.legend(loc="upper left")
    ax.set_xlabel("x (mm, gravity)", labelpad=-4)
    ax.set_ylabel("y (mm)", labelpad=-4)
    ax.set_zlabel("z (mm)", labelpad=-4)
    if title:
        ax.set_title(title)
    return fig


@_styled
def plot_shape_change(change: pd.DataFrame, response=None, *, measure: str | None = None,
                      title: str | None = None, width: str | float = "single",
                      frames: pd.DataFrame | None = None) -> Figure:
    """Shape change over time (minutes) with the response onset and stabilisation marked.

    Parameters
    ----------
    change : DataFrame
        :func:`tendrilkit.sequence.shape_change`.
    response : :class:`tendrilkit.sequence.ResponseTimes`, optional
        Adds the onset (dashed) and stabilisation (dotted) lines (its times
        on the table's time axis: the same ``stimulus_s``).
    measure : str, optional
        Column drawn in black; default the response's measure, else ``shape_mm``.
    frames : DataFrame, optional
        ``frames.csv``: its ``doubtful`` (orange, hatched) and ``failed``
        (grey) frames are shaded, and the lines break there instead of
        bridging them.
    """
    measure = measure or (response.measure if response is not None else "shape_mm")
    _check(change, ("frame", measure), "change")
    x, xlabel = _minutes(change)
    minutes = xlabel.startswith("time")
    names = {"shape_mm": "shape change", "mean_mm": "motion (mean distance)", "tip_displacement_mm": "tip displacement"}
    fig = Figure(figsize=_size(width, 55), layout="constrained")
    ax = fig.add_subplot()
    all_frames = None if frames is None else frames["frame"].to_numpy(int)
    kept = change["frame"].to_numpy(int)
    for col, color in (("mean_mm", "#9a9a9a"), ("tip_displacement_mm", "#c8c8c8")):
        if col in change.columns and col != measure:
            ax.plot(*_gapped(x, change[col].to_numpy(float), all_frames, kept), color=color, lw=0.7, label=names[col])
    ax.plot(*_gapped(x, change[measure].to_numpy(float), all_frames, kept), ".-", color="black", ms=2, lw=0.8,
            label=names.get(measure, measure))
    _status_bands(ax, frames, x_time=minutes)
    if response is not None:
        if response.responded and minutes:
            if np.isfinite(response.onset_s):
                ax.axvline(response.onset_s / 60, color=OKABE_ITO["orange"], ls="--",
                           label=f"onset {response.onset_s / 60:.1f} min")
            if np.isfinite(response.stable_s):
                ax.axvline(response.stable_s / 60, color=OKABE_ITO["green"], ls=":",
                           label=f"stable {response.stable_s / 60:.1f} min")
        elif not response.responded:
            ax.text(0.97, 0.5, "no response", transform=ax.transAxes, color=OKABE_ITO["vermillion"], ha="right",
                    va="center")
    ax.set_xlabel(xlabel)
    ax.set_ylabel("distance to the first frame (mm)")
    ax.set_ylim(bottom=min(0.0, float(np.nanmin(change[measure])) if len(change) else 0.0))
    ax.legend(loc="upper left")
    if title:
        ax.set_title(title)
    return fig


@_styled
def plot_response_fit(fit, *, true_onset_s: float | None = None, true_stable_s: float | None = None,
                      width: str | float = "single") -> Figure:
    """The response-time model (:func:`tendrilkit.response.fit_response_times`) over its two signals.

    Shape change from the first frame (black) and to the last frame (grey),
    the smooth steps fitted at each end (orange), the measured onset and
    stabilisation (dashed) and, on a phantom, the true ones (dotted).
    """
    t = np.asarray(fit.time_s, float) / 60.0
    fig = Figure(figsize=_size(width, 60), layout="constrained")
    ax = fig.add_subplot()
    ax.plot(t, fit.from_first_mm, ".-", color="black", ms=2, lw=0.7, label="change from the first frame")
    ax.plot(t, fit.to_last_mm, ".-", color="#8c8c8c", ms=2, lw=0.7, label="distance to the last frame")
    if np.isfinite(fit.model_first_mm).any():
        ax.plot(t, fit.model_first_mm, color=OKABE_ITO["orange"], lw=1.4, label="smooth step fitted")
        ax.plot(t, fit.model_last_mm, color=OKABE_ITO["orange"], lw=1.4)
    rt = fit.times
    if rt.responded:
        ax.axvline(rt.onset_s / 60, color=OKABE_ITO["blue"], ls="--", label=f"onset {rt.onset_s / 60:.1f} min")
        ax.axvline(rt.stable_s / 60, color=OKABE_ITO["vermillion"], ls="--", label=f"stable {rt.stable_s / 60:.1f} min")
    else:
        ax.text(0.97, 0.5, "no response", transform=ax.transAxes, color=OKABE_ITO["vermillion"], ha="right", va="center")
    for v, col, name in ((true_onset_s, OKABE_ITO["blue"], "true onset"), (true_stable_s, OKABE_ITO["vermillion"], "true stable")):
        if v is not None and np.isfinite(v):
            ax.axvline(v / 60, color=col, ls=":", lw=1.2, label=f"{name} {v / 60:.1f} min")
    ax.set_xlabel("time after stimulus (min)")
    ax.set_ylabel("shape change (mm)")
    ax.legend(loc="best", fontsize=6)
    return fig


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
def plot_site_comparison(table: pd.DataFrame, regions: pd.DataFrame | None = None, *, title: str | None = None,
                         reference_min: tuple[float, float] = (3.0, 12.0), width: str | float = "double") -> Figure:
    """The sites side by side: where each responded, when, and how far the tip went.

    Parameters
    ----------
    table : DataFrame
        :func:`tendrilkit.sequence.compare_sites` (``experiment, site,
        responded, onset_s, stable_s, amplitude_mm, tip_path_mm``).
    regions : DataFrame, optional
        ``experiment, site, region, deformation_mm`` (the
        :func:`tendrilkit.sequence.region_response` of each experiment): panel
        a shows every quarter's deformation per experiment, the stimulated
        quarter outlined. Without it, panel a shows the amplitude.
    reference_min : (float, float)
        The paper's response and stabilisation times (min), drawn as lines.
    """
    _check(table, ("experiment", "site", "responded", "onset_s", "stable_s", "amplitude_mm", "tip_path_mm"), "table")
    t = table.reset_index(drop=True)
    dup = t["site"].duplicated(keep=False) | (t["site"].astype(str) == "")
    labels = [f"{s}\n{e}" if d else str(s) for s, e, d in zip(t["site"], t["experiment"], dup)]
    x = np.arange(len(t))
    fig = Figure(figsize=_size(width, 60), layout="constrained")
    a1, a2, a3 = fig.subplots(1, 3, width_ratios=(1.6, 1.0, 0.8))
    resp = t["responded"].astype(bool).to_numpy()
    if regions is not None and len(regions):
        _check(regions, ("experiment", "region", "deformation_mm"), "regions")
        names = list(dict.fromkeys(regions["region"].tolist()))
        w = 0.8 / max(len(names), 1)
        cm = matplotlib.colormaps["cividis"]
        for ri, rn in enumerate(names):
            vals, edge = [], []
            for e, site in zip(t["experiment"], t["site"]):
                r = regions[(regions["experiment"] == e) & (regions["region"] == rn)]
                vals.append(float(r["deformation_mm"].iloc[0]) if len(r) else np.nan)
                edge.append(str(site) == str(rn))
            bars = a1.bar(x - 0.4 + w * (ri + 0.5), vals, width=w * 0.92, color=cm(0.1 + 0.8 * ri / max(len(names) - 1, 1)),
                          label=f"quarter {rn}", zorder=2)
            for b_, st in zip(bars, edge):
                if st:
                    b_.set_edgecolor(OKABE_ITO["vermillion"])
                    b_.set_linewidth(1.4)
        a1.set_ylabel("deformation first → last frame (mm)")
        a1.legend(loc="upper left", ncols=2, title="quarter (outlined: stimulated)", title_fontsize=6)
    else:
        bars = a1.bar(x, t["amplitude_mm"].astype(float), color=np.where(resp, OKABE_ITO["green"], "#bbbbbb"))
        for b_, r in zip(bars, resp):
            if not r:
                b_.set_hatch("//")
        a1.set_ylabel("shape change amplitude (mm)")
    a1.set_ylim(bottom=0)
    on = t["onset_s"].astype(float).to_numpy() / 60.0
    st = t["stable_s"].astype(float).to_numpy() / 60.0
    a2.plot(x, on, "o", color=OKABE_ITO["blue"], label="onset")
    a2.plot(x, st, "s", color=OKABE_ITO["vermillion"], label="stable")
    for v, col in zip(reference_min, (OKABE_ITO["blue"], OKABE_ITO["vermillion"])):
        a2.axhline(v, color=col, ls=":", lw=0.9)
        a2.text(-0.55, v, f"paper {v:g} min", color=col, va="bottom", ha="left", fontsize=6)
    for xi, r in zip(x, resp):
        if not r:
            a2.text(xi, 0.5, "no\nresponse", ha="center", va="bottom", fontsize=6, color="#555555")
    a2.set_ylim(0, max(15.0, float(np.nanmax(np.r_[st, on, 0.0])) + 1.0))
    a2.set_xlim(-0.6, len(t) - 0.4)
    a2.set_ylabel("time after stimulus (min)")
    a2.legend(loc="center left")
    a3.bar(x, t["tip_path_mm"].astype(float), color="#555555")
    a3.set_ylabel("tip path length (mm)")
    for ax in (a1, a2, a3):
        ax.set_xticks(x, labels)
        ax.grid(axis="x", visible=False)
    _letters((a1, a2, a3))
    if title:
        fig.suptitle(title)
    return fig


# ------------------------------------------------------------------ composites across sites
@_styled
def plot_split_points_sites(splits: dict, *, y: str = "s_norm") -> Figure:
    """Figure 7 across sites: split points of curvature (top row) and torsion (bottom row), one column per site."""
    n = max(len(splits), 1)
    fig = Figure(figsize=_size("double", 70), layout="constrained")
    axes = np.atleast_2d(fig.subplots(2, n, sharex="col", sharey=True, squeeze=False))
    for k, (name, split) in enumerate(splits.items()):
        _draw_split(axes[:, k], split, y, labels=(k == 0))
        axes[0, k].set_title(name)
    _letters(axes[0])
    return fig


@_styled
def plot_kt_maps_sites(maps: dict, curves: dict | None = None, *, percentile: float = 99.0,
                       undefined_fraction: float = 0.05, max_frames: int = 8) -> Figure:
    """Figure 8 across sites: the morphology (3D centrelines, top row), curvature and torsion maps.

    One column per site; colour limits shared by every site (``percentile``
    of all absolute values, 1/mm); torsion masked where the curvature is
    below ``undefined_fraction`` of the limit.
    """
    names = list(maps)
    n = max(len(names), 1)
    rows = 3 if curves else 2
    kv, tv = _map_limits([maps[k] for k in names], percentile) if names else (1.0, 1.0)
    fig = Figure(figsize=_size("double", 45 * rows), layout="constrained")
    gs = fig.add_gridspec(rows, n)
    top = []
    for k, name in enumerate(names):
        r0 = 0
        if curves:
            ax3 = fig.add_subplot(gs[0, k], projection="3d")
            c = curves[name]
            _draw_evolution(ax3, c, _pick_frames(c["frame"].to_numpy(), None, max_frames))
            ax3.set_title(name)
            if k == 0:
                ax3.legend(loc="upper left", fontsize=5.5)
            top.append(ax3)
            r0 = 1
        axk = fig.add_subplot(gs[r0, k])
        axt = fig.add_subplot(gs[r0 + 1, k], sharex=axk)
        if not curves:
            axk.set_title(name)
            top.append(axk)
        meshes = _draw_maps((axk, axt), maps[name], kv, tv, undefined_fraction=undefined_fraction, fig=fig,
                            colorbars=False, labels=(k == 0))
        if k == n - 1 and meshes:
            fig.colorbar(meshes[0], ax=axk, extend="max", pad=0.01).set_label("κ (1/mm)")
            if len(meshes) > 1:
                fig.colorbar(meshes[1], ax=axt, extend="both", pad=0.01).set_label("τ (1/mm)")
    _letters(top)
    return fig


@_styled
def plot_tip_trajectory_sites(trajectories: dict) -> Figure:
    """Figure 9 across sites: each site's tip path in 3D with its projections on the box walls."""
    n = max(len(trajectories), 1)
    fig = Figure(figsize=_size("double", 55), layout="constrained")
    gs = fig.add_gridspec(1, n)
    axes = []
    for k, (name, traj) in enumerate(trajectories.items()):
        ax = _draw_tip(fig, gs[0, k], traj[["x_mm", "y_mm", "z_mm"]].to_numpy(float))
        ax.set_title(name)
        axes.append(ax)
    if axes:
        axes[0].legend(loc="upper left", fontsize=5.5)
    _letters(axes)
    return fig


@_styled
def plot_penalty_fits(fits: dict) -> Figure:
    """Figure 10: measured curvature and torsion with the laws fitted under different penalties.

    Parameters
    ----------
    fits : dict label -> :class:`tendrilkit.pwc.PWCFit`
        e.g. ``{"ε = 0.001": fit_a, "ε = 0.1": fit_b}`` on the same frame.
    """
    fig = Figure(figsize=_size("double", 70), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    palette = [OKABE_ITO[k] for k in ("vermillion", "blue", "green", "purple", "orange")]
    styles = ["-", "--", "-.", ":", "-"]
    first = next(iter(fits.values()), None)
    if first is not None:
        s = np.asarray(first.s_mm)
        ok = np.asarray(first.frames.tau_defined, bool)
        axes[0].plot(s, first.frames.kappa, ".", color="0.6", ms=2, label="measured")
        axes[1].plot(s[ok], np.asarray(first.frames.tau)[ok], ".", color="0.6", ms=2, label="measured")
    for k, (label, f) in enumerate(fits.items()):
        s = np.asarray(f.s_mm)
        for ax, law, y in ((axes[0], f.kappa_law, f.kappa_fit), (axes[1], f.tau_law, f.tau_fit)):
            ax.plot(s, y, color=palette[k % len(palette)], ls=styles[k % len(styles)], lw=1.1,
                    label=f"{label}: {law.n_segments} segments")
    axes[0].set_ylabel("curvature κ (1/mm)")
    axes[1].set_ylabel("torsion τ (1/mm)")
    axes[1].set_xlabel("arc length s (mm)")
    for ax in axes:
        ax.legend(loc="upper left", ncols=2)
    _letters(axes)
    return fig


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
STATUS_COLORS = {"ok": OKABE_ITO["green"], "doubtful": OKABE_ITO["orange"], "failed": OKABE_ITO["vermillion"]}


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
                                   line=dict(color=col, width=5 if col in (FIRST_COLOR.lower(), LAST_COLOR.lower()) else 3,
                                             dash="dash" if col == LAST_COLOR.lower() else "solid")))
        if pwc is not None:
            Q = pwc[pwc["frame"] == f].sort_values("point")[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
            if len(Q):
                fig.add_trace(go.Scatter3d(x=Q[:, 0], y=Q[:, 1], z=Q[:, 2], mode="lines", name=f"PWC {f}",
                                           line=dict(color=col, width=2, dash="dot")))
    return _plotly_layout(fig, title)


__all__ = [
    "STYLE", "plot_split_points", "plot_kt_maps", "plot_tip_trajectory", "plot_tip_trajectory_3d_interactive",
    "plot_curves_3d_interactive", "plot_shape_evolution", "plot_shape_change", "plot_reprojection_bars",
    "plot_site_comparison", "plot_view_overlay", "plot_response_fit", "plot_split_points_sites", "plot_kt_maps_sites",
    "plot_tip_trajectory_sites", "plot_penalty_fits", "plot_reprojection_overlays", "plot_views", "plot_mask_overlay",
    "plot_pwc_fit", "plot_grid_search", "show_interactive", "SINGLE_MM", "DOUBLE_MM",
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
    fig = Figure(figsize=_size("single", 75), layout="constrained")
    axes = fig.subplots(2, 1, sharex=True)
    for ax, kind, meas, law, fitted in ((axes[0], "curvature κ (1/mm)", fr.kappa, fit.kappa_law, fit.kappa_fit),
                                        (axes[1], "torsion τ (1/mm)", fr.tau, fit.tau_law, fit.tau_fit)):
        ok = np.ones(len(s), bool) if ax is axes[0] else np.asarray(fr.tau_defined, bool)
        ax.plot(s[ok], np.asarray(meas)[ok], ".", color="0.55", ms=2.5, label="measured")
        if (~ok).any():
            ax.plot(s[~ok], np.asarray(meas)[~ok], ".", color="0.8", ms=2.5, label="undefined")
        ax.plot(s, fitted, color=OKABE_ITO["vermillion"], lw=1.2, label=f"piece-wise linear ({law.n_segments} segments)")
        for k in np.asarray(law.knots_mm)[1:-1]:
            ax.axvline(k, color=OKABE_ITO["vermillion"], lw=0.5, alpha=0.4)
        ax.set_ylabel(kind)
        ax.legend(loc="upper left")
    axes[1].set_xlabel("arc length s (mm)")
    axes[0].set_title(title or f"R² = {fit.r2:.5f}, SSE = {fit.sse_mm2:.3g} mm²")
    _letters(axes)
    return fig


@_styled
def plot_grid_search(grid) -> Figure:
    """The paper's penalty grid search (Figure 11): R² over each level's grid, the chosen cell marked.

    Every level has its own colour scale (R² differences shrink as the grid
    refines); the best cell of each level is outlined, the search's choice
    (the best over all levels) starred. The caption line says why it stopped.
    """
    levels = list(grid.levels)
    n = max(len(levels), 1)
    fig = Figure(figsize=_size("double", 55), layout="constrained")
    axes = np.atleast_1d(fig.subplots(1, n))
    for k, (ax, lev) in enumerate(zip(axes, levels)):
        pk, pt, r2 = np.asarray(lev.penalty_kappa), np.asarray(lev.penalty_tau), np.asarray(lev.r2)
        im = ax.pcolormesh(pt, pk, r2, shading="nearest", cmap="viridis")
        fig.colorbar(im, ax=ax, location="bottom", shrink=0.9, pad=0.02).set_label("R²")
        i, j = lev.best
        ax.plot([pt[j]], [pk[i]], "s", mfc="none", mec=OKABE_ITO["vermillion"], ms=7, mew=1.0)
        if np.isclose(pk[i], grid.penalty_kappa) and np.isclose(pt[j], grid.penalty_tau):
            ax.plot([pt[j]], [pk[i]], "*", color=OKABE_ITO["yellow"], mec="black", mew=0.4, ms=7)
        ax.set_title(f"level {k + 1}: best R² {r2[i, j]:.5f}")
        ax.set_xlabel("torsion penalty ε_τ")
        ax.set_ylabel("curvature penalty ε_κ")
        ax.grid(False)
    _letters(axes)
    fig.supxlabel(("converged: " if grid.converged else "stopped: ") + (getattr(grid, "reason", "") or ""), fontsize=6.5)
    return fig


class _Interactive:
    """A plotly figure for a notebook: HTML without plotly.js (the page loads one copy) and plotly's own mime type."""

    def __init__(self, fig, div_id: str):
        self.fig, self.div_id = fig, div_id

    def _repr_mimebundle_(self, include=None, exclude=None):
        html = self.fig.to_html(include_plotlyjs=False, full_html=False, div_id=self.div_id)
        return {"text/html": html, "application/vnd.plotly.v1+json": self.fig.to_plotly_json(),
                "text/plain": f"interactive figure {self.div_id}"}


def show_interactive(fig, *, name: str | None = None):
    """Display a plotly figure in a notebook, with a stable element id (the notebook is the same at every run).

    The output holds plotly's JSON (JupyterLab draws it with its plotly
    renderer) and an HTML ``div`` that needs plotly.js on the page: the
    report pages (:mod:`tendrilkit.reports`) load one offline copy; the
    figures saved by :func:`tendrilkit.io.save_figure` embed it.
    """
    title = name or (fig.layout.title.text if fig.layout.title and fig.layout.title.text else "figure")
    div_id = "tk-" + "".join(c if c.isalnum() else "-" for c in title.lower())[:40]
    return _Interactive(fig, div_id)
