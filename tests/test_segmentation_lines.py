"""Lines the darkness rule cannot see: a pale line in front of a leaf, a line broken where it crosses another."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from tendrilkit.evidence import view_evidence
from tendrilkit.segmentation import bridge_line_gaps, light_line_pixels, segment_view

BOARD = (215.0, 225.0, 230.0)
LEAF = (40.0, 120.0, 60.0)
PALE = (172.0, 200.0, 190.0)  # blue 0.8 of the board's


def _render(layers, *, seed=1, shape=(300, 400)):
    """BGR uint8 image: ``layers`` of (mask drawn with cv2 at 255, colour) painted in order, blurred, noisy."""
    img = np.full((*shape, 3), BOARD, np.float32)
    for mask, colour in layers:
        a = cv2.GaussianBlur(mask.astype(np.float32) / 255.0, (0, 0), 0.7)[..., None]
        img = img * (1 - a) + np.array(colour, np.float32) * a
    img += np.random.default_rng(seed).normal(0.0, 2.0, img.shape).astype(np.float32)
    return np.clip(img, 0, 255).astype(np.uint8)


def pale_over_leaf_scene():
    """A pale tendril crossing in front of a dark leaf; a one-pixel vein on the leaf; a second leaf 5 px beside it."""
    shape = (300, 400)
    leaf, leaf2, vein, tube = (np.zeros(shape, np.uint8) for _ in range(4))
    cv2.ellipse(leaf, (200, 150), (90, 45), 0, 0, 360, 255, -1)
    cv2.ellipse(leaf2, (200, 230), (60, 30), 0, 0, 360, 255, -1)     # its top at y = 200, the first's bottom at 195
    cv2.line(vein, (130, 125), (270, 175), 255, 1)
    cv2.line(tube, (30, 150), (370, 150), 255, 5)
    img = _render([(leaf, LEAF), (leaf2, LEAF), (vein, (90.0, 165.0, 110.0)), (tube, PALE)])
    return img, {"leaf": leaf > 0, "leaf2": leaf2 > 0, "vein": vein > 0, "tube": tube > 0}


def test_light_lines_find_a_pale_tendril_in_front_of_a_leaf_and_nothing_else():
    img, truth = pale_over_leaf_scene()
    marks = dict(roi=(0, 0, 400, 300), keep_out=None, base_point_xy=(30, 150))
    over = truth["tube"] & cv2.erode(truth["leaf"].view(np.uint8), np.ones((9, 9), np.uint8)).astype(bool)
    before = segment_view(img, line_width_px=0, **marks).foreground.foreground > 0  # light lines off
    after = segment_view(img, line_width_px=11, **marks).foreground.foreground > 0
    assert np.array_equal(after, segment_view(img, **marks).foreground.foreground > 0)  # the default
    assert before[over].mean() < 0.2  # lighter than the leaf: the darkness rules leave a light gap
    assert after[over].mean() > 0.9
    added = after & ~before
    # nothing beside the tendril: not the vein (one pixel wide), not the board between the two leaves, not an edge
    tube_near = cv2.dilate(truth["tube"].view(np.uint8), np.ones((5, 5), np.uint8)) > 0
    assert not (added & ~tube_near).any()
    assert not added[truth["vein"] & ~tube_near].any()
    # in front of the leaf: a line of its own (a one-pixel rim of the leaf cleared beside it), not part of its blob
    removed = before & ~after
    assert removed.any() and not (removed & ~tube_near).any()
    line = segment_view(img, line_width_px=11, bridge_gap_px=30, roi=(0, 0, 400, 300), keep_out=None,
                        base_point_xy=(200, 150))  # the component at the middle of the leaf
    assert not (line.mask_roi & ~tube_near).any()
    # with the joins at the leaf's edges (where the faint pixels keep their distance from it), the tendril is one
    # line from its base across the leaf
    m = segment_view(img, line_width_px=11, bridge_gap_px=30, **marks)
    xs = np.nonzero(m.mask_roi[145:156])[1]
    assert xs.min() <= 35 and xs.max() >= 365


def test_light_lines_leave_a_dark_tendril_as_the_threshold_finds_it():
    img = np.full((300, 400, 3), 230, np.uint8)
    cv2.line(img, (20, 60), (20, 290), (50, 110, 60), 13)      # stem
    cv2.line(img, (20, 200), (300, 150), (40, 150, 90), 7)     # tendril leaving it at an acute angle
    cv2.circle(img, (320, 250), 30, (40, 150, 90), -1)         # leaf
    marks = dict(roi=(0, 0, 400, 300), keep_out=(10, 185, 25, 30), base_point_xy=(30, 200))
    a = segment_view(img, line_width_px=0, **marks)  # light lines off (the default has them on)
    b = segment_view(img, line_width_px=11, **marks)
    assert np.array_equal(a.foreground.foreground, b.foreground.foreground)


def test_light_line_pixels_example_and_bad_options():
    g = np.full((60, 80), 220, np.uint8)
    g[10:50, 20:60] = 60
    fg = np.where(g < 120, 255, 0).astype(np.uint8)
    g[28:33, :] = 220            # a gap at the board's level: two objects apart, no line in front
    assert not light_line_pixels(g, np.where(g < 120, 255, 0).astype(np.uint8)).any()
    g[28:33, :] = 170
    assert light_line_pixels(g, np.where(g < 120, 255, 0).astype(np.uint8))[30, 40] > 0
    for bad, name in (({"width_px": 2}, "width_px"), ({"contrast": 1.0}, "contrast"), ({"min_width_px": 0}, "min_width_px")):
        with pytest.raises(ValueError, match=name):
            light_line_pixels(g, fg, **bad)
    with pytest.raises(ValueError, match="foreground"):
        light_line_pixels(g, fg[:10])


def test_bridges_join_a_line_across_a_crossing_and_nothing_else():
    fg = np.zeros((120, 200), np.uint8)
    cv2.line(fg, (5, 60), (85, 60), 255, 5)
    cv2.line(fg, (108, 60), (195, 60), 255, 5)        # the same line beyond a 23 px break
    cv2.line(fg, (96, 5), (96, 115), 255, 9)          # the line it crosses (not touching)
    cv2.line(fg, (5, 20), (60, 20), 255, 5)           # two ends side by side, 12 px apart
    cv2.line(fg, (5, 32), (60, 32), 255, 5)
    cv2.line(fg, (150, 10), (150, 48), 255, 3)        # a tip pointing at the line's side
    out = bridge_line_gaps(fg)
    assert out.dtype == np.uint8 and not (fg & ~out).any()  # nothing removed: both lines keep their pixels
    assert (out[58:63, 86:108] > 0).all()                   # joined straight through, at the line's width
    added = (out > 0) & (fg == 0)
    assert not added[:55].any() and not added[66:].any()   # no wider than the line (rows 57-63), give or take one
    n, _ = cv2.connectedComponents(out[52:68], connectivity=8)
    assert n == 2                                            # background + one crossing
    with pytest.raises(ValueError, match="gap_px"):
        bridge_line_gaps(fg, gap_px=0)


def pale_behind_shoot_scene():
    """A pale tendril passing behind a dark shoot 9 px wide: its faint pixels keep off the shoot, a gap."""
    shape = (300, 400)
    tube, shoot = np.zeros(shape, np.uint8), np.zeros(shape, np.uint8)
    cv2.line(tube, (30, 150), (370, 150), 255, 5)
    cv2.line(shoot, (190, 10), (230, 290), 255, 9)
    return _render([(tube, PALE), (shoot, LEAF)]), tube > 0


def test_bridges_make_a_pale_tendril_continuous_where_it_passes_behind_a_shoot():
    img, tube = pale_behind_shoot_scene()
    marks = dict(roi=(0, 0, 400, 300), keep_out=None, base_point_xy=(30, 150))
    before = segment_view(img, **marks)
    after = segment_view(img, bridge_gap_px=30, **marks)
    assert np.nonzero(before.mask_roi[140:161])[1].max() < 250  # the tendril's component stops at the shoot
    xs = np.nonzero(after.mask_roi[140:161])[1]
    assert xs.min() <= 35 and xs.max() >= 365                    # one line across it
    assert (after.foreground.foreground >= before.foreground.foreground).all()


def test_bridges_never_cross_the_keep_out_box():
    img = np.full((480, 640, 3), 230, np.uint8)
    cv2.line(img, (120, 60), (120, 340), (50, 110, 60), 9)      # a stem the keep-out box cuts in two
    cv2.line(img, (120, 200), (400, 150), (40, 150, 90), 7)
    marks = dict(roi=(100, 50, 400, 300), keep_out=(110, 185, 25, 30), base_point_xy=(130, 200))
    a = segment_view(img, line_width_px=0, **marks)  # neither light lines nor joins
    b = segment_view(img, bridge_gap_px=40, line_width_px=11, **marks)
    assert not b.foreground.foreground[185 - 50:215 - 50, 110 - 100:135 - 100].any()
    assert b.n_components == a.n_components == 3
    assert np.array_equal(a.mask_roi, b.mask_roi)


def test_line_options_are_checked_and_reach_the_evidence():
    img, _ = pale_over_leaf_scene()
    marks = dict(roi=(0, 0, 400, 300), keep_out=None, base_point_xy=(30, 150))
    for bad in ({"line_width_px": 2}, {"bridge_gap_px": -1}):
        with pytest.raises(ValueError, match=next(iter(bad))):
            segment_view(img, **marks, **bad)
    seg = segment_view(img, line_width_px=11, **marks)
    ev = view_evidence(img, line_width_px=11, foreground=seg.foreground, **marks)
    assert np.array_equal(ev.foreground, view_evidence(img, line_width_px=11, **marks).foreground)
    with pytest.raises(ValueError, match="line_width_px"):
        view_evidence(img, line_width_px=0, foreground=seg.foreground, **marks)


def test_the_keep_out_box_across_the_node_is_no_light_line():
    """The keep-out box is painted background: across a stem wider than it is tall it would be a gap narrower than a
    light line through a wide object, darker than the board (phantom S3: the stem's pixels around the box were
    cleared as the rim of a 'line in front'). The light-line pieces running into the box are dropped: nothing changes."""
    img = np.full((300, 400, 3), 230, np.uint8)
    cv2.line(img, (20, 60), (20, 290), (50, 110, 60), 15)      # stem, 15 px wide
    cv2.line(img, (28, 200), (300, 150), (40, 150, 90), 7)     # tendril leaving it
    marks = dict(roi=(0, 0, 400, 300), keep_out=(8, 196, 26, 8), base_point_xy=(30, 200))  # 8 px tall, across it
    a = segment_view(img, **marks, line_width_px=0)
    b = segment_view(img, **marks, line_width_px=11)
    assert np.array_equal(a.foreground.foreground, b.foreground.foreground)


@pytest.mark.parametrize("op", [cv2.MORPH_OPEN, cv2.MORPH_CLOSE])
def test_morphology_on_the_masks_box_is_the_whole_images(op):
    """lines._on_box: the opening or closing on the mask's box grown by twice the kernel's half side, bit for bit
    the whole image's; masks small and large, touching the image's sides, along a side's first pixels, empty."""
    from tendrilkit.segmentation.lines import _on_box

    from tests.test_segmentation_kernels import _random_mask

    rng = np.random.default_rng(21)
    for k in range(120):
        shape = tuple(int(v) for v in rng.integers(5, 120, 2))
        mask = _random_mask(rng, shape, 0.01)  # discs, lines, specks
        if k % 10 == 0:
            mask[:, : int(rng.integers(1, 4))] = 255  # along the left side
        for side in (3, 7, 11):
            kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (side, side))
            np.testing.assert_array_equal(_on_box(mask, op, kernel), cv2.morphologyEx(mask, op, kernel))
    empty = np.zeros((20, 30), np.uint8)
    assert not _on_box(empty, op, np.ones((5, 5), np.uint8)).any()


def _light_line_pixels_245f631(grey, foreground, *, width_px=11, contrast=0.1, min_width_px=3):
    """segmentation.light_line_pixels as it was at 245f631 (whole-image morphology and labels), copied unchanged
    but for the argument checks."""
    from tendrilkit.segmentation.lines import board_level

    fg = cv2.compare(foreground, 0, cv2.CMP_GT)
    x, y, w, h = cv2.boundingRect(fg)
    out = np.zeros(grey.shape, np.uint8)
    if w == 0:
        return out
    disk = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (int(width_px) | 1,) * 2)
    free = cv2.compare(fg, 0, cv2.CMP_EQ)
    wide = cv2.morphologyEx(fg, cv2.MORPH_OPEN, disk)
    through = cv2.bitwise_and(cv2.morphologyEx(wide, cv2.MORPH_CLOSE, disk), free)
    if not through.any():
        return out
    gap = cv2.bitwise_and(cv2.morphologyEx(fg, cv2.MORPH_CLOSE, disk), free)
    b = board_level(grey)
    limit = np.ceil((1.0 - float(contrast)) * np.arange(256)).astype(np.uint8)
    darker = cv2.compare(grey, cv2.LUT(b, limit), cv2.CMP_LT)
    gap = cv2.bitwise_and(gap, darker)
    if min_width_px > 1:
        gap = cv2.morphologyEx(gap, cv2.MORPH_OPEN, np.ones((int(min_width_px),) * 2, np.uint8))
    through = cv2.bitwise_and(through, gap)
    if not through.any():
        return out
    n, lab = cv2.connectedComponents(gap, connectivity=8)
    keep = np.zeros(n, bool)
    keep[np.unique(lab[through > 0])] = True
    keep[0] = False
    out[keep[lab]] = 255
    return out


def test_light_line_pixels_are_the_245f631_whole_image_ones():
    """The morphology on boxes and the labels on the gap's box: the whole-image function's pixels, bit for bit, on
    the pale-over-leaf scene, shifted so that the leaf touches the crop's sides, with more leaves and lines."""
    img, _ = pale_over_leaf_scene()
    rng = np.random.default_rng(22)
    found = 0
    for k in range(12):
        g = img[:, :, 0].copy()
        if k % 3 == 1:
            g = np.ascontiguousarray(g[60:, 150:])  # the leaf cut by the crop's sides
        for _ in range(k % 4):
            c = (int(rng.integers(0, g.shape[1])), int(rng.integers(0, g.shape[0])))
            cv2.ellipse(g, c, (int(rng.integers(10, 50)), int(rng.integers(8, 30))), float(rng.uniform(0, 180)), 0,
                        360, 60, -1)
            cv2.line(g, c, (int(rng.integers(0, g.shape[1])), int(rng.integers(0, g.shape[0]))), 185,
                     int(rng.integers(3, 7)))
        fg = np.where(g < 120, 255, 0).astype(np.uint8)
        for width in (7, 11):
            want = _light_line_pixels_245f631(g, fg, width_px=width)
            np.testing.assert_array_equal(light_line_pixels(g, fg, width_px=width), want)
            found += int(want.any())
    assert found >= 12


def _leaf_with_line(*, through: bool, petiole: bool = True, shift_x: int = 0):
    """(lines, foreground) of a 220 x 360 crop: a leaf (an ellipse) with a light line along its long axis; the line
    goes on as a thin dark line on the board at both ends when ``through`` (a tendril lying along the leaf), else it
    ends inside the leaf's tip (a midrib), its petiole going on at the other end when ``petiole``. ``shift_x`` moves
    the leaf left (negative: the crop cuts its left end)."""
    fg = np.zeros((220, 360), np.uint8)
    cx = 180 + shift_x
    cv2.ellipse(fg, (cx, 110), (120, 50), 0, 0, 360, 255, -1)
    line = np.zeros_like(fg)
    if through:
        cv2.line(fg, (0, 110), (359, 110), 255, 5)  # the tendril on the board
        cv2.line(line, (cx - 118, 110), (cx + 118, 110), 255, 5)
    else:
        cv2.line(line, (cx - 110, 110), (cx + 118, 110), 255, 4)
        if petiole:
            cv2.line(fg, (cx + 120, 110), (359, 110), 255, 5)
    fg[line > 0] = 0
    return line, fg


def test_a_midrib_is_a_vein_a_tendril_along_the_leaf_is_not():
    from tendrilkit.segmentation.lines import vein_pixels

    midrib, fg = _leaf_with_line(through=False)
    v = vein_pixels(midrib, fg)
    assert (v > 0).sum() >= 0.9 * (midrib > 0).sum()  # the whole midrib, its ends near the tip and the petiole too
    assert not (v & ~midrib).any()
    bare, fg = _leaf_with_line(through=False, petiole=False)
    assert (vein_pixels(bare, fg) > 0).sum() >= 0.9 * (bare > 0).sum()
    cut, fg = _leaf_with_line(through=False, shift_x=-110)  # the crop (the ROI) cuts the leaf's tip end
    assert (vein_pixels(cut, fg) > 0).sum() >= 0.9 * (cut > 0).sum()
    tendril, fg = _leaf_with_line(through=True)  # on the board beyond both ends: a line in front of the leaf
    assert not vein_pixels(tendril, fg).any()
    # a line across the leaf: the depth changes along it
    across = np.zeros_like(fg)
    cv2.line(across, (180, 62), (180, 158), 255, 5)
    leaf = np.zeros_like(fg)
    cv2.ellipse(leaf, (180, 110), (120, 50), 0, 0, 360, 255, -1)
    leaf[across > 0] = 0
    assert not vein_pixels(across, leaf).any()
