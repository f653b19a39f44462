"""The walk through the skeleton graph, base to tip: :func:`order_skeleton`.

See the package docstring (:mod:`tendrilkit.skeleton`) for the method.
"""

from __future__ import annotations

import warnings
from typing import Any, Iterable, Mapping

import cv2
import numpy as np

from tendrilkit.exceptions import AmbiguousOrderingError, EmptySkeletonError
from tendrilkit.skeleton.centreline import _bridge, _extend_ends, _smooth_resample
from tendrilkit.skeleton.graph import (
    _SHALLOW_X_WIDTHS,
    _build_graph,
    _contract_junctions,
    _keep_component,
    _merge_degree_two,
    _prune,
    _widen_zones,
)
from tendrilkit.skeleton.results import Decision, OrderedCenterline
from tendrilkit.skeleton.tangents import _arc, _direction, _end_tangent, _signed_angle_deg
from tendrilkit.skeleton.thinning import thin_strips

__all__ = ["order_skeleton"]

_MAX_STEPS = 5000  # cap on the depth-first search over walks


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

    Examples
    --------
    A straight tube 9 px wide, ordered from its left end:

    >>> import numpy as np
    >>> mask = np.zeros((40, 120), bool)
    >>> mask[15:24, 10:110] = True
    >>> oc = order_skeleton(mask, base_point_xy=(10, 19))
    >>> oc.n_crossings, oc.decisions
    (0, ())
    >>> np.round(oc.points_xy[[0, -1]]).tolist()
    [[9.0, 19.0], [106.0, 18.0]]
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

    skel = thin_strips(crop)
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
