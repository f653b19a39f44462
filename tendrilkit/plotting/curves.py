"""3D curves: the tip's path and the shape evolution (matplotlib), the same in plotly, and the display of a
plotly figure in a notebook (:func:`show_interactive`)."""

from __future__ import annotations

from typing import Sequence

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from tendrilkit.plotting.style import (
    FIRST_COLOR,
    LAST_COLOR,
    PROJECTION_COLORS,
    _check,
    _equal_3d,
    _frame_colors,
    _letters,
    _pick_frames,
    _size,
    _styled,
)


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

    Examples
    --------
    >>> import pandas as pd
    >>> traj = pd.DataFrame({"x_mm": [0.0, 1.0, 2.0], "y_mm": [0.0, 0.5, 0.7], "z_mm": [50.0, 51.0, 53.0]})
    >>> fig = plot_tip_trajectory(traj)
    >>> type(fig).__name__, len(fig.axes)  # the 3D path and its three projections
    ('Figure', 4)
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
