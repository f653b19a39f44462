"""The verification's fast paths give the answers of the plain computations they replace (random inputs).

Issue 17 cut the checks' cost without changing a figure: the ray ahead of
the tip reads the distance to the dark pixels from small boxes instead of
the whole crop's transform, the base check tests its samples' windows at
once, the crossing rule counts skeleton neighbours on their box, and
one skeleton-to-curve query serves two checks. Issue 17's second pass: the
curve's k-d tree queries skip the points far outside its box, the 3 x 3
largest inside distance and the suffix medians are compiled, the junctions
of the out-of-ROI segments are found from the skeleton's pixels alone, and
the tip continuation's pixel index is built from plain lists. Each is
compared here with the plain computation, written out as it was.
"""

import cv2
import numpy as np
import pytest
from scipy.spatial import cKDTree

from tendrilkit.evidence import ViewEvidence
from tendrilkit.verify_base import base_components, base_on_tendril, thin_at_base
from tendrilkit.verify_beyond import _ray_stop, beyond_tip_px
from tendrilkit.verify_crossing import _neighbour_counts, border_segments
from tendrilkit.verify_tip import bounded_query, local_inside_px, skeleton_to_curve_px, tip_continuation
from tendrilkit.verify_widen import _suffix_medians


def _strokes(rng, h, w, n):
    """A (h, w) bool mask of ``n`` random thick polylines."""
    img = np.zeros((h, w), np.uint8)
    for _ in range(n):
        pts = rng.integers(0, [w, h], (int(rng.integers(2, 5)), 2)).astype(np.int32)
        cv2.polylines(img, [pts], False, 1, int(rng.integers(1, 9)))
    return img.astype(bool)


def _evidence(mask, offset=(30, 20), base=(40.0, 25.0), keep_out=None):
    labels = cv2.connectedComponents(mask.view(np.uint8), connectivity=8, ltype=cv2.CV_32S)[1]
    sk_rc = np.argwhere(mask)[::3]  # any pixels in raster order serve as a skeleton here
    return ViewEvidence(foreground=mask, labels=labels, roi_offset_xy=np.array(offset),
                        base_point_xy=np.array(base), keep_out=keep_out,
                        skeleton_xy=(sk_rc[:, ::-1] + offset).astype(float))


@pytest.mark.parametrize("seed", range(60))
def test_ray_stop_equals_the_whole_distance_transform(seed):
    rng = np.random.default_rng(seed)
    h, w = (int(x) for x in rng.integers(20, 260, 2))
    mask = _strokes(rng, h, w, int(rng.integers(0, 6)))
    ev = _evidence(mask)
    # a ray from a random pixel to the crop's border: in a random direction, or along a row or a column (a
    # thin box, beside which the nearest dark pixel often lies)
    p = rng.uniform([0, 0], [w, h])
    u = rng.normal(size=2) if seed % 2 else np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0]])[seed % 3]
    u /= np.hypot(*u)
    ray = p + np.arange(1, int(np.hypot(h, w)))[:, None] * u
    rc = np.rint(ray).astype(int)
    inside = (rc[:, 0] >= 0) & (rc[:, 0] < w) & (rc[:, 1] >= 0) & (rc[:, 1] < h)
    rc = rc if inside.all() else rc[: int(np.argmin(inside))]
    if len(rc) == 0:
        return
    tol, k = float(rng.choice([1.0, 2.0, 2.5, 4.0])), int(rng.integers(1, 12))
    fast = _ray_stop(ev, rc, tol, k)
    assert "distance_px" not in ev.__dict__  # the whole transform was not made
    light = ev.distance_px[rc[:, 1], rc[:, 0]] > tol
    runs = np.flatnonzero(np.convolve(light.astype(np.int32), np.ones(k, np.int32), "valid") == k)
    assert fast == (int(runs[0]) if runs.size else len(rc))
    assert _ray_stop(ev, rc, tol, k) == fast  # and from the transform, once it is there


def _base_on_tendril_plain(ev, dense, d, tol, length_px=30.0, inside=None):
    """base_on_tendril as it was: one window and one isin per sample."""
    comps = base_components(ev)
    if inside is not None:
        comps = np.union1d(comps, thin_at_base(ev, inside))
    if comps.size == 0 or len(dense) == 0:
        return None
    first, dd = dense[: int(length_px)], d[: int(length_px)]
    off = ev.roi_offset_xy
    h, w = ev.shape
    r = np.clip(np.rint(first[:, 1] - off[1]).astype(int), 0, h - 1)
    c = np.clip(np.rint(first[:, 0] - off[0]).astype(int), 0, w - 1)
    rad = int(np.ceil(tol))
    hit = []
    for k in range(len(first)):
        if dd[k] > tol:
            hit.append(False)
            continue
        win = ev.labels[max(r[k] - rad, 0):r[k] + rad + 1, max(c[k] - rad, 0):c[k] + rad + 1]
        hit.append(bool(np.isin(win, comps).any()))
    return float(np.mean(hit)) if hit else None


@pytest.mark.parametrize("seed", range(40))
def test_base_on_tendril_equals_the_per_sample_loop(seed):
    rng = np.random.default_rng(100 + seed)
    h, w = (int(x) for x in rng.integers(15, 120, 2))
    mask = _strokes(rng, h, w, int(rng.integers(1, 6)))
    off = np.array([30, 20])
    base = off + rng.uniform([0, 0], [w, h])
    ev = _evidence(mask, offset=off, base=base, keep_out=np.array([*(base - 4).astype(int), 8, 8]))
    # a curve leaving the base, partly off the crop, with distances on and off the tolerance
    n = int(rng.integers(0, 45))
    dense = base + np.cumsum(rng.normal(0, 2.0, (n, 2)), axis=0)
    d = rng.uniform(0, 4, n)
    tol = float(rng.choice([1.0, 2.0, 3.0]))
    inside = cv2.distanceTransform(mask.view(np.uint8), cv2.DIST_L2, 5)
    for ins in (None, inside):
        assert base_on_tendril(ev, dense, d, tol, inside=ins) == _base_on_tendril_plain(ev, dense, d, tol, inside=ins)


@pytest.mark.parametrize("seed", range(30))
def test_neighbour_counts_equal_the_box_sum(seed):
    rng = np.random.default_rng(200 + seed)
    h, w = (int(x) for x in rng.integers(1, 90, 2))
    img = (rng.random((h, w)) < rng.random()).astype(np.uint8)
    sr, sc = np.nonzero(img)
    box = cv2.filter2D(img, -1, np.ones((3, 3), np.float32), borderType=cv2.BORDER_CONSTANT)[sr, sc].astype(int) - 1
    assert np.array_equal(_neighbour_counts(sr, sc, (h, w)), box)


@pytest.mark.parametrize("seed", range(20))
def test_one_skeleton_query_serves_the_tip_and_the_beyond_checks(seed):
    rng = np.random.default_rng(300 + seed)
    mask = _strokes(rng, 150, 200, 5)
    ev = _evidence(mask)
    sk = ev.skeleton_xy
    if len(sk) < 2:
        return
    i = int(rng.integers(0, len(sk) - 1))
    dense = sk[: i + 2] + rng.normal(0, 0.7, (i + 2, 2))
    cov_tol = 4.0
    sk_dist = skeleton_to_curve_px(sk, dense, cov_tol)
    plain = cKDTree(dense).query(sk, distance_upper_bound=cov_tol + 1e-9)[0]
    assert np.array_equal(sk_dist, plain)
    assert tip_continuation(ev, dense, cov_tol, sk_dist=sk_dist) == tip_continuation(ev, dense, cov_tol)
    inside = cv2.distanceTransform(mask.view(np.uint8), cv2.DIST_L2, 5)
    kw = dict(cov_tol=cov_tol, tol=2.0, wide_ratio=1.5)
    assert beyond_tip_px(ev, dense, inside, 2.0, sk_dist=sk_dist, **kw) == beyond_tip_px(ev, dense, inside, 2.0, **kw)


@pytest.mark.parametrize("seed", range(20))
def test_bounded_query_equals_the_whole_query(seed):
    rng = np.random.default_rng(400 + seed)
    curve = np.cumsum(rng.normal(0, 1.0, (int(rng.integers(1, 300)), 2)), axis=0) + 100.0
    pts = rng.uniform(0, 250, (int(rng.integers(0, 2000)), 2))
    bound = float(rng.choice([4.0 + 1e-9, 7.0 + 1e-9, 30.0]))
    tree = cKDTree(curve)
    plain_d, plain_i = tree.query(pts, distance_upper_bound=bound)
    for t in (None, tree):
        d, i = bounded_query(curve, pts, bound, tree=t)
        assert np.array_equal(d, plain_d) and np.array_equal(i, plain_i)


@pytest.mark.parametrize("seed", range(20))
def test_local_inside_px_equals_the_plain_maximum(seed):
    rng = np.random.default_rng(500 + seed)
    mask = _strokes(rng, 120, 160, 6)
    ev = _evidence(mask)
    inside = cv2.distanceTransform(mask.view(np.uint8), cv2.DIST_L2, 5)
    xy = rng.uniform(-5, [200, 150], (500, 2))  # crop pixels + the offset (30, 20), some outside the crop
    h, w = inside.shape
    r = np.rint(xy[:, 1] - 20).astype(int)
    c = np.rint(xy[:, 0] - 30).astype(int)
    plain = np.zeros(len(xy), np.float32)
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            plain = np.maximum(plain, inside[np.clip(r + dr, 0, h - 1), np.clip(c + dc, 0, w - 1)])
    got = local_inside_px(ev, xy, inside)
    assert got.dtype == np.float32 and np.array_equal(got, plain)


def _suffix_medians_plain(values):
    n = len(values)
    med, cnt = np.full(n, np.nan), np.zeros(n, np.int64)
    for k in range(n):
        v = values[k:][np.isfinite(values[k:])]
        cnt[k] = len(v)
        if len(v):
            v = np.sort(v)
            med[k] = 0.5 * (v[(len(v) - 1) // 2] + v[len(v) // 2])
    return med, cnt


@pytest.mark.parametrize("seed", range(20))
def test_suffix_medians_equal_the_plain_ones(seed):
    rng = np.random.default_rng(600 + seed)
    n = int(rng.integers(0, 120))
    values = np.round(rng.uniform(0, 12, n), int(rng.integers(0, 3)))  # ties too
    values[rng.random(n) < rng.random()] = np.nan
    med, cnt = _suffix_medians(values)
    plain_med, plain_cnt = _suffix_medians_plain(values)
    assert np.array_equal(med, plain_med, equal_nan=True) and np.array_equal(cnt, plain_cnt)


def _border_segments_plain(img, edge):
    on = img > 0
    p = np.pad(on, 1)
    h, w = on.shape
    ring = [p[r:r + h, c:c + w] for r, c in ((0, 1), (0, 2), (1, 2), (2, 2), (2, 1), (2, 0), (1, 0), (0, 0))]
    runs = sum((~ring[k] & ring[(k + 1) % 8]).astype(np.uint8) for k in range(8))
    junction = on & (runs >= 3)
    zone = cv2.dilate(junction.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool) & on
    n, seg = cv2.connectedComponents((on & ~zone).astype(np.uint8), connectivity=8, ltype=cv2.CV_32S)
    at_edge = np.bincount(seg[on & edge & ~zone], minlength=n) > 0
    at_edge[0] = False
    drop = at_edge[seg] & on
    if (zone & edge).any():
        zl = cv2.connectedComponents(zone.astype(np.uint8), connectivity=8, ltype=cv2.CV_32S)[1]
        hit = np.unique(zl[zone & edge])
        near = cv2.dilate(np.isin(zl, hit).astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
        drop |= np.isin(seg, np.unique(seg[near & (seg > 0)])) & (seg > 0)
        drop |= np.isin(zl, hit) & zone
    return drop


@pytest.mark.parametrize("seed", range(30))
def test_border_segments_equal_the_whole_box_computation(seed):
    from skimage.morphology import skeletonize

    rng = np.random.default_rng(700 + seed)
    img = skeletonize(_strokes(rng, 80, 110, int(rng.integers(1, 7)))).astype(np.uint8)
    edge = np.zeros(img.shape, bool)
    edge[:int(rng.integers(1, 6))] = True
    edge[:, -int(rng.integers(1, 6)):] = True
    assert np.array_equal(border_segments(img, edge), _border_segments_plain(img, edge))
