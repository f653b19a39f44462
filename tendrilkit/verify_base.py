"""Checks of a reconstructed curve's start in one view: does it leave the base along the tendril?

The tendril leaves the base mark (a click at the keep-out box, which covers
the node where it joins the stem); the stem runs beside it, through the box
and out of the region of interest (ROI). A curve that sets off along the stem
or a leaf instead of the tendril is caught by where its first 30 px lie
(:func:`base_on_tendril`, used by :mod:`tendrilkit.verify`): on the dark
components that leave the base mark. Which those are:

* :func:`base_components`: the components at the base mark that do not reach
  the ROI's border (the stem and the node run out of the ROI, the tendril
  does not);
* :func:`thin_at_base`: those at the base mark whose line there is as thin
  as the thinnest one's. Clutter crossing the tendril (a twig, a petiole) or
  its own coil can join the tendril's component to the ROI's border; on
  random seeds 57 and 66 that left only the stem's stub as "leaving the
  base", and right curves were flagged. The stem is thicker than the
  tendril (2.9-4.6 mm against 0.8-2 mm on the random scenes).
"""

from __future__ import annotations

import numpy as np

from tendrilkit.evidence import ViewEvidence

__all__ = ["WIDE_RATIO", "base_reach", "near_base", "base_components", "thin_at_base", "base_on_tendril"]

#: A line whose width (or a skeleton pixel whose inside distance) exceeds this many times the tendril's is
#: clutter (a leaf's blob, the stem, a thicker shoot), not the tendril.
WIDE_RATIO = 1.5

#: Components within this distance of the keep-out box (px) are at the base (the box covers the node):
#: :func:`near_base`.
BOX_RIM_PX = 4.0


def base_reach(ev: ViewEvidence) -> float:
    """How far from the base mark a component is at the base, px: the keep-out box's half diagonal + 4 (3 without)."""
    return 3.0 if ev.keep_out is None else 0.5 * float(np.hypot(ev.keep_out[2], ev.keep_out[3])) + 4.0


def near_base(ev: ViewEvidence) -> np.ndarray:
    """Labels of the dark components with a pixel near the base mark (see :func:`base_components`).

    Near: within :func:`base_reach` of the mark, or within :data:`BOX_RIM_PX`
    of the keep-out box. The box covers the node where the tendril leaves the
    stem, the mark is a click at it: where the mark lies at one edge of the
    box, the tendril can leave from the other, farther from the mark than the
    reach (random seed 9238, multi-view, view 2: the tendril's component
    17 px from a mark at the box's left edge, the stem's stub beside the mark
    taken for the only component leaving the base; six right frames, mean
    error 0.06-0.10 mm, flagged at 0 % of their start on it). With the mark
    at the box's centre the reach covers the rim but for its corners.
    Re-checked offline (the same curves) on development seeds 0-20,
    9200-9239 and 9500-9538 (multi-view, 594 frames) it changes only those
    six frames; chain seeds 0-16 and the untouched 9740-9754 (multi-view)
    and 9740-9750 (chain): no frame changes; the site phantoms: identical.
    """
    L = ev.labels
    h, w = L.shape
    reach = base_reach(ev)
    bx, by = ev.base_point_xy - ev.roi_offset_xy
    r0, r1 = max(int(np.floor(by - reach)), 0), min(int(np.ceil(by + reach)) + 1, h)
    c0, c1 = max(int(np.floor(bx - reach)), 0), min(int(np.ceil(bx + reach)) + 1, w)
    if r1 <= r0 or c1 <= c0:
        return np.zeros(0, int)
    win = L[r0:r1, c0:c1]
    rr, cc = np.nonzero(win)
    out = np.unique(win[rr, cc][np.hypot(rr + r0 - by, cc + c0 - bx) <= reach])
    if ev.keep_out is not None:  # the base mark may be clicked at the box's edge: the box's rim too
        x, y, bw, bh = (np.asarray(ev.keep_out, float) - np.r_[ev.roi_offset_xy, 0, 0])
        m = BOX_RIM_PX
        r0, r1 = max(int(np.floor(y - m)), 0), min(int(np.ceil(y + bh + m)) + 1, h)
        c0, c1 = max(int(np.floor(x - m)), 0), min(int(np.ceil(x + bw + m)) + 1, w)
        if r1 > r0 and c1 > c0:
            rim = L[r0:r1, c0:c1]
            out = np.union1d(out, np.unique(rim[rim > 0]))
    return out


def base_components(ev: ViewEvidence, *, near: np.ndarray | None = None) -> np.ndarray:
    """Labels of the dark components that leave the base mark.

    Those with a pixel within the keep-out box's half diagonal plus 4 px of
    the base mark (3 px without a box) or within :data:`BOX_RIM_PX` of the
    box (:func:`near_base`), except those touching the ROI's
    border: the stem and the node run out of the ROI, the tendril does not
    (the ROI is the region it moves in). ``near``: :func:`near_base` of
    ``ev`` when the caller has it.
    """
    L = ev.labels
    border = np.unique(np.concatenate([L[0], L[-1], L[:, 0], L[:, -1]]))
    return np.setdiff1d(near_base(ev) if near is None else near, np.append(border, 0))


def base_on_tendril(ev: ViewEvidence, dense: np.ndarray, d: np.ndarray, tol: float, length_px: float = 30.0, *,
                     inside: np.ndarray | None = None, near: np.ndarray | None = None):
    """Fraction of the curve's first ``length_px`` (outside the keep-out box) on a component leaving the base.

    The components leaving the base mark are :func:`base_components` and,
    given ``inside`` ((h, w) float array: the distance of every foreground
    pixel of the ROI crop to the background, px), those at the base mark
    that reach the ROI's border but whose line near the base is as thin as
    the thinnest one there (:func:`thin_at_base`): the
    tendril's own component reaches the border where clutter crossing it (a
    twig, a petiole) or its coil does, while the stem it must not set off
    along is thicker than the tendril. None when no component leaves the
    base mark in this view: nothing to compare with. ``near``:
    :func:`near_base` of ``ev`` when the caller has it (computed once for
    both).
    """
    near = near_base(ev) if near is None else near
    comps = base_components(ev, near=near)
    if inside is not None:
        comps = np.union1d(comps, thin_at_base(ev, inside, near=near))
    if comps.size == 0 or len(dense) == 0:
        return None
    first = dense[: int(length_px)]
    dd = d[: int(length_px)]
    off = ev.roi_offset_xy
    h, w = ev.shape
    r = np.clip(np.rint(first[:, 1] - off[1]).astype(int), 0, h - 1)
    c = np.clip(np.rint(first[:, 0] - off[0]).astype(int), 0, w - 1)
    if len(first) == 0:
        return None
    rad = int(np.ceil(tol))
    # a sample is on a leaving component when one of its window's pixels (the (2 rad + 1)^2 pixels around it,
    # cut at the crop's edge) is: the window's offsets gathered at once (one isin on the samples' box, not one
    # per sample)
    r0, r1 = max(int(r.min()) - rad, 0), min(int(r.max()) + rad + 1, h)
    c0, c1 = max(int(c.min()) - rad, 0), min(int(c.max()) + rad + 1, w)
    on_comp = np.isin(ev.labels[r0:r1, c0:c1], comps)
    dr, dc = (a.ravel() for a in np.mgrid[-rad:rad + 1, -rad:rad + 1])
    rr, cc = r[:, None] + dr, c[:, None] + dc  # (samples, offsets)
    ok = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w)
    hit = (on_comp[np.clip(rr, r0, r1 - 1) - r0, np.clip(cc, c0, c1 - 1) - c0] & ok).any(axis=1)
    hit &= ~(dd > tol)
    return float(np.mean(hit))


def thin_at_base(ev: ViewEvidence, inside: np.ndarray, extra_px: float = 30.0, *,
                 near: np.ndarray | None = None) -> np.ndarray:
    """Labels of the components at the base mark whose line there is as thin as the thinnest one's.

    A component's line width at the base is twice the median inside
    distance of its skeleton pixels within the base mark's reach
    (:func:`near_base`) plus ``extra_px``, less one pixel; kept are those
    at most :data:`WIDE_RATIO` times the thinnest. The tendril leaves the
    base as the thinnest line there, the stem beside it is thicker (stems
    2.9-4.6 mm, tendrils 0.8-2 mm on the random scenes). ``near``:
    :func:`near_base` of ``ev`` when the caller has it.
    """
    near = near_base(ev) if near is None else near
    sk = ev.skeleton_xy
    if near.size == 0 or sk is None or len(sk) == 0:
        return np.zeros(0, int)
    off = ev.roi_offset_xy
    r, c = (sk[:, 1] - off[1]).astype(int), (sk[:, 0] - off[0]).astype(int)
    close = np.hypot(*(sk - ev.base_point_xy).T) <= base_reach(ev) + extra_px
    lab = ev.labels[r, c]
    # a line's width is about twice its skeleton's inside distance less one (the skeleton's own pixel)
    widths = {int(k): 2.0 * float(np.median(inside[r[m], c[m]])) - 1.0
              for k in near if (m := close & (lab == k)).any()}
    if not widths:
        return np.zeros(0, int)
    thinnest = min(widths.values())
    return np.array(sorted(k for k, wd in widths.items() if wd <= WIDE_RATIO * thinnest), int)
