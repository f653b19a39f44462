"""The tone ahead of the tip and the colour along the curve (tendrilkit.verify_tone), on tiny drawn images."""

import cv2
import numpy as np

from tendrilkit.evidence import view_evidence
from tendrilkit.params import Verification
from tendrilkit.segmentation import grey_image
from tendrilkit.verify import Thresholds
from tendrilkit.verify_tone import off_colour_message, off_colour_run_px, tip_tone_frac, tip_tone_message

ROI = [0, 0, 300, 120]


def _line(x0, x1, y=60.0):
    """A horizontal polyline every pixel from x0 to x1 (full-image px)."""
    x = np.arange(x0, x1 + 1, dtype=float)
    return np.column_stack([x, np.full_like(x, y)])


def _image(dark_to=250, pale_from=None, pale=(130, 130, 130), colour_from=None, colour=(40, 140, 60)):
    """White board, a 5 px tendril from x 20 to ``dark_to`` (dark grey), then optionally a part the threshold
    misses (``pale`` from ``pale_from``) and a part of another colour (``colour`` from ``colour_from``)."""
    img = np.full((120, 300, 3), 235, np.uint8)
    cv2.line(img, (20, 60), (dark_to, 60), (60, 70, 80), 5)
    if pale_from is not None:
        cv2.line(img, (pale_from, 60), (280, 60), pale, 5)
    if colour_from is not None:
        cv2.line(img, (colour_from, 60), (dark_to, 60), colour, 5)
    return img


def _evidence(img):
    return view_evidence(img, roi=ROI, keep_out=None, base_point_xy=[20, 60], opening_radius_px=0,
                         min_component_px=20, threshold=100, local_contrast=0.0)


def test_tone_ahead_of_a_tip_that_stops_where_a_pale_part_goes_on():
    img = _image(dark_to=150, pale_from=150)  # grey 130 on a 235 board: not dark at threshold 100
    ev = _evidence(img)
    assert not ev.foreground[60, 200]  # the pale part is not segmented: no dark-pixel check can see it
    short = _line(20, 148)
    on = np.ones(len(short), bool)
    assert tip_tone_frac(img, ev, short, on, 2.5) > 0.2
    # the right curve, to the tendril's end: the board ahead of it
    img2 = _image(dark_to=150)
    ev2 = _evidence(img2)
    right = _line(20, 150)
    assert tip_tone_frac(img2, ev2, right, np.ones(len(right), bool), 2.5) == 0.0


def test_tone_of_a_curve_stopping_on_a_dark_continuation_counts_too():
    img = _image(dark_to=250)  # the rest is segmented: the figure does not rest on the segmentation missing it
    ev = _evidence(img)
    short = _line(20, 150)
    assert tip_tone_frac(img, ev, short, np.ones(len(short), bool), 2.5) > 0.2
    full = _line(20, 250)
    assert tip_tone_frac(img, ev, full, np.ones(len(full), bool), 2.5) == 0.0


def test_tone_unknown_without_a_width_or_a_tendril_under_the_curve():
    img = _image()
    ev = _evidence(img)
    c = _line(20, 150)
    assert tip_tone_frac(img, ev, c, np.ones(len(c), bool), float("nan")) is None
    assert tip_tone_frac(img, ev, c, np.zeros(len(c), bool), 2.5) is None


def test_off_colour_run_is_the_stretch_on_another_colour():
    img = _image(dark_to=250, colour_from=170)  # green from x 170 to 250 (a leaf edge-on), the rest brown-grey
    ev = _evidence(img)
    c = _line(20, 250)
    seen = np.ones(len(c), bool)
    run = off_colour_run_px(img, ev, c, seen, seen)
    assert 75 <= run <= 85, run
    plain = _image(dark_to=250)
    assert off_colour_run_px(plain, ev, c, seen, seen) == 0.0
    assert off_colour_run_px(grey_image(plain), ev, c, seen, seen) is None  # no colour, no figure


def test_messages_need_two_views_and_limits_come_from_the_experiment():
    th = Thresholds.from_params(Verification(max_tip_tone_frac=0.2, max_off_colour_run_px=50.0))
    assert (th.max_tip_tone_frac, th.max_off_colour_run_px) == (0.2, 50.0)
    assert tip_tone_message({"tip_tone_frac_v1": 0.4, "tip_tone_frac_v2": 0.1}, 2, 0.2) is None
    m = tip_tone_message({"tip_tone_frac_v1": 0.4, "tip_tone_frac_v2": 0.3, "tip_tone_frac_v3": None}, 3, 0.2)
    assert m.startswith("tip:") and "view 1 (40 %" in m and "view 2 (30 %" in m and "limit 20 %" in m
    assert off_colour_message({"off_colour_run_px_v1": 120.0, "off_colour_run_px_v2": 20.0}, 2, 50.0) is None
    m = off_colour_message({"off_colour_run_px_v1": 120.0, "off_colour_run_px_v2": 60.0}, 2, 50.0)
    assert m.startswith("colour:") and "view 2 (60 px" in m

