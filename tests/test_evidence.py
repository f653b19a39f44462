"""Per-view evidence: foreground, distance transform, skeleton, bilinear sampling (tiny hand-made images)."""

import numpy as np
import pytest

from tendrilkit.evidence import roi_contains, sample_distance, view_evidence
from tendrilkit.segmentation import segment_view


def _image(h=60, w=80):
    img = np.full((h, w, 3), 250, np.uint8)
    img[30:33, 10:70] = 20      # the tendril: a horizontal bar, rows 30-32
    img[5:25, 60:75] = 30       # another dark blob (a leaf)
    img[50:52, 2:4] = 30        # speckle, 4 px
    return img


def test_foreground_independent_of_component_choice():
    img = _image()
    ev = view_evidence(img, roi=[0, 0, 80, 60], keep_out=None, base_point_xy=[10, 31], opening_radius_px=0,
                       min_component_px=10)
    assert ev.labels.max() == 2                      # bar and leaf kept, speckle dropped
    assert not ev.foreground[50, 2]
    assert ev.foreground[31, 40] and ev.foreground[10, 65]
    # the same pixels as the segmentation's chosen component, plus the others
    seg = segment_view(img, roi=[0, 0, 80, 60], keep_out=None, base_point_xy=[10, 31], opening_radius_px=0,
                       min_component_px=10)
    assert np.all(ev.foreground[seg.mask_roi])
    assert ev.foreground.sum() > seg.mask_roi.sum()


def test_distance_and_bilinear_sampling():
    img = _image()
    ev = view_evidence(img, roi=[5, 20, 70, 40], keep_out=None, base_point_xy=[10, 31], opening_radius_px=0)
    assert ev.distance_px.dtype == np.float32 and ev.distance_px.shape == (40, 70)
    d = sample_distance(ev, np.array([[40.0, 31.0], [40.0, 36.0], [40.0, 37.5], [np.nan, 3.0]]))
    assert d[0] == 0.0
    assert d[1] == pytest.approx(4.0, abs=0.1)        # row 36 is 4 px below the bar's last row 32
    assert d[2] == pytest.approx(5.5, abs=0.1)        # bilinear between rows 37 and 38
    assert np.isnan(d[3])
    # outside the ROI: the border value plus the distance to the ROI, continuous at the border
    inside = sample_distance(ev, np.array([[40.0, 59.0]]))[0]
    outside = sample_distance(ev, np.array([[40.0, 69.0]]))[0]
    assert outside == pytest.approx(inside + 10.0, abs=1e-6)
    assert roi_contains(ev, np.array([[40.0, 59.0], [40.0, 69.0]])).tolist() == [True, False]


def test_keep_out_painted_and_skeleton():
    img = _image()
    ev = view_evidence(img, roi=[0, 0, 80, 60], keep_out=[8, 28, 6, 8], base_point_xy=[10, 31], opening_radius_px=0,
                       threshold=128, probability=True)
    assert not ev.foreground[30:33, 8:14].any()
    assert ev.in_keep_out(np.array([[10.0, 31.0], [40.0, 31.0]])).tolist() == [True, False]
    on_bar = (ev.skeleton_xy[:, 1] == 31) & (ev.skeleton_xy[:, 0] > 20) & (ev.skeleton_xy[:, 0] < 55)
    assert on_bar.sum() >= 30                          # the bar's skeleton is its middle row
    assert ev.probability[31, 40] > 0.99 and ev.probability[45, 40] < 0.01
    assert ev.probability[31, 10] == 0.0               # keep-out box
    # Otsu: one half at the threshold, the darker the likelier
    ev2 = view_evidence(img, roi=[0, 0, 80, 60], keep_out=None, base_point_xy=[10, 31], probability=True)
    assert ev2.probability[31, 40] > ev2.probability[10, 65] > 0.5 > ev2.probability[45, 40]


def test_empty_view():
    img = np.full((30, 30, 3), 250, np.uint8)
    ev = view_evidence(img, roi=[0, 0, 30, 30], keep_out=None, base_point_xy=[5, 5], threshold=100)
    assert not ev.foreground.any() and len(ev.skeleton_xy) == 0
    assert np.all(sample_distance(ev, np.array([[10.0, 10.0]])) > 30)


def test_bad_arguments():
    img = _image()
    with pytest.raises(ValueError, match="min_component_px"):
        view_evidence(img, roi=[0, 0, 80, 60], keep_out=None, base_point_xy=[0, 0], min_component_px=-1)
    with pytest.raises(ValueError, match="roi"):
        view_evidence(img, roi=[0, 0, 0, 60], keep_out=None, base_point_xy=[0, 0])


def _strokes_image(seed: int, h=160, w=220) -> np.ndarray:
    import cv2

    rng = np.random.default_rng(seed)
    img = np.full((h, w, 3), 245, np.uint8)
    for _ in range(rng.integers(1, 5)):
        pts = rng.integers(0, [w, h], size=(rng.integers(2, 5), 2)).astype(np.int32)
        cv2.polylines(img, [pts], False, (25, 25, 25), int(rng.integers(1, 9)))
    return img


@pytest.mark.parametrize("run", [256, 7])
@pytest.mark.parametrize("seed", range(12))
def test_sample_distance_from_the_box_is_the_whole_transform(seed, run, monkeypatch):
    """Before distance_px is read, sample_distance transforms only the boxes of its points: the same values."""
    import cv2

    import tendrilkit.evidence as evidence

    monkeypatch.setattr(evidence, "LOCAL_RUN", run)  # one box, or a box per 7 positions

    img = _strokes_image(seed)
    rng = np.random.default_rng(seed)
    kw = dict(roi=[7, 5, 200, 150], keep_out=[60, 40, 12, 12], base_point_xy=[10, 10], opening_radius_px=0)
    on = np.argwhere(view_evidence(img, **kw).foreground)[:, ::-1] + [7, 5]
    near = on[rng.integers(0, len(on), 40)] + rng.normal(0, 4, (40, 2))       # along the strokes (the box path)
    anywhere = rng.uniform([-20, -20], [240, 180], (10, 2))                   # also off the ROI (the whole one)
    few = near[:3]
    for xy in (near, few, np.vstack([near, [[np.nan, 5.0]]]), anywhere, np.vstack([near, anywhere])):
        lazy = view_evidence(img, **kw)
        whole = view_evidence(img, **kw)
        assert whole.distance_px.shape == (150, 200)  # read first: sample_distance then reads the whole transform
        assert np.array_equal(sample_distance(lazy, xy), sample_distance(whole, xy), equal_nan=True)
        if xy is few:  # a few positions on the strokes: boxes answered, the whole transform was never made
            assert "distance_px" not in lazy.__dict__
    ev = view_evidence(img, **kw)
    ref = cv2.distanceTransform(np.where(ev.foreground, np.uint8(0), np.uint8(255)), cv2.DIST_L2, 5)
    assert np.array_equal(ev.distance_px, ref)
    assert np.array_equal(ev.inside_px, cv2.distanceTransform(ev.foreground.view(np.uint8), cv2.DIST_L2, 5))


@pytest.mark.parametrize("seed", range(12))
def test_sample_distance_reads_again_from_the_boxes_it_made(seed, monkeypatch):
    """A later read near the pixels of an earlier one comes from its boxes (no new transform): the same values."""
    import cv2

    import tendrilkit.evidence as evidence

    img = _strokes_image(seed)
    rng = np.random.default_rng(seed)
    kw = dict(roi=[7, 5, 200, 150], keep_out=[60, 40, 12, 12], base_point_xy=[10, 10], opening_radius_px=0)
    on = np.argwhere(view_evidence(img, **kw).foreground)[:, ::-1] + [7, 5]
    # a short stretch of a stroke: a box far smaller than half the crop, so the first read makes boxes
    first = on[rng.integers(0, len(on))] + rng.normal(0, 3, (20, 2))
    lazy, whole = view_evidence(img, **kw), view_evidence(img, **kw)
    assert whole.distance_px.shape == whole.foreground.shape  # the whole crop's transform, made at once
    assert np.array_equal(sample_distance(lazy, first), sample_distance(whole, first), equal_nan=True)
    assert "distance_px" not in lazy.__dict__ and len(lazy._distance_boxes) >= 1
    calls = []
    plain = cv2.distanceTransform
    monkeypatch.setattr(evidence.cv2, "distanceTransform", lambda *a: calls.append(1) or plain(*a))
    inner = first[::2] + rng.uniform(-0.5, 0.5, (10, 2))  # among the first read's pixels: from its boxes
    assert np.array_equal(sample_distance(lazy, inner), sample_distance(whole, inner), equal_nan=True)
    assert calls == [] and "distance_px" not in lazy.__dict__
    for later in (first + rng.normal(0, 1.5, first.shape),                    # beside the first: its boxes or new
                  rng.uniform([-20, -20], [240, 180], (10, 2)),               # anywhere: new boxes or the whole
                  np.vstack([first[:5], [[np.nan, 5.0]]])):
        assert np.array_equal(sample_distance(lazy, later), sample_distance(whole, later), equal_nan=True)
