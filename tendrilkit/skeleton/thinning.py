"""Thinning a mask to its one-pixel skeleton: :func:`skimage.morphology.skeletonize`, pixel for pixel, faster.

scikit-image's 2D skeleton (Zhang and Suen's parallel thinning, with its own
table of removable neighbourhoods) visits every pixel of the array in every
pass, so its cost is the array's area times the number of passes (about the
tube's half width): 4-6 ms per view for the tendril's component of a 1080p
phantom frame, 15-20 ms for every dark component of the region of interest.
:func:`thin` runs the same passes on the same table, but visits only the
pixels that can change: a pixel all of whose eight neighbours are set is
never removed (its neighbourhood code is 255, which the table keeps), so
only the foreground pixels with a background neighbour are evaluated, and a
pixel joins them when one of its neighbours is removed. Every sub-iteration
still decides all its removals from the state before it, as the parallel
algorithm does, so the result is the same array; the cost is the foreground
plus its border times the passes (about 1 ms per view).

``tests/test_skeleton_thinning.py`` checks :func:`thin` against
:func:`skimage.morphology.skeletonize` on random blobs and strokes and on
a phantom view's dark pixels.

Example
-------
>>> import numpy as np
>>> mask = np.zeros((9, 12), bool)
>>> mask[3:6, 1:11] = True
>>> thin(mask).view(np.uint8)[3:6]
array([[0, 0, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0],
       [0, 1, 1, 1, 1, 1, 1, 1, 1, 0, 0, 0],
       [0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]], dtype=uint8)
>>> from skimage.morphology import skeletonize
>>> bool(np.array_equal(thin(mask), skeletonize(mask)))
True
"""

from __future__ import annotations

import cv2
import numpy as np
from numba import njit

__all__ = ["thin", "thin_strips"]

#: Per neighbourhood code (north-west 1, north 2, north-east 4, east 8, south-east 16, south 32, south-west 64,
#: west 128): 1 a pixel removable in the first sub-iteration, 2 in the second, 3 in both, 0 kept. The table
#: of scikit-image's Zhang-Suen thinning (``_fast_skeletonize``), so that the skeletons are the same.
_LUT = np.array([
    0, 0, 0, 1, 0, 0, 1, 3, 0, 0, 3, 1, 1, 0, 1, 3, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 2, 0, 3, 0, 3, 3,
    0, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 3, 0, 2, 2,
    0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    2, 0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 0, 0, 0, 0, 3, 0, 0, 0, 3, 0, 2, 0,
    0, 0, 3, 1, 0, 0, 1, 3, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1,
    3, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    2, 3, 1, 3, 0, 0, 1, 3, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0,
    2, 3, 0, 1, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 3, 3, 0, 1, 0, 0, 0, 0, 2, 2, 0, 0, 2, 0, 0, 0,
], np.uint8)


def thin(mask: np.ndarray) -> np.ndarray:
    """The one-pixel skeleton of a mask (:func:`skimage.morphology.skeletonize`'s, pixel for pixel).

    Parameters
    ----------
    mask : (h, w) array
        Nonzero: foreground (bool or uint8 0/255).

    Returns
    -------
    (h, w) bool array
        The skeleton.

    Raises
    ------
    ValueError
        ``mask`` is not 2D.
    """
    m = np.asarray(mask)
    if m.ndim != 2:
        raise ValueError(f"mask must be a 2D array, got shape {m.shape}")
    padded = np.zeros((m.shape[0] + 2, m.shape[1] + 2), np.uint8)
    padded[1:-1, 1:-1] = m != 0
    _thin_padded(padded, _LUT)
    return np.ascontiguousarray(padded[1:-1, 1:-1]).view(bool)


def thin_strips(mask: np.ndarray, strip: int = 96) -> np.ndarray:
    """The skeleton of a mask thinned strip by strip (:func:`thin` on overlapping bands): the 2D stage's.

    How the walk (:func:`tendrilkit.skeleton.order_skeleton`) and the
    evidence (:func:`tendrilkit.evidence.view_evidence`) have thinned their
    masks since scikit-image's whole-box thinning cost 9 ms on a 400 x 800 px
    box: each horizontal strip of ``strip`` rows is thinned with ``margin``
    extra rows above and below (three of the mask's thicknesses, at least
    24 px), cropped to the columns its rows use. A pixel depends only on
    pixels within one pixel per sub-iteration, so the strips almost always
    give the whole box's skeleton (no pixel differs on 240 masks of the four
    phantom sites), but not always (9 pixels of one view of one frame of the
    random scene of seed 7 differ). :func:`thin` makes the whole box's
    skeleton at a fraction of the strips' former cost; the strips are kept so
    that results stay identical: thinning whole would change those rare
    frames (a decision for whoever accepts result changes).

    Parameters
    ----------
    mask : (h, w) array
        Nonzero: foreground.
    strip : int
        Rows per strip.

    Returns
    -------
    (h, w) bool array
    """
    m8 = np.asarray(mask)
    if m8.ndim != 2:
        raise ValueError(f"mask must be a 2D array, got shape {m8.shape}")
    m8 = np.ascontiguousarray(m8 != 0).view(np.uint8)
    H, W = m8.shape
    if H <= 2 * strip:
        return thin(m8)
    contours, _ = cv2.findContours(m8, cv2.RETR_LIST, cv2.CHAIN_APPROX_NONE)
    perimeter = sum(cv2.arcLength(c, True) for c in contours)
    thickness = 2.0 * float(np.count_nonzero(m8)) / max(perimeter, 1.0)
    margin = max(24, int(np.ceil(3 * thickness)) + 4)
    rows_any = m8.any(axis=1)
    out = np.zeros((H, W), bool)
    for r0 in range(0, H, strip):
        r1 = min(r0 + strip, H)
        if not rows_any[r0:r1].any():
            continue
        a0, a1 = max(r0 - margin, 0), min(r1 + margin, H)
        band = m8[a0:a1]
        cols = np.flatnonzero(band.any(axis=0))
        c0, c1 = max(cols[0] - 1, 0), min(cols[-1] + 2, W)
        out[r0:r1, c0:c1] = thin(band[:, c0:c1])[r0 - a0 : r1 - a0]
    return out


@njit(cache=True)
def _thin_padded(sk, lut):  # pragma: no cover - compiled
    """Thin the 0/1 array ``sk`` (a zero border of one pixel around the mask) in place.

    The pixels evaluated are the foreground's with a background neighbour; one
    that two sub-iterations in a row (one of each kind) kept, its neighbours
    unchanged since, is kept by every later one until a neighbour is removed
    (its neighbourhood code and the sub-iteration's kind decide), so it leaves
    the list and comes back with a neighbour's removal: a thin line already
    thinned is not evaluated again every sub-iteration while a wide region
    goes on thinning (the same removals, sub-iteration by sub-iteration).
    """
    h, w = sk.shape
    n_fg = 0
    for r in range(1, h - 1):
        for c in range(1, w - 1):
            n_fg += sk[r, c]
    # the pixels to evaluate: foreground with a background neighbour (each listed at most once at a time)
    cr = np.empty(n_fg, np.int32)
    cc = np.empty(n_fg, np.int32)
    listed = np.zeros((h, w), np.uint8)
    calm = np.zeros((h, w), np.uint8)  # sub-iterations in a row that kept the pixel, its neighbours unchanged
    n = 0
    for r in range(1, h - 1):
        for c in range(1, w - 1):
            if sk[r, c] and not (sk[r - 1, c - 1] and sk[r - 1, c] and sk[r - 1, c + 1] and sk[r, c + 1]
                                 and sk[r + 1, c + 1] and sk[r + 1, c] and sk[r + 1, c - 1] and sk[r, c - 1]):
                cr[n] = r
                cc[n] = c
                listed[r, c] = 1
                n += 1
    gone = np.zeros(n_fg, np.uint8)
    removed = True
    while removed:
        removed = False
        for first in (True, False):
            n_gone = 0
            for i in range(n):  # decide every removal from the state before this sub-iteration
                r, c = cr[i], cc[i]
                code = (sk[r - 1, c - 1] + 2 * sk[r - 1, c] + 4 * sk[r - 1, c + 1] + 8 * sk[r, c + 1]
                        + 16 * sk[r + 1, c + 1] + 32 * sk[r + 1, c] + 64 * sk[r + 1, c - 1] + 128 * sk[r, c - 1])
                k = lut[code]
                if k == 3 or (k == 1 and first) or (k == 2 and not first):
                    gone[i] = 1
                    n_gone += 1
                elif calm[r, c] < 2:
                    calm[r, c] += 1
            if n_gone == 0:
                continue
            removed = True
            for i in range(n):
                if gone[i]:
                    sk[cr[i], cc[i]] = 0
            n_old = n
            for i in range(n_old):  # the removed pixels' neighbours join the list (their calm ends)
                if gone[i]:
                    r, c = cr[i], cc[i]
                    for dr in range(-1, 2):
                        for dc in range(-1, 2):
                            rr, c2 = r + dr, c + dc
                            if sk[rr, c2]:
                                calm[rr, c2] = 0
                                if not listed[rr, c2]:
                                    listed[rr, c2] = 1
                                    cr[n] = rr
                                    cc[n] = c2
                                    n += 1
            m = 0
            for i in range(n_old):  # the removed and the calm leave the list
                r, c = cr[i], cc[i]
                if gone[i]:
                    gone[i] = 0
                    listed[r, c] = 0
                elif calm[r, c] >= 2:
                    listed[r, c] = 0
                else:
                    cr[m] = r
                    cc[m] = c
                    m += 1
            # the appended ones (from n_old on) move down behind the kept ones
            for i in range(n_old, n):
                cr[m] = cr[i]
                cc[m] = cc[i]
                m += 1
            n = m
