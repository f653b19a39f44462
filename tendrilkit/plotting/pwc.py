"""Piece-wise clothoid figures: one fit against the data, the penalty grid search, penalty fits per site."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from tendrilkit.plotting.style import (
    OKABE_ITO,
    _letters,
    _size,
    _styled,
)


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
