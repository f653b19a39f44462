"""The skeleton of one view as short line pieces, for the multi-view fit (:mod:`tendrilkit.multiview`).

Built on :func:`tendrilkit.evidence.view_evidence` (every dark pixel of the
ROI outside the keep-out box, no component chosen, and its skeleton): the
skeleton pixels of thin structures (the medial axis of a leaf or the stem
is not a tendril's centre line: :data:`WIDE_PX`) go into a k-d tree, and
every pixel gets the mean and the principal direction of its neighbours within 3.5 px, so that the distance of
a projected point to the skeleton (:func:`skeleton_distance`) is sub-pixel
and smooth across the curve.

Speed: the fit and the acquisition ask for the nearest skeleton pixel of a few
hundred thousand points per frame. :func:`skeleton_distance` and
:func:`mark_near` find them on a grid of :data:`GRID_PX` cells (compiled),
with the k-d tree's arithmetic (squared distances, its strict and inclusive
bounds; ties between equally near pixels are left to the k-d tree): the same
pixels, about 3 times faster than the k-d tree's queries on 37-150 points. The
ring search starts past a cell's empty rings (:func:`_empty_rings`), and
:func:`project_distance` projects world points and reads their distances in
one compiled call (the acquisition's :func:`tendrilkit.mv_acquire.point_costs`).

Lines in front of wide objects (:func:`front_line_pixels`, ``reconstruction.front_line_contrast``): where the
tendril lies in front of a leaf or the stem, it is one dark blob with the object and the view shows the place
covered; a line lighter than the object in some colour channel joins the skeleton.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import cv2
import numpy as np
from numba import njit
from scipy.spatial import cKDTree

from tendrilkit.camera import Camera, _project_brown
from tendrilkit.evidence import ViewEvidence
from tendrilkit.exceptions import TendrilLostError
from tendrilkit.segmentation.lines import vein_pixels

__all__ = ["SkeletonEvidence", "skeleton_evidence", "attach_chroma", "front_line_pixels", "front_line_mask", "skeleton_distance", "project_distance", "project_costs", "mark_near", "mark_near_rows", "COVER_PX", "COVER_DEPTH_PX", "WIDE_PX"]

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
    skeleton_chroma : (k, 3) float array or None
        Per skeleton pixel, the image's chromaticity there (B, G, R over
        their sum, the image blurred over 3 x 3 px): the colour of the line
        it lies on, whatever the light (:func:`attach_chroma`; None: not
        read).
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
    skeleton_chroma: np.ndarray | None = None

    @cached_property
    def skeleton_labels(self) -> np.ndarray:
        """(h, w) int32: the 8-connected components of ``skeleton`` (0: none), computed once, when first read.

        Labelled on the skeleton's box, starting on an even row and column
        (the labelling's 2 x 2 blocks and raster order, hence the labels, are
        those of the whole crop), not on the whole crop.
        """
        h, w = self.skeleton.shape
        out = np.zeros((h, w), np.int32)
        if len(self.skeleton_xy) == 0:
            return out
        r = self.skeleton_xy[:, 1].astype(int) - self.offset_xy[1]
        c = self.skeleton_xy[:, 0].astype(int) - self.offset_xy[0]
        r0, c0 = int(r.min()) & ~1, int(c.min()) & ~1
        r1, c1 = int(r.max()) + 1, int(c.max()) + 1
        box = np.ascontiguousarray(self.skeleton[r0:r1, c0:c1]).view(np.uint8)
        out[r0:r1, c0:c1] = cv2.connectedComponents(box, connectivity=8, ltype=cv2.CV_32S)[1]
        return out

    @cached_property
    def skeleton_seen_px(self) -> np.ndarray:
        """(n_labels,) int: per component of ``skeleton_labels``, its pixels the view sees (``seen``); computed once.

        Read at the skeleton's pixels (the labelled ones) only, not over the
        whole crop; label 0 (the background) gets the rest of the seen pixels.
        """
        lab = self.skeleton_labels
        off = self.offset_xy
        r = self.skeleton_xy[:, 1].astype(int) - off[1]
        c = self.skeleton_xy[:, 0].astype(int) - off[0]
        at = lab[r, c]
        out = np.bincount(at[self.seen[r, c]], minlength=int(at.max(initial=0)) + 1)
        out[0] = np.count_nonzero(self.seen) - out[1:].sum()
        return out

    @cached_property
    def _grid(self):
        """:func:`_skeleton_grid` of ``skeleton_xy``: the nearest skeleton pixel of a point without the k-d tree."""
        return _skeleton_grid(self.skeleton_xy, self.offset_xy, self.seen.shape)

    @cached_property
    def _grid_reach(self) -> np.ndarray:
        """:func:`_empty_rings` of :attr:`_grid`: where :func:`_grid_nearest` starts its search, per cell."""
        start, _, cell = self._grid
        return _empty_rings(start, cell)


def skeleton_evidence(ev: ViewEvidence, camera: Camera, *, image_bgr: np.ndarray | None = None,
                      front_line_contrast: float = 0.0) -> SkeletonEvidence:
    """The multi-view fit's view of :func:`tendrilkit.evidence.view_evidence` (made with ``skeleton=True``).

    With ``image_bgr`` (the view's full image) and ``front_line_contrast`` over 0
    (``reconstruction.front_line_contrast``), the lines in front of wide dark objects join the skeleton
    (:func:`front_line_pixels`: a tendril in front of a leaf or the stem, one blob with it in the
    segmentation): a place on them is seen, on the skeleton, and their depth (``inside_px``, what the
    width rules read, :func:`tendrilkit.multiview.skeleton_widths`) is their own half-width instead of
    the object's. The foreground, hence the view's board and the checks (which read
    :class:`tendrilkit.evidence.ViewEvidence`), are unchanged.

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
    inside = ev.inside_px
    img = None if image_bgr is None else np.asarray(image_bgr)
    if front_line_contrast > 0 and img is not None and img.ndim == 3:
        rr, cc, half = front_line_pixels(img[off[1]:off[1] + h, off[0]:off[0] + w], ev.foreground, skel, seen,
                                         contrast=front_line_contrast)
        if len(rr):
            inside = inside.copy()
            inside[rr, cc] = np.minimum(inside[rr, cc], half)
            skel[rr, cc] = True
            xy = np.vstack([xy, np.column_stack([cc + off[0], rr + off[1]]).astype(float)])
    tree = cKDTree(xy)
    centre, tangent = _local_lines(xy, tree)
    return SkeletonEvidence(offset_xy=off, foreground=ev.foreground, skeleton=skel, skeleton_xy=xy, tree=tree,
                            centre_xy=centre, tangent_xy=tangent, near_foreground=_near_foreground(ev.foreground),
                            seen=seen, inside_px=inside, camera=camera)


#: The crop pixels whose 5 x 5 chamfer distance (:attr:`tendrilkit.evidence.ViewEvidence.distance_px`) to the
#: foreground is at most 2 px: steps of 1 (sides), 1.4 (diagonals) and 1 + 1 (two sides straight on); 2.1969
#: (a knight's move) is beyond.
_NEAR_2PX = np.array([[0, 0, 1, 0, 0], [0, 1, 1, 1, 0], [1, 1, 1, 1, 1], [0, 1, 1, 1, 0], [0, 0, 1, 0, 0]], np.uint8)


def _near_foreground(foreground: np.ndarray) -> np.ndarray:
    """(h, w) bool: ``distance_px <= 2.0`` of the evidence, by a dilation (the same pixels: the chamfer distance
    takes the shortest sum of its steps), without the whole crop's distance transform (the verification reads
    that distance on boxes around the curve only)."""
    fg = foreground.view(np.uint8)
    if not fg.any():  # distance_px is then the crop's diagonal everywhere
        return np.full(fg.shape, float(np.hypot(*fg.shape)) <= 2.0)
    return cv2.dilate(fg, _NEAR_2PX) > 0


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


def attach_chroma(ev: SkeletonEvidence, image_bgr: np.ndarray) -> SkeletonEvidence:
    """``ev`` with :attr:`SkeletonEvidence.skeleton_chroma` read from the view's image (in place, once).

    The chromaticity (each channel over the sum of the three, the image
    blurred over 3 x 3 px, one added to every channel against division by
    0) at every skeleton pixel: the multi-view acquisition compares a step's
    colour with the colour its hypothesis followed so far
    (:func:`tendrilkit.mv_acquire.grow_curve`'s ``colour_px``). Set on the
    frozen evidence, as its cached properties are: the evidence is the same
    otherwise.
    """
    if ev.skeleton_chroma is None:
        img = np.asarray(image_bgr)
        xy = np.round(ev.skeleton_xy).astype(np.intp).reshape(-1, 2)
        if img.ndim != 3 or img.shape[2] != 3 or len(xy) == 0:
            chroma = np.full((len(xy), 3), 1.0 / 3.0)
        else:
            h, w = img.shape[:2]
            col, row = np.clip(xy[:, 0], 0, w - 1), np.clip(xy[:, 1], 0, h - 1)
            # blurred on the pixels' box grown by one: every pixel's 3 x 3 window lies in it, or meets the image's
            # border where the box does (the same values as the whole image's blur)
            r0, r1 = max(int(row.min()) - 1, 0), min(int(row.max()) + 2, h)
            c0, c1 = max(int(col.min()) - 1, 0), min(int(col.max()) + 2, w)
            box = np.ascontiguousarray(img[r0:r1, c0:c1])
            px = cv2.blur(box, (3, 3))[row - r0, col - c0].astype(np.float64) + 1.0
            chroma = px / px.sum(axis=1, keepdims=True)
        object.__setattr__(ev, "skeleton_chroma", chroma)
    return ev


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
    h, w = ev.seen.shape
    off = ev.offset_xy.astype(float)
    ok = _inside(p, off, h, w)
    start, items, cell = ev._grid
    idx, tie = _grid_nearest(p, ok, ev.skeleton_xy, off, start, items, cell, ev._grid_reach, float(outside_px))
    if tie.any():  # two skeleton pixels equally near: the k-d tree's choice, as before the grid
        idx[tie] = ev.tree.query(p[tie], distance_upper_bound=outside_px)[1]
    d, g, seen, nearest, background, covered = _line_distance(
        p, ok, idx, off, ev.centre_xy, ev.tangent_xy, ev.seen, ev.near_foreground,
        ev.inside_px, float(outside_px), COVER_DEPTH_PX, COVER_PX)
    return (d, g, seen, nearest, background, covered) if index else (d, g, seen)


def project_distance(ev: SkeletonEvidence, points_mm: np.ndarray, *, outside_px: float = 50.0):
    """``skeleton_distance(ev, ev.camera.project(points_mm), outside_px=outside_px, index=True)`` in one compiled
    call after the rotation (numpy's, as :meth:`~tendrilkit.camera.Camera.project`): the same arrays, bit for bit.

    Parameters
    ----------
    ev : SkeletonEvidence
    points_mm : (n, 3) float array
        World points, mm (NaN allowed).
    outside_px : float

    Returns
    -------
    d, grad, seen, nearest, background, covered
        As :func:`skeleton_distance` with ``index``.
    """
    cam = ev.camera
    X = np.asarray(points_mm, float)
    if X.ndim != 2 or X.shape[1] != 3 or (cam.has_distortion and cam.dist.size > 5):  # OpenCV's longer models
        return skeleton_distance(ev, cam.project(points_mm), outside_px=outside_px, index=True)
    start, items, cell = ev._grid
    off = ev.offset_xy.astype(float)
    out = _project_distance(X @ cam.R.T + cam.t_mm, cam.K, cam.dist, cam.has_distortion, ev.skeleton_xy, off, start,
                            items, cell, ev._grid_reach, float(outside_px), ev.centre_xy, ev.tangent_xy, ev.seen,
                            ev.near_foreground, ev.inside_px, COVER_DEPTH_PX, COVER_PX)
    if out[0]:
        return out[1:7]
    p, ok, idx, tie = out[7:]  # two skeleton pixels equally near: the k-d tree's choice, as skeleton_distance
    idx[tie] = ev.tree.query(p[tie], distance_upper_bound=outside_px)[1]
    return _line_distance(p, ok, idx, off, ev.centre_xy, ev.tangent_xy, ev.seen, ev.near_foreground, ev.inside_px,
                          float(outside_px), COVER_DEPTH_PX, COVER_PX)


@njit(cache=True)
def _project_distance(Xc, K, dist, distort, xy, off, start, items, cell, reach, outside_px, centre, tangent, seen_px,
                      near_fg, inside_px, cover_depth_px, cover_px):
    """:func:`project_distance` from the camera-frame points ``Xc`` (n, 3): the projection
    (:func:`tendrilkit.camera._project_brown`), then :func:`skeleton_distance`'s kernels. Returns ``(done, d, grad,
    seen, nearest, background, covered, p, ok, idx, tie)``; ``done`` False (the distances not computed) where two
    skeleton pixels are equally near a point (``tie``)."""
    p = _project_brown(Xc, K, dist, distort)
    h, w = seen_px.shape
    ok = _inside(p, off, h, w)
    idx, tie = _grid_nearest(p, ok, xy, off, start, items, cell, reach, outside_px)
    n = len(p)
    for i in range(n):
        if tie[i]:
            e = np.zeros(0)
            b = np.zeros(0, np.bool_)
            return False, e, np.zeros((0, 2)), b, np.zeros(0, np.int64), b, b, p, ok, idx, tie
    d, g, seen, nearest, background, covered = _line_distance(p, ok, idx, off, centre, tangent, seen_px, near_fg,
                                                              inside_px, outside_px, cover_depth_px, cover_px)
    return True, d, g, seen, nearest, background, covered, p, ok, idx, tie


def project_costs(ev: SkeletonEvidence, points_mm: np.ndarray, cap_px: float, d: np.ndarray, seen: np.ndarray,
                  nearest: np.ndarray, background: np.ndarray, covered: np.ndarray) -> None:
    """:func:`project_distance` as :func:`tendrilkit.mv_acquire.point_costs` reads it, into its rows (in place):
    ``d`` the distance capped at ``cap_px`` (``np.minimum``), ``seen`` seen and not covered, ``nearest``,
    ``background``, ``covered``; the same numbers, without the arrays it does not read."""
    cam = ev.camera
    X = np.asarray(points_mm, float)
    if X.ndim == 2 and X.shape[1] == 3 and not (cam.has_distortion and cam.dist.size > 5):
        start, items, cell = ev._grid
        if _project_costs(X @ cam.R.T + cam.t_mm, cam.K, cam.dist, cam.has_distortion, ev.skeleton_xy,
                          ev.offset_xy.astype(float), start, items, cell, ev._grid_reach, float(cap_px), ev.centre_xy,
                          ev.tangent_xy, ev.seen, ev.near_foreground, ev.inside_px, COVER_DEPTH_PX, COVER_PX, d, seen,
                          nearest, background, covered):
            return
    # OpenCV's longer models, or two skeleton pixels equally near a point (the k-d tree's choice)
    dv, _, sv, nearest[:], background[:], covered[:] = project_distance(ev, X, outside_px=cap_px)
    d[:] = np.minimum(dv, cap_px)
    seen[:] = sv & ~covered


@njit(cache=True)
def _project_costs(Xc, K, dist, distort, xy, off, start, items, cell, reach, outside_px, centre, tangent, seen_px,
                   near_fg, inside_px, cover_depth_px, cover_px, d_out, seen_out, nearest_out, bg_out, cov_out):
    """:func:`project_costs` in one compiled call (:func:`_project_distance`'s kernels); False, nothing written,
    where two skeleton pixels are equally near a point."""
    p = _project_brown(Xc, K, dist, distort)
    h, w = seen_px.shape
    ok = _inside(p, off, h, w)
    idx, tie = _grid_nearest(p, ok, xy, off, start, items, cell, reach, outside_px)
    for i in range(len(p)):
        if tie[i]:
            return False
    d, _, seen, nearest, background, covered = _line_distance(p, ok, idx, off, centre, tangent, seen_px, near_fg,
                                                              inside_px, outside_px, cover_depth_px, cover_px)
    for i in range(len(p)):
        d_out[i] = d[i] if (d[i] < outside_px or np.isnan(d[i])) else outside_px  # np.minimum: NaN wins
        seen_out[i] = seen[i] and not covered[i]
        nearest_out[i] = nearest[i]
        bg_out[i] = background[i]
        cov_out[i] = covered[i]
    return True


@njit(cache=True)
def _inside(p, off, h, w):
    """(n,) bool: the full-image points ``p`` (n, 2) lie on the crop (NaN: no)."""
    ok = np.zeros(len(p), np.bool_)
    for i in range(len(p)):
        x = p[i, 0] - off[0]
        y = p[i, 1] - off[1]
        ok[i] = np.isfinite(x) and np.isfinite(y) and x >= -0.5 and y >= -0.5 and x < w - 0.5 and y < h - 0.5
    return ok


@njit(cache=True)
def _line_distance(p, ok, idx, off, centre, tangent, seen_px, near_fg, inside_px, outside_px, cover_depth_px,
                   cover_px):
    """:func:`skeleton_distance` from the nearest skeleton pixel ``idx`` (-1: none) of every point on the crop.

    Point by point, the arithmetic of the whole-array expressions it replaces, in the same order (bit for bit).
    """
    n = len(p)
    d = np.full(n, outside_px)
    g = np.zeros((n, 2))
    seen = np.zeros(n, np.bool_)
    nearest = np.full(n, -1)
    background = np.zeros(n, np.bool_)
    covered = np.zeros(n, np.bool_)
    for i in range(n):
        if not ok[i]:
            continue
        j = idx[i]
        if j >= 0:
            # distance to the local line piece of the nearest skeleton pixel, beyond its ends to the piece
            d0 = p[i, 0] - centre[j, 0]
            d1 = p[i, 1] - centre[j, 1]
            t0 = tangent[j, 0]
            t1 = tangent[j, 1]
            n0 = -t1
            n1 = t0
            dn = d0 * n0 + d1 * n1
            dt = d0 * t0 + d1 * t1
            ex = max(abs(dt) - 1.0, 0.0)
            dl = np.hypot(dn, ex)
            if dl < 1e-9:
                g[i, 0] = n0
                g[i, 1] = n1
            else:
                es = ex * np.sign(dt)
                m = max(dl, 1e-9)
                g[i, 0] = (dn * n0 + es * t0) / m
                g[i, 1] = (dn * n1 + es * t1) / m
            d[i] = dl
            nearest[i] = j
        yi = int(np.rint(p[i, 1] - off[1]))
        xi = int(np.rint(p[i, 0] - off[0]))
        s = seen_px[yi, xi]
        seen[i] = s
        background[i] = s and not near_fg[yi, xi]
        covered[i] = s and inside_px[yi, xi] >= cover_depth_px and d[i] > cover_px
    return d, g, seen, nearest, background, covered


#: Side of the cells of :attr:`SkeletonEvidence._grid`, pixels.
GRID_PX = 4


def _skeleton_grid(xy: np.ndarray, off: np.ndarray, shape: tuple[int, int]):
    """The skeleton pixels ``xy`` (k, 2) bucketed in square cells of :data:`GRID_PX` over the crop.

    Returns ``start`` ((rows, cols + 1) int array: the rows of ``items`` of cell (r, c) are
    ``start[r, c]:start[r, c + 1]``, flattened row by row), ``items`` (k,) the skeleton pixels' rows sorted by cell
    then row, and the cell side.
    """
    h, w = shape
    rows, cols = h // GRID_PX + 2, w // GRID_PX + 2
    cx = np.clip(((xy[:, 0] - off[0]) // GRID_PX).astype(np.int64), 0, cols - 1)
    cy = np.clip(((xy[:, 1] - off[1]) // GRID_PX).astype(np.int64), 0, rows - 1)
    key = cy * cols + cx
    items = np.argsort(key, kind="stable")
    counts = np.bincount(key, minlength=rows * cols)
    start = np.zeros(rows * cols + 1, np.int64)
    start[1:] = np.cumsum(counts)
    return start, items, np.array([GRID_PX, rows, cols], np.int64)


def _empty_rings(start: np.ndarray, cell: np.ndarray) -> np.ndarray:
    """(rows, cols) int32: per cell of :func:`_skeleton_grid`, how many square rings of cells around it hold no
    skeleton pixel (the Chebyshev distance, in cells, to the nearest cell that holds one; 0 on such a cell).

    :func:`_grid_nearest` starts its ring search there: the rings inside are empty (what it finds is the same,
    the search without them). Exact: a 3 x 3 distance transform with unit steps (``DIST_C``) is the Chebyshev
    distance.
    """
    _, rows, cols = (int(v) for v in cell)
    empty = (np.diff(start) == 0).reshape(rows, cols).astype(np.uint8)
    if empty.all():  # no skeleton pixel: every ring is empty (the search ends at the grid's edge)
        return np.full((rows, cols), max(rows, cols), np.int32)
    return cv2.distanceTransform(empty, cv2.DIST_C, 3).astype(np.int32)


@njit(cache=True)
def _grid_nearest(p, ok, xy, off, start, items, cell, reach, upper):
    """Row of ``xy`` nearest every point ``p`` (n, 2) with ``ok`` (-1: none nearer than ``upper``), and ties.

    Exact: the cells are searched in square rings around the point's cell until no cell farther out can hold a
    pixel as near as the best (squared distances ``dx * dx + dy * dy`` and the strict ``< upper ** 2``
    of :meth:`scipy.spatial.cKDTree.query`). ``tie``: another pixel is exactly as near (the caller asks the
    k-d tree, whose choice among equals is its own). The search starts at ring ``reach`` (rows, cols) of the
    point's cell (:func:`_empty_rings`): the rings inside hold no pixel, and the search could only have
    ended in them with none found, as it does at the first ring it reads beyond (that ring's pixels are
    then farther than ``upper``).
    """
    S, rows, cols = cell[0], cell[1], cell[2]
    n = len(p)
    out = np.full(n, -1)
    tie = np.zeros(n, np.bool_)
    ub2 = upper ** 2.0
    for i in range(n):
        if not ok[i]:
            continue
        qx, qy = p[i, 0], p[i, 1]
        ux = qx - off[0]
        uy = qy - off[1]
        cx = min(max(int(np.floor(ux / S)), 0), cols - 1)
        cy = min(max(int(np.floor(uy / S)), 0), rows - 1)
        best = ub2
        bi = -1
        eq = False
        r = reach[cy, cx]
        while True:
            for yy in range(max(cy - r, 0), min(cy + r, rows - 1) + 1):
                edge = yy == cy - r or yy == cy + r
                step = 1 if edge else 2 * r
                xx = cx - r
                while xx <= cx + r:
                    if 0 <= xx < cols:
                        k = yy * cols + xx
                        for m in range(start[k], start[k + 1]):
                            j = items[m]
                            dx = qx - xy[j, 0]
                            dy = qy - xy[j, 1]
                            d2 = dx * dx + dy * dy
                            if d2 < best:
                                best = d2
                                bi = j
                                eq = False
                            elif d2 == best and bi >= 0:
                                eq = True
                    if step == 0:
                        break
                    xx += step
            # nearest place outside the searched block of cells
            gap = min(ux - (cx - r) * S, (cx + r + 1) * S - ux, uy - (cy - r) * S, (cy + r + 1) * S - uy)
            if cx - r <= 0 and cy - r <= 0 and cx + r >= cols - 1 and cy + r >= rows - 1:
                break
            if gap > 0 and gap * gap > best:
                break
            r += 1
        out[i] = bi
        tie[i] = eq
    return out, tie


def mark_near(ev: SkeletonEvidence, marked: np.ndarray, points_xy: np.ndarray, radius_px: float) -> None:
    """Set ``marked`` (k,) bool, one per row of ``ev.skeleton_xy``, True for the skeleton pixels within
    ``radius_px`` (inclusive) of any of ``points_xy`` (n, 2) full-image pixels (NaN rows ignored), in place.

    The pixels :meth:`scipy.spatial.cKDTree.query_ball_point` of ``ev.tree`` returns (squared distances
    ``dx * dx + dy * dy <= radius_px ** 2``), from the cells of :attr:`SkeletonEvidence._grid`.
    """
    start, items, cell = ev._grid
    _mark_near(np.asarray(points_xy, float).reshape(-1, 2), ev.skeleton_xy, ev.offset_xy.astype(float), start,
               items, cell, float(radius_px), marked)


def mark_near_rows(ev: SkeletonEvidence, marked: np.ndarray, rows: np.ndarray, points_xy: np.ndarray,
                   radius_px: float) -> None:
    """:func:`mark_near` of several curves at once: ``marked`` (c, k) bool, one row per curve, and ``rows`` (n,)
    int, the row of each of ``points_xy`` (n, 2): each row gets the skeleton pixels near its own points (in
    place; the same pixels as ``mark_near(ev, marked[r], points_xy[rows == r], radius_px)`` per row, in one
    compiled call)."""
    start, items, cell = ev._grid
    _mark_near_rows(np.asarray(points_xy, float).reshape(-1, 2), np.asarray(rows, np.int64), ev.skeleton_xy,
                    ev.offset_xy.astype(float), start, items, cell, float(radius_px), marked)


@njit(cache=True)
def _mark_near(p, xy, off, start, items, cell, radius, marked):
    for i in range(len(p)):
        _mark_point(p[i, 0], p[i, 1], xy, off, start, items, cell, radius, marked)


@njit(cache=True)
def _mark_near_rows(p, rows, xy, off, start, items, cell, radius, marked):
    for i in range(len(p)):
        _mark_point(p[i, 0], p[i, 1], xy, off, start, items, cell, radius, marked[rows[i]])


@njit(cache=True)
def _mark_point(qx, qy, xy, off, start, items, cell, radius, marked):
    """:func:`_mark_near` of one point ``(qx, qy)`` (NaN: nothing marked)."""
    if not (np.isfinite(qx) and np.isfinite(qy)):
        return
    S, rows, cols = cell[0], cell[1], cell[2]
    r2 = radius ** 2.0
    x0 = max(int(np.floor((qx - off[0] - radius) / S)) - 1, 0)
    x1 = min(int(np.floor((qx - off[0] + radius) / S)) + 1, cols - 1)
    y0 = max(int(np.floor((qy - off[1] - radius) / S)) - 1, 0)
    y1 = min(int(np.floor((qy - off[1] + radius) / S)) + 1, rows - 1)
    for yy in range(y0, y1 + 1):
        for xx in range(x0, x1 + 1):
            k = yy * cols + xx
            for m in range(start[k], start[k + 1]):
                j = items[m]
                dx = qx - xy[j, 0]
                dy = qy - xy[j, 1]
                if dx * dx + dy * dy <= r2:
                    marked[j] = True


#: :func:`front_line_mask`: lines up to about this wide (px, the top-hat's disk; a tendril's width and its blur)
#: are found, inside regions at least this wide (the opening of the foreground by the same disk: a leaf, the stem)
FRONT_DISK_PX = 11
#: ... on the lightness map smoothed by this Gaussian (px): the leaf's mottling and the sensor noise are single
#: pixels or blobs, a line runs on
FRONT_SIGMA_PX = 1.0
#: :func:`front_line_pixels`: a front line's skeleton piece (8-connected pixels not on the view's skeleton already)
#: shorter than this (px) is left out: the mottling of a leaf leaves short pieces, and where the tendril crosses
#: itself its lighter core is found in the merged blob beside the skeleton's junction; a tendril crossing a leaf
#: runs across it
FRONT_MIN_PX = 15
#: ... but a piece that starts at an end of the skeleton (within 2 px) needs only this many (px): the tip of a tendril
#: resting on a leaf, a few pixels into it, continues the tendril's own line where its skeleton stops at the leaf's
#: rim (a piece beside a crossing's junction does not start at an end)
FRONT_END_MIN_PX = 5


def front_line_mask(crop_bgr: np.ndarray, foreground: np.ndarray, *, contrast: float, sigma_px: float = FRONT_SIGMA_PX,
                    disk_px: int = FRONT_DISK_PX) -> np.ndarray:
    """Pixels of thin lines inside wide dark regions, lighter than the region around them in a colour channel.

    A tendril in front of a leaf or the stem is as dark as the object in the
    channel the segmentation reads (the blue one), so it is one blob with it:
    the view shows the place covered (:data:`COVER_DEPTH_PX`). In the other
    channels it is often lighter than the object (a yellower, redder or paler
    green), a band of about its width. Here, per channel, the white top-hat
    by a disk of ``disk_px`` (what is lighter than its surroundings and
    narrower than the disk) divided by the board's level in that channel
    (:func:`tendrilkit.segmentation.lines.board_level`); the largest over the
    channels, smoothed by a Gaussian of ``sigma_px``, over ``contrast``, inside
    the wide regions (the foreground's opening by the disk), opened by a
    3 x 3 disk.

    Parameters
    ----------
    crop_bgr : (h, w, 3) uint8 array
        The ROI crop of the view's image.
    foreground : (h, w) bool or uint8 array
        Its dark pixels (:attr:`tendrilkit.evidence.ViewEvidence.foreground`).
    contrast : float
        Least lightness over the surroundings, a fraction of the board's level.
    sigma_px, disk_px : float, int

    Returns
    -------
    (h, w) bool array

    Example
    -------
    >>> img = np.full((60, 80, 3), 220, np.uint8)
    >>> img[10:50, 10:70] = (48, 128, 62)                    # a leaf
    >>> img[28:33, :] = (50, 150, 110)                       # a tendril across it, lighter in green and red
    >>> fg = img[:, :, 0] < 120
    >>> m = front_line_mask(img, fg, contrast=0.09)
    >>> bool(m[30, 40]), bool(m[20, 40]), bool(m[30, 5])
    (True, False, False)
    """
    from tendrilkit.segmentation.lines import _on_box, board_level

    fg = np.asarray(foreground)
    fg = (fg if fg.dtype == bool else fg > 0).view(np.uint8) * np.uint8(255)
    out = np.zeros(fg.shape, bool)
    if crop_bgr.ndim != 3 or crop_bgr.shape[:2] != fg.shape:
        raise ValueError(f"crop_bgr must be a (h, w, 3) image of the foreground's shape {fg.shape}, "
                         f"got {crop_bgr.shape}")
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (int(disk_px) | 1,) * 2)
    wide = _on_box(fg, cv2.MORPH_OPEN, disk)  # the light lines' wide objects, the same way
    x, y, w, h = cv2.boundingRect(wide)
    if w == 0:
        return out
    H, W = fg.shape
    m = int(disk_px)
    r0, r1, c0, c1 = max(y - m, 0), min(y + h + m, H), max(x - m, 0), min(x + w + m, W)
    # the channels at once (each one's own pixels): the top-hat on the box, the board's level on the crop
    top = cv2.morphologyEx(crop_bgr[r0:r1, c0:c1], cv2.MORPH_TOPHAT, disk).reshape(r1 - r0, c1 - c0, -1)
    rel = _largest_ratio(top, board_level(crop_bgr).reshape(H, W, -1), r0, c0)
    if sigma_px > 0:
        rel = cv2.GaussianBlur(rel, (0, 0), float(sigma_px))
    cand = ((rel > float(contrast)) & (wide[r0:r1, c0:c1] > 0)).astype(np.uint8)
    cand = cv2.morphologyEx(cand, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (3, 3)))
    out[r0:r1, c0:c1] = cand > 0
    return out


@njit(cache=True, error_model="numpy")
def _largest_ratio(top, level, r0, c0):
    """(h, w) float32: per pixel of ``top`` ((h, w, c) uint8, C order), the largest over the channels of its
    ratio to ``level`` ((H, W, c) uint8, C order, 1-255) at ``[r0 + row, c0 + column]``: each ratio in float32
    as NumPy's (the same numbers), without the float images of every channel. NumPy's error model (no check
    for a division by 0) lets the divisions of a row run as vectors: about 6 times faster."""
    h, w, nc = top.shape
    n = w * nc
    row = level.shape[1] * nc
    tf = top.reshape(h * n)
    lf = level.reshape(level.shape[0] * row)
    out = np.empty((h, w), np.float32)
    q = np.empty(n, np.float32)
    for i in range(h):
        _divide_row(tf[i * n:(i + 1) * n], lf[(r0 + i) * row + c0 * nc:(r0 + i) * row + c0 * nc + n], q)
        _largest_of_row(q, nc, out[i])
    return out


@njit(cache=True)
def _largest_of_row(q, nc, out):
    """``out[j]``: the largest of ``q[j * nc:(j + 1) * nc]`` and 0."""
    for j in range(out.size):
        best = np.float32(0.0)  # the ratios are 0 or more
        for c in range(nc):
            v = q[j * nc + c]
            if v > best:
                best = v
        out[j] = best


@njit(cache=True, error_model="numpy")
def _divide_row(top, level, out):
    """``out[:] = top / level`` in float32 (uint8 arrays of ``out``'s size)."""
    for k in range(out.size):
        out[k] = np.float32(top[k]) / np.float32(level[k])


def front_line_pixels(crop_bgr: np.ndarray, foreground: np.ndarray, skeleton: np.ndarray, seen: np.ndarray, *,
                      contrast: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The skeleton pixels of the lines in front of wide dark objects that ``skeleton`` lacks (a tendril over a leaf).

    Where the tendril lies in front of a leaf or the stem the segmentation
    makes one blob of them, and the view shows the place covered: neither
    confirmed nor contradicted, the curve's steps there rest on the views that
    see the tendril elsewhere, and its tip, over a leaf in every view, stops
    where the leaf begins. :func:`front_line_mask`'s lines where the view sees
    (``seen``) are thinned; the pieces of at least :data:`FRONT_MIN_PX` pixels
    off ``skeleton`` are returned, and the shorter ones of at least
    :data:`FRONT_END_MIN_PX` that start at an end of ``skeleton`` (a tip a few
    pixels into the leaf it rests on). A leaf's midrib is such a line too, and
    a 3D line on the leaf that every view sees: the curve took it off a coil
    over the leaf (dev seeds 1044, 1059, 1074); lines along the middle of
    their object that end in it are left out
    (:func:`tendrilkit.segmentation.lines.vein_pixels`). :func:`skeleton_evidence` adds them.

    Parameters
    ----------
    crop_bgr : (h, w, 3) uint8 array
        The ROI crop of the view's image.
    foreground, skeleton, seen : (h, w) bool arrays
        The view's dark pixels, its thin skeleton, where it sees.
    contrast : float
        :func:`front_line_mask`'s (``reconstruction.front_line_contrast``).

    Returns
    -------
    rows, cols : (k,) int arrays
        The pixels, on the crop, row by row.
    half_px : (k,) float32 array
        Each one's distance to the line's edge (its half-width).
    """
    from tendrilkit.skeleton.thinning import thin

    none = (np.zeros(0, np.intp), np.zeros(0, np.intp), np.zeros(0, np.float32))
    m = front_line_mask(crop_bgr, foreground, contrast=contrast)
    m &= seen
    if m.any():  # a leaf's midrib is the leaf's own: a 3D line on it that every view sees, not the tendril
        m &= vein_pixels(m.view(np.uint8), foreground.view(np.uint8) if foreground.dtype == bool else foreground,
                         width_px=FRONT_DISK_PX) == 0
    x, y, bw, bh = cv2.boundingRect(m.view(np.uint8))
    if bw == 0:
        return none
    h, w = m.shape
    # on the lines' box (grown by a pixel: the distance transform's border), the same pixels as on the crop
    y0, y1, x0, x1 = max(y - 1, 0), min(y + bh + 1, h), max(x - 1, 0), min(x + bw + 1, w)
    mb = np.ascontiguousarray(m[y0:y1, x0:x1])
    # the pieces the skeleton lacks (a lighter core found where the tendril crosses itself lies on its skeleton)
    fresh = thin(mb) & ~skeleton[y0:y1, x0:x1]
    n, lab = cv2.connectedComponents(fresh.view(np.uint8), connectivity=8)
    # read at the pieces' pixels only (row by row), not over the box: their labels and sizes
    rf, cf = np.nonzero(fresh)
    at = lab[rf, cf]
    area = np.bincount(at, minlength=n)
    keep = area >= FRONT_MIN_PX
    short = (area >= FRONT_END_MIN_PX) & ~keep
    short[0] = False
    if short.any():  # the short pieces that start at an end of the skeleton
        keep[np.unique(at[_near_skeleton_ends(skeleton, y0, y1, x0, x1)[rf, cf] & short[at]])] = True
    keep[0] = False
    sel = keep[at]
    rb, cb = rf[sel], cf[sel]
    if len(rb) == 0:
        return none
    half = cv2.distanceTransform(mb.view(np.uint8), cv2.DIST_L2, 3)[rb, cb]
    return rb + y0, cb + x0, half


def _near_skeleton_ends(skeleton: np.ndarray, y0: int, y1: int, x0: int, x1: int, reach_px: int = 2) -> np.ndarray:
    """(y1 - y0, x1 - x0) bool: the pixels of the box within ``reach_px`` (chessboard) of an end of ``skeleton``
    (a skeleton pixel with one 8-neighbour), the ends just outside the box included."""
    h, w = skeleton.shape
    m = reach_px + 1  # an end's neighbour count needs the pixel beyond it
    Y0, Y1, X0, X1 = max(y0 - m, 0), min(y1 + m, h), max(x0 - m, 0), min(x1 + m, w)
    sk = np.ascontiguousarray(skeleton[Y0:Y1, X0:X1]).view(np.uint8)
    n = cv2.filter2D(sk, -1, np.ones((3, 3), np.float32), borderType=cv2.BORDER_CONSTANT)
    ends = ((sk == 1) & (n == 2)).view(np.uint8)
    k = 2 * reach_px + 1
    near = cv2.dilate(ends, np.ones((k, k), np.uint8)).view(bool)
    return near[y0 - Y0:y1 - Y0, x0 - X0:x1 - X0]
