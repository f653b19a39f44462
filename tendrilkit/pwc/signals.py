"""A centreline's curvature and torsion prepared for the searches: frames, weights, cost tables.

Shared by the automatic selection, the fixed penalties and the paper's grid
search: one smoothing (:mod:`tendrilkit.frenet`), torsion weighted by
curvature squared, the minimum segment size, and both signals' interval costs.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from tendrilkit.frenet import FrenetFrames, _auto_smoothing, frenet_frames
from tendrilkit.pwc.costs import line_costs

__all__: list[str] = []


#: Refined and inserted knots stay at least this many sample spacings apart.
KNOT_GAP_SAMPLES = 9


@dataclass(frozen=True, eq=False)
class _Prepared:
    """One centreline's signals for the searches.

    ``fr``: the Frenet frames (smoothed curve, kappa, tau, 1/mm); ``s`` (n,):
    arc length, mm; ``data`` (n, 3): the input resampled, mm (what the scores
    measure against); ``wk``, ``wt`` (n,): sample weights of curvature (1) and
    torsion (kappa^2 where torsion is defined); ``Ck``, ``Ct`` (n + 1, n + 1):
    interval costs (:func:`~tendrilkit.pwc.costs.line_costs`); ``free_knots``:
    refinement moves the inner knots; ``min_gap_mm``: closest knots, mm; ``noise_mm``: the
    input points' :func:`~tendrilkit.frenet.noise_sigma_mm` where the automatic smoothing
    computed it (else ``None``); ``sst_mm2``: the data's sum of squares about their mean (mm^2,
    the R^2's denominator); ``hinge_xs_mm``: the positions the knot score test tries (mm,
    :func:`~tendrilkit.pwc.refine._hinge_positions`). Each made once per curve.
    """

    fr: FrenetFrames
    s: np.ndarray
    data: np.ndarray
    wk: np.ndarray
    wt: np.ndarray
    Ck: np.ndarray
    Ct: np.ndarray
    free_knots: bool
    min_gap_mm: float
    noise_mm: float | None = None
    sst_mm2: float | None = None
    hinge_xs_mm: np.ndarray | None = None


def _prepare(points_mm, smoothing_length_mm, score, min_segment_mm, n_points, free_knots=True):
    """Smooth ``points_mm`` (n, 3) and cost both signals (options: :func:`~tendrilkit.pwc.fit_piecewise_clothoid`)."""
    fr = noise_mm = None
    if smoothing_length_mm is None:
        # the frames the choice of length computed are reused when they have the points asked for
        smoothing_length_mm, fr, noise_mm = _auto_smoothing(points_mm, with_noise=True)
        if n_points is not None and (fr is None or fr.s_mm.size != n_points):
            fr = None
    if fr is None:
        fr = frenet_frames(points_mm, smoothing_length_mm=smoothing_length_mm, n=n_points)
    s = fr.s_mm
    n = s.size
    h = s[-1] / (n - 1)
    seg_mm = 0.5 * smoothing_length_mm if min_segment_mm is None else min_segment_mm
    min_size = int(max(3, np.ceil(seg_mm / h)))
    min_size = min(min_size, n)
    wk = np.ones(n)
    wt = fr.kappa ** 2 * fr.tau_defined
    if not wt.sum() > 0:
        wt = np.ones(n) * 1e-12
    Ck = line_costs(s, fr.kappa, weights=wk, score=score, min_size=min_size)
    Ct = line_costs(s, fr.tau, weights=wt, score=score, min_size=min_size)
    data = np.ascontiguousarray(fr.data_mm)
    gap = float(KNOT_GAP_SAMPLES * h)
    sst = float(np.sum((data - data.mean(axis=0)) ** 2))
    xs = np.arange(s[0] + gap, s[-1] - gap, max(gap / 2, (s[-1] - s[0]) / 200))
    return _Prepared(fr, s, data, wk, wt, Ck, Ct, free_knots, gap, noise_mm, sst, xs)
