"""Checks of a reconstructed curve's tip in one view: does the tendril end where the curve ends?

Two ways a curve's tip can be wrong while the rest of the curve lies on the
tendril (:mod:`tendrilkit.verify` applies both in every view):

* the curve stops short: the tendril's skeleton goes on beyond the projected
  tip (:func:`tip_continuation`);
* the curve stops short and only one view shows it: the tendril's last
  millimetres point towards the other cameras, foreshortened to a few pixels
  there; where that one view shows the rest both as skeleton and as tone
  ahead of the tip, on the open board, the curve stops short
  (:func:`open_tip_px`);
* the curve runs on past the tendril's end along clutter the tip touches (a
  leaf the tip rests on, a stem, a second tendril's blob): its last pixels lie
  on a dark region wider than the tendril (:func:`tip_wide_fraction`), where
  the images cannot show where the tendril ends. On random seed 214 (a hook
  whose tip rests on a leaf) the multi-view curve follows the leaf's middle
  12 mm past the true tip, on the tendril's pixels and covering its skeleton
  in every view.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable

import cv2
import numpy as np
from numba import njit

from tendrilkit.evidence import ViewEvidence

__all__ = ["TIP_PX", "tip_continuation", "tip_continuation_path", "skeleton_to_curve_px", "bounded_query", "on_wide", "tip_wide_fraction",
           "wide_run_px", "crossing_samples", "rim_lines", "local_inside_px", "open_tip_px", "open_tip_message",
           "failing_views"]

#: The curve's tip, in :func:`tip_wide_fraction`: its last this many pixels of projection (px).
TIP_PX = 20

#: A crossing (:func:`crossing_samples`): the largest angle between the line's direction before or after a
#: region wider than the tendril and the chord across it (degrees).
MAX_CROSSING_TURN_DEG = 30.0

#: A crossing: the largest ratio of the line's widths (median local inside distance) on the two sides.
MAX_CROSSING_WIDTH_RATIO = 1.5

#: A crossing: the region's depth across the curve (twice the largest local inside distance over the stretch)
#: over the stretch's length, at least. Development seeds 9240-9299 (stretches over 40 px): leaves the right
#: curves cross 0.43-1.05, bands of a shoot merged alongside the tendril 0.07-0.26.
MIN_CROSSING_DEPTH_FRAC = 0.35

#: A crossing leaves out only its deep samples: local inside distance above this many times the line's on the
#: two sides (w, the tendril's half width, about 4 px for a 5 px line). A band a shoot merged alongside the
#: tendril makes stays counted up to about 7 tendril widths wide (the test scenes' 15 px band: 2.2 w). A leaf's
#: entry and exit ramps (wide, not yet 5.5 w deep) stay counted too, about 2 x (5.5 - 1.5) w / sin(angle) px:
#: 36-41 px for a curve square to the leaf's edge (test scene), about 50 px at 45 deg, 70 px at 30 deg, under
#: the merged limit (80 px) down to about 30 deg. A small leaf on a band (radius 25 px on a 92 px band, 15 px
#: wide) leaves out 9 px: the band's pieces on both sides count as one run of 83 px (:func:`wide_run_px`); with
#: 5.0 w it left out 14 px (78 px, under the limit).
MIN_CROSSING_DEEP_RATIO = 5.5


def tip_continuation(ev: ViewEvidence, dense_xy: np.ndarray, cov_tol: float, *,
                     sk_dist: np.ndarray | None = None) -> float:
    """Length in px of the tendril's skeleton that goes on beyond the projected tip, unexplained.

    From the skeleton pixels near the projected tip (within ``cov_tol + 3``
    px) that the curve does not explain (farther than ``cov_tol``), the
    longest 8-connected path over unexplained skeleton pixels (steps of 1 or
    1.41 px). A curve that stops short of the tendril's tip (shrunk, or
    stuck at a crossing) leaves the rest of the tendril here; a right curve
    leaves 0 (or the few pixels of the skeleton's end spur).

    Parameters
    ----------
    ev : ViewEvidence
        With its skeleton.
    dense_xy : (n, 2) float array
        The projected curve, resampled every pixel, base to tip, full-image px.
    cov_tol : float
        A skeleton pixel within this distance of the curve is explained.
    sk_dist : (m,) float array, optional
        :func:`skeleton_to_curve_px` of ``ev``, ``dense_xy`` and ``cov_tol``,
        when the caller has it (the same query serves
        :func:`tendrilkit.verify_beyond.beyond_tip_px`).
    """
    return tip_continuation_path(ev, dense_xy, cov_tol, sk_dist=sk_dist)[0]


def tip_continuation_path(ev: ViewEvidence, dense_xy: np.ndarray, cov_tol: float, *,
                          sk_dist: np.ndarray | None = None) -> tuple[float, np.ndarray]:
    """:func:`tip_continuation`'s length (px) and its path: the skeleton pixels from the tip to the farthest.

    The path is (m, 2) float, full-image px, from the unexplained skeleton
    pixel near the tip where it starts to the one farthest along it (m = 0
    when nothing goes on); of equally far ones the first found.
    """
    sk = ev.skeleton_xy
    none = (0.0, np.zeros((0, 2)))
    if sk is None or len(sk) == 0 or len(dense_xy) == 0:
        return none
    dist = skeleton_to_curve_px(sk, dense_xy, cov_tol) if sk_dist is None else sk_dist
    free = ~np.isfinite(dist)
    # not restricted to a line of the tendril's width: where the tendril goes on merged with clutter (along a
    # shoot, over a leaf) its skeleton is wider, and a shrunk chain curve (random seed 214) went unflagged
    tip = dense_xy[-1]
    start = np.nonzero(free & (np.hypot(*(sk - tip).T) <= cov_tol + 3.0))[0]
    if len(start) == 0:
        return none
    # the unexplained pixels by their integer (x, y) (truncated, as int() does), from plain lists: a Python loop
    # over numpy rows costs about ten times as much
    at = np.flatnonzero(free)
    idx = dict(zip(map(tuple, sk[at].astype(np.int64).tolist()), at.tolist()))
    best = {int(i): 0.0 for i in start}
    came = {int(i): -1 for i in start}
    heap = [(0.0, int(i)) for i in start]
    steps = [(dx, dy, float(np.hypot(dx, dy))) for dx in (-1, 0, 1) for dy in (-1, 0, 1) if dx or dy]
    while heap:  # Dijkstra over the unexplained skeleton pixels (a few hundred at most)
        g, i = heapq.heappop(heap)
        if g > best[i]:
            continue
        x, y = int(sk[i, 0]), int(sk[i, 1])
        for dx, dy, w in steps:
            j = idx.get((x + dx, y + dy))
            if j is not None and g + w < best.get(j, np.inf):
                best[j] = g + w
                came[j] = i
                heapq.heappush(heap, (g + w, j))
    far = max(best, key=best.get)
    path = [far]
    while came[path[-1]] >= 0:
        path.append(came[path[-1]])
    return float(best[far]), np.asarray(sk[path[::-1]], float)


def skeleton_to_curve_px(sk_xy: np.ndarray, dense_xy: np.ndarray, cov_tol: float, *, tree=None) -> np.ndarray:
    """(m,) float: each skeleton pixel's distance to the projected curve, px, inf beyond ``cov_tol`` (+ 1e-9).

    ``sk_xy`` (m, 2) and ``dense_xy`` (n, 2, n >= 1) in the same pixels; a
    skeleton pixel with a finite distance is explained by the curve.
    ``tree``: ``cKDTree(dense_xy)`` when the caller has it.
    """
    return bounded_query(dense_xy, sk_xy, cov_tol + 1e-9, tree=tree)[0]


def bounded_query(tree_xy: np.ndarray, xy: np.ndarray, bound_px: float, *, tree=None) -> tuple[np.ndarray, np.ndarray]:
    """``cKDTree(tree_xy).query(xy, distance_upper_bound=bound_px)``, the points far from ``tree_xy`` left out.

    Only the points ``xy`` (m, 2) inside the box of ``tree_xy`` (n, 2, n >=
    1) grown by ``bound_px`` are queried: the others lie farther than the
    bound from every point of the tree and get what the query gives them
    (distance inf, index n). A skeleton's pixels away from the curve (the
    stem, clutter) cost nothing; the values are the whole query's, bit for
    bit (the same tree, each point queried alone). ``tree``:
    ``cKDTree(tree_xy)`` when the caller has it (several checks query the
    same curve; a tree built on the same points is the same tree).

    Returns
    -------
    dist : (m,) float array
        px, inf beyond ``bound_px``.
    index : (m,) int array
        The nearest point of ``tree_xy``, n beyond ``bound_px``.
    """
    from scipy.spatial import cKDTree

    xy = np.asarray(xy, float).reshape(-1, 2)
    lo = tree_xy.min(axis=0) - bound_px
    hi = tree_xy.max(axis=0) + bound_px
    near = np.flatnonzero((xy[:, 0] >= lo[0]) & (xy[:, 0] <= hi[0]) & (xy[:, 1] >= lo[1]) & (xy[:, 1] <= hi[1]))
    dist = np.full(len(xy), np.inf)
    index = np.full(len(xy), len(tree_xy), np.intp)
    if len(near):
        tree = cKDTree(tree_xy) if tree is None else tree
        dist[near], index[near] = tree.query(xy[near], distance_upper_bound=bound_px)
    return dist, index


def on_wide(ev: ViewEvidence, dense_xy: np.ndarray, inside_px: np.ndarray, radius_px: float, *,
            wide_ratio: float = 1.5, local_px: np.ndarray | None = None) -> np.ndarray:
    """(n,) bool: which samples of the projected curve lie on pixels wider than the tendril.

    A sample is on wide pixels when the largest inside distance (distance to
    the background) in the 3 x 3 pixels around it exceeds ``wide_ratio``
    times the tendril's half width ``radius_px`` (the median inside distance
    of the skeleton along the curve): inside a leaf's blob, the stem, or the
    tendril merged with clutter running alongside it, where the images do
    not show where the tendril's line is. The tendril's tip tapers: a curve
    ending on it is not on wide pixels.

    Parameters
    ----------
    ev : ViewEvidence
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, full-image px.
    inside_px : (h, w) float32 array
        Distance of every foreground pixel of the ROI crop to the background, px.
    radius_px : float
        The tendril's half width in this view, px (NaN: unknown, nothing is wide).
    wide_ratio : float
    local_px : (n,) float array, optional
        :func:`local_inside_px` of the samples, when the caller has it already.
    """
    if not (np.isfinite(radius_px) and radius_px > 0) or len(dense_xy) == 0:
        return np.zeros(len(dense_xy), bool)
    local = local_inside_px(ev, dense_xy, inside_px) if local_px is None else local_px
    return local > wide_ratio * radius_px


def local_inside_px(ev: ViewEvidence, xy: np.ndarray, inside_px: np.ndarray) -> np.ndarray:
    """The largest inside distance in the 3 x 3 pixels around each point (the crop's edge clamped).

    Parameters
    ----------
    ev : ViewEvidence
        The view's evidence (its ROI offset).
    xy : (n, 2) float array
        Full-image px.
    inside_px : (h, w) float32 array
        Distance of every foreground pixel of the ROI crop to the background, px.

    Returns
    -------
    (n,) float32 array
        px: about the line's half width where a point lies on it (0 off the foreground).
    """
    off = ev.roi_offset_xy
    r = np.rint(xy[:, 1] - off[1]).astype(np.int64)
    c = np.rint(xy[:, 0] - off[0]).astype(np.int64)
    return _max_3x3(np.asarray(inside_px, np.float32), r, c)


@njit(cache=True)
def _max_3x3(inside_px, r, c):  # pragma: no cover - compiled
    """(n,) float32: the largest of ``inside_px`` (float32) in the 3 x 3 pixels around each ``(r[k], c[k])``, the
    rows and columns clipped to the array (0 at least: the maximum of none is 0, as the plain one starts)."""
    h, w = inside_px.shape
    out = np.zeros(len(r), np.float32)
    for k in range(len(r)):
        m = np.float32(0.0)
        for dr in range(-1, 2):
            rr = min(max(r[k] + dr, 0), h - 1)
            for dc in range(-1, 2):
                v = inside_px[rr, min(max(c[k] + dc, 0), w - 1)]
                if v > m:
                    m = v
        out[k] = m
    return out


def tip_wide_fraction(wide: np.ndarray, on: np.ndarray, *, tip_px: int = TIP_PX) -> float | None:
    """Fraction of the curve's last ``tip_px`` samples (those ``on`` the dark pixels) that are ``wide`` (:func:`on_wide`).

    None when the view sees none of them on the dark pixels.
    """
    tip = wide[-tip_px:][on[-tip_px:]]
    return float(np.mean(tip)) if len(tip) else None


def wide_run_px(wide: np.ndarray, on: np.ndarray, *, exempt: np.ndarray | None = None) -> float:
    """The longest run of consecutive samples (px) on the dark pixels and ``wide`` (:func:`on_wide`).

    ``exempt`` (n,) bool, optional: samples left out (a region the curve crosses, :func:`crossing_samples`);
    they neither count nor break a run: the wide pieces on both sides of a leaf crossed on a band add up.

    Examples
    --------
    >>> wide = np.zeros(100, bool); wide[10:60] = True; on = np.ones(100, bool)
    >>> ex = np.zeros(100, bool); ex[30:40] = True
    >>> wide_run_px(wide, on), wide_run_px(wide, on, exempt=ex)
    (50.0, 40.0)
    """
    counted = wide & on
    if exempt is None:
        exempt = np.zeros(len(counted), bool)
    counted = counted & ~exempt
    best = 0
    for a, b in zip(*_runs(counted | exempt)):
        best = max(best, int(counted[a:b].sum()))
    return float(best)


def _runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Starts and ends (exclusive) of the runs of True in a 1D bool array."""
    d = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return np.flatnonzero(d == 1), np.flatnonzero(d == -1)


def crossing_samples(dense_xy: np.ndarray, wide: np.ndarray, on: np.ndarray, local_px: np.ndarray, *,
                     count_lines: Callable[[np.ndarray], int | None] | None = None, side_px: int = TIP_PX,
                     max_turn_deg: float = MAX_CROSSING_TURN_DEG, max_width_ratio: float = MAX_CROSSING_WIDTH_RATIO,
                     min_depth_frac: float = MIN_CROSSING_DEPTH_FRAC,
                     min_deep_ratio: float = MIN_CROSSING_DEEP_RATIO) -> np.ndarray:
    """(n,) bool: the deep wide samples (:func:`on_wide`) where the curve crosses a region wider than the tendril.

    A tendril passing behind a leaf (or in front of it, dark on dark) runs
    over the leaf's wide pixels, as does a curve running on along a leaf or a
    shoot merged with the tendril, or a curve going straight across a leaf
    onto another thin line (a twig) where the tendril bends away. What tells
    a crossing is that the tendril's line goes in and comes out and nothing
    else thin leaves the region, the curve going on as it went in. A stretch
    of the projected curve is a crossing when

    * its wide samples are separated by fewer than ``side_px`` thin samples
      (on the dark pixels, not wide), and ``side_px`` thin samples lie
      before it and after it: the curve enters the region and leaves it (a
      curve ending in it, along a leaf past the tip, does not);
    * the line before and the line after run straight through it: the
      directions of the ``side_px`` samples before and after each within
      ``max_turn_deg`` of the chord joining the two sides (a curve taking a
      turn inside the region, onto another line, is no crossing);
    * the line is as wide on both sides: median local inside distance
      (``local_px``, :func:`local_inside_px`) of the two sides within
      ``max_width_ratio`` of each other (a curve coming out on a thinner or
      thicker line is on another object);
    * the region is deep across the curve, not a band along it: twice the
      largest local inside distance over the stretch at least
      ``min_depth_frac`` times its length (a shoot merged alongside the
      tendril makes a band a few tendril widths wide, as long as they run
      together);
    * exactly two thin lines leave the region's rim where the tendril may
      go, the way in and the way out (``count_lines`` of the stretch's
      samples from its first wide sample to its last, :func:`rim_lines`:
      a stalk leading to the stem, or a stub, is not counted): a third (a
      twig the curve may have taken straight on while the tendril bends
      away inside the region) or a rim it cannot read (None) is no
      crossing. Without
      ``count_lines`` (None) this test is skipped.

    Of a crossing only the deep samples are left out: local inside distance
    above ``min_deep_ratio`` times the mean of the two sides' (the region's
    entry and exit ramps and a band the region lies on stay counted,
    :data:`MIN_CROSSING_DEEP_RATIO`).

    Parameters
    ----------
    dense_xy : (n, 2) float array
        The projected curve resampled every pixel, base to tip, px.
    wide, on : (n,) bool arrays
        Samples on pixels wider than the tendril; samples on the dark pixels
        (seen by the view).
    local_px : (n,) float array
        Each sample's local inside distance, px.
    count_lines : callable, optional
        ``count_lines(path_xy)`` with ``path_xy`` (m, 2) the stretch's
        samples from its first wide one to its last: the number of thin
        lines leaving the rim of the region they lie on, None where it
        cannot tell (:func:`rim_lines` of the view).

    Examples
    --------
    >>> xy = np.column_stack([np.arange(100.0), np.zeros(100)])
    >>> wide = np.zeros(100, bool); wide[40:60] = True
    >>> on = np.ones(100, bool); local = np.where(wide, 20 - 2 * np.abs(np.arange(100) - 49.5), 2.0)  # 38 px deep
    >>> int(crossing_samples(xy, wide, on, local).sum())  # in and out on the same straight line: its middle (> 11 px)
    8
    >>> int(crossing_samples(xy, wide, on, local, count_lines=lambda p: 3).sum())  # a third line leaves the rim
    0
    >>> int(crossing_samples(xy, wide, on, np.where(wide, 3.2, 3.0)).sum())  # a band 6.4 px deep along it
    0
    >>> wide[40:] = True  # runs on to the tip: no crossing
    >>> int(crossing_samples(xy, wide, on, np.where(wide, 9.0, 3.0)).sum())
    0
    """
    n = len(dense_xy)
    out = np.zeros(n, bool)
    thin = on & ~wide
    starts, ends = _runs(wide & on)
    if not len(starts):
        return out
    # a stretch: wide runs with fewer than side_px thin samples between them (a leaf's pale vein, two
    # leaves close together)
    t_starts, t_ends = _runs(thin)
    solid = np.zeros(n, bool)  # thin stretches of side_px samples or more
    for a, b in zip(t_starts, t_ends):
        if b - a >= side_px:
            solid[a:b] = True
    cos_max = np.cos(np.radians(max_turn_deg))
    for a, b in zip(*_runs(~solid)):
        w_idx = np.flatnonzero(wide[a:b] & on[a:b])
        if not len(w_idx):
            continue
        if a < side_px or b + side_px > n or not (solid[a - side_px:a].all() and solid[b:b + side_px].all()):
            continue  # not entered and left on the thin line (at the curve's base or tip)
        before = dense_xy[a - 1] - dense_xy[a - side_px]
        after = dense_xy[b + side_px - 1] - dense_xy[b]
        chord = dense_xy[b] - dense_xy[a - 1]
        norms = [np.linalg.norm(x) for x in (before, after, chord)]
        if min(norms) <= 0:
            continue
        before, after, chord = before / norms[0], after / norms[1], chord / norms[2]
        if float(before @ chord) < cos_max or float(after @ chord) < cos_max:
            continue
        w0 = float(np.median(local_px[a - side_px:a]))
        w1 = float(np.median(local_px[b:b + side_px]))
        if min(w0, w1) <= 0 or max(w0, w1) > max_width_ratio * min(w0, w1):
            continue
        if 2.0 * float(local_px[a:b].max()) < min_depth_frac * (b - a):
            continue  # a band along the curve (a shoot merged alongside the tendril), not a region it crosses
        deep = wide[a:b] & on[a:b] & (local_px[a:b] > min_deep_ratio * 0.5 * (w0 + w1))
        if not deep.any():
            continue
        if count_lines is not None and count_lines(dense_xy[a + w_idx[0]:a + w_idx[-1] + 1]) != 2:
            continue  # another thin line leaves the region (the curve may have taken it), or unreadable
        out[a:b] = deep
    return out


#: Another thin line leaving a crossed region's rim and ending free is a place the tendril may have gone on to its tip
#: (:func:`rim_lines`) unless its pixels number under this fraction of the longer line the curve enters or leaves by (a
#: leaf's stalk, a bud: dev seed 9248's leaf, a 45 px stub beside a tendril going on 150 px and more).
MIN_FREE_LINE_FRAC = 0.5


def rim_lines(ev: ViewEvidence, inside_px: np.ndarray, radius_px: float, path_xy: np.ndarray, *,
              wide_ratio: float = 1.5) -> int | None:
    """The number of thin lines leaving the rim of the wide region a stretch of the curve lies on (None: unknown).

    The region: the components of the view's core pixels (inside distance
    above ``wide_ratio * radius_px``) that the curve's samples ``path_xy``
    touch (within their 3 x 3 pixels, as :func:`on_wide`), with the path
    itself (the tendril between two leaves close together), grown by the
    core's reach ``R = ceil(wide_ratio * radius_px) + 2`` px (the object's
    margin). Its rim: the ring of pixels ``R`` to ``R + L`` px from the
    core and path, ``L = ceil(4 * radius_px) + 2`` (18 px for a 5 px line:
    the part of a pointed leaf's apex the growing leaves out stays inside it
    down to about 14 deg half angle; with ``2 * radius_px`` such an apex
    counted as a line). The thin pixels: dark
    pixels farther than ``R`` from every core pixel (not part of any wide
    object). A line leaving the rim: an 8-connected component of thin pixels
    in the ring reaching both its inner and its outer edge (a leaf's pointed
    apex, or a speck, reaches only one). Of more than two, the two nearest
    the curve's first and last samples are its way in and out; another
    counts only where the tendril may have gone on along it to a free tip:
    not where its thin line leads to another wide object (a leaf's stalk to
    the stem, a shoot) or to the ROI crop's edge, nor where it has fewer
    than ``MIN_FREE_LINE_FRAC`` times the pixels of the longer of the
    curve's two lines (a stalk's stub, a bud). The work is done on the
    region's box (plus ``R + L + 1`` px) clipped to the ROI crop (a line
    leaving where the view cannot see leads out of the ROI); None when the
    half width is unknown or the curve's way in and out are one line.

    Parameters
    ----------
    ev : ViewEvidence
    inside_px : (h, w) float32 array
        Distance of every foreground pixel of the ROI crop to the background, px.
    radius_px : float
        The tendril's half width in this view, px.
    path_xy : (m, 2) float array
        The curve's samples over the region, full-image px.
    wide_ratio : float
        As :func:`on_wide`.
    """
    from scipy import ndimage

    if not (np.isfinite(radius_px) and radius_px > 0) or len(path_xy) == 0:
        return None
    thr = wide_ratio * radius_px
    reach = int(np.ceil(thr)) + 2
    ring = int(np.ceil(4.0 * radius_px)) + 2
    h, w = inside_px.shape
    off = ev.roi_offset_xy
    r = np.rint(path_xy[:, 1] - off[1]).astype(int)
    c = np.rint(path_xy[:, 0] - off[0]).astype(int)
    if r.min() < 0 or c.min() < 0 or r.max() >= h or c.max() >= w:
        return None
    core = inside_px > thr
    labels, _ = ndimage.label(core, structure=np.ones((3, 3), bool))
    touched = np.unique(np.concatenate([labels[np.clip(r + dr, 0, h - 1), np.clip(c + dc, 0, w - 1)]
                                        for dr in (-1, 0, 1) for dc in (-1, 0, 1)]))
    touched = touched[touched > 0]
    r0, r1, c0, c1 = r.min(), r.max() + 1, c.min(), c.max() + 1
    boxes = ndimage.find_objects(labels)
    for k in touched:
        sr, sc = boxes[k - 1]
        r0, r1, c0, c1 = min(r0, sr.start), max(r1, sr.stop), min(c0, sc.start), max(c1, sc.stop)
    m = reach + ring + 1
    # clipped to the ROI crop: a line leaving where the view cannot see leads out of the ROI, as one reaching its edge
    r0, r1, c0, c1 = max(r0 - m, 0), min(r1 + m, h), max(c0 - m, 0), min(c1 + m, w)
    lab = labels[r0:r1, c0:c1]
    seed = np.isin(lab, touched)
    seed[r - r0, c - c0] = True
    d_region = ndimage.distance_transform_edt(~seed)
    d_core = ndimage.distance_transform_edt(~core[r0:r1, c0:c1])
    thin = (inside_px[r0:r1, c0:c1] > 0) & (d_core > reach)
    band = thin & (d_region > reach) & (d_region <= reach + ring)
    comps, n = ndimage.label(band, structure=np.ones((3, 3), bool))
    if n == 0:
        return 0
    idx = np.arange(1, n + 1)
    inner = ndimage.minimum(d_region, comps, idx)
    outer = ndimage.maximum(d_region, comps, idx)
    lines = idx[(inner <= reach + 1.5) & (outer >= reach + ring - 1.5)]
    if len(lines) <= 2:
        return int(len(lines))
    # more than two: the lines the curve enters and leaves by (nearest its first and last samples) and the others;
    # another line that leads to another wide object (a petiole to the stem, a shoot) or out of the ROI is no
    # place the tendril can have gone on to its free tip
    ends = [np.array([r[0] - r0, c[0] - c0]), np.array([r[-1] - r0, c[-1] - c0])]
    used = set()
    for e in ends:
        d = [float(np.min(np.hypot(*(np.argwhere(comps == k) - e).T))) for k in lines]
        used.add(int(lines[int(np.argmin(d))]))
    if len(used) < 2:
        return None
    other = core & ~np.isin(labels, touched)  # the wide objects not crossed here
    # the thin pixels over the whole crop, as ``thin`` on the box (exact distances to the core: the same pixels)
    thin_all = (inside_px > 0) & (cv2.distanceTransform((~core).astype(np.uint8), cv2.DIST_L2,
                                                        cv2.DIST_MASK_PRECISE) > reach)
    _, thin_lab, thin_box, _ = cv2.connectedComponentsWithStats(thin_all.astype(np.uint8), connectivity=8,
                                                                 ltype=cv2.CV_32S)

    def line_px(k):  # the thin pixels of the line a rim piece belongs to (none if the two readings disagree)
        ys, xs = np.nonzero(comps == k)
        labs = thin_lab[ys + r0, xs + c0]
        labs = labs[labs > 0]
        if not len(labs):
            return np.zeros(0, int), np.zeros(0, int)
        x, y, bw, bh = (int(a) for a in thin_box[labs[0], :4])  # its pixels, in raster order, from its box
        ys, xs = np.nonzero(thin_lab[y:y + bh, x:x + bw] == labs[0])
        return ys + y, xs + x

    def near_other(rows, cols):
        """Whether a wide object not crossed here lies within ``reach + 1.5`` px of a line's pixels: the exact
        distance transform of ``other`` on the line's box grown by more than that (a nearer pixel lies inside
        it, a farther one's distance stays above the limit: the whole crop's answer)."""
        m = int(np.ceil(reach + 1.5)) + 1
        y0, y1 = max(int(rows.min()) - m, 0), min(int(rows.max()) + m + 1, h)
        x0, x1 = max(int(cols.min()) - m, 0), min(int(cols.max()) + m + 1, w)
        sub = other[y0:y1, x0:x1]
        if not sub.any():
            return False
        d_other = cv2.distanceTransform((~sub).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
        return float(d_other[rows - y0, cols - x0].min()) <= reach + 1.5

    way_out = max(len(line_px(k)[0]) for k in used)  # the longer of the curve's two lines: the one it goes on along
    free = 0
    for k in lines:
        if int(k) in used:
            continue
        rows, cols = line_px(k)
        if not len(rows):
            return None  # cannot tell where this line goes
        border = rows.min() == 0 or cols.min() == 0 or rows.max() == h - 1 or cols.max() == w - 1
        if border or near_other(rows, cols):
            continue  # it leads to another wide object or out of the ROI
        if len(rows) < MIN_FREE_LINE_FRAC * way_out:
            continue  # a stub (a leaf's stalk, a bud) far shorter than the line the curve goes on along
        free += 1
    return 2 + free


def open_tip_px(continuation_px: float | None, tone_frac: float | None, object_px: float | None, *,
                max_tone_frac: float) -> float | None:
    """The tendril going on beyond the projected tip over the open board in one view, px (0: it does not).

    The tip continuation (:func:`tip_continuation`, px) counts where the
    image ahead of the tip is also as dark as the tendril
    (:func:`tendrilkit.verify_tone.tip_tone_frac` above ``max_tone_frac``)
    and no pixel wider than the tendril lies within reach ahead of it
    (:func:`tendrilkit.verify_object.tip_object_px` None): the skeleton and
    the tone agree that a line goes on, and it is no object's (a shoot or a
    leaf at the tip has its own skeleton and tone). A curve stopping 3-6 mm
    short of a tip whose last part points towards the other cameras shows it
    in one view only (development seeds 9805, 9806, 9808: 5-14 px of
    skeleton, 0.07-0.17 of the corridor), which the two-view tip checks let
    through. None where either figure was not read.

    Examples
    --------
    >>> open_tip_px(13.7, 0.17, None, max_tone_frac=0.05)
    13.7
    >>> open_tip_px(91.0, 0.2, 0.0, max_tone_frac=0.05)  # a shoot at the tip: its skeleton, not the tendril's
    0.0
    >>> open_tip_px(12.0, 0.0, None, max_tone_frac=0.05)  # a skeleton spur the image does not show as a line
    0.0
    """
    if continuation_px is None or tone_frac is None:
        return None
    if object_px is not None or not tone_frac > max_tone_frac:
        return 0.0
    return float(continuation_px)


def failing_views(figures: dict, stem: str, n_views: int, fails, *, min_views: int = 1) -> list[tuple[int, float]]:
    """``(view, figure)`` of the views whose ``<stem>_v<view>`` (1-based) is known and ``fails(figure)``, when
    ``min_views`` or more do, else [] (the per-view checks' messages: most need two views, where one view may
    see the tendril in front of an object or foreshortened).

    Examples
    --------
    >>> failing_views({"x_v1": 3.0, "x_v2": None, "x_v3": 9.0}, "x", 3, lambda x: x > 2)
    [(1, 3.0), (3, 9.0)]
    >>> failing_views({"x_v1": 3.0, "x_v3": 1.0}, "x", 3, lambda x: x > 2, min_views=2)
    []
    """
    hits = [(v, x) for v in range(1, n_views + 1) if (x := figures.get(f"{stem}_v{v}")) is not None and fails(x)]
    return hits if len(hits) >= min_views else []


def px_over_message(figures: dict, stem: str, n_views: int, limit_px: float, says: str) -> str | None:
    """The message ``says`` + the views whose ``<stem>_v<i>`` (px) exceeds ``limit_px`` in one view or more, else
    None (the one-view pixel checks: open tip, lone tip, bypass).

    Example
    -------
    >>> px_over_message({"x_v1": 12.0, "x_v2": 3.0}, "x", 2, 5.0, "tip: too far")
    'tip: too far in view 1 (12 px) (limit 5 px in one view)'
    """
    hits = failing_views(figures, stem, n_views, lambda x: x > limit_px)
    if not hits:
        return None
    return (says + " in " + ", ".join(f"view {v} ({x:.0f} px)" for v, x in hits)
            + f" (limit {limit_px:g} px in one view)")


def open_tip_message(figures: dict, n_views: int, limit_px: float) -> str | None:
    """The message when the tendril goes on over the open board beyond the tip (``open_tip_px_v<i>``) by more
    than ``limit_px`` in one view or more, else None."""
    return px_over_message(figures, "open_tip_px", n_views, limit_px,
                           "tip: the tendril goes on beyond the curve's tip over the open board (its skeleton and the "
                           "image's tone ahead of the tip, no object there)")
