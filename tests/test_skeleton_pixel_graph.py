"""skeleton.graph.skeleton_graph: skan's pixel graph and paths, without skan (same nodes, degrees, paths, order)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from skimage.morphology import skeletonize

from tendrilkit.skeleton import _testdata
from tendrilkit.skeleton.graph import skeleton_graph

skan = pytest.importorskip("skan")


def _random_skeleton(seed: int) -> np.ndarray:
    """The skeleton of a few thick random strokes and blobs (crossings, loops, junction clusters, spurs)."""
    rng = np.random.default_rng(seed)
    img = np.zeros((120, 160), np.uint8)
    for _ in range(rng.integers(1, 6)):
        pts = rng.integers(5, [155, 115], size=(rng.integers(2, 6), 2)).astype(np.int32)
        cv2.polylines(img, [pts], bool(rng.integers(0, 2)), 255, int(rng.integers(1, 9)))
    for _ in range(rng.integers(0, 3)):
        cv2.circle(img, tuple(int(v) for v in rng.integers(10, [150, 110])), int(rng.integers(3, 15)), 255,
                   int(rng.choice([-1, 2, 4])))
    return skeletonize(img > 0)


def _assert_same_as_skan(skel: np.ndarray) -> None:
    coords, deg, paths = skeleton_graph(skel)
    S = skan.Skeleton(skel, keep_images=False)
    assert np.array_equal(coords, S.coordinates)
    assert np.array_equal(deg, S.degrees)
    ref = S.paths_list()
    assert len(paths) == len(ref)
    for p, q in zip(paths, ref):
        assert p.tolist() == [int(i) for i in q]


@pytest.mark.parametrize("seed", range(40))
def test_random_skeletons_give_skans_graph(seed):
    _assert_same_as_skan(_random_skeleton(seed))


@pytest.mark.parametrize("name", ["SPUR", "TWO_LINES", "X_AS_TWO_Y"])
def test_hand_drawn_skeletons_give_skans_graph(name):
    _assert_same_as_skan(getattr(_testdata, name))


def test_junction_clusters_isolated_cycles_and_pixels():
    skel = np.zeros((30, 40), bool)
    skel[2:5, 2:5] = True                   # a 3x3 block: every pixel a junction, a spanning tree kept
    skel[5:9, 3] = True
    skel[20, 20] = True                     # an isolated pixel: no path
    cv2.circle(img := np.zeros((30, 40), np.uint8), (30, 20), 6, 1, 1)
    skel |= img.astype(bool)                # an isolated cycle
    skel[10, 10:20] = True
    skel[11, 15] = skel[12, 15] = True      # a T
    coords, deg, paths = skeleton_graph(skel)
    assert (deg == 0).sum() == 1
    assert any(p[0] == p[-1] for p in paths)   # the cycle, its first node repeated
    _assert_same_as_skan(skel)
