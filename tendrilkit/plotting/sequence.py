"""Figures over a sequence of frames and across sites: split points, curvature/torsion maps, shape change,
response fit, the site comparison and the cross-site composites (paper Figures 9-12)."""

from __future__ import annotations

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from tendrilkit.plotting.curves import _draw_evolution, _draw_tip
from tendrilkit.plotting.style import (
    OKABE_ITO,
    _check,
    _gapped,
    _letters,
    _minutes,
    _pick_frames,
    _size,
    _status_bands,
    _styled,
)


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
