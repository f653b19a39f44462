"""skeleton.thinning.thin: skimage.morphology.skeletonize's skeleton, pixel for pixel, visiting only what can change."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from skimage.morphology import skeletonize

from tendrilkit.skeleton.thinning import thin


def _strokes(seed: int, shape=(150, 200)) -> np.ndarray:
    """Thick random strokes, rings and discs: crossings, loops, blobs, diagonal and two-pixel-wide parts."""
    rng = np.random.default_rng(seed)
    img = np.zeros(shape, np.uint8)
    h, w = shape
    for _ in range(rng.integers(1, 7)):
        pts = rng.integers(0, [w, h], size=(rng.integers(2, 6), 2)).astype(np.int32)
        cv2.polylines(img, [pts], bool(rng.integers(0, 2)), 255, int(rng.integers(1, 14)))
    for _ in range(rng.integers(0, 3)):
        cv2.circle(img, tuple(int(v) for v in rng.integers(0, [w, h])), int(rng.integers(2, 25)), 255,
                   int(rng.choice([-1, 2, 5])))
    return img


@pytest.mark.parametrize("seed", range(30))
def test_thin_is_skimage_skeletonize_on_strokes(seed):
    img = _strokes(seed)
    assert np.array_equal(thin(img), skeletonize(img > 0))


@pytest.mark.parametrize("seed", range(30))
def test_thin_is_skimage_skeletonize_on_noise(seed):
    """Random pixels (every neighbourhood code occurs), some grown into blobs touching the array's border."""
    rng = np.random.default_rng(1000 + seed)
    m = rng.random(tuple(rng.integers(1, 60, 2))) < rng.uniform(0.1, 0.95)
    if seed % 2:
        m = cv2.dilate(m.view(np.uint8), np.ones((3, 3), np.uint8), iterations=int(rng.integers(1, 4))) > 0
    out = thin(m)
    assert out.dtype == bool and out.shape == m.shape
    assert np.array_equal(out, skeletonize(m))


def test_thin_edge_cases():
    assert not thin(np.zeros((5, 7), bool)).any()
    assert thin(np.ones((1, 1), bool)).tolist() == skeletonize(np.ones((1, 1), bool)).tolist()
    full = np.ones((20, 30), np.uint8)
    assert np.array_equal(thin(full), skeletonize(full > 0))
    with pytest.raises(ValueError, match="2D"):
        thin(np.zeros((3, 3, 3), bool))


@pytest.mark.slow
def test_thin_is_skimage_skeletonize_on_a_phantom_view():
    """Every dark pixel of a phantom view's region of interest (tendril, stem, leaves: what the evidence thins)."""
    from tendrilkit import phantom
    from tendrilkit.segmentation import label_foreground

    ph = phantom.make_phantom("S3", n_frames=2, seed=3)
    for v, marks in enumerate(ph.views):
        fg = label_foreground(phantom.render_view(ph, 1, v), roi=marks["roi"], keep_out=marks["keep_out"]).foreground
        assert fg.any()
        assert np.array_equal(thin(fg), skeletonize(fg > 0))


@pytest.mark.parametrize("seed", range(8))
def test_thin_strips_is_the_strips_of_skimage_skeletonize(seed, monkeypatch):
    """The 2D stage's strip-by-strip thinning: the same bands thinned by skimage give the same skeleton."""
    import tendrilkit.skeleton.thinning as thinning

    img = _strokes(seed, shape=(420, 260))
    fast = thinning.thin_strips(img)
    assert fast.dtype == bool and fast.shape == img.shape and fast.any()
    monkeypatch.setattr(thinning, "thin", lambda m: skeletonize(np.asarray(m) > 0))
    assert np.array_equal(fast, thinning.thin_strips(img))
    small = img[:150]                                   # up to two strips: thinned whole
    assert np.array_equal(thinning.thin_strips(small), skeletonize(small > 0))
