"""The skeleton of one view as short line pieces, for the multi-view fit (:mod:`tendrilkit.multiview`).

Built on :func:`tendrilkit.evidence.view_evidence` (every dark pixel of the
ROI outside the keep-out box, no component chosen, and its skeleton): the
skeleton pixels of thin structures (the medial axis of a leaf or the stem
is not a tendril's centre line: :data:`WIDE_PX`) go into a k-d tree, and
every pixel gets the mean and the principal direction of its neighbours within 3.5 px, so that the distance of
a projected point to the skeleton (:func:`skeleton_distance`) is sub-pixel
and smooth across the curve.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from tendrilkit.camera import Camera
from tendrilkit.evidence import ViewEvidence
from tendrilkit.exceptions import TendrilLostError

__all__ = ["SkeletonEvidence", "skeleton_evidence", "skeleton_distance", "COVER_PX", "COVER_DEPTH_PX", "WIDE_PX"]

#: A place ``COVER_DEPTH_PX`` or more inside a dark region (pixels from the board) and farther than
#: ``COVER_PX`` from the skeleton is covered in that view (a leaf or the stem in front of or behind the
#: tendril). A tendril's own pixels lie within its half-width (1-5 px) of its skeleton; where two thin
#: structures cross (the tendril over its coil, a second tendril) the dark region is 4-5 px deep: not covered,
#: else the crossing would not constrain the curve and it could turn onto the other branch there.
COVER_PX = 3.0
COVER_DEPTH_PX = 6.0
#: A skeleton pixel ``WIDE_PX`` or more inside its dark region lies on the medial axis of something wider
#: than a tendril (a leaf, the stem): it is not evidence of the tendril's centre line and is left out. On
#: the phantoms' tendrils (0.8-2 mm) 98 % of the centre line's skeleton pixels lie under 6 px deep (crossings
#: of two thin structures reach 4-6 px), most skeleton pixels of leaves and the stem deeper.
WIDE_PX = 7.0
#: ... or ``WIDE_FACTOR`` times the median depth of the view's skeleton pixels (a tendril imaged wider: about its
#: half-width, the skeleton being mostly the tendril's), whichever is larger.
WIDE_FACTOR = 2.0


@dataclass(frozen=True, eq=False)
class SkeletonEvidence:
    """One view's evidence as the multi-view fit reads it (ROI crop).

    Attributes
    ----------
    offset_xy : (2,) int array
        Full-image pixel ``(x, y)`` of the crop's pixel ``[0, 0]``.
    foreground : (h, w) bool array
        Every dark pixel of the ROI (:attr:`tendrilkit.evidence.ViewEvidence.foreground`).
    skeleton : (h, w) bool array
        Its skeleton on thin structures (``skeleton_xy``), on the crop.
    skeleton_xy : (k, 2) float array
        The skeleton's pixels on thin structures (under :data:`WIDE_PX`, or
        :data:`WIDE_FACTOR` times the median depth, inside their dark region),
        full-image ``(x, y)``.
    tree : scipy.spatial.cKDTree
        Of ``skeleton_xy``: the nearest skeleton pixel of any point.
    centre_xy, tangent_xy : (k, 2) float arrays
        Per skeleton pixel, the mean of the skeleton pixels within 3.5 px
        and their principal direction (unit): the skeleton as short line
        pieces, for sub-pixel distances.
    near_foreground : (h, w) bool array
        Within 2 px of the foreground: a point projecting outside it is on
        the board in that view (the view contradicts it).
    seen : (h, w) bool array
        Pixels where the view can see the tendril: inside the ROI and the
        image, outside the keep-out box.
    inside_px : (h, w) float32 array
        :attr:`tendrilkit.evidence.ViewEvidence.inside_px` (the same array):
        per pixel, its distance to the nearest board pixel (0 on the board):
        how deep inside a dark region it lies. A place ``COVER_DEPTH_PX`` or
        more inside a region and farther than ``COVER_PX`` from the skeleton is covered by
        something wider than a tendril (a leaf, the stem): the view can
        neither see the tendril there nor contradict it
        (``covered`` of :func:`skeleton_distance`).
    camera : Camera
        The view's calibrated camera.
    """

    offset_xy: np.ndarray
    foreground: np.ndarray
    skeleton: np.ndarray
    skeleton_xy: np.ndarray
    tree: cKDTree
    centre_xy: np.ndarray
    tangent_xy: np.ndarray
    near_foreground: np.ndarray
    seen: np.ndarray
    inside_px: np.ndarray
    camera: Camera


def skeleton_evidence(ev: ViewEvidence, camera: Camera) -> SkeletonEvidence:
    """The multi-view fit's view of :func:`tendrilkit.evidence.view_evidence` (made with ``skeleton=True``).

    Raises
    ------
    TendrilLostError
        The ROI's foreground thins to fewer than 3 skeleton pixels.
    """
    if ev.skeleton_xy is None:
        raise ValueError("the evidence must be made with skeleton=True")
    xy = np.asarray(ev.skeleton_xy, float)
    if len(xy) < 3:
        raise TendrilLostError(f"the foreground of the roi thins to {len(xy)} skeleton pixel(s)")
    h, w = ev.shape
    off = np.asarray(ev.roi_offset_xy, int)
    # the medial axis of a region wider than a tendril (a leaf, the stem) is not the tendril's centre line
    depth = ev.inside_px[xy[:, 1].astype(int) - off[1], xy[:, 0].astype(int) - off[0]]
    thin = depth < max(WIDE_PX, WIDE_FACTOR * float(np.median(depth)))
    xy = xy[thin]
    if len(xy) < 3:
        raise TendrilLostError(f"the foreground of the roi thins to {len(xy)} skeleton pixel(s) on structures "
                               f"as thin as a tendril")
    skel = np.zeros((h, w), bool)
    skel[xy[:, 1].astype(int) - off[1], xy[:, 0].astype(int) - off[0]] = True
    seen = np.ones((h, w), bool)
    if ev.keep_out is not None:
        kx, ky, kw, kh = (int(v) for v in ev.keep_out)
        seen[max(ky - off[1], 0):max(ky + kh - off[1], 0), max(kx - off[0], 0):max(kx + kw - off[0], 0)] = False
    tree = cKDTree(xy)
    centre, tangent = _local_lines(xy, tree)
    return SkeletonEvidence(offset_xy=off, foreground=ev.foreground, skeleton=skel, skeleton_xy=xy, tree=tree,
                            centre_xy=centre, tangent_xy=tangent, near_foreground=ev.distance_px <= 2.0,
                            seen=seen, inside_px=ev.inside_px,
                            camera=camera)


def _local_lines(xy: np.ndarray, tree: cKDTree, radius_px: float = 3.5, k: int = 9):
    """Per skeleton pixel, the centre (k, 2) and unit tangent (k, 2) of its neighbours within ``radius_px``."""
    dd, idx = tree.query(xy, k=min(k, len(xy)), distance_upper_bound=radius_px)
    ok = np.isfinite(dd)
    nb = xy[np.where(ok, idx, 0)]
    w = ok.astype(float)
    n = w.sum(axis=1, keepdims=True)
    c = (nb * w[..., None]).sum(axis=1) / n
    r = (nb - c[:, None, :]) * w[..., None]
    sxx, syy, sxy = (r[..., 0] ** 2).sum(1), (r[..., 1] ** 2).sum(1), (r[..., 0] * r[..., 1]).sum(1)
    ang = 0.5 * np.arctan2(2 * sxy, sxx - syy)
    return c, np.column_stack([np.cos(ang), np.sin(ang)])


def skeleton_distance(ev: SkeletonEvidence, points_xy: np.ndarray, *, outside_px: float = 50.0, index: bool = False):
    """Distance to the skeleton at full-image pixels, with its gradient.

    Parameters
    ----------
    ev : SkeletonEvidence
    points_xy : (n, 2) float array
        Full-image pixels (NaN allowed).
    outside_px : float
        Distances are capped at this; also the value outside the ROI.

    Returns
    -------
    d : (n,) float array
        Distance to the nearest skeleton pixel, pixels.
    grad : (n, 2) float array
        ``(dd/dx, dd/dy)`` (unit vector away from that pixel; zero on it or beyond the cap).
    seen : (n,) bool array
        The view sees that place (inside the ROI, outside the keep-out box).
    nearest : (n,) int array
        With ``index``: the row of ``skeleton_xy`` nearest each point (-1: none within ``outside_px``).
    background : (n,) bool array
        With ``index``: seen, and on the board (outside ``near_foreground``).
    covered : (n,) bool array
        With ``index``: seen, ``COVER_DEPTH_PX`` or more inside a dark region and
        farther than ``COVER_PX`` from the skeleton (see :attr:`SkeletonEvidence.inside_px`).
    """
    p = np.asarray(points_xy, float)
    x = p[:, 0] - ev.offset_xy[0]
    y = p[:, 1] - ev.offset_xy[1]
    h, w = ev.seen.shape
    ok = np.isfinite(x) & np.isfinite(y) & (x >= -0.5) & (y >= -0.5) & (x < w - 0.5) & (y < h - 0.5)
    d = np.full(len(p), float(outside_px))
    g = np.zeros((len(p), 2))
    seen = np.zeros(len(p), bool)
    nearest = np.full(len(p), -1)
    background = np.zeros(len(p), bool)
    covered = np.zeros(len(p), bool)
    if ok.any():
        dd, idx = ev.tree.query(p[ok], distance_upper_bound=outside_px)
        near = np.isfinite(dd)
        # distance to the local line piece of the nearest skeleton pixel, beyond its ends to the piece
        j = idx[near]
        diff = p[ok][near] - ev.centre_xy[j]
        t = ev.tangent_xy[j]
        nrm = np.column_stack([-t[:, 1], t[:, 0]])
        dn = np.einsum("ka,ka->k", diff, nrm)
        dt = np.einsum("ka,ka->k", diff, t)
        ex = np.maximum(np.abs(dt) - 1.0, 0.0)
        dl = np.hypot(dn, ex)
        gl = (dn[:, None] * nrm + (ex * np.sign(dt))[:, None] * t) / np.maximum(dl, 1e-9)[:, None]
        gl[dl < 1e-9] = nrm[dl < 1e-9]
        gg = np.zeros((ok.sum(), 2))
        gg[near] = gl
        dv = np.full(ok.sum(), float(outside_px))
        dv[near] = dl
        d[ok] = dv
        g[ok] = gg
        yi, xi = np.rint(y[ok]).astype(int), np.rint(x[ok]).astype(int)
        seen[ok] = ev.seen[yi, xi]
        nearest[ok] = np.where(near, idx, -1)
        background[ok] = seen[ok] & ~ev.near_foreground[yi, xi]
        covered[ok] = seen[ok] & (ev.inside_px[yi, xi] >= COVER_DEPTH_PX) & (d[ok] > COVER_PX)
    return (d, g, seen, nearest, background, covered) if index else (d, g, seen)
