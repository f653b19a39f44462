"""The curve against itself: a tendril cannot pass through itself.

A tendril is a tube about as wide as the dark line it makes in the images
(``line_width_mm``, :mod:`tendrilkit.verify`). Two parts of it, far apart
along it, can touch (adjacent turns of a tight coil), but their centrelines
can never come closer than one width: the tube would pass through itself.
A reconstructed curve that does has taken a wrong turn that every view
accepts, because its projections lie on the tendril's pixels:

* at a loop whose passes touch in two views, the curve cuts across from one
  pass to the other (the S3 phantom of seed 11 with the grid-refined
  calibration, frame 4: mean 0.34 mm, max 2.9 mm, every image check passed;
  the curve's centreline comes within 0.07 mm of itself, the tendril is
  1.7 mm wide);
* where a second tendril crosses it, the curve runs out along the second
  tendril and back along the same pixels, a hairpin (random seed 2: mean
  4.3-4.7 mm, reported ``ok``; 0.25-1.2 mm from itself on a 1.5-1.6 mm
  wide tendril in four of its six frames).

Figure (column of ``frames.csv``)
    ``self_distance_mm``
        The smallest distance between two points of the curve more than
        :data:`SEPARATION_MM` apart along it, mm (:func:`self_distance_mm`).

The check (``verification.min_self_distance_frac``, 1.0): the frame is
``doubtful`` when ``self_distance_mm`` is below that fraction of the
measured line width. Right frames of the development scenes stay well above
(multi-view, random seeds 0-39: at least 1.8 line widths; the four site
phantoms at least 3.6 mm on 1.5-1.6 mm wide tendrils).
"""

from __future__ import annotations

import numpy as np

__all__ = ["SEPARATION_MM", "self_distance_mm", "self_contact_message"]

#: Two points of the curve closer than this along it (mm) are neighbours, not two parts that could touch:
#: a tendril bent to its tightest (a hook of radius 1.5 mm) keeps points 5 mm apart along it 3 mm apart in
#: space, more than any tendril's width (0.8-2 mm).
SEPARATION_MM = 5.0


def self_distance_mm(points_mm: np.ndarray, *, separation_mm: float = SEPARATION_MM) -> float | None:
    """The smallest distance between two points of the curve more than ``separation_mm`` apart along it.

    Parameters
    ----------
    points_mm : (n, 3) float array
        The centreline, base to tip, world mm (a few hundred points: the
        pairwise distances are computed at once).
    separation_mm : float
        Pairs closer than this along the curve are not compared, mm.

    Returns
    -------
    float or None
        mm; None when no two points are that far apart along the curve
        (or fewer than two finite points).

    Examples
    --------
    A hairpin: out 20 mm along x and back 0.2 mm beside itself.

    >>> out = np.column_stack([np.linspace(0, 20, 41), np.zeros(41), np.zeros(41)])
    >>> back = np.column_stack([np.linspace(20, 0, 41), np.full(41, 0.2), np.zeros(41)])
    >>> round(self_distance_mm(np.vstack([out, back])), 3)
    0.2
    >>> round(self_distance_mm(out), 3)  # a straight line (points 0.5 mm apart): the nearest pair over 5 mm along it
    5.5
    """
    X = np.asarray(points_mm, float).reshape(-1, 3)
    X = X[np.all(np.isfinite(X), axis=1)]
    if len(X) < 2:
        return None
    s = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(X, axis=0), axis=1))])
    far = np.abs(s[:, None] - s[None, :]) > separation_mm
    if not far.any():
        return None
    Xc = X - X.mean(axis=0)  # centred: the expansion below loses no digits to a far origin
    n2 = np.einsum("ij,ij->i", Xc, Xc)
    d2 = n2[:, None] + n2[None, :] - 2.0 * (Xc @ Xc.T)
    return float(np.sqrt(max(float(d2[far].min()), 0.0)))


def self_contact_message(distance_mm: float | None, line_width_mm: float | None, min_frac: float) -> str | None:
    """The check's message when the curve comes closer to itself than ``min_frac`` line widths, else None.

    Parameters
    ----------
    distance_mm : float or None
        :func:`self_distance_mm` (None: not measured, no message).
    line_width_mm : float or None
        The tendril's measured width, mm (None or not finite: no message).
    min_frac : float
        The limit as a fraction of the width.
    """
    if distance_mm is None or line_width_mm is None or not np.isfinite(line_width_mm) or line_width_mm <= 0:
        return None
    limit = min_frac * line_width_mm
    if distance_mm >= limit:
        return None
    return (f"self: two parts of the curve over {SEPARATION_MM:g} mm apart along it come within "
            f"{distance_mm:.2f} mm of each other (limit {limit:.2f} mm: {min_frac:g} x the {line_width_mm:.2f} mm "
            "line width): a tendril cannot pass through itself")
