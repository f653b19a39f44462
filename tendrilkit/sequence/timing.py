"""Response onset and stabilisation times from a shape-change table.

Paper: the Discussion's response ~3 min / stable ~12 min.

Response times (:func:`response_times`)
    On a shape-change measure :math:`D(t)` of ok frames (default
    ``shape_mm``), median-filtered over ``median_frames`` frames
    (:math:`\\tilde D`; windows shrink at the ends):

    - de-biasing (``debias=True``): a mean of distances to a noisy
      reference never goes down to 0; noise adds in quadrature,
      :math:`D^2 \\approx S^2 + b^2` with :math:`b` the early level, so the
      analysis runs on :math:`\\operatorname{sign}(D^2 - b^2)\\sqrt{|D^2 - b^2|}`
      (small changes are otherwise compressed under the noise floor and the
      onset comes late: +22 s at 0.3 mm point noise on 20 s frames, -2..+3 s
      with de-biasing);
    - noise :math:`\\sigma`: robust standard deviation of the frame-to-frame
      noise, :math:`1.4826\\,\\mathrm{MAD}(\\Delta^2 D)/\\sqrt 6` (second
      differences remove a slow trend);
    - baseline :math:`b`: median of :math:`D` over frames 1..``baseline_frames``
      (frame 0 is the reference, 0 by construction);
    - plateau :math:`P`: median of :math:`\\tilde D` over the last
      ``plateau_frames`` frames; amplitude :math:`A = P - b`;
    - responded: :math:`A \\ge` ``min_amplitude_mm`` (default 2 mm) and
      :math:`A > k\\sigma` (``noise_k`` = 3); otherwise both times are NaN;
    - onset: first time :math:`\\tilde D` exceeds
      :math:`b + \\max(f_{on} A, k\\sigma)`, linearly interpolated between the
      two frames around the crossing;
    - stabilisation: first time after which :math:`|\\tilde D - P|` stays
      within :math:`\\max((1 - f_{st}) A, k\\sigma)` until the end of the
      sequence (interpolated likewise). NaN, with a warning, if the last frame
      is still outside the band.

    Times are ``time_s - stimulus_s`` (``stimulus_s`` = 0: the video starts at
    the stimulus).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy.ndimage import median_filter

from tendrilkit.sequence._common import _checked


@dataclass(frozen=True, eq=False)


class ResponseTimes:
    """When and how much a tendril responded (module notes, "Response times").

    Attributes
    ----------
    responded : bool
    onset_s, stable_s : float
        Response onset and stabilisation, s after ``stimulus_s``; NaN when not
        responded (``stable_s`` also NaN when the sequence ends unsettled).
    amplitude_mm : float
        Plateau minus baseline of the (de-biased) measure, mm: with
        ``debias``, an estimate of the noise-free final change.
    baseline_mm, plateau_mm, peak_mm : float
        Early level, final level and maximum of the measure as given
        (smoothed), mm: the levels to draw over it.
    noise_mm : float
        Robust frame-to-frame noise (standard deviation) of the (de-biased) measure, mm.
    onset_frame, stable_frame : int
        First frame beyond the onset threshold / first frame of the final band (-1 if none).
    measure : str
        Column of the shape-change table used.
    note : str
        Why not responded, or a caveat ("" otherwise).
    """

    responded: bool
    onset_s: float
    stable_s: float
    amplitude_mm: float
    baseline_mm: float
    plateau_mm: float
    peak_mm: float
    noise_mm: float
    onset_frame: int = -1
    stable_frame: int = -1
    measure: str = "shape_mm"
    note: str = ""


def running_median(y: np.ndarray, width: int) -> np.ndarray:
    """Median over ``width`` samples centred on each sample; the window shrinks at the ends.

    The first and last samples take the median of the three end samples.
    Unlike padding with the end values, a single outlier in the last (or
    first) sample does not survive the filter.
    """
    y = np.asarray(y, dtype=float)
    h = int(width) // 2
    if h < 1 or y.size < 3:
        return y.copy()
    out = median_filter(y, size=2 * h + 1, mode="nearest")
    n = y.size
    for i in sorted(set(range(min(h, n))) | set(range(max(n - h, 0), n))):
        k = min(i, n - 1 - i, h)
        if k > 0:
            out[i] = np.median(y[i - k:i + k + 1])
        else:  # the first / last sample: median of the three end samples
            out[i] = np.median(y[:3]) if i == 0 else np.median(y[-3:])
    return out


def _crossing(t0, t1, y0, y1, level):
    if not np.isfinite(y0) or y1 == y0:
        return float(t1)
    w = float(np.clip((level - y0) / (y1 - y0), 0.0, 1.0))
    return float(t0 + w * (t1 - t0))


def response_times(
    change: pd.DataFrame,
    *,
    measure: str = "shape_mm",
    onset_fraction: float = 0.1,
    stable_fraction: float = 0.9,
    median_frames: int | None = None,
    baseline_frames: int | None = None,
    plateau_frames: int | None = None,
    noise_k: float = 3.0,
    min_amplitude_mm: float = 2.0,
    stimulus_s: float = 0.0,
    debias: bool = True,
) -> ResponseTimes:
    """Response onset and stabilisation times from a :func:`shape_change` table.

    Parameters
    ----------
    change : DataFrame
        ``time_s`` and the ``measure`` column (mm), one row per kept frame;
        NaN rows are dropped.
    measure : str
        ``shape_mm`` (default: change of shape, rigid motion removed),
        ``mean_mm`` (motion), ``tip_displacement_mm``, ...
    onset_fraction : float
        Fraction of the amplitude that marks the onset (default 0.1).
    stable_fraction : float
        The measure is stable once it stays within ``(1 - stable_fraction)``
        of the amplitude around the plateau (default 0.9: within 10 %).
    median_frames : int, optional
        Width of the median filter (frames; 1 = none). Default: 5, at most a
        quarter of the sequence (odd).
    baseline_frames, plateau_frames : int, optional
        Frames used for the baseline (after the reference frame) and the
        plateau. Default: 5, at most an eighth of the sequence (at least 1),
        so that a short sequence is not all baseline and plateau.
    noise_k : float
        Thresholds are at least ``noise_k`` noise standard deviations.
    min_amplitude_mm : float
        Below this amplitude the tendril is reported as not responding
        (default 2 mm, about a tenth of a tendril's typical bending
        displacement, several times the reconstruction noise).
    stimulus_s : float
        Time of the stimulus on the ``time_s`` axis.
    debias : bool
        Remove the noise floor in quadrature before anything else (module
        notes); False: use the measure as it is.

    Returns
    -------
    ResponseTimes
    """
    for name, v in (("onset_fraction", onset_fraction), ("stable_fraction", stable_fraction)):
        if not 0 < v < 1:
            raise ValueError(f"{name} must be in (0, 1), got {v}")
    for name, v in (("median_frames", median_frames), ("baseline_frames", baseline_frames),
                    ("plateau_frames", plateau_frames)):
        if v is not None and int(v) < 1:
            raise ValueError(f"{name} must be >= 1, got {v}")
    c = _checked(change, ("time_s", measure), "change")
    c = c[np.isfinite(c[measure].to_numpy(float)) & np.isfinite(c["time_s"].to_numpy(float))]
    c = c.sort_values("time_s", kind="stable")
    t = c["time_s"].to_numpy(float) - float(stimulus_s)
    y = c[measure].to_numpy(float)
    fr = c["frame"].to_numpy(int) if "frame" in c.columns else np.arange(len(c))
    n = len(y)
    nan = float("nan")
    if n < 3:
        return ResponseTimes(False, nan, nan, nan, nan, nan, nan, nan, measure=measure,
                             note=f"only {n} frame(s)")
    if median_frames is None:
        median_frames = max(1, min(5, n // 4) | 1)
    if baseline_frames is None:
        baseline_frames = max(1, min(5, n // 8))
    if plateau_frames is None:
        plateau_frames = max(1, min(5, n // 8))
    raw_baseline = float(np.median(y[1:1 + int(baseline_frames)]))
    raw_smooth = running_median(y, int(median_frames))
    raw_plateau = float(np.median(raw_smooth[-int(plateau_frames):]))
    raw_peak = float(raw_smooth.max())
    if debias and raw_baseline > 0:
        # noise adds in quadrature to a mean of distances: D^2 ~ S^2 + b^2
        q = y * y - raw_baseline ** 2
        y = np.where(y == 0, 0.0, np.sign(q) * np.sqrt(np.abs(q)))
    ys = running_median(y, int(median_frames))
    d2 = np.diff(y, 2)
    noise = float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / np.sqrt(6.0)) if d2.size else 0.0
    baseline = float(np.median(y[1:1 + int(baseline_frames)]))
    plateau = float(np.median(ys[-int(plateau_frames):]))
    amplitude = plateau - baseline
    peak = float(ys.max())
    floor = noise_k * noise
    if not (amplitude >= min_amplitude_mm and amplitude > floor):
        why = (f"amplitude {amplitude:.3g} mm below the floor max({min_amplitude_mm:g} mm, "
               f"{noise_k:g} x noise {noise:.3g} mm)")
        if peak - baseline >= min_amplitude_mm and peak - baseline > floor:
            why += f"; transient change up to {peak - baseline:.3g} mm that did not last"
        return ResponseTimes(False, nan, nan, amplitude, raw_baseline, raw_plateau, raw_peak, noise,
                             measure=measure, note=why)
    on_level = baseline + max(onset_fraction * amplitude, floor)
    above = np.flatnonzero(ys > on_level)
    i = int(above[0])
    onset = float(t[0]) if i == 0 else _crossing(t[i - 1], t[i], ys[i - 1], ys[i], on_level)
    tol = max((1.0 - stable_fraction) * amplitude, floor)
    outside = np.flatnonzero(np.abs(ys - plateau) > tol)
    note = ""
    if outside.size == 0:
        j, stable = 0, float(t[0])
    elif outside[-1] == n - 1:
        j, stable = -1, nan
        note = "the sequence ends before the change settles"
        warnings.warn(f"response_times: {note}", UserWarning, stacklevel=2)
    else:
        k = int(outside[-1])
        j = k + 1
        level = plateau + tol if ys[k] > plateau else plateau - tol
        stable = _crossing(t[k], t[j], ys[k], ys[j], level)
    if j >= 0 and j >= n - int(plateau_frames):
        note = "stabilises within the plateau window: the sequence may be too short"
        warnings.warn(f"response_times: {note}", UserWarning, stacklevel=2)
    return ResponseTimes(True, onset, stable, amplitude, raw_baseline, raw_plateau, raw_peak, noise,
                         onset_frame=int(fr[i]), stable_frame=int(fr[j]) if j >= 0 else -1,
                         measure=measure, note=note)
