"""The house style of every figure: backend choice, rcParams (:data:`STYLE`), journal sizes, colours,
and the small helpers the figure families share (column checks, time axes, frame picks, panel letters)."""

from __future__ import annotations

import functools
import os
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
