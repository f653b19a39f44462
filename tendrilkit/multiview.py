"""Multi-view tracked reconstruction: one 3D curve that every view agrees on, frame after frame.

``reconstruction: {method: multiview}`` (the other method, ``chain``, orders
each view on its own and then matches and triangulates the 2D curves).

Model
    The centreline is a chain of nodes :math:`X_0 \\dots X_M` (world mm)
    about ``segment_mm`` apart, :math:`X_0` at the base point triangulated
    from the marks.

Objective (:func:`refine_curve`)
    Gauss-Newton on

    .. math::

        \\sum_v \\sum_i w_{vi}\\, D_v(\\pi_v(X_i))^2
        + w_l^2 \\sum_i (\\lVert X_{i+1} - X_i \\rVert - \\ell)^2
        + w_b^2 \\sum_i \\lVert X_{i-1} - 2 X_i + X_{i+1} \\rVert^2
        + w_0^2 \\lVert X_0 - B \\rVert^2

    with :math:`D_v` the distance (pixels, bilinear) to view ``v``'s skeleton
    (:mod:`tendrilkit.mv_evidence`), :math:`w_{vi}` Huber weights, zero where
    the view does not see the node (keep-out box, outside its ROI) or the
    node is farther than a cap from any skeleton (occluded or merged there:
    that part rests on the other views). The bending term interpolates what
    no view sees (the first millimetres in the keep-out box); it barely
    biases a smooth curve (its normal equations act as a fourth difference).

Coverage (:func:`adjust_tip`)
    The tip is moved outward, 0.5 mm at a time, while two views or more see
    the extension on their skeletons (up to ``EXTEND_MM``: the evidence ends
    it, not a budget), and back while the tip is not on the skeleton of at
    least two views: the curve explains the tendril's pixels
    from the base outward and can neither shrink nor run on. A place one
    view shows as the open board stops it (``BOARD_VETO_VIEWS``: with 2, two
    views must; a last stretch over one view's board shorter than
    ``BOARD_RUN_MM`` is then undone). The views'
    skeletons hold thin structures only (:data:`tendrilkit.mv_evidence.WIDE_PX`):
    a tip cannot run along the medial axis of a leaf it touches. An
    extension that ends where two views' ROIs end is undone: it ran onto
    something hanging in from outside (a second tendril, a petiole), and
    the tendril's tip is a free end inside every ROI. Where the extension
    stops because no two views see on (a leaf over the tendril in every
    view, a pale tendril over the stem, a thin structure crossing it), it
    crosses the gap to where the views see the tendril again
    (:func:`tendrilkit.mv_acquire.bridge_gap`, at most ``MAX_GAP_MM``, or
    ``MAX_COVER_GAP_MM`` along a chord two views show covered: a long leaf
    over or under it) and goes on from there, up to ``BRIDGE_EXTEND_MM``
    (the acquisition's beam stopped at the gap: the rest of the tendril is
    the extension's to follow); the nodes in the gap rest on the bending
    term. Up to ``MAX_BRIDGES`` gaps; gaps crossed one after the other are
    undone together unless the extension past the last goes on along two
    views for ``BRIDGE_CONFIRM_MM``.

Width (:func:`wide_tail_start`)
    A shoot, a petiole or the stem crossing or touching the tendril passes
    for a thin structure in the skeleton, but it is wider than the tendril,
    which tapers to its tip: a curve whose tail runs on skeleton pixels
    ``WIDE_RATIO`` times as deep inside their dark region as its own near
    the base, in two views, left the tendril where that tail begins. The
    acquisition's candidates are cut there, and the tip's extension
    (:func:`adjust_tip`, its trim) does not step onto such pixels.

Tracking (:func:`reconstruct_multiview`)
    A frame starts from the previous frame's curve (identity carried in 3D),
    whose length is a prior: up to it, the tip is kept and extended wherever
    two views see it on their skeletons, also over pixels the curve explains
    already (a tip lying over its own coil in a view); beyond it, only over
    new pixels, and by ``max_growth`` (8 %) at most.
    The result is checked on every view: precision (nodes on the skeleton)
    and coverage (skeleton pixels of the touched components explained). When
    there is no previous curve, or the check fails, the curve is acquired
    from the base (:func:`tendrilkit.mv_acquire.grow_curve`) and the better
    of the two is kept; a tracked curve that shrank (``max_shrink``) is not
    weighed: the views may explain a part of the tendril better than all of it. With ``choice_candidates`` over 1 (6, the default
    since 2026-12-01, with the pale segmentation options;
    ``reconstruction.choice_candidates`` of the experiment file), of the acquisition's
    best few finished hypotheses (tips apart), each refined on every view,
    the one whose beam score plus a cost per degree of its sharpest local
    turn (:func:`local_kink_deg`: where a path leaves the tendril at a
    junction) is least is the tendril.
    A curve under ``STUB_MM`` that runs out of two views' ROIs is a stem
    stub, not the tendril: the frame fails.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from numba import njit
from scipy.linalg.lapack import dpbsv as _pbsv

from tendrilkit.camera import Camera, _project_brown
from tendrilkit.exceptions import DegenerateCurveError, TendrilLostError
from tendrilkit.geometry import arc_length, resample_polyline, section_masks
from tendrilkit.mv_acquire import (ON_PX, TURN_PX, advance, bridge_gap, claim, cone_directions, grow_curve, point_costs,
                                  runs_out)
from tendrilkit.mv_evidence import (COVER_DEPTH_PX, COVER_PX, SkeletonEvidence, _grid_nearest, _inside,
                                    _line_distance, skeleton_distance)
from tendrilkit.triangulation import triangulate

__all__ = ["MultiviewResult", "refine_curve", "adjust_tip", "curve_support", "local_kink_deg", "reconstruct_multiview",
           "base_point_from_marks", "distance_table"]



#: A curve shorter than this (mm) that runs out of two views' ROIs is a stem stub, not the tendril: the marks put
#: the tendril inside every ROI, and it is tens of millimetres long.
STUB_MM = 20.0
#: The tip's extension crosses at most this many gaps that no two views see on their skeletons (a tendril under
#: leaves, over the stem, crossing a second tendril), each up to ``MAX_GAP_MM`` long; past a gap it must go on
#: along two views for ``BRIDGE_CONFIRM_MM`` (a gap crossed right after another confirms both).
MAX_BRIDGES = 4
MAX_GAP_MM = 15.0
BRIDGE_CONFIRM_MM = 3.0
#: A gap that two views show covered (a leaf over or under the tendril: its semi-axes are 18-30 mm in the random
#: scenes) is crossed up to this long (mm; :func:`tendrilkit.mv_acquire.bridge_gap`'s ``max_cover_gap_mm``). Dev
#: seeds 9248, 9254, 9260, 9269, 9282: leaves over 17-25 mm of the tendril in every view, the curve stopped at them
#: 64-110 mm short of the tip in 24 frames (rerun with cached evidence, 9240-9299: all three 30.6 -> 37.2 %).
MAX_COVER_GAP_MM = 40.0
#: Past a gap the extension goes on up to this far (mm; before the first gap ``adjust_tip``'s ``max_extend_mm``): the
#: acquisition's beam stopped at the gap, the rest of the tendril is the extension's to follow (dev seed 9248: a
#: leaf over 17 mm of a 191 mm tendril 82 mm from the base; with 60 mm the curve stopped 30 mm short).
BRIDGE_EXTEND_MM = 200.0
#: The tip's extension before any gap goes on up to this far (mm; :func:`adjust_tip`'s ``max_extend_mm``), as far as
#: past a gap: the extension stops where two views stop seeing new skeleton pixels, not at a budget. With 60 (until
#: 2026-12-01) an acquired curve whose beam stopped early (a kink, a crossing) was cut 60 mm past the beam's tip while
#: two views still saw the tendril on (dev seed 1044 frame 1: 24 mm short). Measured 2026-12-01
#: (``rerun_multiview.py --no-fit``, against main 4b08771): dev 1040-1079 all three 41.7 -> 42.1 % (1044 frame 1
#: gained, no frame lost or otherwise changed), dev 9240-9299 44.7 -> 44.7 % (no frame changed).
EXTEND_MM = 200.0
#: The final choice of the acquisition (``_choose_acquired``): the beam score (pixels per step) a degree of a local
#: kink costs (30 degrees as much as 15 steps on the skeletons). How many of its best finished hypotheses are weighed,
#: each refined, is :func:`reconstruct_multiview`'s ``choice_candidates`` (``reconstruction.choice_candidates``):
#: 1, the beam's own choice, was the default until 2026-12-01 (with 6 alone, validation seeds 1000-1039 measured all
#: three criteria 34.2 -> 34.2 %, mean and max better, ``ok`` with an end or the max over 2 mm 6 -> 7, 21 ms more per
#: frame; with the pale segmentation options it keeps more of what they gain: README, Options).
KINK_PX_PER_DEG = 1.0

#: After an acquisition's fit, the tip is extended again from the refined curve (and the curve refined again) at most
#: this many times while an extension adds :data:`REEXTEND_MIN_MM` or more and the views explain the longer curve
#: about as well (precision x coverage, :func:`_score`, lower by at most :data:`REEXTEND_SCORE_DROP`). The first
#: extension runs on the unrefined curve, whose tip drifts mm off the tendril across gaps until the views stop
#: agreeing (dev seed 1068 frame 0: three gaps crossed 3-5 mm off, stopped 70 mm short; the refined tip 0.5 mm from
#: the tendril, every view seeing it go on). Tracked fits are not extended again: they start from the previous
#: frame's curve and its length; extended again, validation seed 1313 frame 1 became ``ok`` with its last 25 mm
#: 2.7 mm off in depth, carried by tracking to the next frame. Measured 2026-12-02 (rerun_multiview, 240 frames
#: each): dev 1040-1079 all three criteria 42.1 -> 42.1 %, ends 46.2 -> 47.1 %, ``ok`` with the max or an end
#: over 2 mm 8 -> 9 (1068 frame 0: mean 0.30, max 2.06 mm, tip 0.09 mm, 70 mm short before); validation 1280-1319
#: 45.4 -> 46.2 %, ends 50.4 -> 51.2 %, 7 -> 7 (see the README for the held-out figures). On other machines scene
#: 1068's beam takes another path; the test rebuilds dev scene 1075 frame 3 (16.5 mm short without the second extension).
REEXTEND_ROUNDS = 3
REEXTEND_MIN_MM = 2.0
REEXTEND_SCORE_DROP = 0.02

#: The tip's extension (:func:`adjust_tip`; not :func:`_trim`, where any view showing the board contradicts a node)
#: stops at a place this many views or more show as the open board: 1, any view (the default). With 2, where two
#: views see a pale tendril one view's segmentation missed (dev seed 1075: its last 6-16 mm) the tip goes on, a last
#: such stretch under ``BOARD_RUN_MM`` undone. Measured 2026-12-01 (all three criteria, stops short, tip off, ok
#: with an end or the max over 2 mm): dev 1040-1079 40.8 -> 41.7 %, 47 -> 41, 77 -> 80, 9 -> 10; dev 9240-9299
#: 44.2 -> 44.2 %, 52 -> 44, 127 -> 134, 12 -> 13; validation 1160-1199 48.8 -> 50.0 % (3 gained, none lost),
#: 29 -> 24, 65 -> 66, 14 -> 14, mean <= 0.5 mm 66.2 -> 65.4 %; silent unchanged. Not the default: the tip runs off
#: in pale coils, where two views agree on a ghost in the coil's dense projection (requiring that view to show no
#: unexplained skeleton within 10 px, against ghosts, lost the gains too: dev 40.8 -> 40.8 %, 44.2 -> 43.9 %).
BOARD_VETO_VIEWS = 1
#: With ``BOARD_VETO_VIEWS`` 2: an extension's last stretch taken where one view showed the board is undone when
#: shorter than this (mm): past a free tip two views' skeleton ends, or an object the tip touches, agree a few mm on
#: (dev 9240-9299: tips 0.5-3 mm past the true tip without it); a pale tendril one view misses goes on for longer.
BOARD_RUN_MM = 4.0
#: The tendril's width along the curve (:func:`skeleton_widths`): a skeleton pixel whose depth inside its dark region
#: (``inside_px``, about the half width) is ``WIDE_RATIO`` times or more the curve's own near the base (its median
#: from ``REF_FROM_MM`` to ``REF_TO_MM`` of arc length, per view) lies on something wider than the tendril (a shoot, a
#: petiole, the stem: they pass for thin structures in the skeleton). A tendril tapers to its tip; a curve whose
#: last ``WIDE_TAIL_MM`` or more run wide in two views (at ``WIDE_SHARE`` of their nodes) left the tendril where that
#: run begins (:func:`wide_tail_start`), and the tip's extension does not step onto such pixels.
#: Measured 2026-12-01 (``rerun_multiview.py`` with the fit): dev 1040-1079 all three 40.8 -> 41.7 %, ``tip off``
#: 77 -> 62, ``ok`` off 9 -> 9; dev 9240-9299 44.2 -> 44.7 %, 127 -> 109, 12 -> 14; validation 1160-1199 48.8 -> 49.2 %,
#: mean <= 0.5 mm 66.2 -> 70.8 %, ``ok`` off 14 -> 12, silent 1 -> 1. Tried and not kept: (a) ``bridge_gap``'s far
#: end and its lead not on such pixels either (a synthetic shoot's junction is then crossed to the tip): dev 1040-1079
#: 41.7 -> 41.7 %, 9240-9299 44.7 -> 44.2 % (1 gained, 3 lost); (b) an acquired curve covering under 90 % of the
#: skeleton grown again from where unexplained pieces fork off it in two views, kept on a better precision x
#: coverage: on dev seeds 1059, 1066, 1067 the truth scores lower than the wrong curve (the touched components hold
#: the other object's pixels; a pale tendril beside a darker shoot lies off the skeletons), two frames worse.
WIDE_RATIO = 1.5
REF_FROM_MM = 5.0
REF_TO_MM = 35.0
WIDE_TAIL_MM = 6.0
WIDE_SHARE = 0.7


@dataclass(frozen=True, eq=False)
class MultiviewResult:
    """The multi-view curve of one frame.

    Attributes
    ----------
    nodes_mm : (m, 3) float array
        The curve's nodes, base first, about ``segment_mm`` apart, world mm.
    mode : str
        ``tracked`` (from the previous frame's curve) or ``acquired``.
    precision : (V,) float array
        Per view, fraction of the nodes the view sees that lie within
        ``ON_PX`` of its skeleton (NaN: the view sees none).
    coverage : (V,) float array
        Per view, fraction of the skeleton pixels of the components the
        projection touches that lie within 3 px of the projected curve.
    note : str
        Why the frame was acquired afresh, if it was.
    candidates : list of dict
        The curves considered (``mode``, ``precision``, ``coverage``,
        ``score``, ``nodes_mm``), for the notebooks' figures.
    """

    nodes_mm: np.ndarray
    mode: str
    precision: np.ndarray
    coverage: np.ndarray
    note: str = ""
    candidates: list = field(default_factory=list)


def base_point_from_marks(base_points_xy: list, cameras: list[Camera], *, max_px: float) -> np.ndarray:
    """The base point (3,) mm triangulated from every view's ``base_point`` mark.

    Raises
    ------
    DegenerateCurveError
        The marks do not triangulate to one point within ``max_px``.
    """
    tri = triangulate(np.array([[p] for p in base_points_xy], float), cameras)
    B = tri.points_mm[0]
    if not np.all(np.isfinite(B)) or np.nanmax(tri.reproj_err_px) > max_px:
        raise DegenerateCurveError(f"the base_point marks do not agree (reprojection "
                                   f"{np.nanmax(tri.reproj_err_px):.1f} px > {max_px} px)")
    return B


def _bending_blocks(n: int) -> np.ndarray:
    """(D2^T D2) of the second difference on ``n`` nodes as banded upper rows (3, n) (bandwidth 2).

    The sums of the ``n - 2`` stencils' outer products ``[1, -2, 1]^T [1, -2, 1]``, written directly (small
    integers: exact): diagonal 1, 5, 6, ..., 6, 5, 1; first off-diagonal -2, -4, ..., -4, -2; second 1.
    """
    diag, off1, off2 = np.zeros(n), np.zeros(n - 1), np.zeros(n - 2)
    k = np.arange(1, n - 1)  # the stencils' centres
    np.add.at(diag, k - 1, 1.0)
    np.add.at(diag, k, 4.0)
    np.add.at(diag, k + 1, 1.0)
    np.add.at(off1, k - 1, -2.0)
    np.add.at(off1, k, -2.0)
    off2[:] = 1.0
    return np.stack([np.r_[np.zeros(2), off2], np.r_[0.0, off1], diag])


@njit(cache=True)
def _add_view(Hd, g, d, gd, seen, J, huber_px, cap):
    """Add one view's Huber-weighted Gauss-Newton terms to ``Hd`` (n, 3, 3) and ``g`` (n, 3), in place.

    Per node: the weight ``w`` (1 within ``huber_px``, ``huber_px / d`` beyond; 0 unseen or beyond ``cap``),
    the row ``gd^T J`` (3,), ``Hd += w row row^T``, ``g += w d row`` (the arithmetic of the numpy expressions it
    replaced, in the same order: bit for bit).
    """
    row = np.empty(3)
    for k in range(len(d)):
        w = 1.0 if d[k] <= huber_px else huber_px / max(d[k], 1e-9)
        w = w * (1.0 if (seen[k] and d[k] <= cap) else 0.0)
        for i in range(3):
            acc = 0.0
            acc += gd[k, 0] * J[k, 0, i]
            acc += gd[k, 1] * J[k, 1, i]
            row[i] = acc
        wd = w * d[k]
        for i in range(3):
            for j in range(3):
                Hd[k, i, j] += w * (row[i] * row[j])
            g[k, i] += wd * row[i]


@njit(cache=True)
def _banded_normal(Hd, tt, bend):
    """The normal matrix as upper banded rows (9, 3n) for ``solveh_banded``: node blocks ``Hd`` (n, 3, 3),
    between nodes i and i+1 ``-tt[i]`` (n-1, 3, 3), plus bending ``bend`` (3, n) kron I3; the diagonal lifted
    (see :func:`refine_curve`). Each entry summed in the order of the numpy code it replaced (bit for bit)."""
    n = Hd.shape[0]
    N = 3 * n
    ab = np.zeros((9, N))
    for i in range(n):
        for a in range(3):
            for b in range(a, 3):
                ab[8 - (b - a), 3 * i + b] += Hd[i, a, b]
    for i in range(1, n):
        for a in range(3):
            for b in range(3):
                ab[8 - (3 + b - a), 3 * i + b] -= tt[i - 1, a, b]
    for k in range(3):
        for c in range(N):
            ab[8 - 3 * k, c] += bend[2 - k, c // 3]
    m = ab[8, 0]
    for c in range(1, N):  # np.max: NaN wins
        if np.isnan(ab[8, c]) or ab[8, c] > m:
            m = ab[8, c]
    lift = 1e-3 * m * 1e-3 + 1e-6
    for c in range(N):
        ab[8, c] += lift
        ab[8, c] *= 1.0 + 1e-3
    return ab


@njit(cache=True)
def _shifted_copies(X, step_mm):
    """(4n, 3): the nodes ``X`` (n, 3), then three copies of them each shifted by ``step_mm`` along one axis
    (:meth:`tendrilkit.camera.Camera.project_jacobian`'s forward differences: the same sums)."""
    n = X.shape[0]
    S = np.empty((4 * n, 3))
    for k in range(n):
        for c in range(3):
            S[k, c] = X[k, c]
    for a in range(3):
        for k in range(n):
            for c in range(3):
                S[(a + 1) * n + k, c] = X[k, c]
            S[(a + 1) * n + k, a] += step_mm
    return S


@njit(cache=True)
def _view_terms(Xc, K, dist, distort, step_mm, xy, off, start, items, cell, reach, centre, tangent, seen_px, near_fg,
                inside_px, cover_depth_px, cover_px, huber_px, cap, Hd, g):
    """One view's Gauss-Newton terms of :func:`refine_curve` from the camera-frame points ``Xc`` (4n, 3) of
    :func:`_shifted_copies`, added to ``Hd`` (n, 3, 3) and ``g`` (n, 3) in place.

    In one call what :meth:`~tendrilkit.camera.Camera.project_jacobian` (``distort=True``, a 5-coefficient or no
    distortion), :func:`tendrilkit.mv_evidence.skeleton_distance` (``outside_px=1e3``) and :func:`_add_view`
    compute, with their kernels (bit for bit). Returns ``(done, u, J, ok, idx, tie)``: ``done`` False, nothing
    added, where two skeleton pixels are equally near a projection (``tie``): the caller asks the k-d tree, as
    :func:`~tendrilkit.mv_evidence.skeleton_distance` does, and finishes with :func:`_view_terms_from`.
    """
    n = Xc.shape[0] // 4
    U = _project_brown(Xc, K, dist, distort)
    u = np.empty((n, 2))
    for k in range(n):
        u[k, 0] = U[k, 0]
        u[k, 1] = U[k, 1]
    J = np.empty((n, 2, 3))
    for a in range(3):
        for k in range(n):
            for c in range(2):
                J[k, c, a] = (U[(a + 1) * n + k, c] - u[k, c]) / step_mm
    h, w = seen_px.shape
    ok = _inside(u, off, h, w)
    idx, tie = _grid_nearest(u, ok, xy, off, start, items, cell, reach, 1e3)
    for k in range(n):
        if tie[k]:
            return False, u, J, ok, idx, tie
    _view_terms_from(u, J, ok, idx, off, centre, tangent, seen_px, near_fg, inside_px, cover_depth_px, cover_px,
                     huber_px, cap, Hd, g)
    return True, u, J, ok, idx, tie


@njit(cache=True)
def _view_terms_from(u, J, ok, idx, off, centre, tangent, seen_px, near_fg, inside_px, cover_depth_px, cover_px,
                     huber_px, cap, Hd, g):
    """The end of :func:`_view_terms` from the nearest skeleton pixels ``idx``: distances, then :func:`_add_view`."""
    d, gd, seen, _, _, _ = _line_distance(u, ok, idx, off, centre, tangent, seen_px, near_fg, inside_px, 1e3,
                                          cover_depth_px, cover_px)
    _add_view(Hd, g, d, gd, seen, J, huber_px, cap)


@njit(cache=True)
def _assemble(X, B, Hd, g, bend, segment_mm, length_weight, base_weight):
    """The rest of :func:`refine_curve`'s normal equations, in place on ``Hd`` (n, 3, 3) and ``g`` (n, 3): the
    base anchor, the segment lengths, the bending; returns the banded matrix of :func:`_banded_normal`.

    The arithmetic of the numpy expressions it replaced (``refine_curve`` before 2026-12-01), element by
    element in the same order (bit for bit).
    """
    n = X.shape[0]
    bw2 = base_weight ** 2
    for i in range(3):
        for j in range(3):
            Hd[0, i, j] += bw2 * (1.0 if i == j else 0.0)
    for i in range(3):
        g[0, i] += bw2 * (X[0, i] - B[i])
    lw2 = length_weight ** 2
    tt = np.empty((n - 1, 3, 3))
    t = np.empty((n - 1, 3))
    r = np.empty(n - 1)
    for k in range(n - 1):
        e0 = X[k + 1, 0] - X[k, 0]
        e1 = X[k + 1, 1] - X[k, 1]
        e2 = X[k + 1, 2] - X[k, 2]
        L = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        m = max(L, 1e-9)
        if np.isnan(L):  # np.maximum: NaN wins
            m = L
        t[k, 0] = e0 / m
        t[k, 1] = e1 / m
        t[k, 2] = e2 / m
        r[k] = L - segment_mm
        for i in range(3):
            for j in range(3):
                tt[k, i, j] = lw2 * (t[k, i] * t[k, j])
    for k in range(n - 1):  # Hd[:-1] += tt, then Hd[1:] += tt
        for i in range(3):
            for j in range(3):
                Hd[k, i, j] += tt[k, i, j]
    for k in range(n - 1):
        for i in range(3):
            for j in range(3):
                Hd[k + 1, i, j] += tt[k, i, j]
    for k in range(n - 1):  # g[:-1] -= lw2 r t, then g[1:] += lw2 r t
        for i in range(3):
            g[k, i] -= (lw2 * r[k]) * t[k, i]
    for k in range(n - 1):
        for i in range(3):
            g[k + 1, i] += (lw2 * r[k]) * t[k, i]
    ab = _banded_normal(Hd, tt, bend)
    for k in range(n):
        for i in range(3):
            g[k, i] += bend[2, k] * X[k, i]
    for d in range(1, 3):  # the off-diagonals d of the bending band, above then below (numpy's order of sums)
        for k in range(n - d):
            for i in range(3):
                g[k, i] += bend[2 - d, k + d] * X[k + d, i]
        for k in range(n - d):
            for i in range(3):
                g[k + d, i] += bend[2 - d, k + d] * X[k, i]
    return ab


@njit(cache=True)
def _take_step(X, x):
    """``X`` + the step ``-x`` (3n,) of the normal equations, at most 1 mm per node, and the largest node step
    before the limit (``np.max`` of the nodes' norms: NaN wins), as :func:`refine_curve` did in numpy (bit for bit)."""
    n = X.shape[0]
    step = np.empty((n, 3))
    big = 0.0
    for k in range(n):
        for i in range(3):
            step[k, i] = -x[3 * k + i]
        nk = np.sqrt(step[k, 0] * step[k, 0] + step[k, 1] * step[k, 1] + step[k, 2] * step[k, 2])
        if k == 0 or np.isnan(nk) or (nk > big and not np.isnan(big)):
            big = nk
    if big > 1.0:
        f = 1.0 / big
        for k in range(n):
            for i in range(3):
                step[k, i] *= f
    out = np.empty((n, 3))
    for k in range(n):
        for i in range(3):
            out[k, i] = X[k, i] + step[k, i]
    return out, big


def refine_curve(X0_mm: np.ndarray, evidence: list[SkeletonEvidence], *, base_mm: np.ndarray, segment_mm: float,
                 iterations: int = 20, bend_weight: float = 20.0, length_weight: float = 30.0,
                 base_weight: float = 3.0, huber_px: float = 1.5, cap_px: tuple[float, float] = (25.0, 8.0)
                 ) -> np.ndarray:
    """Gauss-Newton fit of the node chain to every view's distance field (see the module's Objective).

    Parameters
    ----------
    X0_mm : (m, 3) float array
        Start nodes, base first.
    evidence : list of SkeletonEvidence
    base_mm : (3,) float array
    segment_mm : float
        Rest length of a segment, mm.
    iterations : int
    bend_weight, length_weight, base_weight : float
        :math:`w_b, w_l, w_0`, pixels per mm.
    huber_px : float
        Huber threshold of the image residuals.
    cap_px : (float, float)
        Nodes farther than the cap from a view's skeleton are ignored in
        that view; the cap shrinks from the first value to the second.

    Returns
    -------
    (m, 3) float array

    Notes
    -----
    A step is a few compiled calls (:func:`_view_terms` per view, :func:`_assemble`, :func:`_take_step`) around
    the projections' rotation (numpy's matrix product, as :meth:`~tendrilkit.camera.Camera.project` does) and
    LAPACK's banded Cholesky solve (``dpbsv``, what :func:`scipy.linalg.solveh_banded` calls): the same numbers,
    bit for bit, as the numpy step it replaced, in about a third of the time (its Python overhead was about
    0.36 ms a step). A camera with OpenCV's longer distortion models takes the general path.
    """
    X = np.array(X0_mm, float)
    n = len(X)
    if n < 3:
        return X
    bend = _bending_blocks(n) * bend_weight ** 2
    B = np.asarray(base_mm, float)
    step_h = 1e-3  # mm: the forward differences of the projections (Camera.project_jacobian's default step)
    # per view, what its terms read at every iteration (None: OpenCV's longer distortion models, the general path)
    views = []
    for ev in evidence:
        cam = ev.camera
        if cam.has_distortion and cam.dist.size > 5:
            views.append((ev, None, None, None, None))
            continue
        start, items, cell = ev._grid
        off = ev.offset_xy.astype(float)
        views.append((ev, cam.R.T, cam.t_mm, off, (cam.K, cam.dist, cam.has_distortion, step_h, ev.skeleton_xy, off, start,
                                               items, cell, ev._grid_reach, ev.centre_xy, ev.tangent_xy, ev.seen,
                                               ev.near_foreground, ev.inside_px, COVER_DEPTH_PX, COVER_PX, huber_px)))
    for it in range(iterations):
        cap = max(cap_px[1], cap_px[0] * 0.75 ** it)
        Hd = np.zeros((n, 3, 3))
        g = np.zeros((n, 3))
        S = None
        for ev, RT, t_mm, off, fixed in views:
            if fixed is None:  # OpenCV's projection: the general path
                u, J = ev.camera.project_jacobian(X, distort=True, step_mm=step_h)
                d, gd, seen = skeleton_distance(ev, u, outside_px=1e3)
                _add_view(Hd, g, d, gd, seen, J, huber_px, cap)
                continue
            if S is None:
                S = _shifted_copies(X, step_h)
            done, u, J, ok, idx, tie = _view_terms(S @ RT + t_mm, *fixed, cap, Hd, g)
            if not done:  # two skeleton pixels equally near: the k-d tree's choice (skeleton_distance)
                idx[tie] = ev.tree.query(u[tie], distance_upper_bound=1e3)[1]
                _view_terms_from(u, J, ok, idx, off, ev.centre_xy, ev.tangent_xy, ev.seen, ev.near_foreground,
                                 ev.inside_px, COVER_DEPTH_PX, COVER_PX, huber_px, cap, Hd, g)
        ab = _assemble(X, B, Hd, g, bend, float(segment_mm), float(length_weight), float(base_weight))
        _, x, info = _pbsv(ab, g.ravel(), lower=0, overwrite_ab=1, overwrite_b=0)
        if info > 0:  # not positive definite (solveh_banded's LinAlgError)
            break
        if info < 0:
            raise ValueError(f"illegal value in {-info}th argument of internal pbsv")
        X, big = _take_step(X, x)
        if big < 5e-3:
            break
    return X


def skeleton_widths(evidence: list[SkeletonEvidence], P_mm: np.ndarray, *, d=None, seen=None, near=None) -> np.ndarray:
    """(V, n) per view, the depth inside its dark region (``inside_px``, px) of the skeleton pixel nearest each
    point's projection, where the point is on the view's skeleton (within ``ON_PX``, seen); NaN elsewhere.

    ``d``, ``seen``, ``near``: :func:`tendrilkit.mv_acquire.point_costs` of the points (``nearest=True``), if known.
    """
    if d is None:
        d, seen, near, _ = point_costs(evidence, P_mm, nearest=True)
    W = np.full(d.shape, np.nan)
    for v, ev in enumerate(evidence):
        ok = seen[v] & (d[v] <= ON_PX) & (near[v] >= 0)
        if ok.any():
            xy = ev.skeleton_xy[near[v, ok]].astype(int) - ev.offset_xy
            W[v, ok] = ev.inside_px[xy[:, 1], xy[:, 0]]
    return W


def reference_widths(X_mm: np.ndarray, evidence: list[SkeletonEvidence]) -> np.ndarray:
    """(V,) the curve's median skeleton width per view from ``REF_FROM_MM`` to ``REF_TO_MM`` of arc length (NaN: fewer
    than 3 nodes on the view's skeleton there)."""
    X = np.asarray(X_mm, float)
    s = arc_length(X)
    P = X[(s >= REF_FROM_MM) & (s <= REF_TO_MM)]
    ref = np.full(len(evidence), np.nan)
    if len(P) == 0:
        return ref
    W = skeleton_widths(evidence, P)
    for v in range(len(evidence)):
        w = W[v][np.isfinite(W[v])]
        if len(w) >= 3:
            ref[v] = float(np.median(w))
    return ref


def wide_tail_start(X_mm: np.ndarray, evidence: list[SkeletonEvidence], ref: np.ndarray | None = None) -> int | None:
    """The node where the curve's wide tail begins (see ``WIDE_RATIO``), or None: the earliest node past
    ``REF_TO_MM`` from which at least ``WIDE_TAIL_MM`` run to the tip with ``WIDE_SHARE`` of the nodes wide in two
    views, itself wide in two."""
    X = np.asarray(X_mm, float)
    s = arc_length(X)
    if len(X) < 3 or s[-1] < REF_TO_MM + WIDE_TAIL_MM:
        return None
    ref = reference_widths(X, evidence) if ref is None else ref
    if np.isfinite(ref).sum() < 2:
        return None
    W = skeleton_widths(evidence, X)
    with np.errstate(invalid="ignore"):
        wide = (W >= WIDE_RATIO * ref[:, None]).sum(axis=0) >= 2
    share = np.cumsum(wide[::-1])[::-1] / np.arange(len(X), 0, -1)  # share of wide nodes from each node to the tip
    ok = wide & (share >= WIDE_SHARE) & (s[-1] - s >= WIDE_TAIL_MM) & (s > REF_TO_MM)
    return int(np.flatnonzero(ok)[0]) if ok.any() else None


def step_conditions(evidence: list[SkeletonEvidence], tip_mm: np.ndarray, P_mm: np.ndarray, ref: np.ndarray) -> dict:
    """The conditions of one step of the tip's extension (:func:`adjust_tip`) from ``tip_mm`` to each point of
    ``P_mm`` (k, 3), per view: (V, k) bool arrays ``on`` (on the view's skeleton, seen), ``board`` (the place is
    the open board in ``BOARD_VETO_VIEWS`` views or more: vetoed in every view), ``advance`` (the step is not along
    the view's line of sight), ``wide`` (on skeleton pixels ``WIDE_RATIO`` times as deep as ``ref``, the curve's
    :func:`reference_widths`); and :func:`~tendrilkit.mv_acquire.point_costs`' ``d``, ``seen``, ``near``, ``bg``. A view
    counts a point when ``on & ~board & advance & ~wide`` (and, past the prior length, the pixel is not explained
    yet: ``near`` against the claims). ``benchmarks/diagnose_short.py`` reads which condition stopped a tip."""
    d, seen, near, bg = point_costs(evidence, P_mm, nearest=True)
    board = np.broadcast_to(bg.sum(axis=0) >= BOARD_VETO_VIEWS, d.shape)
    adv = advance(evidence, np.repeat(np.asarray(tip_mm, float)[None], len(P_mm), axis=0), P_mm)
    with np.errstate(invalid="ignore"):  # not onto something wider than the tendril
        wide = skeleton_widths(evidence, P_mm, d=d, seen=seen, near=near) >= WIDE_RATIO * ref[:, None]
    return {"on": seen & (d <= ON_PX), "board": board, "advance": adv, "wide": wide, "d": d, "seen": seen,
            "near": near, "bg": bg}


def _cut_wide_tail(X: np.ndarray, evidence: list[SkeletonEvidence], ref: np.ndarray | None = None) -> np.ndarray:
    """The curve cut where its wide tail begins (:func:`wide_tail_start`; at least 3 nodes kept), else itself."""
    j = wide_tail_start(X, evidence, ref)
    return X if j is None else X[:max(j, 3)]


def _support(evidence, P):
    d, seen = point_costs(evidence, P)
    on = seen & (d <= ON_PX)
    return d, seen, on


def adjust_tip(X_mm: np.ndarray, evidence: list[SkeletonEvidence], *, step_mm: float = 0.5,
               max_extend_mm: float = EXTEND_MM, prior_mm: float = 0.0, max_length_mm: float = np.inf) -> np.ndarray:
    """Move the tip to where the views' evidence ends (extend, then trim), base kept.

    Each step goes the way of the 30-degree cone that costs least: the mean
    distance to the skeletons plus ``TURN_PX`` at the cone's edge (growing
    with the square of the angle), so where the views cannot tell
    directions apart the tip goes straight on instead of wandering.

    Parameters
    ----------
    X_mm : (m, 3) float array
        Nodes, base first.
    evidence : list of SkeletonEvidence
    step_mm : float
    max_extend_mm : float
        Longest extension, mm (``EXTEND_MM``; past a gap crossed by ``bridge_gap`` the
        extension may go on up to ``BRIDGE_EXTEND_MM`` further); when
        ``max_length_mm`` is finite, at least up to it (a tracked curve's tip can lag the tendril's by tens of mm after
        a large change between processed frames: the curve refitted from the
        previous frame is cut back where the views stop agreeing, and grows
        again along them).
    prior_mm : float
        Arc length (from the base) the curve is known to have (tracking: the
        previous frame's curve, a tendril does not shrink). Up to it, a node
        is kept, and the tip extended, while two views see it on their
        skeletons, also on pixels the curve explains already (the tip lying
        over its own coil in a view); beyond it, only on new pixels.
    max_length_mm : float
        The extension stops at this arc length (tracking: the previous
        frame's length and the growth a tendril can have between processed
        frames): a tip that would run on is stopped where the tendril ends.

    Returns
    -------
    (k, 3) float array
        Nodes ending at the new tip (spacing of the input up to the tip;
        the caller resamples).
    """
    ref = reference_widths(np.asarray(X_mm, float), evidence)
    X = [np.asarray(p, float) for p in _trim(np.asarray(X_mm, float), evidence, prior_mm=prior_mm, ref=ref)]
    ext = []
    tip = X[-1]
    t = X[-1] - X[max(len(X) - 1 - max(int(round(2.0 / max(np.linalg.norm(X[-1] - X[-2]), 1e-6))), 1), 0)]
    t = t / max(np.linalg.norm(t), 1e-9)
    # what the curve explains already, but its last 3 mm: the extension must explain new pixels
    Xa = np.asarray(X)
    s_ = arc_length(Xa)
    body = Xa[s_ <= s_[-1] - 3.0]
    claims = claim(evidence, None, resample_polyline(body, step=0.25)) if len(body) >= 2 else None
    lag = int(round(3.0 / step_mm))
    if np.isfinite(max_length_mm):  # tracking: the tip may have moved far since the last processed frame
        max_extend_mm = max(max_extend_mm, max_length_mm - s_[-1])
    ext_mm = 0.0  # arc length added
    budget_mm = max_extend_mm  # the extension's end: past a gap, a new extension of BRIDGE_EXTEND_MM
    bridges = 0
    pending = None  # where the gaps crossed since the last confirmed extension began, in ext
    over = []  # per node of ext: taken where a view showed the board (BOARD_VETO_VIEWS)
    while True:
        stopped = False  # by the evidence (not by a length limit)
        while ext_mm + step_mm <= budget_mm + 1e-9:
            if s_[-1] + ext_mm + step_mm > max_length_mm:
                break
            dirs = cone_directions(t, 30.0, 3)
            P = tip + step_mm * dirs
            c = step_conditions(evidence, tip, P, ref)
            d, seen, near, bg = c["d"], c["seen"], c["near"], c["bg"]
            on = c["on"] & ~c["board"] & c["advance"] & ~c["wide"]
            if claims is not None and s_[-1] + ext_mm + step_mm > prior_mm:
                for v, c in enumerate(claims):
                    on[v] &= ~((near[v] >= 0) & c[np.maximum(near[v], 0)])
            ok = on.sum(axis=0) >= 2
            if not ok.any():
                stopped = True
                break
            cost = np.where(ok, (d * seen).sum(0) / np.maximum(seen.sum(0), 1), np.inf)
            # bending, as in the acquisition: where the views cannot tell the directions apart (the tangent in
            # the plane of the camera centres) the tip goes straight on instead of wandering in that plane
            # (a wandering extension is too long, and the refit buckles it: mm off, on the skeleton in every view)
            cost = cost + TURN_PX * (np.degrees(np.arccos(np.clip(dirs @ t, -1.0, 1.0))) / 30.0) ** 2
            i = int(np.argmin(cost))
            over.append(bool(bg[:, i].any()))
            tip = P[i]
            t = 0.7 * t + 0.3 * dirs[i]
            t /= np.linalg.norm(t)
            ext.append(tip)
            ext_mm += step_mm
            if len(ext) > lag:
                claims = claim(evidence, claims, np.asarray(ext[-lag - 2:-lag]))
        if pending is not None and len(ext) - bridged_at >= BRIDGE_CONFIRM_MM / step_mm:
            pending = None  # the far end of the last gap led on along two views: the tendril came out again
        if not stopped or bridges == MAX_BRIDGES:
            break
        room = min(MAX_COVER_GAP_MM, max_length_mm - s_[-1] - ext_mm)
        far = bridge_gap(evidence, np.asarray(X + ext, float), t, max_gap_mm=min(MAX_GAP_MM, room),
                         max_cover_gap_mm=room) if room >= 2.0 else None
        if far is None:
            break
        gap = float(np.linalg.norm(far - tip))
        if pending is None:
            pending = len(ext)  # undone unless some gap from here on leads on along two views
        t = (far - tip) / gap
        tip = far
        ext.append(tip)
        over.append(False)
        ext_mm += gap
        budget_mm = ext_mm + max(max_extend_mm, BRIDGE_EXTEND_MM)
        bridges += 1
        bridged_at = len(ext)
        # past the gap the tip explains new pixels only (the curve up to the gap's near end claims its own)
        claims = claim(evidence, claims, resample_polyline(np.asarray(X + ext[:-1], float), step=0.25))
    if pending is not None:
        # the far end of the last gap did not lead on along two views (nor did a gap crossed from near it): not
        # the tendril coming out again
        del ext[pending:]
        del over[pending:]
    # the last stretch where a view showed the board (after the last two nodes no view did), when short: two views'
    # skeleton ends past a free tip, not a pale tendril one view misses
    clear = [k for k in range(1, len(over)) if not over[k] and not over[k - 1]]
    first = clear[-1] + 1 if clear else 0
    if any(over[first:]) and _length(np.asarray([X[-1]] + ext, float)[first:]) < BOARD_RUN_MM:
        del ext[first:]
    if ext and runs_out(evidence, [np.asarray(X + ext, float)], 2.0)[0] \
            and not runs_out(evidence, [np.asarray(X, float)], 2.0)[0]:
        # the extension ends where two views stop seeing (their ROIs' edge): it ran onto something hanging in
        # from outside (a second tendril, a petiole); the tendril's tip is a free end inside every ROI
        return np.asarray(X, float)
    return np.asarray(X + ext, float)


def _trim(X: np.ndarray, evidence: list[SkeletonEvidence], *, lag_mm: float = 1.5, radius_px: float = 4.0,
          prior_mm: float = 0.0, ref: np.ndarray | None = None) -> np.ndarray:
    """The curve up to its last node that two views see on skeleton pixels the curve had not explained yet.

    A node's nearest skeleton pixel is explained already when the projection of the curve at least
    ``lag_mm`` before the node passed within ``radius_px`` of it. Nodes within ``prior_mm`` of arc length
    from the base need only lie on the skeletons (see :func:`adjust_tip`). With ``ref`` (the curve's
    :func:`reference_widths`), a curve is first cut where its wide tail begins (:func:`wide_tail_start`).
    """
    if ref is not None:
        X = _cut_wide_tail(X, evidence, ref)
    from scipy.spatial import cKDTree

    s = arc_length(X)
    d, seen, near, bg = point_costs(evidence, X, nearest=True)
    on = seen & (d <= ON_PX)
    on[:, 1:] &= advance(evidence, X[:-1], X[1:])
    on &= ~bg.any(axis=0)  # a view showing the board there contradicts the node
    dense = resample_polyline(X, step=0.25)
    s_dense = np.linspace(0.0, s[-1], len(dense))
    for v, ev in enumerate(evidence):
        ok = on[v] & (near[v] >= 0)
        if not ok.any():
            continue
        tree = cKDTree(ev.camera.project(dense))
        for i, lst in zip(np.flatnonzero(ok), tree.query_ball_point(ev.skeleton_xy[near[v, ok]], radius_px)):
            if lst and s_dense[min(lst)] <= s[i] - lag_mm and s[i] > prior_mm:
                on[v, i] = False
    good = np.flatnonzero(on.sum(axis=0) >= 2)
    last = int(good[-1]) if len(good) else 2
    return X[:max(last + 1, 3)]


def _resample(X: np.ndarray, segment_mm: float) -> np.ndarray:
    """The curve resampled at the count nearest ``segment_mm`` spacing (at least 3 nodes)."""
    return resample_polyline(X, max(int(round(_length(X) / segment_mm)) + 1, 3))


def _length(X: np.ndarray) -> float:
    return float(arc_length(X)[-1])


def _segment(X: np.ndarray) -> float:
    return _length(X) / (len(X) - 1)


def curve_support(X_mm: np.ndarray, evidence: list[SkeletonEvidence], *, tol_px: float = 3.0):
    """Precision and coverage per view of a curve (see :class:`MultiviewResult`).

    Returns
    -------
    precision, coverage : (V,) float arrays
    """
    Xd = resample_polyline(X_mm, max(int(_length(X_mm) / 0.5), 4))
    d, seen = point_costs(evidence, Xd)
    prec = np.full(len(evidence), np.nan)
    cov = np.full(len(evidence), np.nan)
    for v, ev in enumerate(evidence):
        if seen[v].sum() >= 3:
            prec[v] = float(np.mean(d[v][seen[v]] <= tol_px))
        u = ev.camera.project(Xd) - ev.offset_xy
        pts = np.round(u[np.all(np.isfinite(u), axis=1)] * 4).astype(np.int32)
        # the line drawn on the box it can paint only (its points' box grown by its half width, inside the crop),
        # not on the whole crop: the same pixels (the drawing moves with the box's whole-pixel offset)
        thick = int(2 * tol_px + 1)
        x0, y0, x1, y1 = _painted_box(pts, thick, ev.skeleton.shape)
        drawn = np.zeros((y1 - y0, x1 - x0), np.uint8)
        if drawn.size:
            cv2.polylines(drawn, [pts - np.array([4 * x0, 4 * y0], np.int32)], False, 1, thick, cv2.LINE_8, 2)
        lab = ev.skeleton_labels[y0:y1, x0:x1]
        near = (drawn > 0) & (lab > 0)  # the skeleton's pixels are the labelled ones
        touched = np.unique(lab[near])
        touched = touched[touched > 0]
        if len(touched) == 0:
            cov[v] = 0.0 if seen[v].any() else np.nan
            continue
        comp = int(ev.skeleton_seen_px[touched].sum())  # the seen skeleton pixels of the touched components
        cov[v] = float(np.count_nonzero(near & ev.seen[y0:y1, x0:x1]) / max(comp, 1))
    return prec, cov


def _painted_box(pts: np.ndarray, thickness: int, shape: tuple[int, int]) -> tuple[int, int, int, int]:
    """``(x0, y0, x1, y1)``: the pixels of a crop of ``shape`` (h, w) that ``cv2.polylines`` of ``pts`` (n, 2)
    (int32, 2 fractional bits) with ``thickness`` can paint: the points' box grown by half the thickness and
    2 px (round caps and joins), clipped to the crop (empty without points)."""
    h, w = shape
    if len(pts) == 0:
        return 0, 0, 0, 0
    r = thickness // 2 + 2
    x0 = max(int(np.floor(pts[:, 0].min() / 4)) - r, 0)
    y0 = max(int(np.floor(pts[:, 1].min() / 4)) - r, 0)
    x1 = max(min(int(np.ceil(pts[:, 0].max() / 4)) + r + 1, w), x0)
    y1 = max(min(int(np.ceil(pts[:, 1].max() / 4)) + r + 1, h), y0)
    return x0, y0, x1, y1


def local_kink_deg(X_mm: np.ndarray, *, chord_mm: float = 3.0, near_mm: float = 3.0, far_mm: float = 10.0) -> float:
    """The sharpest turn of a curve beyond the turns around it (degrees): where it takes a junction.

    At every node the turn between the chords ``chord_mm`` before and after
    it, less the median turn of the nodes ``near_mm`` to ``far_mm`` before and
    after: a coil turns steadily (its turns are alike over a few mm), a
    path that leaves the tendril at a crossing onto a shoot, a petiole or
    another tendril turns at one place.

    Parameters
    ----------
    X_mm : (m, 3) float array
        Nodes about 1 mm apart (:func:`reconstruct_multiview`'s curves).

    Returns
    -------
    float
        0 for a curve too short to tell.
    """
    X = np.asarray(X_mm, float)
    w = max(int(round(chord_mm / max(_segment(X), 1e-9))), 1) if len(X) >= 2 else 1
    if len(X) <= 2 * w + 1:
        return 0.0
    a = X[w:-w] - X[:-2 * w]
    b = X[2 * w:] - X[w:-w]
    c = np.einsum("ij,ij->i", a, b) / np.maximum(np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1), 1e-12)
    turn = np.degrees(np.arccos(np.clip(c, -1.0, 1.0)))
    seg = max(_segment(X), 1e-9)
    lo, hi = int(round(near_mm / seg)), int(round(far_mm / seg))
    # per node the turns lo + 1 to hi nodes before and after it (NaN beyond the ends)
    pad = np.r_[np.full(hi, np.nan), turn, np.full(hi, np.nan)]
    i = np.arange(len(turn))[:, None] + hi
    ring = pad[np.c_[i - np.arange(hi, lo, -1), i + np.arange(lo + 1, hi + 1)]]
    some = np.isfinite(ring).any(axis=1)
    around = np.zeros(len(turn))
    if some.any():
        around[some] = np.nanmedian(ring[some], axis=1)
    return float(np.max(turn - around))


def _choose_acquired(grown: list, evidence: list[SkeletonEvidence], B: np.ndarray, segment_mm: float) -> np.ndarray:
    """The acquisition's final choice among its best finished hypotheses, each refined on every view.

    ``grown``: (nodes, beam score) of ``grow_curve``'s candidates, the beam's own choice first. The beam's score
    prefers the longest curve the views explain, and a path that leaves the tendril at a crossing (onto a shoot,
    a petiole, another tendril, a coil's other pass) runs on along the other structure: each candidate, refined
    on every view (a few ms), pays ``KINK_PX_PER_DEG`` per degree of its :func:`local_kink_deg` (where it left the
    tendril); the least is fitted to the end (tip extended, refined again).
    """
    # a candidate that ran onto something wider than the tendril is cut where it did (the tip's extension goes on
    # from there along the tendril, across the crossing)
    grown = [(_cut_wide_tail(G, evidence), sc) for G, sc in grown]
    if len(grown) == 1:
        return _fit(grown[0][0], evidence, B, segment_mm, reextend=True)
    refined = [refine_curve(_resample(G, segment_mm), evidence, base_mm=B, segment_mm=segment_mm) for G, _ in grown]
    k = min(range(len(grown)), key=lambda k: grown[k][1] + KINK_PX_PER_DEG * local_kink_deg(refined[k]))
    return _fit(refined[k], evidence, B, segment_mm, refined=True, reextend=True)


def _score(prec: np.ndarray, cov: np.ndarray) -> float:
    """Mean over the views that see the curve of precision x coverage."""
    s = prec * cov
    s = s[np.isfinite(s)]
    return float(s.mean()) if s.size else 0.0


def _fit(X0, evidence, B, segment_mm, prior_mm=0.0, max_length_mm=np.inf, refined=False, reextend=False):
    """``X0`` refined on every view, its tip moved to where the views' evidence ends, refined again.

    ``refined``: ``X0`` is refined already. ``reextend`` (an acquisition's fit): then extended again from the
    refined curve (:data:`REEXTEND_ROUNDS`).
    """
    X = X0 if refined else refine_curve(_resample(X0, segment_mm), evidence, base_mm=B, segment_mm=segment_mm)
    X = adjust_tip(X, evidence, prior_mm=prior_mm, max_length_mm=max_length_mm)
    X = _resample(X, segment_mm)
    # 30 iterations: along the directions no view constrains (the tangent in the plane of the camera centres)
    # only the bending and length terms move the nodes, and slowly (the site S3 phantom's frame 26: 2.2 mm off
    # after 10, 0.3 mm after 60)
    X = refine_curve(X, evidence, base_mm=B, segment_mm=_segment(X), cap_px=(8.0, 6.0), iterations=30, huber_px=3.0)
    score = None  # the views' precision x coverage of X, once needed
    for _ in range(REEXTEND_ROUNDS if reextend else 0):
        # the extension ran on the unrefined curve, whose tip drifts off the tendril (mm, along the directions the
        # views hardly constrain) until the views stop agreeing; from the refined tip, back on the tendril, the
        # views may still see it going on: extend again from there, and refine; kept while the views explain the
        # longer curve about as well (not where it ran on onto clutter)
        Y = adjust_tip(X, evidence, prior_mm=prior_mm, max_length_mm=max_length_mm)
        if _length(Y) < _length(X) + REEXTEND_MIN_MM:
            break
        Y = _resample(Y, segment_mm)
        Y = refine_curve(Y, evidence, base_mm=B, segment_mm=_segment(Y), cap_px=(8.0, 6.0), iterations=30,
                         huber_px=3.0)
        score_y = _score(*curve_support(Y, evidence))
        if score is None:
            score = _score(*curve_support(X, evidence))
        if score_y < score - REEXTEND_SCORE_DROP:
            break
        X, score = Y, score_y
    return X


def reconstruct_multiview(evidence: list[SkeletonEvidence], base_mm: np.ndarray, *, previous_mm: np.ndarray | None = None,
                          segment_mm: float = 1.0, min_score: float = 0.9, max_shrink: float = 0.08,
                          max_growth: float = 0.08, choice_candidates: int = 6,
                          keep_candidates: bool = False, colour_px: float = 1.0) -> MultiviewResult:
    """The 3D curve of one frame from every view's evidence, tracked or acquired.

    Parameters
    ----------
    evidence : list of SkeletonEvidence
        Every usable view (at least two).
    base_mm : (3,) float array
        The base point, world mm.
    previous_mm : (k, 3) float array, optional
        The previous processed frame's curve, base first (tracking); None:
        acquire.
    segment_mm : float
        Node spacing, mm.
    max_shrink : float
        A tracked curve shorter than the previous one by more than this
        fraction is lost too (a tendril grows; it does not shrink by 8 %
        between processed frames), and is kept only if the fresh acquisition
        finds no curve: it is not weighed against the acquired one, however well
        the views explain it (its part of the tendril).
    max_growth : float
        The length prior's other side: a tracked curve's tip is not extended
        beyond the previous curve's length plus this fraction (a tendril's
        length changes by well under 1 % per minute; the rest is the
        previous curve's own error): it is not run on past the tip onto a
        leaf or another object touching it. A curve acquired afresh (tracking
        lost: the previous curve does not explain this frame) is not capped.
    min_score : float
        A tracked curve whose precision x coverage (mean over the views)
        is below this, or below this less 0.1 in one view, is lost: the frame is acquired afresh too and the better
        curve kept.
    choice_candidates : int
        An acquisition weighs this many of its best finished hypotheses (tips
        apart), each refined on every view, and keeps the one whose beam score
        plus a cost per degree of its sharpest local turn is least (6); 1: the
        beam's own choice (the former default).
    keep_candidates : bool
        Keep every candidate's nodes in the result (figures).
    colour_px : float
        The acquisition's cost of a step onto a line of another colour than
        the one its hypothesis followed so far (:func:`tendrilkit.mv_acquire.grow_curve`;
        the evidence's :attr:`~tendrilkit.mv_evidence.SkeletonEvidence.skeleton_chroma`
        needed, :func:`~tendrilkit.mv_evidence.attach_chroma`); 0: off, the default before 2026-12-02.

    Returns
    -------
    MultiviewResult

    Raises
    ------
    TendrilLostError
        Fewer than two views of evidence, or no curve that two views explain.
    """
    if len(evidence) < 2:
        raise TendrilLostError(f"multiview needs the evidence of two views or more, got {len(evidence)}")
    B = np.asarray(base_mm, float)
    cands = []
    note = ""
    cap_mm = np.inf  # the length prior: the previous curve's length and the growth between processed frames
    if previous_mm is not None and len(previous_mm) >= 3:
        cap_mm = (1.0 + max_growth) * _length(np.asarray(previous_mm, float))
        P = np.asarray(previous_mm, float)
        P = P - P[0] + B  # the base does not move
        X = _fit(P, evidence, B, segment_mm, prior_mm=_length(P), max_length_mm=cap_mm)
        prec, cov = curve_support(X, evidence)
        cands.append({"mode": "tracked", "nodes_mm": X, "precision": prec, "coverage": cov, "score": _score(prec, cov)})
        worst = float(np.nanmin(prec * cov)) if np.any(np.isfinite(prec * cov)) else 0.0
        shrink = _length(X) / max(_length(P), 1e-9)
        shrunk = shrink < 1.0 - max_shrink
        if cands[-1]["score"] < min_score or worst < min_score - 0.1:
            note = (f"tracking lost (precision x coverage {cands[-1]['score']:.2f}, worst view {worst:.2f}; "
                    f"limits {min_score}, {min_score - 0.1:.1f}): acquired afresh")
        elif shrunk:
            note = f"tracking lost (length {100 * (shrink - 1):.0f} % from the previous frame): acquired afresh"
        # a tracked curve this much shorter than the previous one is not the tendril (which does not shrink), even
        # where the views explain it better than the fresh acquisition: not a candidate then (dev seed 1072 frame
        # 3: 49 mm of a 138 mm tendril, precision x coverage 0.79 against the right acquisition's 0.72)
        cands[-1]["shrunk"] = shrunk
    if not cands or note:
        # (nodes, beam score) of the hypotheses the final choice weighs: the beam's own choice alone with 1
        grown = (grow_curve(evidence, B, candidates=int(choice_candidates), colour_px=colour_px)
                 if choice_candidates > 1 else [(grow_curve(evidence, B, colour_px=colour_px), 0.0)])
        grown = [(G, sc) for G, sc in grown if len(G) >= 3]
        if not grown:
            if not cands:
                raise TendrilLostError("no curve from the base that two views explain")
        else:
            X = _choose_acquired(grown, evidence, B, segment_mm)
            prec, cov = curve_support(X, evidence)
            cands.append({"mode": "acquired", "nodes_mm": X, "precision": prec, "coverage": cov,
                          "score": _score(prec, cov)})
    eligible = [c for c in cands if not c.get("shrunk")] or cands  # a shrunk tracked curve: only if nothing else
    best = max(eligible, key=lambda c: (round(c["score"], 3), _length(c["nodes_mm"])))  # ties: the longer, then tracked
    length = _length(best["nodes_mm"])
    if length < 5 * segment_mm:
        raise TendrilLostError(f"the curve that two views explain is only {length:.1f} mm long")
    if length < STUB_MM and runs_out(evidence, [best["nodes_mm"]], 2.0)[0]:
        raise TendrilLostError(f"the only curve from the base that two views explain runs out of their ROIs after "
                               f"{length:.1f} mm (a stem stub or a leaf's stalk, not the tendril)")
    keep = cands if keep_candidates else []
    return MultiviewResult(nodes_mm=best["nodes_mm"], mode=best["mode"], precision=best["precision"],
                           coverage=best["coverage"], note=note if best["mode"] == "acquired" else "", candidates=keep)


def distance_table(points_mm: np.ndarray, evidence: list[SkeletonEvidence | None]) -> list[dict]:
    """Table 1 rows against each view's skeleton pixels (views without evidence skipped).

    Returns rows ``view, section, mean_px, std_px, max_px, n_points`` as
    :func:`tendrilkit.triangulation.reprojection_table`, the distance being
    that of each projected point to the nearest skeleton pixel of the view
    (points the view does not see are left out).
    """
    X = np.asarray(points_mm, float)
    sec = section_masks(arc_length(X))
    rows = []
    for v, ev in enumerate(evidence):
        if ev is None:
            continue
        d, _, seen = skeleton_distance(ev, ev.camera.project(X))
        for name in ("base", "tip", "entire"):
            dd = d[sec[name] & seen]
            rows.append({"view": v + 1, "section": name, "mean_px": float(dd.mean()) if dd.size else None,
                         "std_px": float(dd.std()) if dd.size else None,
                         "max_px": float(dd.max()) if dd.size else None, "n_points": int(dd.size)})
    return rows
