"""The coverage's reading of thin skeleton joined to the tendril only through wider clutter (verify_coverage)."""

import numpy as np

from tendrilkit.verify_coverage import _behind_clutter


def _line(n_near: int, n_wide: int, n_thin: int, *, comp_of_thin: int = 1, tip_at_end: bool = False):
    """A row of skeleton pixels: explained (the curve), then wider clutter, then an unexplained thin branch."""
    n = n_near + n_wide + n_thin
    sr = np.full(n, 5)
    sc = np.arange(n) + 3
    sk = np.column_stack([sc, sr]).astype(float)
    near = np.arange(n) < n_near
    thin = ~((np.arange(n) >= n_near) & (np.arange(n) < n_near + n_wide))
    branch = np.where(np.arange(n) >= n_near + n_wide, 1, 0)
    comp = np.where(branch == 1, comp_of_thin, 1)
    at_tip = np.zeros(n, bool)
    if tip_at_end:
        at_tip[n_near - 1] = True  # the curve's tip is where the clutter begins
    return sk, sr, sc, near, thin, branch, np.array([1]), comp, at_tip


def test_thin_end_of_long_wider_clutter_is_not_the_tendril():
    # a shoot joined to the tendril: 50 px of it wider than the tendril, then its thin tapering end
    assert _behind_clutter(*_line(10, 50, 20), reach_px=40.0).tolist() == [True]


def test_thin_line_across_a_short_crossing_is_the_tendril():
    # the tendril's missed part beyond a crossing a few widths long
    assert _behind_clutter(*_line(10, 12, 20), reach_px=40.0).tolist() == [False]


def test_rest_of_the_tendril_beyond_an_object_at_the_tip_is_the_tendril():
    # the curve stops at a leaf the tendril passes behind: its rest is reached from the tip across the leaf
    assert _behind_clutter(*_line(10, 50, 20, tip_at_end=True), reach_px=40.0).tolist() == [False]


def test_piece_in_a_component_the_curve_does_not_explain_is_kept():
    # beyond a break in the dark pixels (another component): the break's rule, not this one
    assert _behind_clutter(*_line(10, 50, 20, comp_of_thin=2), reach_px=40.0).tolist() == [False]
