"""The distal widening check (:mod:`tendrilkit.verify_widen`): a curve whose last part runs on a wider object."""

from pathlib import Path

import cv2
import numpy as np
import pytest

from tendrilkit.verify import Thresholds, verify_curve, verify_frame
from tendrilkit.verify_widen import distal_widening, distal_widening_message
from tests.test_verify import _scene, _tendril_mm


def _leaf_at_tip(T, half_axes_mm=(7.0, 3.0), ahead_mm=6.0):
    """A flat leaf (an ellipse in the tendril's plane) whose near end is at the tip of ``T``; its middle line.

    Returns ``draw(img, cam)`` and the leaf's middle line (world mm) from the tip to its far end.
    """
    d = (T[-1] - T[-10]) / np.linalg.norm(T[-1] - T[-10])
    n = np.array([-d[1], d[0], 0.0])
    c = T[-1] + ahead_mm * d
    a = np.linspace(0, 2 * np.pi, 120, endpoint=False)
    outline = c + half_axes_mm[0] * np.cos(a)[:, None] * d + half_axes_mm[1] * np.sin(a)[:, None] * n

    def draw(img, cam):
        cv2.fillPoly(img, [np.round(cam.project(outline) * 16).astype(np.int32)], (30, 30, 30), cv2.LINE_AA, 4)
    middle = T[-1] + np.linspace(0.25, ahead_mm + half_axes_mm[0] - 0.5, 60)[:, None] * d
    return draw, middle


def test_curve_running_on_along_a_leaf_under_the_tip_is_caught():
    """The tip rests on a leaf; a curve that runs on 12 mm along the leaf's middle to its pointed end is on dark
    pixels in every view, its last pixels on the leaf's narrow point: the line under its last part is wider."""
    T = _tendril_mm()
    draw, middle = _leaf_at_tip(T)
    cams, ev = _scene(draw)
    right = T
    wrong = np.vstack([T, middle])
    for v in range(2):
        assert distal_widening(right, cams[v], ev[v]) <= 1.1
        assert distal_widening(wrong, cams[v], ev[v]) > 1.5
    assert not any(m.startswith("widening:") for m in verify_frame(right, cams, ev, {}, Thresholds()))
    q = verify_curve(wrong, cams, ev)
    assert q["on_tendril_frac_v1"] == 1.0 and q["on_tendril_frac_v2"] == 1.0
    msgs = verify_frame(wrong, cams, ev, {}, Thresholds())
    assert any(m.startswith("widening:") and "view 2" in m for m in msgs)
    # the limit is the experiment's key: a larger ratio asked for, no message
    assert not any(m.startswith("widening:")
                   for m in verify_frame(wrong, cams, ev, {}, Thresholds(max_distal_widening=50.0)))
    from tendrilkit.params import Verification

    assert Thresholds.from_params(Verification(max_distal_widening=2.0)).max_distal_widening == 2.0


def test_widening_in_one_view_only_is_not_enough():
    """In one view the tendril's last part may pass in front of a leaf: two views are needed."""
    assert distal_widening_message({"distal_widening_ratio_v1": 3.0, "distal_widening_ratio_v2": 1.0}, 2, 1.2) is None
    assert distal_widening_message({"distal_widening_ratio_v1": 3.0, "distal_widening_ratio_v2": None}, 2, 1.2) is None
    m = distal_widening_message({"distal_widening_ratio_v1": 3.0, "distal_widening_ratio_v2": 1.3}, 2, 1.2)
    assert m.startswith("widening:") and "view 1 (3.00 x)" in m and "view 2 (1.30 x)" in m


def test_leaf_crossed_mid_curve_and_tapering_tip_are_not_widening():
    """A leaf under the middle of the tendril widens a stretch, not the distal part; a tapering tip narrows it."""
    from tests.test_verify import _leaf

    cams, ev = _scene(_leaf(0.5, axes=(20, 12)))
    for v in range(2):
        assert distal_widening(_tendril_mm(), cams[v], ev[v]) <= 1.15
    assert not any(m.startswith("widening:") for m in verify_frame(_tendril_mm(), cams, ev, {}, Thresholds()))


@pytest.mark.slow
def test_phantom_curve_run_on_along_a_leaf_at_its_tip_is_caught(tmp_path):
    """The S3 site phantom's first frame (rendered: shading, blur, noise): the true centreline passes; the same with a
    leaf drawn under its tip in every view (projected from one flat 3D leaf) and the curve run on 12 mm along the
    leaf's middle is flagged, in all three views."""
    from tendrilkit.io import open_views
    from tendrilkit.evidence import view_evidence
    from tendrilkit.options import stage_options
    from tendrilkit.params import load_experiment
    from tendrilkit.phantom import read_ground_truth, write_phantom_experiment

    exp_path = Path(write_phantom_experiment("S3", tmp_path / "exp", n_frames=1, seed=12))
    exp = load_experiment(exp_path)
    gt = read_ground_truth(tmp_path / "exp")
    T = np.asarray(gt.curves[0], float)
    draw, middle = _leaf_at_tip(T, half_axes_mm=(7.0, 3.0), ahead_mm=6.0)
    seg = stage_options(exp, "segmentation")
    srcs = open_views(list(exp.videos))
    try:
        images = [s.read(0) for s in srcs]
    finally:
        for s in srcs:
            s.close()
    cams = gt.cameras

    def evidence(imgs):
        return [view_evidence(img, roi=m.roi, keep_out=m.keep_out, base_point_xy=m.base_point, **seg)
                for img, m in zip(imgs, exp.views)]

    ev = evidence(images)
    assert all(distal_widening(T, c, e) <= 1.1 for c, e in zip(cams, ev))
    assert not any(m.startswith("widening:") for m in verify_frame(T, cams, ev, {}, Thresholds()))
    leafy = [img.copy() for img in images]
    for img, cam in zip(leafy, cams):
        draw(img, cam)
    ev = evidence(leafy)
    assert not any(m.startswith("widening:") for m in verify_frame(T, cams, ev, {}, Thresholds()))
    wrong = np.vstack([T, middle])
    figures = [distal_widening(wrong, c, e) for c, e in zip(cams, ev)]
    assert sum(f > Thresholds().max_distal_widening for f in figures) >= 2, figures
    assert any(m.startswith("widening:") for m in verify_frame(wrong, cams, ev, {}, Thresholds()))


def test_suffix_medians_are_those_of_a_list_grown_from_the_end():
    """The vectorised suffix medians equal the sorted list grown from the tip backwards, bit for bit."""
    import bisect

    from tendrilkit.verify_widen import _suffix_medians

    rng = np.random.default_rng(3)
    for n in (0, 1, 2, 7, 150, 401):
        for share in (0.0, 0.3, 1.0):
            v = np.round(rng.uniform(1, 12, n) * 4) / 4 + rng.uniform(0, 1e-12, n) * (rng.random(n) < 0.5)
            v[rng.random(n) < share] = np.nan
            med, cnt = _suffix_medians(v)
            kept: list[float] = []
            for k in range(n - 1, -1, -1):
                if np.isfinite(v[k]):
                    bisect.insort(kept, float(v[k]))
                m = len(kept)
                assert cnt[k] == m
                if m:
                    assert med[k] == 0.5 * (kept[(m - 1) // 2] + kept[m // 2])
                else:
                    assert np.isnan(med[k])
