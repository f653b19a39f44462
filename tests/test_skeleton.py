"""Skeleton graph and base-to-tip ordering on drawn tubes of known centreline."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest

from tendrilkit.exceptions import AmbiguousOrderingError, EmptySkeletonError, TendrilLostError
from tendrilkit.skeleton import compare_centerlines, order_skeleton, process_view

WIDTH = 9


def draw(curve_xy: np.ndarray, width: int = WIDTH, shape=(700, 800)) -> np.ndarray:
    """A bool mask of a tube of ``width`` px around the polyline (sub-pixel, round caps)."""
    img = np.zeros(shape, np.uint8)
    cv2.polylines(img, [np.round(curve_xy * 16).astype(np.int32)], False, 255, width, cv2.LINE_8, 4)
    return img > 0


def line(p0, p1, n=300) -> np.ndarray:
    return np.linspace(p0, p1, n)


def bezier(p0, d0, p3, d3, k=200.0, n=800) -> np.ndarray:
    p0, d0, p3, d3 = (np.asarray(a, float) for a in (p0, d0, p3, d3))
    u = np.linspace(0, 1, n)[:, None]
    p1, p2 = p0 + k * d0, p3 - k * d3
    return (1 - u) ** 3 * p0 + 3 * (1 - u) ** 2 * u * p1 + 3 * (1 - u) * u**2 * p2 + u**3 * p3


def crossing_curve(angle_deg: float, tail: float | None = None, L: float = 150.0, centre=(400, 330)) -> np.ndarray:
    """Base line along +x through the centre, a loop back, and a line crossing it at ``angle_deg``.

    ``tail``: how far the last line runs past the crossing (default ``L``).
    """
    a = np.radians(angle_deg)
    d2 = np.array([np.cos(a), np.sin(a)])
    first = line([-L, 0.0], [L, 0.0], 500)
    loop = bezier(first[-1], [1.0, 0.0], -L * d2, d2)
    last = -L * d2 + np.linspace(0, L + (L if tail is None else tail), 500)[:, None] * d2
    return np.vstack([first, loop[1:], last[1:]]) + np.asarray(centre, float)


def two_loops() -> np.ndarray:
    c1 = crossing_curve(70) - (400, 330)
    d = (c1[-1] - c1[-2]) / np.hypot(*(c1[-1] - c1[-2]))
    th = np.arctan2(d[1], d[0])
    R = np.array([[np.cos(th), -np.sin(th)], [np.sin(th), np.cos(th)]])
    c2 = ((c1 - c1[0]) @ R.T) * 0.8 + c1[-1]
    return np.vstack([c1, c2[1:]]) * 0.75 + (300, 350)


def check(oc, truth, *, mean_px=1.0):
    m = compare_centerlines(oc.points_xy, truth)
    assert m["mean_px"] < mean_px, m
    assert m["arc_corr"] > 0.99, m
    assert m["fraction_max_px"] < 0.03 * compare_len(truth) + 6, m
    assert m["base_px"] < 8 and m["tip_px"] < 8, m
    return m


def compare_len(c):
    return float(np.hypot(*np.diff(c, axis=0).T).sum())


def test_straight_tube_ordered_from_the_base_point():
    truth = line([100.0, 200.3], [500.0, 320.7])
    mask = draw(truth)
    oc = order_skeleton(mask, base_point_xy=(95, 200))
    m = check(oc, truth, mean_px=0.5)
    assert oc.decisions == () and oc.n_crossings == 0
    assert abs(oc.width_px - WIDTH) < 1.5
    spacing = np.hypot(*np.diff(oc.points_xy, axis=0).T)
    assert np.allclose(spacing, spacing.mean(), atol=0.05) and abs(spacing.mean() - 1) < 0.05
    # the other end as base reverses the order
    rev = order_skeleton(mask, base_point_xy=(505, 320))
    assert compare_centerlines(rev.points_xy, truth[::-1])["arc_corr"] > 0.99
    assert m["tip_px"] < 3


def test_offset_is_added():
    truth = line([50.0, 60.0], [250.0, 90.0])
    mask = draw(truth, shape=(200, 300))
    oc = order_skeleton(mask, offset_xy=(1000, 500), base_point_xy=(1050, 560))
    check(oc, truth + (1000, 500), mean_px=0.5)


@pytest.mark.parametrize("angle", [20, 30, 45, 60, 90, 120, 150, 160])
def test_one_crossing_away_from_tip(angle):
    truth = crossing_curve(angle)
    oc = order_skeleton(draw(truth), base_point_xy=truth[0])
    check(oc, truth)
    assert oc.n_crossings == 1
    assert len(oc.decisions) == 1
    d = oc.decisions[0]
    assert d.chosen == 0 and d.method == "smooth" and len(d.candidates) == 3
    assert np.hypot(*(d.junction_xy - (400, 330))) < WIDTH
    assert abs(d.candidates[0][1]) < 15  # straight through the crossing


@pytest.mark.parametrize("angle", [45, 90, 135])
def test_paper_method_matches_on_one_crossing(angle):
    truth = crossing_curve(angle)
    oc = order_skeleton(draw(truth), base_point_xy=truth[0], method="paper")
    check(oc, truth)
    assert oc.decisions[0].method == "paper"


def test_crossing_near_tip():
    # the tip runs only a little past the crossing (the paper's two sub-sets)
    for tail in (3.0, 25.0):
        truth = crossing_curve(80, tail=tail)
        for method in ("smooth", "paper"):
            oc = order_skeleton(draw(truth), base_point_xy=truth[0], method=method)
            check(oc, truth)
            assert oc.n_crossings == 1


def test_two_crossings():
    truth = two_loops()
    oc = order_skeleton(draw(truth, shape=(800, 900)), base_point_xy=truth[0])
    check(oc, truth)
    assert oc.n_crossings == 2 and len(oc.decisions) == 2
    assert [d.junction for d in oc.decisions] == [0, 1]
    with pytest.raises(AmbiguousOrderingError, match="at most one crossing"):
        order_skeleton(draw(truth, shape=(800, 900)), base_point_xy=truth[0], method="paper")


def test_override_forces_a_branch_and_is_recorded():
    truth = crossing_curve(90)
    mask = draw(truth)
    free = order_skeleton(mask, base_point_xy=truth[0], frame=3, view=2)
    other_frame = [{"frame": 4, "view": 2, "junction": 0, "branch": 1}]
    same = order_skeleton(mask, base_point_xy=truth[0], frame=3, view=2, overrides=other_frame)
    assert np.allclose(same.points_xy, free.points_xy)
    forced = order_skeleton(
        mask, base_point_xy=truth[0], frame=3, view=2, overrides=[{"frame": 3, "view": 2, "junction": 0, "branch": 1}]
    )
    d = forced.decisions[0]
    assert d.method == "override" and d.chosen == 1 and (d.frame, d.view) == (3, 2)
    assert compare_centerlines(forced.points_xy, truth)["fraction_max_px"] > 50  # a wrong turn, as asked
    with pytest.raises(AmbiguousOrderingError, match="branch 7"):
        order_skeleton(mask, base_point_xy=truth[0], overrides=[{"frame": 0, "view": 1, "junction": 0, "branch": 7}])
    as_dict = free.decisions[0].as_dict()
    assert set(as_dict) >= {"frame", "view", "junction", "junction_x_px", "junction_y_px", "candidates", "chosen", "method"}


def test_short_spur_is_pruned():
    truth = line([100.0, 200.0], [500.0, 200.0])
    mask = draw(truth)
    cv2.line(mask.view(np.uint8), (300, 200), (300, 212), 1, 3)  # a bump of 8 px beyond the tube
    oc = order_skeleton(mask, base_point_xy=(100, 200), prune_px=12)
    check(oc, truth, mean_px=0.6)
    assert oc.decisions == ()


def test_failures_are_named():
    with pytest.raises(EmptySkeletonError):
        order_skeleton(np.zeros((50, 50), bool), base_point_xy=(0, 0))
    ring = np.zeros((200, 200), np.uint8)
    cv2.circle(ring, (100, 100), 60, 1, 7)
    with pytest.raises(AmbiguousOrderingError, match="closed ring"):
        order_skeleton(ring.astype(bool), base_point_xy=(40, 100))
    with pytest.raises(ValueError, match="method"):
        order_skeleton(ring.astype(bool), base_point_xy=(40, 100), method="walk")


def test_process_view_on_a_colour_image():
    truth = crossing_curve(100) + (300, 200)
    img = np.full((1080, 1920, 3), 230, np.uint8)
    x0, y0 = truth[0]
    cv2.line(img, (500, 250), (500, 800), (50, 110, 60), 15)  # the stem
    cv2.line(img, (500, int(y0)), (int(x0), int(y0)), (40, 150, 90), WIDTH)  # tendril leaving the stem
    cv2.polylines(img, [np.round(truth * 16).astype(np.int32)], False, (40, 150, 90), WIDTH, cv2.LINE_AA, 4)
    roi, keep_out = (480, 100, 900, 800), (490, int(y0) - 20, 25, 40)
    full_truth = np.vstack([line([515.0, y0], [x0, y0], 40), truth[1:]])
    res = process_view(img, roi=roi, keep_out=keep_out, base_point_xy=(505, y0), frame=2, view=3)
    check(res, full_truth)
    assert res.n_crossings == 1 and res.decisions[0].view == 3
    assert res.area_px > 1000 and roi[0] < res.centroid_xy[0] < roi[0] + roi[2]
    with pytest.raises(TypeError, match="unexpected keyword argument 'prune'"):  # an unknown option, named
        process_view(img, roi=roi, keep_out=keep_out, base_point_xy=(505, y0), ordering={"prune": 3})
    with pytest.raises(TendrilLostError):
        process_view(np.full_like(img, 230), roi=roi, keep_out=keep_out, base_point_xy=(505, y0))


def test_compare_centerlines_detects_reversed_order():
    truth = crossing_curve(90)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        oc = order_skeleton(draw(truth), base_point_xy=truth[0])
    m = compare_centerlines(oc.points_xy[::-1], truth)
    assert m["arc_corr"] < 0 and m["base_px"] > 100


@pytest.mark.parametrize("offset", [0.0, 4.0])
def test_loop_running_along_itself(offset):
    # a full loop that comes back tangent to its own start: the two passes
    # merge into one band of skeleton that the walk must take twice
    th = np.linspace(0, 2 * np.pi, 600)[1:]
    R = 70.0
    base = line([100.0, 300.0], [300.0, 300.0], 300)
    loop = np.c_[300 + R * np.sin(th), 300 - R * (1 - np.cos(th)) + offset * th / (2 * np.pi)]
    tail = line(loop[-1], loop[-1] + [200.0, 0.0], 300)[1:]
    truth = np.vstack([base, loop, tail])
    oc = order_skeleton(draw(truth), base_point_xy=truth[0])
    m = compare_centerlines(oc.points_xy, truth)
    # along the band both passes are nearest to the points: the arc
    # correlation drops, the same-fraction distance shows the order
    assert m["mean_px"] < 1.0 and m["fraction_max_px"] < 8 and m["arc_corr"] > 0.85, m
    assert oc.n_crossings == 1
