"""Skeleton graph, pruning and base-to-tip ordering through self-crossings
(paper: "Ordering the Points"; stages 3-4 of ``../shared/REFERENCE_NOTES.md``).

:func:`order_skeleton` turns the tendril's mask of one view into an ordered
centreline, base to tip:

1. **Skeleton.** The mask is cropped to its bounding box and thinned
   (:func:`skimage.morphology.skeletonize`, strip by strip with overlapping
   margins: the same skeleton at 40 % of the cost for a diagonal tendril);
   the tube width ``w`` is the mask's area over the skeleton's length.
2. **Graph.** :class:`skan.Skeleton` splits the skeleton into *branches*
   (pixel paths between endpoints and junction pixels; about 2 ms on a 1080p
   view, well inside the 20 ms budget, so no hand-written graph). Spurs (a branch ending
   in an endpoint, attached to a junction, shorter than ``prune_px``) are
   removed, repeatedly. Junctions joined by a branch shorter than
   ``merge_width * w`` are one crossing (an X crossing thins to two Y
   junctions joined by a short branch); so are two junctions joined by a
   longer branch (up to 15 w) when their other branches continue straight
   through it (a shallow X crossing, whose middle is about
   ``w / tan(angle / 2)`` long). They are contracted into one node, and
   closed branches at a junction shorter than twice the merge length (pin
   holes) are dropped. Any other
   branch between two junctions (up to 15 w long) gets an optional *twin*:
   where the tendril runs along itself its two passes thin to one band, which
   the walk must take twice; the degrees' parity lets a complete walk use the
   twin only then.
3. **Walk.** From the endpoint nearest the base point, the walk follows
   branches; at a node with several unused branches it takes one (a
   *decision*) and every branch is used once: the tendril's centreline is an
   Euler trail of the graph (at an X crossing the tendril passes twice, in and
   out along opposite branches). Two rules pick the branch:

   - ``method="smooth"`` (default, any number of crossings): the turn of the
     tangent from the incoming branch to each candidate is measured; tangents
     are lines fitted (principal axis) to the ``tangent_window_px`` of
     skeleton just outside the junction zone (radius ``span/2 + zone_width *
     w`` around the crossing, grown along the branches to where the mask is a
     single tube again: inside, the skeleton bends toward the junction and
     says nothing about the tendril). A depth-first search tries candidates
     smoothest first and keeps, among the walks that use every branch, the
     one with the fewest twins (above) and then the smallest sum of turns
     (branch and bound); with one crossing that is the smoothest turn at it.
   - ``method="paper"`` (at most one crossing): the paper's sub-set cases.
     With a closed loop at the crossing and a tip branch (three sub-sets), the
     tip branch :math:`\\mathcal{S}_3` is the one whose far end is farthest
     from the crossing :math:`p_c` and comes last; the direction through the
     loop is chosen by the angle between lines fitted to the last :math:`N_1`
     skeleton points before :math:`p_c` and the first :math:`N_2` after it,

     .. math::

        \\alpha_j = \\operatorname{atan2}\\left(\\det[\\vec L_{N_1}; \\vec L_j],
        \\; \\vec L_{N_1} \\cdot \\vec L_j\\right), \\quad j = N_2, N_2^*,

     taking :math:`\\mathcal{S}_2` if :math:`|\\alpha_{N_2}| \\le
     |\\alpha_{N_2^*}|`. (The paper's equation compares the signed angles,
     which picks the right loop direction only for one sense of rotation; the
     magnitudes are what its text and figure describe.) :math:`N_1 = N_2 =`
     ``tangent_window_px`` points. The first complete walk in this
     preference is taken.

   Every decision is recorded (:class:`Decision`) and can be overridden:
   ``overrides`` entries ``{frame, view, junction, branch}`` force, at the
   ``junction``-th decision met (0-based) of that frame and view, the
   ``branch``-th candidate (0-based, candidates listed smoothest first).
4. **Centreline.** Along the walk, the skeleton inside every junction zone is
   replaced by a cubic Hermite bridge between the tangents of the branches
   just outside it (the skeleton bends toward the junction; the bridge
   follows the tendril). The ends are extended along their tangents to the
   mask boundary: the skeleton of a tube stops short of a cut end (the base at
   the keep-out box) by about the half-width; at the tip the extension stops
   ``tip_inset`` half-widths before the boundary (a disc-capped tube's
   skeleton reaches its true end). A walk that ends in a crossing (the tip
   crosses the tendril and stops a few pixels beyond it, a stub the pruning
   removed) continues along its tangent through the crossing to the end of
   the stub. The path is smoothed
   (Gaussian, ``smooth_px``) and resampled every pixel of arc length.

:func:`process_view` is segmentation (:func:`tendrilkit.segmentation.segment_view`)
followed by :func:`order_skeleton`.

Failures are named exceptions: :class:`~tendrilkit.exceptions.EmptySkeletonError`
(nothing to order), :class:`~tendrilkit.exceptions.AmbiguousOrderingError` (no
endpoint to start from, a walk that leaves a long part of the skeleton unused,
an override that does not fit, more than one crossing with ``method="paper"``).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any, Iterable, Mapping

import cv2
import numpy as np
import skan
from scipy.ndimage import gaussian_filter1d
from skimage.morphology import skeletonize

from tendrilkit.exceptions import AmbiguousOrderingError, EmptySkeletonError
from tendrilkit.segmentation import segment_view

__all__ = ["Decision", "OrderedCenterline", "ViewCenterline", "compare_centerlines", "order_skeleton", "process_view"]

_MAX_STEPS = 5000  # cap on the depth-first search over walks
_SHALLOW_X_WIDTHS = 15.0  # longest middle of a shallow X crossing, in tube widths (about 8 deg)


@dataclass(frozen=True, eq=False)
class Decision:
    """One choice of branch at a junction.

    Attributes
    ----------
    frame, view : int
        Frame (0-based) and view (1-based).
    junction : int
        Index of this decision among the decisions of the walk, in the order
        met (0-based); the ``junction`` of an override.
    junction_xy : (2,) float array
        Centre of the junction (crossing), full-image pixels.
    candidates : tuple of (int, float)
        ``(branch_id, angle_deg)`` for every unused branch leaving the
        junction, smoothest first: ``angle_deg`` is the signed turn from the
        incoming tangent to the branch's tangent (degrees, positive
        counter-clockwise in image axes). ``branch_id`` indexes
        :attr:`OrderedCenterline.branches_xy`; a closed branch (loop) leaving
        and returning to the junction appears twice, the reversed direction as
        ``-1 - branch_id``.
    chosen : int
        Index of the chosen candidate (the ``branch`` of an override).
    method : str
        ``smooth``, ``paper`` or ``override``.
    """

    frame: int
    view: int
    junction: int
    junction_xy: np.ndarray
    candidates: tuple
    chosen: int
    method: str

    def as_dict(self) -> dict:
        """Plain data (for JSON/CSV), e.g. to write the decisions of a run."""
        return {
            "frame": int(self.frame),
            "view": int(self.view),
            "junction": int(self.junction),
            "junction_x_px": float(self.junction_xy[0]),
            "junction_y_px": float(self.junction_xy[1]),
            "candidates": [[int(b), round(float(a), 2)] for b, a in self.candidates],
            "chosen": int(self.chosen),
            "method": self.method,
        }


@dataclass(frozen=True, eq=False)
class OrderedCenterline:
    """The ordered 2D centreline of one view.

    Attributes
    ----------
    points_xy : (n, 2) float array
        Full-image pixels (distorted, as observed), base (row 0) to tip, about
        one pixel apart.
    decisions : tuple of Decision
        Every branch choice of the walk, in the order met.
    n_crossings : int
        Junctions the walk passes more than once (self-crossings; a tip
        touching the tendril counts, and a band where the tendril runs along
        itself, walked twice between two junctions, counts once).
    width_px : float
        Tube width estimated from the skeleton's distance transform.
    branches_xy : tuple of (k, 2) float arrays
        The pruned skeleton's branches (full-image pixels), indexed by the
        ``branch_id`` of the decisions.
    unused_px : float
        Skeleton length the walk left out (0 for a complete walk).
    """

    points_xy: np.ndarray
    decisions: tuple
    n_crossings: int
    width_px: float
    branches_xy: tuple
    unused_px: float


@dataclass(frozen=True, eq=False)
class ViewCenterline:
    """Result of :func:`process_view` for one view and frame.

    Attributes
    ----------
    points_xy : (n, 2) float array
        Ordered centreline base to tip, full-image (distorted) pixels.
    centroid_xy : (2,) float array
        Centroid of the tendril's mask (the next frame's tracking point).
    decisions : tuple of Decision
    n_crossings : int
    area_px : int
        Pixels of the tendril's mask.
    width_px : float
        Estimated tube width, pixels.
    """

    points_xy: np.ndarray
    centroid_xy: np.ndarray
    decisions: tuple
    n_crossings: int
    area_px: int
    width_px: float


# ---------------------------------------------------------------------------
# skeleton


def _skeletonize_strips(mask_u8: np.ndarray, strip: int = 96) -> np.ndarray:
    """:func:`skimage.morphology.skeletonize` of a mask, strip by strip.

    Zhang-Suen thinning costs in proportion to the array's area, and a
    diagonal tendril fills a small part of its bounding box (9 ms for a
    400 x 800 px box on a 1080p phantom view). Each horizontal strip of
    ``strip`` rows is thinned with ``margin`` extra rows above and below,
    cropped to the columns its rows use; a pixel depends only on pixels within
    one pixel per sub-iteration, and the sub-iterations are about the mask's
    thickness, so a margin of three thicknesses (at least 24 px) gives the
    same skeleton as the whole box (no pixel differs on 96 phantom frames of
    the four sites) at about 40 % of the cost.
    """
    H, W = mask_u8.shape
    if H <= 2 * strip:
        return skeletonize(mask_u8.astype(bool))
    contours, _ = cv2.findContours(mask_u8, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    perimeter = sum(cv2.arcLength(c, True) for c in contours)
    thickness = 2.0 * float(np.count_nonzero(mask_u8)) / max(perimeter, 1.0)
    margin = max(24, int(np.ceil(3 * thickness)) + 4)
    rows_any = mask_u8.any(axis=1)
    out = np.zeros((H, W), bool)
    for r0 in range(0, H, strip):
        r1 = min(r0 + strip, H)
        if not rows_any[r0:r1].any():
            continue
        a0, a1 = max(r0 - margin, 0), min(r1 + margin, H)
        band = mask_u8[a0:a1]
        cols = np.flatnonzero(band.any(axis=0))
        c0, c1 = max(cols[0] - 1, 0), min(cols[-1] + 2, W)
        out[r0:r1, c0:c1] = skeletonize(band[:, c0:c1].astype(bool))[r0 - a0 : r1 - a0]
    return out


# ---------------------------------------------------------------------------
# graph


class _Graph:
    """Nodes (xy, kind) and branches (u, v, pixel path xy) of a skeleton."""

    def __init__(self) -> None:
        self.node_xy: list[np.ndarray] = []
        self.node_junction: list[bool] = []  # came from junction pixels
        self.node_span: list[float] = []
        self.edges: list[list] = []  # [u, v, pts_xy (k, 2), length]

    def degrees(self) -> np.ndarray:
        deg = np.zeros(len(self.node_xy), int)
        for u, v, _, _ in self.edges:
            deg[u] += 1
            deg[v] += 1
        return deg


def _path_length(pts: np.ndarray) -> float:
    return float(np.hypot(*np.diff(pts, axis=0).T).sum()) if len(pts) > 1 else 0.0


def _build_graph(skel: np.ndarray) -> _Graph:
    S = skan.Skeleton(skel, keep_images=False)
    coords_xy = S.coordinates[:, ::-1].astype(float)
    deg = S.degrees
    g = _Graph()
    index: dict[int, int] = {}

    def node(pix: int) -> int:
        if pix not in index:
            index[pix] = len(g.node_xy)
            g.node_xy.append(coords_xy[pix].copy())
            g.node_junction.append(bool(deg[pix] >= 3))
            g.node_span.append(0.0)
        return index[pix]

    for path in S.paths_list():
        path = np.asarray(path)
        pts = coords_xy[path]
        u, v = node(int(path[0])), node(int(path[-1]))
        g.edges.append([u, v, pts, _path_length(pts)])
    return g


def _prune(g: _Graph, prune_px: float) -> None:
    """Remove spurs (endpoint-to-junction branches shorter than ``prune_px``)."""
    for _ in range(10):
        deg = g.degrees()
        drop = set()
        for i, (u, v, _, length) in enumerate(g.edges):
            if length >= prune_px or u == v:
                continue
            if (deg[u] == 1 and deg[v] >= 3) or (deg[v] == 1 and deg[u] >= 3):
                drop.add(i)
        if not drop or len(drop) >= len(g.edges):
            return
        # two spurs on one junction of degree 3 would leave a dangling path:
        # drop them all the same (the junction then ends the remaining branch)
        g.edges = [e for i, e in enumerate(g.edges) if i not in drop]
        _merge_degree_two(g)


def _merge_degree_two(g: _Graph) -> None:
    """Join the two branches of plain skeleton nodes left with degree 2."""
    while True:
        deg = g.degrees()
        cand = [n for n in range(len(deg)) if deg[n] == 2 and g.node_span[n] == 0.0]
        done = False
        for n in cand:
            inc = [i for i, e in enumerate(g.edges) if e[0] == n or e[1] == n]
            if len(inc) != 2:
                continue  # a closed loop on itself
            a, b = (g.edges[i] for i in inc)
            pa = a[2] if a[1] == n else a[2][::-1]
            ua = a[0] if a[1] == n else a[1]
            pb = b[2] if b[0] == n else b[2][::-1]
            vb = b[1] if b[0] == n else b[0]
            pts = np.vstack([pa, pb[1:]])
            g.edges = [e for i, e in enumerate(g.edges) if i not in inc]
            g.edges.append([ua, vb, pts, _path_length(pts)])
            g.node_junction[n] = False
            done = True
            break
        if not done:
            return


def _is_shallow_x(g: _Graph, i: int, deg: np.ndarray, width: float, window: float, max_turn_deg: float = 35.0) -> bool:
    """Is branch ``i`` the shared middle of a shallow X crossing?

    Two tubes crossing at a small angle thin to two Y junctions joined by a
    branch several widths long (about ``w / tan(angle / 2)``). The branch is
    such a middle when it joins two degree-3 junctions and the two other
    branches at one end continue, each with a turn under ``max_turn_deg``,
    into the two other branches at the other end.
    """
    u, v, _, _ = g.edges[i]
    if u == v or deg[u] != 3 or deg[v] != 3:
        return False
    a_xy, b_xy = g.node_xy[u], g.node_xy[v]
    mid = b_xy - a_xy
    if np.hypot(*mid) == 0:
        return False
    mid = mid / np.hypot(*mid)

    def others(nd: int) -> list[np.ndarray]:
        out = []
        for k, (p, q, pts, _) in enumerate(g.edges):
            if k == i:
                continue
            for end, node_end, path in ((0, p, pts), (1, q, pts[::-1])):
                if node_end == nd:
                    out.append(_end_tangent(path, g.node_xy[nd], width, window))
        return out

    ta, tb = others(u), others(v)
    if len(ta) != 2 or len(tb) != 2:
        return False
    # arriving at u along -ta (heading towards v), leaving v along tb
    if any(float(-t @ mid) < np.cos(np.radians(60)) for t in ta) or any(float(t @ mid) < np.cos(np.radians(60)) for t in tb):
        return False
    for pairing in (((0, 0), (1, 1)), ((0, 1), (1, 0))):
        if all(abs(_signed_angle_deg(-ta[x], tb[y])) < max_turn_deg for x, y in pairing):
            return True
    return False


def _contract_junctions(g: _Graph, merge_len: float, width: float = 0.0, window: float = 15.0, max_len: float = 0.0) -> None:
    """Contract branches between junction nodes: those shorter than ``merge_len``
    and, up to ``max_len``, the middles of shallow X crossings."""
    n = len(g.node_xy)
    parent = list(range(n))

    def find(a: int) -> int:
        while parent[a] != a:
            parent[a] = parent[parent[a]]
            a = parent[a]
        return a

    deg = g.degrees()
    short = []
    for i, (u, v, _, length) in enumerate(g.edges):
        if deg[u] >= 3 and deg[v] >= 3 and (
            length < merge_len or (length < max_len and _is_shallow_x(g, i, deg, width, window))
        ):
            short.append(i)
            parent[find(u)] = find(v)
    if not short:
        return
    members: dict[int, list[int]] = {}
    for a in range(n):
        members.setdefault(find(a), []).append(a)
    for root, mem in members.items():
        if len(mem) < 2:
            continue
        xy = np.array([g.node_xy[m] for m in mem])
        centre = xy.mean(axis=0)
        g.node_xy[root] = centre
        g.node_span[root] = float(2 * np.hypot(*(xy - centre).T).max())
        g.node_junction[root] = True
    short_set = set(short)
    edges = []
    for i, (u, v, pts, length) in enumerate(g.edges):
        if i in short_set:
            continue
        edges.append([find(u), find(v), pts, length])
    g.edges = edges
    # pin holes: closed branches shorter than the merge length at a junction
    g.edges = [e for e in g.edges if not (e[0] == e[1] and e[3] < 2 * merge_len and g.node_junction[e[0]])]


def _keep_component(g: _Graph, start: int) -> float:
    """Keep the branches connected to node ``start``; return the dropped length."""
    adj: dict[int, set[int]] = {}
    for u, v, _, _ in g.edges:
        adj.setdefault(u, set()).add(v)
        adj.setdefault(v, set()).add(u)
    seen, stack = {start}, [start]
    while stack:
        a = stack.pop()
        for b in adj.get(a, ()):
            if b not in seen:
                seen.add(b)
                stack.append(b)
    dropped = sum(e[3] for e in g.edges if e[0] not in seen)
    g.edges = [e for e in g.edges if e[0] in seen]
    return dropped


# ---------------------------------------------------------------------------
# tangents


def _direction(pts: np.ndarray) -> np.ndarray:
    """Unit direction of the line fitted to ``pts`` (principal axis), oriented first -> last."""
    d = pts[-1] - pts[0]
    if len(pts) >= 3:
        c = pts - pts.mean(axis=0)
        _, _, vt = np.linalg.svd(c, full_matrices=False)
        a = vt[0]
        if a @ d < 0:
            a = -a
        d = a
    nrm = np.hypot(*d)
    return d / nrm if nrm > 0 else np.array([1.0, 0.0])


def _arc(pts: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(pts, axis=0).T))])


def _end_tangent(pts: np.ndarray, centre: np.ndarray, radius: float, window: float) -> np.ndarray:
    """Direction away from the node at ``pts[0]``, fitted outside ``radius``."""
    if radius > 0:
        out = np.nonzero(np.hypot(*(pts - centre).T) >= radius)[0]
        start = int(out[0]) if len(out) else max(len(pts) - 2, 0)
    else:
        start = 0
    s = _arc(pts[start:])
    sel = pts[start:][s <= window]
    if len(sel) < 2:
        sel = pts[max(len(pts) - 2, 0):] if len(pts) >= 2 else np.vstack([centre, pts])
        if len(pts) >= 2 and start >= len(pts) - 1:
            sel = pts
    return _direction(sel)


def _widen_zones(g: _Graph, radius: np.ndarray, crop: np.ndarray, width: float, ratio: float = 1.2) -> None:
    """Grow each junction zone to where its branches are single tubes again.

    Where two passes of the tendril meet at a small angle, the mask is wider
    than one tube over ``(w / 2) / sin(angle / 2)`` or more from the crossing,
    and the skeleton there follows neither pass. Along every branch leaving a
    junction, the zone ends where the distance to the background (computed in
    a window around the junction) falls back to ``ratio`` times the branch's
    own median (the single tube's), for at least 3 pixels; the zone radius is
    the largest such distance from the junction's centre (capped at 6 w,
    enough for a 10 degree crossing).
    """
    H, W = crop.shape
    half = int(np.ceil(8 * width)) + 4
    for n in np.nonzero(radius > 0)[0]:
        cx, cy = g.node_xy[n]
        x0, y0 = max(int(cx) - half, 0), max(int(cy) - half, 0)
        x1, y1 = min(int(cx) + half + 1, W), min(int(cy) + half + 1, H)
        dt = cv2.distanceTransform(crop[y0:y1, x0:x1], cv2.DIST_L2, cv2.DIST_MASK_5)
        grow = radius[n]
        for u, v, pts, _ in g.edges:
            for node_end, path in ((u, pts), (v, pts[::-1])):
                if node_end != n:
                    continue
                c, r = path[:, 0].astype(int) - x0, path[:, 1].astype(int) - y0
                inside = (c >= 0) & (c < x1 - x0) & (r >= 0) & (r < y1 - y0)
                run = int(np.argmin(inside)) if not inside.all() else len(path)
                if run < 6:
                    continue
                d = dt[r[:run], c[:run]]
                dist = np.hypot(path[:run, 0] - cx, path[:run, 1] - cy)
                far = d[dist > 2 * width]
                ref = float(np.median(far)) if len(far) >= 3 else float(np.median(d))
                thin = d <= ratio * ref
                ok = thin[:-2] & thin[1:-1] & thin[2:]
                if ok.any():
                    grow = max(grow, float(dist[int(np.argmax(ok))]))
        radius[n] = min(grow, max(radius[n], 6 * width))


def _signed_angle_deg(d_in: np.ndarray, d_out: np.ndarray) -> float:
    return float(np.degrees(np.arctan2(d_in[0] * d_out[1] - d_in[1] * d_out[0], d_in @ d_out)))


# ---------------------------------------------------------------------------
# walk


def _parse_overrides(overrides: Iterable, frame: int, view: int) -> dict[int, int]:
    out: dict[int, int] = {}
    for o in overrides or ():
        get = o.get if isinstance(o, Mapping) else (lambda k, _o=o: getattr(_o, k))
        try:
            f, v, j, b = (int(get(k)) for k in ("frame", "view", "junction", "branch"))
        except (TypeError, ValueError, AttributeError, KeyError):
            raise ValueError(f"overrides: expected entries {{frame, view, junction, branch}} of integers, got {o!r}") from None
        if f == frame and v == view:
            out[j] = b
    return out


def order_skeleton(
    mask_roi: np.ndarray,
    *,
    offset_xy=(0, 0),
    base_point_xy,
    prune_px: float = 12.0,
    method: str = "smooth",
    tangent_window_px: float = 15.0,
    overrides: Iterable = (),
    frame: int = 0,
    view: int = 1,
    zone_width: float = 1.0,
    merge_width: float = 1.5,
    smooth_px: float = 1.5,
    tip_inset: float = 1.0,
    max_unused_fraction: float = 0.1,
) -> OrderedCenterline:
    """Order the skeleton of a tendril's mask from base to tip.

    Parameters
    ----------
    mask_roi : (h, w) bool array
        The tendril's mask (one component) in the ROI crop.
    offset_xy : (2,) sequence of int
        Full-image position of ``mask_roi[0, 0]``.
    base_point_xy : (2,) sequence of float
        Full-image base point; the walk starts at the endpoint nearest it.
    prune_px : float
        Spurs shorter than this (pixels of skeleton) are removed.
    method : {"smooth", "paper"}
        Branch choice at junctions (see the module docstring).
    tangent_window_px : float
        Length of skeleton (pixels) the tangents are fitted to.
    overrides : iterable of mappings
        ``{frame, view, junction, branch}`` entries; those of this frame and
        view force the ``branch``-th candidate at the ``junction``-th decision.
    frame, view : int
        Recorded in the decisions; select the overrides.
    zone_width : float
        Junction-zone radius beyond half the crossing's span, in tube widths.
    merge_width : float
        Junctions joined by a branch shorter than this many tube widths are
        one crossing.
    smooth_px : float
        Gaussian smoothing of the pixel path (sigma, pixels of arc length).
    tip_inset : float
        The tip end is extended to the mask boundary minus ``tip_inset``
        half-widths (0: to the boundary).
    max_unused_fraction : float
        A walk leaving more than this fraction of the skeleton (and more than
        ``2 * prune_px``) unused raises :class:`AmbiguousOrderingError`.

    Returns
    -------
    OrderedCenterline

    Raises
    ------
    EmptySkeletonError, AmbiguousOrderingError
    """
    mask = np.asarray(mask_roi)
    if mask.ndim != 2:
        raise ValueError(f"mask_roi must be a 2D array, got shape {mask.shape}")
    if method not in ("smooth", "paper"):
        raise ValueError(f"method must be 'smooth' or 'paper', got {method!r}")
    if tangent_window_px <= 0:
        raise ValueError(f"tangent_window_px must be > 0, got {tangent_window_px}")
    m8 = (mask != 0).view(np.uint8) if mask.dtype == bool else (mask != 0).astype(np.uint8)
    bx, by, bw, bh = cv2.boundingRect(m8)
    if bw == 0 or bh == 0:
        raise EmptySkeletonError("the tendril's mask is empty")
    pad = 2
    crop = np.zeros((bh + 2 * pad, bw + 2 * pad), np.uint8)
    crop[pad:-pad, pad:-pad] = m8[by : by + bh, bx : bx + bw]
    off = np.asarray(offset_xy, dtype=float).reshape(2) + (bx - pad, by - pad)
    base = np.asarray(base_point_xy, dtype=float).reshape(2) - off
    overrides_here = _parse_overrides(overrides, int(frame), int(view))

    skel = _skeletonize_strips(crop)
    n_skel = int(np.count_nonzero(skel))
    if n_skel < 3:
        raise EmptySkeletonError(f"the mask thins to {n_skel} skeleton pixel(s)")
    g = _build_graph(skel)
    # tube width: mask area over skeleton length (a distance transform costs
    # 4 ms on a 1080p crop and gives the same to a few tenths of a pixel)
    skel_len = sum(e[3] for e in g.edges)
    width = float(np.count_nonzero(crop)) / max(skel_len, 1.0)
    half = 0.5 * width
    _prune(g, prune_px)
    _contract_junctions(g, merge_width * width, width, tangent_window_px, max_len=_SHALLOW_X_WIDTHS * width)
    _merge_degree_two(g)
    if not g.edges:
        raise EmptySkeletonError("no skeleton branch left after pruning")

    deg = g.degrees()
    ends = [n for n in range(len(deg)) if deg[n] == 1]
    if not ends:
        raise AmbiguousOrderingError("the skeleton has no free end (a closed ring): cannot tell base from tip")
    node_xy = np.array(g.node_xy)
    start = ends[int(np.argmin(np.hypot(*(node_xy[ends] - base).T)))]
    _keep_component(g, start)
    total_len = sum(e[3] for e in g.edges)
    n_branches = len(g.edges)
    deg = g.degrees()
    # twins: a branch between two junctions may be walked twice (where the
    # tendril runs along itself, its two passes thin to one band). Its twin is
    # optional; parity decides: an Euler walk can use it only where the
    # junctions' degrees need a second pass.
    twin_of: dict[int, int] = {}
    for i in range(n_branches):
        u, v, pts, length = g.edges[i]
        if u != v and deg[u] >= 3 and deg[v] >= 3 and length < _SHALLOW_X_WIDTHS * width:
            twin_of[len(g.edges)] = i
            g.edges.append([u, v, pts, length])

    radius = np.array(
        [0.5 * g.node_span[n] + zone_width * width if (deg[n] >= 3 or g.node_span[n] > 0 or g.node_junction[n]) else 0.0 for n in range(len(deg))]
    )
    _widen_zones(g, radius, crop, width)
    n_junctions = int(np.sum(deg >= 3))
    if method == "paper" and n_junctions > 1:
        raise AmbiguousOrderingError(
            f"method 'paper' handles at most one crossing, the skeleton has {n_junctions} junctions (use method 'smooth')"
        )

    # tangents at both ends of every branch, pointing away from the node
    tangent = {}
    for i, (u, v, pts, _) in enumerate(g.edges):
        for end, nd, p in ((0, u, pts), (1, v, pts[::-1])):
            if method == "paper":
                s = _arc(p)
                tangent[i, end] = _direction(p[s <= tangent_window_px] if np.sum(s <= tangent_window_px) >= 2 else p[:2])
            else:
                tangent[i, end] = _end_tangent(p, node_xy[nd], radius[nd], tangent_window_px)

    incident: dict[int, list[tuple[int, int]]] = {}
    for i, (u, v, _, _) in enumerate(g.edges):
        incident.setdefault(u, []).append((i, 0))  # leave u through end 0 (forward)
        incident.setdefault(v, []).append((i, 1))  # leave v through end 1 (reversed)

    def far_end_distance(i: int, end: int, nd: int) -> float:
        u, v, pts, _ = g.edges[i]
        far = pts[-1] if end == 0 else pts[0]
        return float(np.hypot(*(far - node_xy[nd])))

    def candidates(nd: int, d_in: np.ndarray | None, used: set) -> list:
        out = []
        for i, end in incident.get(nd, ()):
            if i in used or (i in twin_of and twin_of[i] not in used):
                continue
            ang = _signed_angle_deg(d_in, tangent[i, end]) if d_in is not None else 0.0
            b = twin_of.get(i, i)
            bid = b if end == 0 else (-1 - b if g.edges[i][0] == g.edges[i][1] else b)
            out.append([i, end, bid, ang])
        if method == "paper" and len(out) >= 3:
            tip = out[max(range(len(out)), key=lambda k: far_end_distance(out[k][0], out[k][1], nd))]
            out.sort(key=lambda c: (c is tip, abs(c[3])))
        else:
            out.sort(key=lambda c: abs(c[3]))
        return out

    # depth-first search over walks, smoothest candidate first; among the
    # complete walks (every branch used) the one with the fewest twins, then
    # the smallest total turn, is kept (branch and bound on that cost)
    best: dict[str, Any] = {"covered": -1.0, "trail": None, "decisions": None}
    done: dict[str, Any] = {"cost": (np.inf, np.inf), "trail": None, "decisions": None}
    steps = [0]

    def dfs(nd: int, d_in, used: set, trail: list, decs: list, covered: float, twins: int, turn: float) -> None:
        steps[0] += 1
        if (twins, turn) >= done["cost"] or (method == "paper" and done["trail"] is not None):
            return
        cands = candidates(nd, d_in, used)
        if not cands:
            if covered >= total_len - 1e-6:
                done.update(cost=(twins, turn), trail=list(trail), decisions=list(decs))
            elif covered > best["covered"] + 1e-6:
                best.update(covered=covered, trail=list(trail), decisions=list(decs))
            return
        if steps[0] > _MAX_STEPS:
            return
        order = list(range(len(cands)))
        kind = method
        if len(cands) >= 2:
            j = len(decs)
            if j in overrides_here:
                b = overrides_here[j]
                if not 0 <= b < len(cands):
                    raise AmbiguousOrderingError(
                        f"ordering.overrides: frame {frame} view {view} junction {j}: branch {b} is not among the {len(cands)} candidates"
                    )
                order, kind = [b], "override"
        for k in order:
            i, end, bid, ang = cands[k]
            used.add(i)
            trail.append((i, end))
            if len(cands) >= 2:
                decs.append((nd, tuple((c[2], c[3]) for c in cands), k, kind))
            nxt = g.edges[i][1] if end == 0 else g.edges[i][0]
            dfs(nxt, -tangent[i, 1 - end], used, trail, decs, covered + (0.0 if i in twin_of else g.edges[i][3]),
                twins + (i in twin_of), turn + abs(ang))
            if len(cands) >= 2:
                decs.pop()
            trail.pop()
            used.discard(i)

    dfs(start, None, set(), [], [], 0.0, 0, 0.0)
    complete = done["trail"] is not None
    if complete:
        best.update(covered=total_len, trail=done["trail"], decisions=done["decisions"])
    trail, decs = best["trail"], best["decisions"]
    unused = total_len - best["covered"]
    if not complete and unused > max(max_unused_fraction * total_len, 2 * prune_px):
        raise AmbiguousOrderingError(
            f"no walk from the base uses the whole skeleton: {unused:.0f} of {total_len:.0f} px left out"
        )
    if not complete and unused > 0:
        warnings.warn(f"frame {frame} view {view}: ordering leaves {unused:.0f} px of skeleton out", stacklevel=2)

    # node passages and the oriented pixel paths
    visits: dict[int, int] = {}
    pieces = []
    nodes_seq = [start]
    for i, end in trail:
        u, v, pts, _ = g.edges[i]
        p = pts if end == 0 else pts[::-1]
        pieces.append(p)
        nxt = v if end == 0 else u
        nodes_seq.append(nxt)
    for nd in nodes_seq:
        visits[nd] = visits.get(nd, 0) + 1
    # a band walked twice (twin) has a junction at each end: one crossing
    twins_used = sum(1 for i, _ in trail if i in twin_of)
    n_crossings = sum(1 for nd, c in visits.items() if c >= 2 and deg[nd] >= 3) - twins_used

    path = _bridge(pieces, nodes_seq, node_xy, radius, tangent_window_px)
    last = nodes_seq[-1]
    tip_reach = 4.0 * half + 4.0 + (radius[last] + prune_px if deg[last] != 1 else 0.0)
    path = _extend_ends(path, crop, half, tangent_window_px, tip_inset, tip_reach=tip_reach)
    path = _smooth_resample(path, smooth_px)

    decisions = tuple(
        Decision(
            frame=int(frame),
            view=int(view),
            junction=j,
            junction_xy=node_xy[nd] + off,
            candidates=tuple((int(b), float(a)) for b, a in cands),
            chosen=int(k),
            method=kind,
        )
        for j, (nd, cands, k, kind) in enumerate(decs)
    )
    return OrderedCenterline(
        points_xy=path + off,
        decisions=decisions,
        n_crossings=int(n_crossings),
        width_px=width,
        branches_xy=tuple(e[2] + off for e in g.edges[:n_branches]),
        unused_px=float(max(unused, 0.0)),
    )


# ---------------------------------------------------------------------------
# centreline geometry


def _bridge(pieces: list, nodes_seq: list, node_xy: np.ndarray, radius: np.ndarray, window: float) -> np.ndarray:
    """Concatenate the oriented branch paths, replacing junction zones by Hermite bridges."""
    keep_parts = []
    flags = []
    for k, p in enumerate(pieces):
        a, b = nodes_seq[k], nodes_seq[k + 1]
        keep = np.ones(len(p), bool)
        if radius[a] > 0:
            inside = np.hypot(*(p - node_xy[a]).T) < radius[a]
            # only the run touching the start of the piece
            run = np.argmin(inside) if not inside.all() else len(p)
            keep[:run] = False
        if radius[b] > 0:
            inside = np.hypot(*(p[::-1] - node_xy[b]).T) < radius[b]
            run = np.argmin(inside) if not inside.all() else len(p)
            keep[len(p) - run :] = False
        if k > 0:
            keep_parts.append(p[1:])
            flags.append(keep[1:])
        else:
            keep_parts.append(p)
            flags.append(keep)
    pts = np.vstack(keep_parts)
    keep = np.concatenate(flags)
    if keep.all():
        return pts
    if not keep.any():
        return pts  # nothing outside the zones: keep the skeleton as it is
    out = []
    idx = np.arange(len(pts))
    n = len(pts)
    i = 0
    while i < n:
        if keep[i]:
            j = i
            while j < n and keep[j]:
                j += 1
            out.append(pts[i:j])
            i = j
            continue
        j = i
        while j < n and not keep[j]:
            j += 1
        # gap [i, j): bridge from pts[i-1] to pts[j]
        if j == n:
            # the walk ends in a crossing (a tip stub shorter than prune_px
            # was pruned, or the tip touches the tendril): drop the bent
            # skeleton, the tip is extended along its tangent instead
            break
        if i == 0:
            out.append(pts[i:j])
            i = j
            continue
        left = pts[:i][keep[:i]]
        right = pts[j:][keep[j:]]
        p0, p1 = pts[i - 1], pts[j]
        tl = _run_tangent(pts, keep, i - 1, -1, window)
        tr = _run_tangent(pts, keep, j, +1, window)
        d = float(np.hypot(*(p1 - p0)))
        m = max(int(np.ceil(d)), 1)
        t = np.linspace(0, 1, m + 1)[1:-1, None]
        h00 = 2 * t**3 - 3 * t**2 + 1
        h10 = t**3 - 2 * t**2 + t
        h01 = -2 * t**3 + 3 * t**2
        h11 = t**3 - t**2
        bridge = h00 * p0 + h10 * d * tl + h01 * p1 + h11 * d * tr
        out.append(bridge)
        del left, right
        i = j
    del idx
    return np.vstack(out)


def _run_tangent(pts: np.ndarray, keep: np.ndarray, i: int, step: int, window: float) -> np.ndarray:
    """Tangent (direction of travel) at ``pts[i]`` from the kept run on the side ``step``."""
    j = i
    run = [pts[i]]
    length = 0.0
    while 0 <= j + step < len(pts) and keep[j + step] and length < window:
        length += float(np.hypot(*(pts[j + step] - pts[j])))
        j += step
        run.append(pts[j])
    run = np.array(run)
    if len(run) < 2:
        return np.zeros(2)
    d = _direction(run)  # oriented from pts[i] outward along `step`
    return -d if step < 0 else d


def _extend_ends(path: np.ndarray, crop: np.ndarray, half: float, window: float, tip_inset: float, *, tip_reach: float) -> np.ndarray:
    """Extend both ends along their tangents to the mask boundary (tip: minus ``tip_inset`` half-widths).

    The base goes at most ``4 half + 4`` px, the tip at most ``tip_reach``
    (more when the walk ends in a crossing: through it, and through a pruned
    stub of the tip beyond it).
    """
    h, w = crop.shape

    def reach(p: np.ndarray, d: np.ndarray, limit: float) -> float:
        step = 0.5
        s = 0.0
        while s < limit:
            q = p + (s + step) * d
            c, r = int(round(q[0])), int(round(q[1]))
            if not (0 <= r < h and 0 <= c < w) or crop[r, c] == 0:
                break
            s += step
        return s

    def line(p: np.ndarray, d: np.ndarray, length: float) -> np.ndarray:
        n = int(np.floor(length))
        if n < 1:
            return np.empty((0, 2))
        return p + np.arange(1, n + 1)[:, None] * d

    s = _arc(path)
    if len(path) < 2:
        return path
    d0 = _direction(path[s <= window][::-1]) if np.sum(s <= window) >= 2 else path[0] - path[1]
    ext0 = line(path[0], d0, reach(path[0], d0, 4.0 * half + 4.0) + 0.5)
    parts = [ext0[::-1], path]
    sel = path[s >= s[-1] - window]
    d1 = _direction(sel) if len(sel) >= 2 else path[-1] - path[-2]
    length = reach(path[-1], d1, tip_reach) + 0.5 - tip_inset * half
    parts.append(line(path[-1], d1, length))
    return np.vstack(parts)


def _smooth_resample(path: np.ndarray, sigma: float, spacing: float = 1.0) -> np.ndarray:
    """Resample every ``spacing`` px of arc length and smooth (Gaussian, odd reflection at the ends)."""
    keep = np.ones(len(path), bool)
    keep[1:] = np.hypot(*np.diff(path, axis=0).T) > 1e-9
    path = path[keep]
    if len(path) < 2:
        return path
    s = _arc(path)
    n = max(int(round(s[-1] / spacing)), 1) + 1
    si = np.linspace(0, s[-1], n)
    p = np.column_stack([np.interp(si, s, path[:, 0]), np.interp(si, s, path[:, 1])])
    if sigma > 0 and len(p) > 3:
        k = min(int(np.ceil(4 * sigma)), len(p) - 1)
        head = 2 * p[0] - p[1 : k + 1][::-1]
        tail = 2 * p[-1] - p[-k - 1 : -1][::-1]
        q = np.vstack([head, p, tail])
        q = gaussian_filter1d(q, sigma, axis=0, mode="nearest")
        p = q[k : k + len(p)]
        # the pixel staircase is longer than the curve: resample the smoothed path again
        s = _arc(p)
        n = max(int(round(s[-1] / spacing)), 1) + 1
        si = np.linspace(0, s[-1], n)
        p = np.column_stack([np.interp(si, s, p[:, 0]), np.interp(si, s, p[:, 1])])
    return p


# ---------------------------------------------------------------------------

def process_view(
    image_bgr: np.ndarray,
    *,
    roi,
    keep_out,
    base_point_xy,
    prev_centroid_xy=None,
    frame: int = 0,
    view: int = 1,
    segmentation: dict | None = None,
    ordering: dict | None = None,
) -> ViewCenterline:
    """Segment, skeletonise and order one view of one frame.

    Parameters
    ----------
    image_bgr : (H, W, 3) uint8 array
        The full frame.
    roi, keep_out, base_point_xy, prev_centroid_xy
        As in :func:`tendrilkit.segmentation.segment_view`.
    frame, view : int
        Recorded in the decisions; select the ordering overrides.
    segmentation, ordering : dict, optional
        Keyword options of :func:`~tendrilkit.segmentation.segment_view` and
        of :func:`order_skeleton` (an experiment's:
        ``tendrilkit.options.stage_options(exp, "segmentation")`` and
        ``(exp, "ordering")``; None: the functions' defaults).

    Returns
    -------
    ViewCenterline

    Raises
    ------
    TendrilLostError, EmptySkeletonError, AmbiguousOrderingError
    """
    seg = segment_view(
        image_bgr,
        roi=roi,
        keep_out=keep_out,
        base_point_xy=base_point_xy,
        prev_centroid_xy=prev_centroid_xy,
        **(segmentation or {}),
    )
    oc = order_skeleton(
        seg.mask_roi,
        offset_xy=seg.roi_offset_xy,
        base_point_xy=base_point_xy,
        frame=frame,
        view=view,
        **(ordering or {}),
    )
    return ViewCenterline(
        points_xy=oc.points_xy,
        centroid_xy=seg.centroid_xy,
        decisions=oc.decisions,
        n_crossings=oc.n_crossings,
        area_px=seg.area_px,
        width_px=oc.width_px,
    )


def compare_centerlines(points_xy: np.ndarray, truth_xy: np.ndarray) -> dict:
    """Accuracy and order of an ordered centreline against a true one (both base to tip).

    Parameters
    ----------
    points_xy : (n, 2) float array
        The measured centreline, ordered base to tip.
    truth_xy : (m, 2) float array
        The true centreline (e.g. the ground-truth projection), base to tip.

    Returns
    -------
    dict
        ``mean_px``, ``max_px``: distance of every measured point to the true
        polyline; ``arc_corr``: correlation between a point's index and the arc
        position of its nearest true point (1 for a right order; a crossing
        makes a few points' nearest true point lie on the other pass, which
        barely moves it); ``fraction_max_px``: the largest distance between
        the measured and the true point at the same fraction of arc length
        (101 fractions); ``base_px``, ``tip_px``: distances between the ends.
    """
    from scipy.spatial import cKDTree

    p = np.asarray(points_xy, float)
    t = np.asarray(truth_xy, float)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < 2 or t.ndim != 2 or t.shape[1] != 2 or len(t) < 2:
        raise ValueError(f"points_xy and truth_xy must have shape (n >= 2, 2), got {p.shape} and {t.shape}")
    st = _arc(t)
    dense_s = np.arange(0.0, st[-1] + 0.25, 0.25)
    dense = np.column_stack([np.interp(dense_s, st, t[:, 0]), np.interp(dense_s, st, t[:, 1])])
    d, idx = cKDTree(dense).query(p)
    arc_corr = float(np.corrcoef(np.arange(len(p)), dense_s[idx])[0, 1]) if np.ptp(idx) > 0 else 0.0
    f = np.linspace(0, 1, 101)
    sp = _arc(p)

    def at(pts, s):
        return np.column_stack([np.interp(f * s[-1], s, pts[:, 0]), np.interp(f * s[-1], s, pts[:, 1])])

    frac = np.hypot(*(at(p, sp) - at(t, st)).T)
    return {
        "mean_px": float(d.mean()),
        "max_px": float(d.max()),
        "arc_corr": arc_corr,
        "fraction_max_px": float(frac.max()),
        "base_px": float(np.hypot(*(p[0] - t[0]))),
        "tip_px": float(np.hypot(*(p[-1] - t[-1]))),
    }
