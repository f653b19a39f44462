r"""Response onset and stabilisation by fitting a smooth step to the shape change.

Paper, "Discussion": tendrils respond within about 3 min of the stimulus (the
first movement) and their shape is stable after about 12 min. A threshold
rule on the shape change (:func:`tendrilkit.sequence.response_times`: onset
when the change passes 10 % of its plateau, stable when it stays within
10 %) measures something else on a smooth transition: a movement that starts
gently crosses 10 % late, and one that settles gently enters the 10 % band
early. On a quintic smooth step from 3 to 12 min the rule gives 4.8 and
10.2 min (10 % and 90 % of the step are reached 20 % of the way in and out).

Definition used here (:func:`fit_response_times`)
------------------------------------------------
Two shape-change signals of the ok frames, both with rigid motion removed
(:func:`tendrilkit.sequence.shape_change`, ``shape_mm``):

- :math:`D_0(t)`: distance to the *first* frame's shape (grows from 0);
- :math:`D_1(t)`: distance to the *last* frame's shape (falls to 0).

Both are de-biased in quadrature by the noise floor :math:`b` (the level of
:math:`D_0` over the ``floor_frames`` frames after the reference, before
anything moves): :math:`\sqrt{D^2 - b^2}`.
Near its two ends a transition is linear in how far it has gone (a small
change of shape moves every point in proportion), while in the middle a
distance between shapes need not be (a curl passes through shapes farther
from the first than the final one: :math:`D_0` overshoots on the S3
phantom). So each end is fitted on its own part of the sequence:

.. math::

    D_0(t) \approx c_0 + A_0\, q\!\left(\frac{t - t_{on}}{T_0}\right)
    \quad (t \le t_{50}(D_0)), \qquad
    D_1(t) \approx c_1 + A_1\left(1 - q\!\left(\frac{t - t_{st} + T_1}{T_1}\right)\right)
    \quad (t \ge t_{50}(D_1))

with :math:`q(x) = 6x^5 - 15x^4 + 10x^3` on [0, 1] (0 before, 1 after: a
step with zero speed and acceleration at both ends) and :math:`t_{50}` the
first (resp. last) time the signal is at ``window`` (half) of its maximum.
:math:`t_{on}` is the first movement, :math:`t_{st}` the time the shape
stops changing. Least squares over an exhaustive grid of start and end
times (``grid`` steps over the sequence: 7.5 s on 15 min), :math:`c, A`
solved in closed form.

Accuracy (tests/test_response.py): on the phantoms' true centrelines with
0.3 mm noise per point (60 frames of 15 s, S2-S4, seeds 0-3) the onset is
within 0.35 min of the truth and stabilisation within 1.25 min (S3: 0.5-1.2
min early, because its curl keeps a slow wobble of a few per cent that the
smooth step does not have; S2, S4 within 0.6 min). With 20 frames (45 s
apart) the small change of S4 (3-4.5 mm) is located less well: errors up to
1.5 min at the onset and 1.2 min at stabilisation.

Whether the tendril responded is decided as in
:func:`tendrilkit.sequence.response_times` (amplitude at least
``min_amplitude_mm`` and above the noise floor); otherwise both times are NaN.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd

from tendrilkit.sequence import ResponseTimes, response_times, shape_change

WINDOW = 0.5


def smooth_step(x: np.ndarray) -> np.ndarray:
    """Quintic smooth step :math:`6x^5 - 15x^4 + 10x^3`, clipped to [0, 1] outside [0, 1]."""
    x = np.clip(np.asarray(x, dtype=float), 0.0, 1.0)
    return x * x * x * (x * (6.0 * x - 15.0) + 10.0)


@dataclass(frozen=True, eq=False)
class ResponseFit:
    """The smooth-step model of a response (module notes).

    Attributes
    ----------
    times : ResponseTimes
        Onset and stabilisation (s after the stimulus) from the model; the
        other fields (amplitude, noise, baseline, plateau) from
        :func:`tendrilkit.sequence.response_times` on :math:`D_0`.
    time_s : (m,) float array
        Times of the ok frames (s, on the table's axis).
    from_first_mm, to_last_mm : (m,) float arrays
        :math:`D_0`, :math:`D_1` de-biased, mm.
    model_first_mm, model_last_mm : (m,) float arrays
        The fitted model at ``time_s`` (NaN when not responded).
    rms_mm : float
        RMS residual of the joint fit, mm.
    """

    times: ResponseTimes
    time_s: np.ndarray
    from_first_mm: np.ndarray
    to_last_mm: np.ndarray
    model_first_mm: np.ndarray
    model_last_mm: np.ndarray
    rms_mm: float


def _debias(y: np.ndarray, b: float) -> np.ndarray:
    """:math:`\\operatorname{sign}(y^2 - b^2)\\sqrt{|y^2 - b^2|}` (0 stays 0: the reference frame)."""
    q = y * y - b * b
    return np.where(y == 0, 0.0, np.sign(q) * np.sqrt(np.abs(q)))


def _best_fits(t: np.ndarray, y: np.ndarray, a: np.ndarray, b: np.ndarray, exponents, falling: bool):
    """Least squares of ``c + A q^p`` for every (start, end) pair and the best ``p`` of ``exponents``.

    Returns (K,) residual sums of squares, exponent indices, offsets c and amplitudes A.
    """
    x = (t[None, :] - a[:, None]) / (b - a)[:, None]
    g0 = smooth_step(x)
    base = 1.0 - g0 if falling else g0
    ym = y.mean()
    yy = float(((y - ym) ** 2).sum())
    best = np.full(len(a), np.inf)
    arg = np.zeros(len(a), int)
    amp = np.zeros(len(a))
    off = np.zeros(len(a))
    for k, p in enumerate(exponents):
        G = base ** p
        gm = G.mean(axis=1, keepdims=True)
        cov = ((G - gm) * (y - ym)).sum(axis=1)
        var = ((G - gm) ** 2).sum(axis=1)
        A = np.where(var > 1e-15, cov / np.maximum(var, 1e-15), 0.0)
        res = yy - A * cov
        better = res < best
        best = np.where(better, res, best)
        arg = np.where(better, k, arg)
        amp = np.where(better, A, amp)
        off = np.where(better, ym - A * gm[:, 0], off)
    return best, arg, off, amp


def fit_response_times(curves: pd.DataFrame, *, frames: pd.DataFrame | None = None, stimulus_s: float = 0.0,
                       grid: int = 120, floor_frames: int = 3, window: float = WINDOW,
                       **threshold_kwargs) -> ResponseFit:
    """Response onset and stabilisation of one experiment by the smooth-step model (module notes).

    Parameters
    ----------
    curves : DataFrame
        ``frame, time_s, point, x_mm, y_mm, z_mm`` (the pipeline's ``curves.csv``).
    frames : DataFrame, optional
        The run's ``frames`` table (failed frames are dropped).
    stimulus_s : float
        Time of the stimulus on the ``time_s`` axis (0: the video starts at it).
    grid : int
        Steps of the (onset, stabilisation) grid over the sequence's duration.
    window : float
        Fraction of each signal's maximum that ends its fitted part.
    floor_frames : int
        Frames after the first used for the noise floor (de-biasing); they must precede the onset.
    **threshold_kwargs
        Passed to :func:`tendrilkit.sequence.response_times`, which decides
        whether the tendril responded (``min_amplitude_mm``, ``noise_k``).

    Returns
    -------
    ResponseFit
    """
    if not 0 < window < 1:
        raise ValueError(f"window must be in (0, 1), got {window}")
    if grid < 4:
        raise ValueError(f"grid must be >= 4, got {grid}")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # frames dropped are reported by shape_change's caller
        first = shape_change(curves, frames=frames)
    nan = float("nan")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the threshold rule's caveats are about its own times
        thr = response_times(first, stimulus_s=stimulus_s, **threshold_kwargs)
    t = first["time_s"].to_numpy(float)
    n = len(t)
    empty = np.full(n, nan)
    if n < 6:
        return ResponseFit(thr, t, empty, empty, empty, empty, nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        last = shape_change(curves, frames=frames, reference_frame=int(first["frame"].iloc[-1]))
    k = max(1, int(floor_frames))
    # the noise floor of a distance between two shapes, measured where nothing moves yet (the first frames
    # after the reference); the frames before the last may still be moving, so the same floor serves both
    raw0 = first["shape_mm"].to_numpy(float)
    floor = float(np.median(raw0[1:1 + k]))
    d0 = _debias(raw0, floor)
    d1 = _debias(last["shape_mm"].to_numpy(float), floor)
    if not thr.responded:
        return ResponseFit(thr, t, d0, d1, empty, empty, nan)
    tt = np.linspace(t[0], t[-1], int(grid) + 1)
    A_, B_ = np.meshgrid(tt, tt, indexing="ij")
    keep = B_ > A_ + 1e-9
    a, b = A_[keep], B_[keep]
    # near its ends a transition is linear in how far it has gone: fit each end on its own part
    early = np.arange(n) <= int(np.argmax(d0 >= window * np.max(d0)))
    late = np.arange(n) >= n - 1 - int(np.argmax(d1[::-1] >= window * np.max(d1)))
    r0, _, c0, a0 = _best_fits(t[early], d0[early], a, b, (1.0,), falling=False)
    r1, _, c1, a1 = _best_fits(t[late], d1[late], a, b, (1.0,), falling=True)
    j0 = int(np.argmin(np.where(a0 > 0, r0, np.inf)))
    j1 = int(np.argmin(np.where(a1 > 0, r1, np.inf)))
    ton, tst = float(a[j0]), float(b[j1])
    m0 = np.where(early, c0[j0] + a0[j0] * smooth_step((t - a[j0]) / (b[j0] - a[j0])), nan)
    m1 = np.where(late, c1[j1] + a1[j1] * (1.0 - smooth_step((t - a[j1]) / (b[j1] - a[j1]))), nan)
    rms = float(np.sqrt((r0[j0] + r1[j1]) / (early.sum() + late.sum())))
    note = f"smooth-step model at both ends (rms {rms:.2g} mm)"
    if tst >= t[-1] - 1e-9:
        note += "; still changing at the last frame: stabilisation is at least the end of the sequence"
    times = ResponseTimes(True, ton - float(stimulus_s), tst - float(stimulus_s), thr.amplitude_mm,
                          thr.baseline_mm, thr.plateau_mm, thr.peak_mm, thr.noise_mm,
                          onset_frame=int(first["frame"].iloc[int(np.searchsorted(t, ton))]) if ton <= t[-1] else -1,
                          stable_frame=int(first["frame"].iloc[min(int(np.searchsorted(t, tst)), n - 1)]),
                          measure="shape_mm", note=note)
    return ResponseFit(times, t, d0, d1, m0, m1, rms)
