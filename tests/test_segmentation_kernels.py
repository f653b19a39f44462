"""The segmentation's faster paths against the reference ones, bit for bit (issue 17: the evidence's cost).

* :func:`tendrilkit.segmentation.kernels.binary_morphology` against ``cv2.morphologyEx``;
* :func:`tendrilkit.segmentation.faint_pixels` with ``at`` / ``reduced`` against the function without them;
* :func:`tendrilkit.segmentation.faint.drop_unanchored` against main 8382d0e's whole-image function;
* the board's level (:func:`tendrilkit.segmentation.lines.board_level`, floored by ``cv2.max``) against main
  cd9d4c9's;
* the pale options' whole foreground (:func:`tendrilkit.segmentation.foreground_roi`) against main 8382d0e's
  composition (the plain faint pass on every pixel, the board level reducing grey again).
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from tendrilkit.segmentation import faint_pixels, foreground_roi
from tendrilkit.segmentation.faint import drop_unanchored, reduce_grey
from tendrilkit.segmentation.kernels import binary_morphology
from tendrilkit.segmentation.lines import board_level


def _random_mask(rng, shape, density):
    mask = np.zeros(shape, np.uint8)
    for _ in range(int(rng.integers(0, 6))):
        c = (int(rng.integers(-10, shape[1] + 10)), int(rng.integers(-10, shape[0] + 10)))
        if rng.random() < 0.5:
            cv2.circle(mask, c, int(rng.integers(1, 25)), 255, -1)
        else:
            cv2.line(mask, c, (int(rng.integers(0, shape[1])), int(rng.integers(0, shape[0]))), 255,
                     int(rng.integers(1, 6)))
    mask[rng.random(shape) < density] = 255
    return mask


@pytest.mark.parametrize("op", [cv2.MORPH_OPEN, cv2.MORPH_CLOSE, cv2.MORPH_ERODE, cv2.MORPH_DILATE])
def test_binary_morphology_is_opencvs(op):
    """Packed rows: the same pixels as cv2.morphologyEx for ellipses, squares and crosses of odd sides, on masks of
    every width around a word's 64 bits (the last word's bits beyond the image), touching the sides, dense, empty
    and full (the border: outside counts as set for an erosion, as clear for a dilation)."""
    rng = np.random.default_rng(31)
    shapes = [(1, 1), (1, 70), (70, 1), (5, 63), (9, 64), (9, 65), (40, 127), (33, 128), (12, 129), (200, 300)]
    shapes += [tuple(int(v) for v in rng.integers(1, 160, 2)) for _ in range(25)]
    for k, shape in enumerate(shapes):
        for density in (0.0, 0.01, 0.4, 0.95):
            mask = _random_mask(rng, shape, density)
            if k % 7 == 0:
                mask[:] = 255
            for side in (1, 3, 5, 9, 11, 13):
                for kernel in (cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (side, side)),
                               np.ones((side, side), np.uint8), np.ones((side, 1), np.uint8),
                               np.ones((1, side), np.uint8),
                               cv2.getStructuringElement(cv2.MORPH_CROSS, (side, side))):
                    got = binary_morphology(mask, op, kernel)
                    assert got.dtype == np.uint8 and got.shape == mask.shape
                    np.testing.assert_array_equal(got, cv2.morphologyEx(mask, op, kernel))


def test_binary_morphology_passes_other_elements_to_opencv():
    mask = _random_mask(np.random.default_rng(2), (40, 50), 0.2)
    odd = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1]], np.uint8)   # rows not centred on the middle column
    for kernel in (odd, np.ones((4, 4), np.uint8)):
        np.testing.assert_array_equal(binary_morphology(mask, cv2.MORPH_OPEN, kernel),
                                      cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel))


def _scene_grey(seed, shape=(240, 330)):
    """A board with uneven light and noise, pale arcs, a dark leaf with a pale stretch beside it."""
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    board = 150 + 60 * xx / shape[1] + rng.normal(0, 3, shape)
    for a in (0.004, -0.003):
        board[np.abs(yy - a * (xx - shape[1] / 2) ** 2 - rng.uniform(40, 180)) < rng.uniform(1.5, 3.5)] *= 0.8
    r0, c0 = int(rng.integers(20, shape[0] - 40)), int(rng.integers(10, shape[1] - 100))
    board[r0:r0 + 15, c0:c0 + 80] *= 0.3          # a dark leaf
    board[r0 - 6:r0, c0 + 10:c0 + 40] *= 0.85     # a pale stretch beside it
    return np.clip(board, 0, 255).astype(np.uint8)


def test_faint_pixels_at_some_pixels_are_those_of_every_pixel():
    """``at``: the pixels asked for get the whole computation's values (with and without exclude), the others 0;
    ``reduced``: the same as reducing grey inside."""
    for seed in range(8):
        grey = _scene_grey(seed)
        _, dark = cv2.threshold(grey, 0, 255, cv2.THRESH_BINARY_INV | cv2.THRESH_OTSU)
        for exclude in (None, cv2.dilate(dark, np.ones((5, 5), np.uint8))):
            for window in (9, 4, 1):
                whole = faint_pixels(grey, exclude=exclude, local_window_px=window)
                rng = np.random.default_rng(seed)
                for at in (whole, cv2.dilate(whole, np.ones((3, 3), np.uint8)),
                           np.where(rng.random(grey.shape) < 0.05, 255, 0).astype(np.uint8), np.zeros_like(grey)):
                    got = faint_pixels(grey, exclude=exclude, local_window_px=window, at=at,
                                       reduced=reduce_grey(grey))
                    np.testing.assert_array_equal(got, np.where(at > 0, whole, 0))
    with pytest.raises(ValueError, match="at"):
        faint_pixels(grey, at=grey[:10])
    with pytest.raises(ValueError, match="reduced"):
        faint_pixels(grey, reduced=grey)
    with pytest.raises(ValueError, match="reduced"):
        board_level(grey, reduced=grey)
    np.testing.assert_array_equal(board_level(grey, reduced=reduce_grey(grey)), board_level(grey))


def _drop_unanchored_8382d0e(faint, plain, *, min_plain_frac=0.5):
    """faint.drop_unanchored as it was at main 8382d0e (the whole image labelled and counted), checks left out."""
    fa = cv2.compare(faint, 0, cv2.CMP_GT)
    pl = cv2.compare(plain, 0, cv2.CMP_GT)
    extra = cv2.bitwise_and(fa, cv2.compare(pl, 0, cv2.CMP_EQ))
    if not extra.any():
        return fa
    n, lab = cv2.connectedComponents(fa, connectivity=8)
    total = np.bincount(lab.ravel(), minlength=n)
    found = np.bincount(lab[cv2.bitwise_and(fa, pl) > 0], minlength=n)
    alone = found < min_plain_frac * total
    alone[0] = False
    fa[alone[lab] & (extra > 0)] = 0
    return fa


def test_drop_unanchored_is_the_whole_image_function():
    rng = np.random.default_rng(5)
    for k in range(60):
        shape = tuple(int(v) for v in rng.integers(3, 150, 2))
        faint = _random_mask(rng, shape, float(rng.choice([0.0, 0.02, 0.3])))
        plain = np.where(rng.random(shape) < rng.uniform(0, 1), faint, 0).astype(np.uint8)
        plain |= _random_mask(rng, shape, 0.01)   # the plain rule's pixels outside the faint ones do not count
        for frac in (0.0, 0.3, 0.5, 1.0):
            np.testing.assert_array_equal(drop_unanchored(faint, plain, min_plain_frac=frac),
                                          _drop_unanchored_8382d0e(faint, plain, min_plain_frac=frac))


def test_pale_foreground_is_8382d0es(monkeypatch):
    """The pale options' foreground with the plain pass at the faint pixels only and grey reduced once: the same as
    with main 8382d0e's calls (the plain faint pixels everywhere, the board level reducing grey itself)."""
    import tendrilkit.segmentation.foreground as F

    def plain_everywhere(grey, *, at=None, reduced=None, **kw):  # the plain pass as called at 8382d0e
        return faint_pixels(grey, **kw)

    from tests.test_segmentation import taped_stem_scene
    from tests.test_segmentation_lines import pale_over_leaf_scene

    scenes = [(np.dstack([g, g, g]), dict(roi=(3, 5, 290, 250), keep_out=(150, 100, 12, 12)))
              for g in (_scene_grey(seed, (260, 300)) for seed in range(4))]
    scenes += [(taped_stem_scene(seed=s)[0], dict(roi=(0, 0, 400, 300), keep_out=None)) for s in (1, 2)]
    scenes += [(pale_over_leaf_scene()[0], dict(roi=(10, 0, 380, 290), keep_out=(20, 145, 10, 10)))]
    changed = 0
    for img, marks in scenes:
        got, _ = foreground_roi(img, **marks)
        with monkeypatch.context() as m:
            m.setattr(F, "faint_pixels", lambda grey, **kw: (plain_everywhere(grey, **kw) if "at" in kw
                                                             else faint_pixels(grey, **kw)))
            plain_lines = F.light_line_pixels
            m.setattr(F, "light_line_pixels", lambda grey, fg, *, reduced=None, **kw: plain_lines(grey, fg, **kw))
            want, _ = foreground_roi(img, **marks)
            m.setattr(F, "drop_unanchored", lambda faint, plain, **kw: faint)
            changed += int(not np.array_equal(foreground_roi(img, **marks)[0], want))
        np.testing.assert_array_equal(got, want)
    assert changed >= 1  # the rule acts on these scenes: the comparison can fail


def _fill_from_board_8382d0e(small, hole):
    """faint._fill_from_board as it was at main 8382d0e (whole-image dilations per step)."""
    if not hole.any():
        return small
    out = small.copy()
    out[hole > 0] = 0
    todo = hole > 0
    kernel = np.ones((3, 3), np.uint8)
    for _ in range(max(small.shape)):
        if not todo.any():
            break
        grown = cv2.dilate(out, kernel)
        reach = todo & (cv2.dilate((~todo).view(np.uint8), kernel) > 0)
        if not reach.any():
            break
        out[reach] = grown[reach]
        todo &= ~reach
    out[todo] = 255
    return out


def test_fill_from_board_is_8382d0es():
    """The compiled growth (kernels.grow_fill): the same levels as the whole-image dilations, on holes of every
    shape, touching the sides, a whole image of hole (255), a single pixel of board."""
    from tendrilkit.segmentation.faint import _fill_from_board

    rng = np.random.default_rng(7)
    for k in range(80):
        shape = tuple(int(v) for v in rng.integers(2, 90, 2))
        small = rng.integers(0, 256, shape).astype(np.uint8)
        hole = _random_mask(rng, shape, float(rng.choice([0.0, 0.05, 0.5])))
        if k % 9 == 0:
            hole[:] = 255
        if k % 9 == 1:
            hole[:] = 255
            hole[int(rng.integers(0, shape[0])), int(rng.integers(0, shape[1]))] = 0
        np.testing.assert_array_equal(_fill_from_board(small, hole), _fill_from_board_8382d0e(small, hole))


def _board_level_cd9d4c9(grey, window_px=124):
    """lines.board_level as it was at main cd9d4c9 (floored by np.maximum)."""
    h, w = grey.shape[:2]
    small = reduce_grey(grey)
    if min(small.shape[:2]) >= 3:
        small = cv2.medianBlur(small, 3)
    k = max(3, (int(window_px) // 4) | 1)
    env = cv2.blur(cv2.dilate(small, cv2.getStructuringElement(cv2.MORPH_RECT, (k, k))), (k, k))
    level = cv2.resize(env, (w, h), interpolation=cv2.INTER_LINEAR)
    return np.maximum(level, np.uint8(1), out=level)


def test_board_level_is_cd9d4c9s():
    """The level floored at 1 on a one-channel view (cv2.max): main cd9d4c9's, of one and of three channels, on
    images of every size (a pixel, a row, a column), dark (the floor matters) and bright."""
    rng = np.random.default_rng(12)
    for k in range(80):
        shape = tuple(int(v) for v in rng.integers(1, 120, 2))
        if k % 8 == 0:
            shape = (1, 1)
        if k % 2:
            shape = shape + (3,)
        top = int(rng.choice([2, 30, 256]))
        grey = rng.integers(0, top, shape).astype(np.uint8)
        got, want = board_level(grey), _board_level_cd9d4c9(grey)
        assert got.dtype == want.dtype and got.shape == want.shape
        np.testing.assert_array_equal(got, want)
        assert got.min() >= 1
