"""The nearly-straight check: a straight centreline has no normal, so its torsion is undefined.

A centreline within :data:`STRAIGHT_FRACTION` of its length of its chord is
``nearly straight``; the frame stays ``ok`` with a note, whatever the
piece-wise clothoid fit says about its torsion.
"""

from __future__ import annotations

import numpy as np

__all__ = ["STRAIGHT_FRACTION", "straightness_note"]

#: A centreline within this fraction of its length of its chord is straight: torsion undefined (a note).
STRAIGHT_FRACTION = 0.01


def straightness_note(points_mm: np.ndarray, length_mm: float) -> str | None:
    """The note for a nearly straight centreline, or None.

    Parameters
    ----------
    points_mm : (n, 3) float array
        The centreline, base to tip, mm.
    length_mm : float
        Its length, mm.

    Returns
    -------
    str or None

    Examples
    --------
    >>> line = np.c_[np.linspace(0, 100, 11), np.zeros(11), np.zeros(11)]
    >>> straightness_note(line, 100.0)
    'nearly straight (at most 0.00 mm from its chord over 100.0 mm): torsion undefined'
    >>> straightness_note(np.c_[line[:, :2], 5 * np.sin(line[:, 0] / 30)], 105.0) is None
    True
    """
    chord = points_mm[-1] - points_mm[0]
    if not np.linalg.norm(chord) > 0:
        return None
    rel = points_mm - points_mm[0]
    chord = chord / np.linalg.norm(chord)
    dev = float(np.linalg.norm(rel - np.outer(rel @ chord, chord), axis=1).max())
    if dev <= STRAIGHT_FRACTION * length_mm:
        return f"nearly straight (at most {dev:.2f} mm from its chord over {length_mm:.1f} mm): torsion undefined"
    return None
