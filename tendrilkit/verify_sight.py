"""The lone tip: the tendril goes on beyond the curve's tip in one view, and the other views cannot see it.

The tip checks of :mod:`tendrilkit.verify_tip` count a tendril going on
beyond the projected tip in two views or more (one view may show clutter
beyond the tip: a second tendril, a stalk, a leaf's edge). A curve that
stops short of the tendril's end shows the rest in one view only when the
other views cannot see it: the rest is covered there (a leaf or an object at
the tip), out of their image or ROI, or runs along their line of sight
(foreshortened to a few pixels). Of these only the last can be told from the
one view alone, by the geometry of the rig:

the rest of the tendril beyond the tip, a 3D line starting at the tip, is
seen by view B as a few pixels only where it runs along B's line of sight
through the tip, the ray from B's centre through the tip. View A sees that
ray as a line through its own projected tip (the epipolar line of B's tip).
So where the skeleton going on beyond the tip in view A
(:func:`tendrilkit.verify_tip.tip_continuation_path`) stays within a few
pixels of that line, B's not showing it is no evidence against it; where it
leaves the line, B would show it beside its own tip (the point's projection
in B lies on the epipolar line of the point in A, which misses B's tip by
about as much) and does not: clutter in view A, not the tendril.

:func:`lone_tip_px` is the continuation in view A where every other view
that reads the tip is blind to it this way, or cannot see beyond the tip at
all (its projected tip outside its ROI or image: the ROI's border, as
``tip_border_px_v<i>``). An object at B's tip (``tip_object_px_v<i>``) is
not taken as blindness: clutter ahead of a right curve's tip in one view is
common, and an object at the tip is what makes the continuation ambiguous.

Measured on the multi-view curves of development seeds 1040-1079 and
9240-9299 (main 4b08771's run, tag m19: 595 reconstructed frames, 261 right
on all three accuracy criteria): 33 frames have more than 3 px of lone
continuation (``SIGHT_TOL_PX`` 6 px), every one wrong (tip 2.1-87 mm off), 8
of them reported ``ok`` before (seed 1077 frame 3, 3.0 mm short, 7.7 px;
seed 9265 frames 0-2, 4, 5, a hook's tip cut 1.3-1.9 mm before its end,
2.4-2.8 mm off, 4.4-6.0 px; seed 9270 frame 2, 4.5 mm, 7.4 px; seed 9293
frame 5, 2.1 mm, 3.8 px, view 2's tip outside its ROI); no right frame. The
right frames' skeleton spurs beyond the tip read 0-3.4 px; with a tolerance
of 8 px one of them (seed 1070 frame 0, 3.4 px, 7.3-7.9 px from the lines)
would count. Re-run with the check (tracking starts only from ``ok``
frames, so later curves can change): the frames ``ok`` with the max or an
end over 2 mm went 9 -> 8 and 13 -> 7 (one new: seed 9251 frame 5, max
2.15 mm, reconstructed afresh after its predecessors were flagged), the
frames right on all three criteria flagged 15 -> 15 of 100 and 38 -> 38 of
161, silent 0 -> 0. Validation seeds 1200-1239 (``bench_generalize``): no
frame changed status (five frames already doubtful read over 3 px); 0
silent, 5 ``ok`` with the max or an end over 2 mm, 20 of 81 right frames
flagged, as before.

Seen and left: a coil seen end-on hides the rest of the tendril behind the
curve's own projection in a view (seed 1056 frame 3, 12.6 mm short: 59.5 px
going on in view 3, 20.5 px from view 2's line of sight, where the rest
runs over the coil already explained and then over a green leaf); the
visibility of such a rest is not read here.
"""

from __future__ import annotations

import numpy as np

from tendrilkit.verify_tip import px_over_message

__all__ = ["SIGHT_TOL_PX", "SIGHT_REACH_MM", "sight_line_xy", "sight_deviation_px", "lone_tip_px",
           "lone_tip_message"]

#: The continuation in view A runs along view B's line of sight through the tip when no pixel of it lies farther
#: than this from that line's projection (px): the skeleton's pixel steps and the tip's few px of play.
SIGHT_TOL_PX = 6.0

#: How far along B's line of sight, either side of the tip, its projection into A is drawn (mm).
SIGHT_REACH_MM = 150.0


def sight_line_xy(cam_a, cam_b, tip_world: np.ndarray, *, reach_mm: float = SIGHT_REACH_MM,
                  step_mm: float = 1.0) -> np.ndarray:
    """View B's line of sight through the tip, as view A sees it: (k, 2) float, full-image px of A.

    The points ``tip + s u`` (``u`` the unit direction from B's centre to
    the tip, ``s`` from ``-reach_mm`` to ``reach_mm`` every ``step_mm``, those
    in front of both cameras) projected into A (with A's distortion, so a
    curve in general).
    """
    tip = np.asarray(tip_world, float).reshape(3)
    u = tip - cam_b.center_world
    n = float(np.linalg.norm(u))
    if not n > 0:
        return np.zeros((0, 2))
    u /= n
    s = np.arange(-reach_mm, reach_mm + 0.5 * step_mm, step_mm)
    P = tip[None] + s[:, None] * u[None]
    front = (cam_a.world_to_cam(P)[:, 2] > 1.0) & (cam_b.world_to_cam(P)[:, 2] > 1.0)
    xy = cam_a.project(P[front])
    return xy[np.all(np.isfinite(xy), axis=1)]


def sight_deviation_px(path_xy: np.ndarray, line_xy: np.ndarray) -> float:
    """The largest distance of a path's pixels to a polyline, px (inf: no line).

    Examples
    --------
    >>> line = np.array([[0.0, 0.0], [10.0, 0.0], [20.0, 0.0]])
    >>> sight_deviation_px(np.array([[3.0, 1.0], [15.0, -2.5]]), line)
    2.5
    """
    path = np.asarray(path_xy, float).reshape(-1, 2)
    line = np.asarray(line_xy, float).reshape(-1, 2)
    if len(line) < 2:
        return float("inf")
    if len(path) == 0:
        return 0.0
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.einsum("nkd,kd->nk", path[:, None, :] - a[None], ab) / np.maximum((ab ** 2).sum(1), 1e-12)
    c = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
    return float(np.linalg.norm(path[:, None, :] - c, axis=2).min(axis=1).max())


def lone_tip_px(paths: list, lengths: list, cameras: list, tip_world: np.ndarray, blind_out: list, *,
                tol_px: float = SIGHT_TOL_PX) -> list:
    """Per view, the continuation beyond the tip that the other views cannot see, px (0: they could; None: unread).

    Parameters
    ----------
    paths : list of (m, 2) float arrays or None
        Per view, :func:`tendrilkit.verify_tip.tip_continuation_path`'s path (None: the view was not read).
    lengths : list of float or None
        Per view, its length, px.
    cameras : list of Camera
    tip_world : (3,) float array
        The curve's tip, world mm.
    blind_out : list of bool
        Per view, whether it cannot see beyond the tip at all (its projected tip outside its ROI or image, or
        the view not read).
    tol_px : float
        :data:`SIGHT_TOL_PX`.

    Returns
    -------
    list of float or None
        Per view A: its continuation length where every other view B is ``blind_out`` or the continuation in
        A stays within ``tol_px`` of B's line of sight through the tip (:func:`sight_line_xy`); else 0.
    """
    out: list = []
    for a, (path, length) in enumerate(zip(paths, lengths)):
        if path is None or length is None:
            out.append(None)
            continue
        if not length > 0 or len(path) == 0:
            out.append(0.0)
            continue
        blind = True
        for b in range(len(cameras)):
            if b == a or blind_out[b]:
                continue
            dev = sight_deviation_px(path, sight_line_xy(cameras[a], cameras[b], tip_world))
            if not dev <= tol_px:
                blind = False
                break
        out.append(float(length) if blind else 0.0)
    return out


def lone_tip_message(figures: dict, n_views: int, limit_px: float) -> str | None:
    """The message when the tendril goes on beyond the tip, unseen by the other views (``lone_tip_px_v<i>``),
    by more than ``limit_px`` in one view or more, else None."""
    return px_over_message(figures, "lone_tip_px", n_views, limit_px,
                           "tip: the tendril goes on beyond the curve's tip where the other views cannot see it "
                           "(along their line of sight, or beyond their ROI)")
