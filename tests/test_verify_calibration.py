"""The calibration's world frame check (tendrilkit.verify_calibration) and its place in a run's statuses.

A world marker whose corners are wrong in one view (partly covered) makes the
joint adjustment rescale the whole world: every curve passes the image checks
yet is millimetres off (old dev seed 9201: 11 %, base 3.25 mm off, frames
reported ``ok``). The check must flag that calibration and leave right ones.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from tendrilkit.assembly import with_run_checks
from tendrilkit.calibration import calibrate_from_observations
from tendrilkit.calibration.synthetic import L, WORLD_ID, distorted_rig, observe_markers, synthetic_markers
from tendrilkit.pipeline import FrameResult
from tendrilkit.verify import Thresholds
from tendrilkit.verify_calibration import world_marker_fit, world_marker_message


def _calibrate(cover_px: float):
    """Calibrate the synthetic rig from noisy corners (0.05 px), two corners of the world marker in view 1 moved
    ``cover_px`` towards the others (what a cover over the marker's edge does to the detection)."""
    rng = np.random.default_rng(3)
    truth = distorted_rig()
    obs = observe_markers(truth, synthetic_markers(rng), rng, 0.05)
    w = obs[0][WORLD_ID].copy()
    centre = w.mean(axis=0)
    for k in (0, 1):
        w[k] += cover_px * (centre - w[k]) / np.linalg.norm(centre - w[k])
    obs[0][WORLD_ID] = w
    res = calibrate_from_observations(obs, truth, world_id=WORLD_ID, length_mm=L)
    # scale of the calibrated world against the truth: distance between two camera centres
    centres = [np.array([c.center_world for c in cams])
               for cams in (res.cameras, truth)]
    scale = np.linalg.norm(centres[0][0] - centres[0][2]) / np.linalg.norm(centres[1][0] - centres[1][2])
    return res, scale


def test_right_calibration_passes():
    res, scale = _calibrate(0.0)
    worst, _, others = world_marker_fit(res.markers, WORLD_ID)
    assert worst < 0.5 and abs(scale - 1) < 0.002
    assert world_marker_message(res.markers, WORLD_ID, Thresholds().max_world_marker_px) is None


def test_covered_world_marker_is_flagged():
    res, scale = _calibrate(4.0)
    worst, view, others = world_marker_fit(res.markers, WORLD_ID)
    assert abs(scale - 1) > 0.003  # the world is rescaled (0.04 % when right): every mm off, which no image check sees
    assert view == 1 and worst > 3 * others
    msg = world_marker_message(res.markers, WORLD_ID, Thresholds().max_world_marker_px)
    assert msg is not None and msg.startswith(f"calibration: the world marker (id {WORLD_ID})") and "view 1" in msg


def test_no_adjusted_world_marker_no_check():
    t = pd.DataFrame({"view": [1, 2], "marker_id": [WORLD_ID, WORLD_ID], "stage": "single", "max_px": [3.0, 3.0]})
    assert world_marker_fit(t, WORLD_ID) is None and world_marker_message(t, WORLD_ID) is None
    # without other markers the absolute limit alone decides
    t["stage"] = "adjusted"
    assert world_marker_message(t, WORLD_ID) is not None and world_marker_message(t, WORLD_ID, 3.5) is None


def test_run_check_turns_every_reconstructed_frame_doubtful():
    pts = np.zeros((3, 3))
    ok = FrameResult(frame=0, time_s=0.0, status="ok", message="tracking lost: acquired afresh", points_mm=pts)
    doubt = FrameResult(frame=1, time_s=15.0, status="doubtful", message="tip: x; a note", points_mm=pts,
                        checks=["tip: x"])
    failed = FrameResult(frame=2, time_s=30.0, status="failed", message="no tendril")
    out = with_run_checks([ok, doubt, failed], ["calibration: c"])
    assert [r.status for r in out] == ["doubtful", "doubtful", "failed"]
    assert out[0].message == "calibration: c; tracking lost: acquired afresh" and out[0].checks == ["calibration: c"]
    assert out[1].message == "tip: x; calibration: c; a note" and out[1].checks == ["tip: x", "calibration: c"]
    assert out[2].message == "no tendril"
    assert [r.status for r in with_run_checks([ok], [])] == ["ok"]


def test_run_check_after_a_shape_jump_repeats_no_part_of_the_message():
    """A shape-jump check names its parts joined by "; ": the run's check goes after it, the note last, once each."""
    from tendrilkit.assembly import with_temporal_checks

    s = np.linspace(0, 1, 100)
    curve = np.column_stack([40 * s, 18 * s**2, 0 * s])
    curves = [curve, curve, curve + [0, 200, 0], curve, curve]
    results = [FrameResult(frame=i, time_s=15.0 * i, status="ok", message="a note", points_mm=c)
               for i, c in enumerate(curves)]
    jumped = with_temporal_checks(results)[2]
    assert jumped.status == "doubtful" and jumped.checks
    out = with_run_checks([jumped], ["calibration: c"])[0]
    assert out.message == "; ".join(list(jumped.checks) + ["calibration: c", "a note"])
    assert out.checks == list(jumped.checks) + ["calibration: c"]
