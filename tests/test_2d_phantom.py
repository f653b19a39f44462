"""Accuracy of the 2D stage on rendered phantom views of the four sites.

Requirements (issue "Per-view 2D stage"): in every view the ordered 2D
centreline lies within 1.5 px (mean) of the ground-truth projection, the
base-to-tip order is right on every frame and every S3 crossing is resolved.

The order check: the measured and the true centrelines (the visible part: the
keep-out box hides the first ``hidden_base_mm``) are compared at the same
fractions of their arc length; a wrong turn at a crossing or a reversed curve
moves some fraction by the size of a loop (tens of pixels), a right order by
the few pixels the ends differ. The nearest-point arc correlation is checked
too, loosely (> 0.9): where the tendril crosses itself at a small angle or
runs along itself, both passes are nearest to some points.
"""

from __future__ import annotations

import numpy as np
import pytest

from tendrilkit.skeleton import compare_centerlines, process_view

phantom = pytest.importorskip("tendrilkit.phantom")

pytestmark = pytest.mark.slow

N_FRAMES = 12


def run_views(site: str, seed: int, frames: list[int]):
    """Process ``frames`` of every view (tracking from frame to frame); yield the comparisons."""
    ph = phantom.make_phantom(site, n_frames=N_FRAMES, seed=seed)
    for v, marks in enumerate(ph.views):
        prev = None
        visible = ph.s_mm >= ph.hidden_base_mm[v]
        for f in frames:
            img = phantom.render_view(ph, f, v)
            res = process_view(img, roi=marks["roi"], keep_out=marks["keep_out"], base_point_xy=marks["base_point"],
                               prev_centroid_xy=prev, frame=f, view=v + 1)
            prev = res.centroid_xy
            m = compare_centerlines(res.points_xy, ph.projections_px[f, v][visible])
            yield ph, f, v, res, m


def check(site: str, seed: int, frames: list[int]) -> int:
    crossings = 0
    for ph, f, v, res, m in run_views(site, seed, frames):
        where = f"{site} seed {seed} frame {f} view {v + 1}: {m}"
        assert m["mean_px"] < 1.5, where
        assert m["fraction_max_px"] < 8.0, where
        assert m["arc_corr"] > 0.9, where
        assert m["base_px"] < 6.0 and m["tip_px"] < 6.0, where
        # the ground truth counts intersections of the projected polyline; the
        # walk counts junctions passed twice (a band where the tendril runs
        # along itself is one junction pair, tangent or crossing): compare
        # presence, the order check above says whether they were resolved
        n_true = len(ph.crossings[f][v])
        assert (res.n_crossings > 0) == (n_true > 0), where + f" crossings {res.n_crossings} (true {n_true})"
        crossings += n_true
    return crossings


@pytest.mark.parametrize("site", ["S1", "S2", "S4"])
def test_in_plane_sites(site):
    check(site, 0, [0, 6, 11])


def test_s3_every_crossing_resolved():
    # every frame of the nominal S3 phantom: the loop appears at frame 6 in all views
    assert check("S3", 0, list(range(N_FRAMES))) >= 18


def test_s3_other_seed():
    assert check("S3", 2, [0, 7, 9, 11]) >= 9
