"""Segmentation of the tendril in one view: channel, threshold, keep-out, components, tracking."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from tendrilkit.exceptions import TendrilLostError
from tendrilkit.segmentation import grey_image, segment_view

GREEN = (40, 150, 90)  # BGR: dark in blue, saturated
ROI = (100, 50, 400, 300)


def scene(*, stem=True, blob=True, speck=True) -> np.ndarray:
    img = np.full((480, 640, 3), 230, np.uint8)
    if stem:
        cv2.line(img, (120, 60), (120, 340), (50, 110, 60), 13)
    cv2.line(img, (120, 200), (400, 150), GREEN, 7)  # the tendril, leaving the stem at (120, 200)
    if blob:
        cv2.circle(img, (420, 300), 20, GREEN, -1)  # a leaf
    if speck:
        cv2.circle(img, (300, 300), 2, GREEN, -1)  # 13 px: dropped
    return img


def test_first_frame_takes_the_component_at_the_base_point():
    img = scene()
    m = segment_view(img, roi=ROI, keep_out=(110, 185, 25, 30), base_point_xy=(130, 200))
    assert m.mask_roi.shape == (300, 400) and m.mask_roi.dtype == bool
    assert tuple(m.roi_offset_xy) == (100, 50)
    # the keep-out box cuts the stem from the tendril (and in two): stem above, stem below,
    # tendril, leaf; the speck is dropped
    assert m.n_components == 4
    ys, xs = np.nonzero(m.mask_roi)
    assert xs.min() + 100 >= 135 - 1 and xs.max() + 100 <= 404
    assert np.allclose(m.centroid_xy, [xs.mean() + 100, ys.mean() + 50])
    assert m.area_px == len(xs)


def test_without_keep_out_the_stem_joins_the_tendril():
    m = segment_view(scene(), roi=ROI, keep_out=None, base_point_xy=(130, 200))
    ys, xs = np.nonzero(m.mask_roi)
    assert ys.min() + 50 < 70  # the stem's top is in the component


def test_later_frames_track_the_nearest_centroid():
    img = scene()
    m = segment_view(img, roi=ROI, keep_out=(110, 185, 25, 30), base_point_xy=(130, 200), prev_centroid_xy=(415, 290))
    assert np.hypot(*(m.centroid_xy - (420, 300))) < 2  # the leaf is now nearest


def test_base_point_outside_every_component_takes_the_nearest():
    m = segment_view(scene(stem=False), roi=ROI, keep_out=None, base_point_xy=(110, 215))
    assert m.mask_roi[200 - 50, 125 - 100]


def test_fixed_threshold_hsv_and_opening():
    img = scene(stem=False, blob=False)
    a = segment_view(img, roi=ROI, keep_out=None, base_point_xy=(130, 200), threshold=120)
    b = segment_view(img, roi=ROI, keep_out=None, base_point_xy=(130, 200), channel="hsv")
    c = segment_view(img, roi=ROI, keep_out=None, base_point_xy=(130, 200), opening_radius_px=0, min_component_px=5)
    assert a.n_components == 1 and b.n_components == 1 and c.n_components == 2  # the speck kept
    assert abs(a.area_px - b.area_px) < 0.1 * a.area_px
    grey = grey_image(img, channel="hsv")
    assert grey[150, 400] < 130 and grey[10, 10] > 200
    # a fixed threshold darker than the tendril finds nothing (without the faint pixels, which find it)
    with pytest.raises(TendrilLostError, match="no component"):
        segment_view(img, roi=ROI, keep_out=None, base_point_xy=(130, 200), threshold=30, local_contrast=0)
    assert segment_view(img, roi=ROI, keep_out=None, base_point_xy=(130, 200), threshold=30).area_px > 0.8 * a.area_px


def test_lost_and_bad_arguments():
    blank = np.full((480, 640, 3), 230, np.uint8)
    with pytest.raises(TendrilLostError):
        segment_view(blank, roi=ROI, keep_out=None, base_point_xy=(130, 200))
    img = scene()
    with pytest.raises(ValueError, match="roi"):
        segment_view(img, roi=(10, 10, 0, 5), keep_out=None, base_point_xy=(0, 0))
    with pytest.raises(ValueError, match="overlap"):
        segment_view(img, roi=(700, 10, 50, 50), keep_out=None, base_point_xy=(0, 0))
    with pytest.raises(ValueError, match="threshold"):
        segment_view(img, roi=ROI, keep_out=None, base_point_xy=(0, 0), threshold="mean")
    with pytest.raises(ValueError, match="channel"):
        segment_view(img, roi=ROI, keep_out=None, base_point_xy=(0, 0), channel="red")
    with pytest.raises(ValueError, match="image_bgr"):
        segment_view(img.astype(float), roi=ROI, keep_out=None, base_point_xy=(0, 0))


def test_roi_is_clipped_to_the_image():
    img = scene(stem=False, blob=False, speck=False)
    m = segment_view(img, roi=(-50, -50, 500, 400), keep_out=None, base_point_xy=(130, 200))
    assert tuple(m.roi_offset_xy) == (0, 0) and m.mask_roi.shape == (350, 450)


def test_base_point_against_the_stem_takes_the_thin_tendril():
    # the base point lies in the keep-out box, touching the thick stem: the
    # stem and the tendril are equally near it, the thinner one is the tendril
    img = np.full((480, 640, 3), 230, np.uint8)
    cv2.line(img, (100, 60), (100, 400), (50, 110, 60), 21)  # stem, 21 px thick, edge at x = 110
    cv2.line(img, (112, 200), (420, 330), GREEN, 5)  # the tendril, leaving the stem
    m = segment_view(img, roi=(60, 50, 420, 380), keep_out=(106, 193, 14, 14), base_point_xy=(110, 200))
    ys, xs = np.nonzero(m.mask_roi)
    assert xs.min() + 60 >= 118 and xs.max() + 60 > 400 and m.n_components == 2


@pytest.mark.parametrize("opts", [{}, {"channel": "hsv", "threshold": 120, "opening_radius_px": 0}])
def test_evidence_from_the_segmentations_foreground_is_the_evidence_from_the_image(opts):
    """The verification reuses the segmentation's labelled dark pixels: the same evidence as thresholding again."""
    from tendrilkit.evidence import view_evidence

    img = scene()
    marks = dict(roi=ROI, keep_out=(110, 185, 25, 30), base_point_xy=(130, 200))
    seg = segment_view(img, **marks, **opts)
    fg = seg.foreground
    assert fg.labels.shape == seg.mask_roi.shape and fg.n_labels == int(fg.labels.max()) + 1
    assert np.array_equal(seg.mask_roi, fg.labels == fg.labels[seg.mask_roi][0])
    again = view_evidence(img, **marks, **opts)
    reused = view_evidence(img, **marks, foreground=fg, **opts)
    for name in ("foreground", "labels", "distance_px", "roi_offset_xy", "base_point_xy", "keep_out", "skeleton_xy"):
        assert np.array_equal(getattr(again, name), getattr(reused, name)), name
    assert again.width_px == reused.width_px
    with pytest.raises(ValueError, match="other segmentation options"):
        view_evidence(img, **marks, foreground=fg, opening_radius_px=2)


def pale_scene(*, seed=0, tendril_bgr=(160, 200, 190)) -> np.ndarray:
    """A dark stem and a pale, tapering tendril on a board lit unevenly (vignetting), with sensor noise."""
    h, w = 480, 640
    yy, xx = np.mgrid[0:h, 0:w]
    light = 1.0 - 0.35 * (((xx - 320) / 400.0) ** 2 + ((yy - 240) / 300.0) ** 2)
    img = (np.array([215.0, 225.0, 230.0]) * light[..., None]).astype(np.float32)
    tube = np.zeros((h, w), np.uint8)
    pts = [(120 + 28 * i, 200 - 5 * i) for i in range(11)]  # (120, 200) -> (400, 150)
    for i in range(10):
        cv2.line(tube, pts[i], pts[i + 1], 255, 7 - i // 3)  # 7 px at the base, 4 px at the tip
    a = cv2.GaussianBlur(tube.astype(np.float32) / 255.0, (0, 0), 0.7)[..., None]
    img = img * (1 - a) + np.array(tendril_bgr, np.float32) * light[..., None] * a
    cv2.line(img, (120, 60), (120, 340), (50, 110, 60), 13)
    img += np.random.default_rng(seed).normal(0.0, 3.0, img.shape).astype(np.float32)
    return np.clip(img, 0, 255).astype(np.uint8), tube > 0


def test_faint_pixels_find_a_pale_tendril_that_otsu_leaves_with_the_board():
    img, truth = pale_scene()
    marks = dict(roi=ROI, keep_out=(110, 185, 25, 30), base_point_xy=(130, 200))
    otsu = segment_view(img, local_contrast=0, **marks)
    m = segment_view(img, **marks)
    x0, y0 = m.roi_offset_xy
    t = truth[y0:y0 + 300, x0:x0 + 400]
    t[:, :35] = False  # the keep-out box and the stem
    assert otsu.mask_roi[t].mean() < 0.1  # Otsu's threshold falls between the stem and the board
    assert m.mask_roi[t].mean() > 0.8  # from base to tip
    ys, xs = np.nonzero(m.mask_roi)
    assert xs.max() + x0 >= 398  # the thin tip too
    near = cv2.dilate(t.astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert near[m.mask_roi].mean() > 0.97  # few false pixels


def test_faint_pixels_leave_a_dark_tendril_as_the_threshold_finds_it():
    img = scene()
    for kw in ({}, {"channel": "hsv"}, {"threshold": 120}):
        a = segment_view(img, roi=ROI, keep_out=(110, 185, 25, 30), base_point_xy=(130, 200), **kw)
        b = segment_view(img, roi=ROI, keep_out=(110, 185, 25, 30), base_point_xy=(130, 200), local_contrast=0, **kw)
        assert np.array_equal(a.foreground.foreground, b.foreground.foreground)
        assert np.array_equal(a.mask_roi, b.mask_roi)


def test_faint_pixels_follow_uneven_light_and_reject_bad_options():
    from tendrilkit.segmentation import faint_pixels

    img, _ = pale_scene(tendril_bgr=(215, 225, 230))  # no tendril: only the board, its vignetting and noise
    g = grey_image(img)[50:350, 100:500].copy()
    g[:, :40] = 230  # no stem
    assert (faint_pixels(g) > 0).mean() < 0.002
    for bad in ({"local_contrast": 1.0}, {"local_noise_k": -1}, {"background_px": 2}, {"local_window_px": 0},
                {"local_margin_px": -1}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            segment_view(img, roi=ROI, keep_out=None, base_point_xy=(130, 200), **bad)


def _faint_pixels_every_pixel(grey, *, local_contrast=0.1, local_noise_k=5.0, background_px=36, local_window_px=9):
    """faint_pixels' definition computed on every pixel (np.median noise, full-image depth and dilation)."""
    h, w = grey.shape
    small = cv2.resize(grey, (max(w // 4, 1), max(h // 4, 1)), interpolation=cv2.INTER_AREA)
    k = max(3, (int(background_px) // 4) | 1)
    bg_small = cv2.medianBlur(small, k) if min(small.shape) >= 2 else small
    bg = cv2.resize(bg_small, (w, h), interpolation=cv2.INTER_LINEAR).astype(np.float32)
    ratio = grey.astype(np.float32) / np.maximum(bg, np.float32(1.0))
    sample = ratio[::3, ::3]
    c = max(local_contrast, local_noise_k * 1.4826 * float(np.median(np.abs(sample - np.median(sample)))))
    depth = np.float32(1.0) - ratio
    half = np.float32(0.5) * cv2.dilate(depth, cv2.getStructuringElement(cv2.MORPH_RECT, (local_window_px,) * 2))
    return cv2.bitwise_and(cv2.compare(depth, c, cv2.CMP_GT), cv2.compare(depth, half, cv2.CMP_GT))


@pytest.mark.parametrize("opts", [{}, {"local_contrast": 0.05, "local_noise_k": 0.0}, {"local_contrast": 0.01, "local_noise_k": 3.0},
                                  {"background_px": 20, "local_window_px": 4}, {"local_window_px": 1}])
def test_faint_pixels_equal_their_definition_on_every_pixel(opts):
    # faint_pixels skips pixels that cannot pass and takes the noise from a histogram: the mask must not change
    from tendrilkit.segmentation import faint_pixels
    rng = np.random.default_rng(3)
    yy, xx = np.mgrid[0:300, 0:260]
    board = 150 + 60 * xx / 260 + rng.normal(0, 3, (300, 260))            # uneven light, noise
    board[np.abs(yy - 0.004 * (xx - 130) ** 2 - 60) < 2.5] *= 0.8          # a pale arc
    board[200:215, 20:90] *= 0.3                                           # a dark leaf
    pale = np.clip(board, 0, 255).astype(np.uint8)
    noise = rng.integers(0, 256, (97, 131)).astype(np.uint8)
    for grey in (pale, noise, pale[:7, :5], pale[:2, :300]):
        got, want = faint_pixels(grey, **opts), _faint_pixels_every_pixel(grey, **opts)
        assert got.dtype == np.uint8 and np.array_equal(got, want)
    assert faint_pixels(pale, **opts).any()


def pale_beside_leaf_scene(*, seed=1):
    """A pale tendril (blue 0.8 of the board) running along a dark leaf's edge, 3-5 px from it, then away."""
    h, w = 300, 400
    img = np.full((h, w, 3), (215.0, 225.0, 230.0), np.float32)
    cv2.ellipse(img, (200, 170), (90, 40), 0, 0, 360, (40, 120, 60), -1)  # the leaf: its top edge at y = 130
    tube = np.zeros((h, w), np.uint8)
    cv2.line(tube, (60, 125), (340, 125), 255, 4)  # 3-5 px above the leaf's top from x = 180 to 220
    a = cv2.GaussianBlur(tube.astype(np.float32) / 255.0, (0, 0), 0.7)[..., None]
    img = img * (1 - a) + np.array((172.0, 200.0, 190.0), np.float32) * a
    img += np.random.default_rng(seed).normal(0.0, 2.0, img.shape).astype(np.float32)
    return np.clip(img, 0, 255).astype(np.uint8), tube > 0


def test_local_exclude_dark_keeps_a_pale_tendril_where_it_passes_a_leaf():
    img, truth = pale_beside_leaf_scene()
    marks = dict(roi=(0, 0, 400, 300), keep_out=None, base_point_xy=(60, 125))
    along = np.zeros_like(truth)
    along[:, 180:221] = True  # where the tendril runs beside the leaf's top
    along &= truth
    away = truth.copy()
    away[:, 100:301] = False  # far from the leaf
    before = segment_view(img, local_exclude_dark=False, **marks).foreground.foreground > 0  # the former default
    after = segment_view(img, local_exclude_dark=True, **marks).foreground.foreground > 0
    assert np.array_equal(after, segment_view(img, line_width_px=0, **marks).foreground.foreground > 0)  # default
    assert before[away].mean() > 0.5 and after[away].mean() > 0.5  # the pale line is found away from the leaf
    assert before[along].mean() < 0.2  # the leaf's depth and its pull on the background drop it there
    assert after[along].mean() > 0.5  # measured against the board beside it: kept
    # the line's pixels join up across the leaf's stretch: one component from x = 70 to 330
    m = segment_view(img, local_exclude_dark=True, **marks)
    xs = np.nonzero(m.mask_roi[115:135])[1]
    assert xs.min() <= 70 and xs.max() >= 330
    # no board pixel taken: everything added lies on the tendril, the leaf or within 2 px of them
    leaf = cv2.inRange(img, (0, 0, 0), (120, 255, 255)) > 0
    near = cv2.dilate((truth | leaf).astype(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert not (after & ~near).any()


def test_local_exclude_dark_leaves_a_dark_tendril_as_the_threshold_finds_it():
    img = scene()
    for kw in ({}, {"channel": "hsv"}, {"threshold": 120}):
        a = segment_view(img, roi=ROI, keep_out=(110, 185, 25, 30), base_point_xy=(130, 200), local_exclude_dark=True,
                         **kw)
        b = segment_view(img, roi=ROI, keep_out=(110, 185, 25, 30), base_point_xy=(130, 200), local_contrast=0, **kw)
        assert np.array_equal(a.mask_roi, b.mask_roi)


def test_faint_pixels_with_exclude_equal_their_definition_on_every_pixel():
    # the bands skipped by faint_pixels must not change the mask when the excluded pixels' depth is zeroed
    from tendrilkit.segmentation import faint_pixels
    rng = np.random.default_rng(4)
    yy, xx = np.mgrid[0:300, 0:260]
    board = 150 + 60 * xx / 260 + rng.normal(0, 3, (300, 260))
    board[np.abs(yy - 0.004 * (xx - 130) ** 2 - 60) < 2.5] *= 0.8
    board[200:215, 20:90] *= 0.3
    grey = np.clip(board, 0, 255).astype(np.uint8)
    exclude = np.zeros_like(grey)
    exclude[198:217, 18:92] = 255
    from tendrilkit.segmentation.faint import _fill_from_board
    # every pixel: the board's background (masked 4x reduction, filled holes), the depth and its dilation
    h, w = grey.shape
    valid = (exclude == 0).astype(np.float32)
    share = cv2.resize(valid, (w // 4, h // 4), interpolation=cv2.INTER_AREA)
    total = cv2.resize(grey.astype(np.float32) * valid, (w // 4, h // 4), interpolation=cv2.INTER_AREA)
    small = np.clip(np.round(total / np.maximum(share, np.float32(0.5))), 0, 255).astype(np.uint8)
    small = _fill_from_board(small, (share < 0.5).astype(np.uint8))
    assert small.min() > 100  # the leaf's hole is filled with the board's level
    bg = np.maximum(cv2.resize(cv2.medianBlur(small, 9), (w, h), interpolation=cv2.INTER_LINEAR), 1).astype(np.float32)
    ratio = grey.astype(np.float32) / bg
    sample = ratio[::3, ::3]
    c = max(0.1, 5.0 * 1.4826 * float(np.median(np.abs(sample - np.median(sample)))))
    depth = np.float32(1.0) - ratio
    own = depth.copy()
    own[exclude > 0] = 0
    half = np.float32(0.5) * cv2.dilate(own, cv2.getStructuringElement(cv2.MORPH_RECT, (9, 9)))
    want = cv2.bitwise_and(cv2.compare(depth, c, cv2.CMP_GT), cv2.compare(depth, half, cv2.CMP_GT))
    got = faint_pixels(grey, exclude=exclude)
    assert np.array_equal(got, want)
    assert got[55:66].any()  # the pale arc
    with pytest.raises(ValueError, match="exclude"):
        faint_pixels(grey, exclude=exclude[:10])


def taped_stem_scene(*, seed=1):
    """A dark stem 17 px wide, taped over for 40 px (translucent: blue 0.7 of the board's there), a pale tendril 4 px
    wide running beside it 6 px above its top edge, then away."""
    h, w = 300, 400
    img = np.full((h, w, 3), (215.0, 225.0, 230.0), np.float32)
    stem = np.zeros((h, w), np.uint8)
    cv2.line(stem, (0, 170), (400, 170), 255, 17)
    tape = np.zeros((h, w), np.uint8)
    tape[140:200, 180:220] = 255
    tube = np.zeros((h, w), np.uint8)
    cv2.line(tube, (60, 153), (340, 153), 255, 4)
    cv2.line(tube, (340, 153), (390, 60), 255, 4)
    for mask, colour in ((stem, (40.0, 120.0, 60.0)), (stem & tape, (150.0, 205.0, 200.0)), (tube, (172.0, 200.0, 190.0))):
        a = cv2.GaussianBlur(mask.astype(np.float32) / 255.0, (0, 0), 0.7)[..., None]
        img = img * (1 - a) + np.array(colour, np.float32) * a
    img += np.random.default_rng(seed).normal(0.0, 2.0, img.shape).astype(np.float32)
    return np.clip(img, 0, 255).astype(np.uint8), stem > 0, tape > 0, tube > 0


def test_local_exclude_dark_leaves_out_the_stems_taped_stretch(monkeypatch):
    """The stem's stretch under translucent tape is a pale part of it: the board-beside rule alone finds its ends next
    to the dark stem (phantom S2, view 3: their skeletons, a break away from the stem at the base mark, failed the
    coverage check). Regions found mostly by that rule alone lose its pixels; the pale tendril running beside the
    stem, found by the plain rule where it goes on over the board, keeps them."""
    import tendrilkit.segmentation.foreground as F
    from tendrilkit.segmentation.faint import drop_unanchored

    img, stem, tape, tube = taped_stem_scene()
    marks = dict(roi=(0, 0, 400, 300), keep_out=None, base_point_xy=(60, 153))
    plain = segment_view(img, **marks, local_exclude_dark=False).foreground.foreground > 0
    beside = segment_view(img, **marks, local_exclude_dark=True).foreground.foreground > 0
    with monkeypatch.context() as m:  # the board-beside rule without the drop
        m.setattr(F, "drop_unanchored", lambda faint, plain, **kw: faint)
        unruled = segment_view(img, **marks, local_exclude_dark=True).foreground.foreground > 0
    ends = stem & tape & unruled & ~plain  # the taped stretch's pixels only that rule takes
    assert ends.sum() > 100
    assert beside[ends].mean() < 0.1, (ends.sum(), beside[ends].sum())
    assert not (plain & ~beside & stem & tape).any()  # what the plain rule finds of it stays
    assert beside[tube].mean() > 0.95 and plain[tube].mean() < 0.9  # the tendril: the board-beside rule's gain kept
    assert np.array_equal(beside & tube, unruled & tube)
    with pytest.raises(ValueError, match="plain"):
        drop_unanchored(stem.view(np.uint8), stem[:10].view(np.uint8))
    with pytest.raises(ValueError, match="min_plain_frac"):
        drop_unanchored(stem.view(np.uint8), stem.view(np.uint8), min_plain_frac=2.0)
