"""Compiled kernels of the segmentation, each the same pixels as the OpenCV call it replaces (tests compare them).

* :func:`binary_morphology`: ``cv2.morphologyEx`` (opening, closing), ``cv2.erode`` and ``cv2.dilate`` of a binary
  image by a structuring element whose rows are runs centred on its middle column (``cv2.MORPH_ELLIPSE``,
  ``cv2.MORPH_RECT`` and ``cv2.MORPH_CROSS`` of odd sides), OpenCV's default border (outside counts as set for
  an erosion, as clear for a dilation), on rows packed 64 pixels to a machine word: a row's erosion by a run of
  half width ``a`` is the AND of ``2 a + 1`` shifted words, the element's the AND over its rows of its rows'
  runs (OR for a dilation). The light lines' disk of 11 px: OpenCV visits its 97 offsets per pixel; here a
  word of 64 pixels takes about 25 word operations.
* :func:`grow_fill`: a hole of a uint8 image filled from its rim one pixel a step, each pixel with the largest
  level of its 3 x 3 neighbours at the step before (the faint pixels' board level beside a leaf: the loop of
  ``cv2.dilate`` over the whole reduced image it replaces, about 0.1 ms a step), visiting only the hole's pixels
  next to the last step's.
"""

from __future__ import annotations

import cv2
import numpy as np
from numba import njit

__all__ = ["binary_morphology", "grow_fill"]

_OPS = {cv2.MORPH_ERODE: (True,), cv2.MORPH_DILATE: (False,), cv2.MORPH_OPEN: (True, False),
        cv2.MORPH_CLOSE: (False, True)}


def _centred_runs(kernel: np.ndarray) -> np.ndarray | None:
    """Per row of ``kernel`` (odd sides), the half width of its run centred on the middle column (-1: empty
    row), or None when a row is not such a run."""
    k = np.asarray(kernel) != 0
    kh, kw = k.shape
    if kh % 2 == 0 or kw % 2 == 0 or kw // 2 > 63:
        return None
    c = kw // 2
    hw = np.full(kh, -1, np.int64)
    for i in range(kh):
        cols = np.flatnonzero(k[i])
        if len(cols) == 0:
            continue
        a = c - int(cols[0])
        if int(cols[-1]) != c + a or len(cols) != 2 * a + 1:
            return None
        hw[i] = a
    return hw if (hw >= 0).any() else None


def binary_morphology(mask: np.ndarray, op: int, kernel: np.ndarray) -> np.ndarray:
    """``cv2.morphologyEx(mask, op, kernel)`` of a binary uint8 image, bit for bit (0 / 255 out).

    Parameters
    ----------
    mask : (h, w) uint8 array
        0 or 255 (any nonzero value is taken as set; OpenCV's result is then
        the same only for 0 / 255 images).
    op : int
        ``cv2.MORPH_OPEN``, ``cv2.MORPH_CLOSE``, ``cv2.MORPH_ERODE`` or ``cv2.MORPH_DILATE``.
    kernel : (kh, kw) uint8 array
        Odd sides, anchored at its centre; each row a run centred on the
        middle column (or empty). Any other element is passed to OpenCV.

    Returns
    -------
    (h, w) uint8 array
        255 where set, 0 elsewhere.
    """
    m = np.asarray(mask)
    hw = _centred_runs(kernel)
    if hw is None or op not in _OPS or m.ndim != 2 or m.dtype != np.uint8 or m.size == 0:
        return cv2.morphologyEx(m, op, kernel)
    h, w = m.shape
    words = _pack(m)
    for erode in _OPS[op]:
        words = _morph_words(words, w, hw, erode)
    return _unpack(words, w)


def _pack(mask: np.ndarray) -> np.ndarray:
    """(h, ceil(w / 64)) uint64: bit ``k`` of word ``i`` of a row is its pixel ``64 i + k`` (nonzero: set)."""
    h, w = mask.shape
    nw = (w + 63) // 64
    out = np.zeros((h, nw * 8), np.uint8)
    out[:, :(w + 7) // 8] = np.packbits(mask, axis=1, bitorder="little")
    return out.view(np.uint64)


def _unpack(words: np.ndarray, w: int) -> np.ndarray:
    bits = np.unpackbits(np.ascontiguousarray(words).view(np.uint8), axis=1, count=w, bitorder="little")
    if bits.size < 2:  # OpenCV takes a 1 x 1 array for a scalar
        return bits * np.uint8(255)
    return cv2.compare(bits, 0, cv2.CMP_GT)


@njit(cache=True)
def _morph_words(x, width, hw, erode):  # pragma: no cover - compiled
    """One erosion (``erode``) or dilation of the packed rows ``x`` (h, nw) by the element of row half widths
    ``hw`` ((2 R + 1,), -1: an empty row); outside the image: set for an erosion, clear for a dilation."""
    h, nw = x.shape
    full = ~np.uint64(0)
    zero = np.uint64(0)
    border = full if erode else zero
    used = width - 64 * (nw - 1)  # bits of the last word inside the image, 1-64
    pad = (full << np.uint64(used)) if used < 64 else zero  # the last word's bits beyond the image
    src = x.copy()
    for r in range(h):  # beyond the image's last column: the border's value
        if erode:
            src[r, nw - 1] |= pad
        else:
            src[r, nw - 1] &= ~pad
    amax = 0
    for v in hw:
        amax = max(amax, v)
    # runs[a]: each pixel's row run of half width a (AND / OR of the pixels a or fewer to either side), nested
    runs = np.empty((amax + 1, h, nw), np.uint64)
    runs[0] = src
    for a in range(1, amax + 1):
        sa = np.uint64(a)
        sb = np.uint64(64 - a)
        for r in range(h):
            for i in range(nw):
                cur = src[r, i]
                nxt = src[r, i + 1] if i + 1 < nw else border
                prv = src[r, i - 1] if i > 0 else border
                right = (cur >> sa) | (nxt << sb)  # pixel p + a
                left = (cur << sa) | (prv >> sb)  # pixel p - a
                if erode:
                    runs[a, r, i] = runs[a - 1, r, i] & right & left
                else:
                    runs[a, r, i] = runs[a - 1, r, i] | right | left
    R = len(hw) // 2
    out = np.empty((h, nw), np.uint64)
    for r in range(h):
        for i in range(nw):
            acc = full if erode else zero
            for d in range(len(hw)):
                a = hw[d]
                if a < 0:
                    continue
                rr = r + d - R
                v = runs[a, rr, i] if 0 <= rr < h else border
                if erode:
                    acc &= v
                else:
                    acc |= v
            out[r, i] = acc
        out[r, nw - 1] &= ~pad
    return out


def grow_fill(image: np.ndarray, hole: np.ndarray) -> np.ndarray:
    """``image`` (uint8, 2D) with its ``hole`` pixels (nonzero) filled from the rim in, one pixel a step.

    Step by step, every hole pixel with a pixel outside the hole among its
    8 neighbours takes the largest of its 3 x 3 neighbourhood's levels at
    the step before (hole pixels count as 0), and leaves the hole; after as
    many steps as the image's longer side, or when no hole pixel has such a
    neighbour, what is left is 255. The same as, per step, a 3 x 3
    ``cv2.dilate`` of the levels and of the pixels outside the hole over the
    whole image (OpenCV's border: outside the image counts for nothing).
    Returns a new array.
    """
    img = np.ascontiguousarray(image, dtype=np.uint8)
    todo = np.ascontiguousarray(np.asarray(hole) != 0)
    if img.ndim != 2 or todo.shape != img.shape:
        raise ValueError(f"hole must have the shape of image {img.shape}, got {np.asarray(hole).shape}")
    return _grow_fill(img, todo.view(np.uint8).copy())


@njit(cache=True)
def _grow_fill(img, todo):  # pragma: no cover - compiled
    h, w = img.shape
    out = img.copy()
    n = 0
    for r in range(h):
        for c in range(w):
            if todo[r, c]:
                out[r, c] = 0
                n += 1
    fr = np.empty(n, np.int64)  # this step's pixels (rows, columns)
    fc = np.empty(n, np.int64)
    val = np.empty(n, np.uint8)
    queued = np.zeros((h, w), np.uint8)
    m = 0
    for r in range(h):  # the first step: hole pixels with a neighbour outside the hole
        for c in range(w):
            if todo[r, c]:
                edge = False
                for dr in range(-1, 2):
                    for dc in range(-1, 2):
                        rr, cc = r + dr, c + dc
                        if 0 <= rr < h and 0 <= cc < w and not todo[rr, cc]:
                            edge = True
                if edge:
                    fr[m] = r
                    fc[m] = c
                    queued[r, c] = 1
                    m += 1
    steps = 0
    while m > 0 and steps < max(h, w):
        steps += 1
        for k in range(m):  # every level from the step before
            r, c = fr[k], fc[k]
            best = 0
            for dr in range(-1, 2):
                for dc in range(-1, 2):
                    rr, cc = r + dr, c + dc
                    if 0 <= rr < h and 0 <= cc < w and out[rr, cc] > best:
                        best = out[rr, cc]
            val[k] = best
        for k in range(m):
            out[fr[k], fc[k]] = val[k]
            todo[fr[k], fc[k]] = 0
        m2 = 0
        nr = np.empty(n, np.int64)
        nc = np.empty(n, np.int64)
        for k in range(m):  # the next step: the hole pixels next to this step's
            r, c = fr[k], fc[k]
            for dr in range(-1, 2):
                for dc in range(-1, 2):
                    rr, cc = r + dr, c + dc
                    if 0 <= rr < h and 0 <= cc < w and todo[rr, cc] and not queued[rr, cc]:
                        queued[rr, cc] = 1
                        nr[m2] = rr
                        nc[m2] = cc
                        m2 += 1
        fr, fc, m = nr, nc, m2
    for r in range(h):
        for c in range(w):
            if todo[r, c]:
                out[r, c] = 255
    return out
