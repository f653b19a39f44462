"""The lone tip check (:mod:`tendrilkit.verify_sight`): the tendril goes on beyond the tip along another view's line
of sight, so one view alone shows it."""

import cv2
import numpy as np

from tendrilkit.verify import Thresholds, verify_curve, verify_frame
from tendrilkit.verify_sight import lone_tip_message, lone_tip_px, sight_deviation_px, sight_line_xy
from tests.test_verify import _cameras, _scene, _tendril_mm


def _tail_along_sight_of_view_2(length_mm=100.0, n=100):
    """The tendril's rest beyond its tip, running from the tip towards camera 2 (along its line of sight)."""
    T = _tendril_mm()
    cam2 = _cameras()[1]
    u = (T[-1] - cam2.center_world) / np.linalg.norm(T[-1] - cam2.center_world)
    return T[-1] - np.linspace(0.0, length_mm, n)[:, None] * u


def _draw_3d(X, only_view=None):
    """Draw a 3D line 5 px wide (as the tendril) in every view, or in the view whose camera sits at x = only_view."""
    def draw(img, cam):
        if only_view is not None and cam.center_world[0] != only_view:
            return
        xy = cam.project(X)
        cv2.polylines(img, [np.round(xy * 16).astype(np.int32)], False, (30, 30, 30), 5, cv2.LINE_AA, 4)
    return draw


def test_sight_line_of_view_2_runs_through_the_tip_in_view_1_along_its_epipolar_line():
    cams = _cameras()
    tip = _tendril_mm()[-1]
    line = sight_line_xy(cams[0], cams[1], tip)
    t1 = cams[0].project(tip[None])[0]
    assert sight_deviation_px(t1[None], line) < 1e-6
    # side by side cameras: the epipolar lines are the rows
    assert np.ptp(line[:, 1]) < 1e-6 and np.ptp(line[:, 0]) > 50
    # the tail towards camera 2 is a point in view 2 and a line on that row in view 1
    tail = _tail_along_sight_of_view_2()
    assert np.ptp(cams[1].project(tail), axis=0).max() < 1e-6
    assert sight_deviation_px(cams[0].project(tail), line) < 1e-6


def test_tip_going_on_along_another_views_line_of_sight_is_caught_in_one_view():
    tail = _tail_along_sight_of_view_2()
    cams, ev = _scene(_draw_3d(tail))
    th = Thresholds()
    q = {}
    msgs = verify_frame(_tendril_mm(), cams, ev, q, th)
    assert q["tip_continuation_px_v1"] > 20 and q["tip_continuation_px_v2"] <= th.max_tip_continuation_px
    assert not any(m.startswith("tip: the tendril goes on beyond the curve's tip in") for m in msgs)  # two views
    assert q["lone_tip_px_v1"] == q["tip_continuation_px_v1"] and q["lone_tip_px_v1"] > th.max_lone_tip_px
    assert any(m.startswith("tip: the tendril goes on beyond the curve's tip where the other views cannot see it")
               for m in msgs)
    # the curve that follows the tail to its end passes
    whole = np.vstack([_tendril_mm(), tail[1:]])
    right = verify_curve(whole, cams, ev)
    assert all(right[f"lone_tip_px_v{v}"] <= th.max_lone_tip_px for v in (1, 2))


def test_clutter_beyond_the_tip_in_one_view_across_the_others_line_of_sight_is_not_the_tendril():
    """View 2 would see a tendril going on this way beside its tip, and shows nothing: view 1's line is clutter."""
    tip = _tendril_mm()[-1]
    across = tip + np.linspace(0.0, 5.0, 30)[:, None] * np.array([0.0, 1.0, 0.0])  # down the image, 25 px
    cams, ev = _scene(_draw_3d(across, only_view=0.0))
    q = verify_curve(_tendril_mm(), cams, ev)
    assert q["tip_continuation_px_v1"] > 10 and q["tip_continuation_px_v2"] == 0.0
    assert q["lone_tip_px_v1"] == 0.0


def test_lone_tip_px_counts_a_view_whose_tip_is_outside_its_roi_as_blind():
    cams = _cameras()
    tip = _tendril_mm()[-1]
    t1 = cams[0].project(tip[None])[0]
    across = np.column_stack([np.full(20, t1[0]), t1[1] + np.arange(20.0)])  # square to view 2's line of sight
    assert lone_tip_px([across, np.zeros((0, 2))], [19.0, 0.0], cams, tip, [False, False]) == [0.0, 0.0]
    assert lone_tip_px([across, np.zeros((0, 2))], [19.0, 0.0], cams, tip, [False, True]) == [19.0, 0.0]
    assert lone_tip_px([None, np.zeros((0, 2))], [None, 0.0], cams, tip, [False, False]) == [None, 0.0]


def test_lone_tip_message_names_the_view_its_figure_and_the_limit():
    m = lone_tip_message({"lone_tip_px_v1": 0.0, "lone_tip_px_v2": 7.4, "lone_tip_px_v3": None}, 3, 3.0)
    assert m.endswith("in view 2 (7 px) (limit 3 px in one view)")
    assert lone_tip_message({"lone_tip_px_v1": 3.0, "lone_tip_px_v2": 0.0}, 2, 3.0) is None
