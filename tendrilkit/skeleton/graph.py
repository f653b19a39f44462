"""The skeleton graph: nodes, branches and their surgery.

The thinned mask (:func:`tendrilkit.skeleton.thinning.thin_strips`) is split into
branches (:func:`_build_graph`: the pixel graph of :func:`skeleton_graph`,
skan's graph, computed without importing skan or compiling its uncached
kernels in every process); spurs are pruned
(:func:`_prune`), plain nodes left with two branches merged
(:func:`_merge_degree_two`), junctions of one crossing contracted into one
node (:func:`_contract_junctions`, with :func:`_is_shallow_x` for shallow X
crossings) and the component of the base kept (:func:`_keep_component`,
with :mod:`scipy.sparse.csgraph`). :func:`_widen_zones` grows each
junction's zone to where its branches are single tubes again.
"""

from __future__ import annotations

import cv2
import numpy as np
from numba import njit
from scipy.sparse import coo_matrix, csr_matrix
from scipy.sparse.csgraph import connected_components, minimum_spanning_tree

from tendrilkit.skeleton.tangents import _end_tangent, _signed_angle_deg

__all__ = ["skeleton_graph"]

_SHALLOW_X_WIDTHS = 15.0  # longest middle of a shallow X crossing, in tube widths (about 8 deg)


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


#: The 8 neighbours of a pixel (row, column offsets) and their distances (px).
_STEPS_RC = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)])
_STEP_PX = np.sqrt(np.sum(_STEPS_RC.astype(float) ** 2, axis=1))


def skeleton_graph(skel: np.ndarray) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
    """The pixel graph of a skeleton and its paths between junctions and ends.

    Parameters
    ----------
    skel : (h, w) bool array
        A one-pixel-wide skeleton.

    Returns
    -------
    coords_rc : (n, 2) int array
        Row and column of every skeleton pixel (node), in raster order.
    degrees : (n,) int array
        Neighbours of every node in the graph.
    paths : list of (k,) int arrays
        Node indices of every path: from every end or junction (nodes in
        order) along each of its unwalked edges through the nodes of degree 2
        to the next end or junction, then each remaining isolated cycle from
        its first node (its first node repeated at its end).

    Notes
    -----
    The graph joins 8-connected pixels (edge weight 1 or :math:`\\sqrt 2` px);
    where junction pixels (degree >= 3) touch one another, only the edges of
    their minimum spanning tree are kept (``scipy.sparse.csgraph``), so that a
    cluster of junction pixels is a tree. Graph, degrees and paths are those
    of :class:`skan.Skeleton` (same nodes, same paths in the same order, as
    ``tests/test_skeleton_pixel_graph.py`` checks against skan), built with scipy
    and one cached compiled walk: importing skan and compiling its uncached
    kernels cost seconds in every process.
    """
    skel = np.asarray(skel, bool)
    h, w = skel.shape
    flat = np.flatnonzero(skel)
    n = len(flat)
    r, c = np.divmod(flat, w)
    # every node's neighbour in each of the 8 steps (-1: none), found among the sorted raster indices of the
    # nodes (a node's index is its rank there) instead of an image-sized table of indices
    nb = np.full((n, len(_STEPS_RC)), -1, np.int64)
    for k, (dr, dc) in enumerate(_STEPS_RC):
        rr, cc = r + dr, c + dc
        target = rr * w + cc
        pos = np.searchsorted(flat, target)
        pos_in = np.minimum(pos, max(n - 1, 0))
        found = (rr >= 0) & (rr < h) & (cc >= 0) & (cc < w) & (pos < n)
        found &= flat[pos_in] == target
        nb[found, k] = pos[found]
    # the adjacency in CSR form, row by row; within a row the steps' raster order is the neighbours' order
    ok = nb >= 0
    indptr = np.concatenate([[0], np.cumsum(ok.sum(axis=1))])
    G = csr_matrix((np.broadcast_to(_STEP_PX, nb.shape)[ok], nb[ok], indptr), shape=(n, n))
    G = _junction_trees(G)
    degrees = np.diff(G.indptr)
    flat_paths, starts = _walk_paths(G.indptr.astype(np.int64), G.indices.astype(np.int64), degrees.astype(np.int64))
    paths = [flat_paths[starts[i]:starts[i + 1]] for i in range(len(starts) - 1)]
    return np.column_stack([r, c]), degrees, paths


def _junction_trees(G: csr_matrix) -> csr_matrix:
    """``G`` without the edges between junction pixels (degree >= 3) that are not in their minimum spanning tree."""
    n = G.shape[0]
    deg = np.diff(G.indptr)
    row = np.repeat(np.arange(n), deg)
    junction = deg >= 3
    jj = junction[row] & junction[G.indices]
    if not jj.any():
        return G
    # the junction-junction edges as a matrix of the whole graph's shape and entry order: the spanning tree
    # (whose ties between equal weights depend on that order) is the one of the reference
    J = csr_matrix((G.data[jj], G.indices[jj], np.concatenate([[0], np.cumsum(np.bincount(row[jj], minlength=n))])),
                   shape=(n, n))
    T = minimum_spanning_tree(J).tocoo()
    # a junction-junction edge stays when the tree holds it, either way round (keys i * n + j)
    tree = np.concatenate([T.row.astype(np.int64) * n + T.col, T.col.astype(np.int64) * n + T.row])
    drop = jj.copy()
    drop[jj] = ~np.isin(row[jj].astype(np.int64) * n + G.indices[jj], tree)
    keep = ~drop
    indptr = np.concatenate([[0], np.cumsum(np.bincount(row[keep], minlength=n))])
    return csr_matrix((G.data[keep], G.indices[keep], indptr), shape=(n, n))


@njit(cache=True)
def _walk_paths(indptr, indices, degrees):  # pragma: no cover - compiled
    """The paths of :func:`skeleton_graph`: (node indices of all paths end to end, start of each path and the end)."""
    n = len(degrees)
    visited = np.zeros(len(indices), np.bool_)
    out = np.empty(len(indices) + n + 1, np.int64)
    starts = np.empty(len(indices) + 2, np.int64)
    n_out = 0
    n_paths = 0
    for sweep in range(2):
        for node in range(n):
            if sweep == 0:
                if not (degrees[node] > 2 or degrees[node] == 1):
                    continue
                first, last = indptr[node], indptr[node + 1]
            else:  # what is left: isolated cycles, entered through the node's first neighbour
                if degrees[node] == 0:
                    continue
                first, last = indptr[node], indptr[node] + 1
            for e in range(first, last):
                if visited[e]:
                    continue
                starts[n_paths] = n_out
                n_paths += 1
                start = node
                a, e_ab = node, e
                out[n_out] = a
                n_out += 1
                while not visited[e_ab]:
                    b = indices[e_ab]
                    visited[e_ab] = True
                    for f in range(indptr[b], indptr[b + 1]):  # the same edge seen from b
                        if indices[f] == a:
                            visited[f] = True
                    out[n_out] = b
                    n_out += 1
                    if degrees[b] != 2 or b == start:
                        break
                    nxt = indptr[b]
                    if indices[nxt] == a:
                        nxt += 1
                    a, e_ab = b, nxt
    starts[n_paths] = n_out
    return out[:n_out].copy(), starts[:n_paths + 1].copy()


def _build_graph(skel: np.ndarray) -> _Graph:
    coords_rc, deg, paths = skeleton_graph(skel)
    coords_xy = coords_rc[:, ::-1].astype(float)
    g = _Graph()
    index: dict[int, int] = {}

    def node(pix: int) -> int:
        if pix not in index:
            index[pix] = len(g.node_xy)
            g.node_xy.append(coords_xy[pix].copy())
            g.node_junction.append(bool(deg[pix] >= 3))
            g.node_span.append(0.0)
        return index[pix]

    for path in paths:
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
    n = len(g.node_xy)
    u = np.array([e[0] for e in g.edges], int)
    v = np.array([e[1] for e in g.edges], int)
    adj = coo_matrix((np.ones(len(u)), (u, v)), shape=(n, n))
    _, label = connected_components(adj, directed=False)
    seen = set(np.flatnonzero(label == label[start]).tolist())
    dropped = sum(e[3] for e in g.edges if e[0] not in seen)
    g.edges = [e for e in g.edges if e[0] in seen]
    return dropped


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
