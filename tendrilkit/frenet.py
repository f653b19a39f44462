"""Smoothing, Frenet frames, curvature, torsion and the integration of a frame.

Paper: "Discrete Frenet-Serrat Point Fitting" and "Three-dimensional
Reconstruction" (Fan et al., IJCV 2025). Stage 7 of ``../shared/REFERENCE_NOTES.md``.

The chain is

1. :func:`resample_curve`: repeated points are dropped and the polyline is
   resampled at uniform chord length (PCHIP, as the reference does);
2. :func:`tendrilkit.geometry.whittaker_smooth`: a second-order Whittaker smoother on x, y, z whose
   strength is a *length in mm* (see below), not a bare lambda;
3. :func:`frenet_frames`: arc length of the smoothed curve, T, N, B, curvature
   and torsion from its derivatives, and a flag where torsion is undefined;
4. :func:`integrate_frenet`: the inverse, rebuilding a curve from curvature and
   torsion laws and an initial frame (exact rotation per step about the
   Darboux vector, step-mean curvature and torsion: second order; positions by
   the paper's trapezoidal rule or the exact integral of the rotating tangent).

Smoothing strength
------------------
The second-order Whittaker smoother solves
:math:`(I + \\lambda D_2^T D_2) z = y` on points a distance :math:`h` apart. Its
gain at wavelength :math:`\\ell` is :math:`1 / (1 + \\lambda (2 \\sin(\\pi h /
\\ell))^4) \\approx 1 / (1 + \\lambda (2\\pi h/\\ell)^4)`. tendrilkit sets

.. math:: \\lambda = \\left(\\frac{L_s}{2 \\pi h}\\right)^4

so that ``length_mm`` :math:`= L_s` is the wavelength passed at half gain:
features shorter than :math:`L_s` are smoothed away, longer ones kept (a coil
of wavelength :math:`3 L_s` keeps 99 % of its amplitude). The value does not
depend on the number of points. (The reference's fixed :math:`\\lambda = 10^4`
on 200 points of a 150 mm tendril corresponds to :math:`L_s \\approx 47` mm.)
Both ends are padded by a local cubic extrapolation before smoothing, so the
smoother does not straighten them. By default :math:`L_s` is chosen per curve
(:func:`auto_smoothing_length_mm`): 20 mm at 0.15 mm of noise, growing as
:math:`\\sigma^{0.4}` with the noise estimated from third differences
(:func:`noise_sigma_mm`), capped below the coil wavelength.

Curvature and torsion
---------------------
From the derivatives of the smoothed curve with respect to its arc length
(second-order finite differences),

.. math::

    \\kappa = \\frac{|r' \\times r''|}{|r'|^3}, \\qquad
    \\tau = \\frac{(r' \\times r'') \\cdot r'''}{|r' \\times r''|^2}.

The paper's discrete formulas (:math:`\\kappa_i = |T_i - T_{i-1}|`) omit the
step length and define torsion as a vector; the continuous formulas above are
their intended limit. Torsion is undefined where :math:`\\kappa \\to 0` (the
normal has no direction); those samples are flagged (``tau_defined`` false),
their torsion set to 0, and the piece-wise fit weights torsion by
:math:`\\kappa^2` (the sensitivity of the shape to torsion), so an
ill-defined torsion cannot wreck the fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from tendrilkit.exceptions import DegenerateCurveError
from tendrilkit.geometry import arc_length, check_points, resample_polyline, whittaker_smooth

__all__ = [
    "FrenetFrames",
    "resample_curve",
    "whittaker_lambda",
    "frenet_frames",
    "integrate_frenet",
    "noise_sigma_mm",
    "auto_smoothing_length_mm",
]


def resample_curve(points_mm: np.ndarray, n: int | None = None, *, min_points: int = 5) -> np.ndarray:
    """Drop repeated points and resample a polyline at uniform chord length.

    Parameters
    ----------
    points_mm : (m, 3) float array
        Ordered points, base to tip, mm.
    n : int, optional
        Number of output points (default: ``m``).
    min_points : int
        Fewest distinct points accepted.

    Returns
    -------
    (n, 3) float array
        Points equally spaced along the chord length (PCHIP interpolation).

    Raises
    ------
    DegenerateCurveError
        Fewer than ``min_points`` distinct points, or zero length.
    """
    pts = check_points(points_mm, dim=3, name="points_mm")
    return resample_polyline(pts, n, method="pchip", min_points=min_points, repeat_tol=1e-9)


def whittaker_lambda(length_mm: float, spacing_mm: float) -> float:
    """Second-order Whittaker lambda whose half-gain wavelength is ``length_mm``.

    :math:`\\lambda = (L_s / (2 \\pi h))^4` for points ``spacing_mm`` apart
    (see the module notes). ``length_mm = 0`` gives no smoothing.
    """
    if not length_mm >= 0:
        raise ValueError(f"length_mm must be >= 0, got {length_mm}")
    if not spacing_mm > 0:
        raise ValueError(f"spacing_mm must be > 0, got {spacing_mm}")
    return float((length_mm / (2.0 * np.pi * spacing_mm)) ** 4)


def _extrapolate(end: np.ndarray, m_fit: int, m_pad: int) -> np.ndarray:
    """``m_pad`` points continuing ``end[0]`` backwards: a local cubic in the sample index."""
    k = np.arange(m_fit, dtype=float)
    deg = min(3, m_fit - 1)
    V = np.vander(k, deg + 1)
    coef, *_ = np.linalg.lstsq(V, end[:m_fit], rcond=None)
    kp = -np.arange(m_pad, 0, -1, dtype=float)
    return np.vander(kp, deg + 1) @ coef


def _smooth_padded(data: np.ndarray, lam: float, length_mm: float, h: float) -> np.ndarray:
    """Whittaker smoothing with both ends padded by a local polynomial extrapolation.

    A second-order Whittaker smoother straightens the curve near its ends (its
    natural boundary condition is zero second derivative), which would drive
    the curvature to zero over the last ``length_mm``. The curve is extended
    by ``length_mm`` at each end with a cubic fitted to its first/last
    ``1.5 length_mm``, smoothed, and the padding dropped.
    """
    if lam == 0:
        return data.copy()
    m = data.shape[0]
    m_pad = int(min(np.ceil(length_mm / h), 4 * m))
    m_fit = int(min(max(np.ceil(1.5 * length_mm / h), 6), m))
    if m_pad < 1 or m_fit < 4:
        return whittaker_smooth(data, lam=lam)
    head = _extrapolate(data, m_fit, m_pad)
    tail = _extrapolate(data[::-1], m_fit, m_pad)[::-1]
    z = whittaker_smooth(np.vstack([head, data, tail]), lam=lam)
    return z[m_pad:m_pad + m]


@dataclass(frozen=True, eq=False)
class FrenetFrames:
    """Discrete Frenet description of a smoothed curve.

    Attributes
    ----------
    data_mm : (n, 3) float array
        The input resampled at uniform chord length (the data every score is measured against).
    smooth_mm : (n, 3) float array
        ``data_mm`` after Whittaker smoothing.
    s_mm : (n,) float array
        Arc length of ``smooth_mm`` from the base, mm.
    T, N, B : (n, 3) float arrays
        Unit tangent, normal and binormal. Where ``tau_defined`` is false the
        normal is carried over from the nearest defined sample (or chosen
        perpendicular to T), so the frame stays right-handed and orthonormal.
    kappa : (n,) float array
        Curvature, 1/mm (>= 0).
    tau : (n,) float array
        Torsion, 1/mm; 0 where undefined.
    tau_defined : (n,) bool array
        False where curvature is below ``kappa_floor`` (torsion undefined).
    kappa_floor : float
        The curvature threshold used, 1/mm.
    smoothing_length_mm : float
        Half-gain wavelength of the smoother, mm.
    lam : float
        The Whittaker lambda it corresponds to.
    """

    data_mm: np.ndarray
    smooth_mm: np.ndarray
    s_mm: np.ndarray
    T: np.ndarray
    N: np.ndarray
    B: np.ndarray
    kappa: np.ndarray
    tau: np.ndarray
    tau_defined: np.ndarray
    kappa_floor: float
    smoothing_length_mm: float
    lam: float

    @property
    def length_mm(self) -> float:
        return float(self.s_mm[-1])


def _perpendicular(t: np.ndarray) -> np.ndarray:
    a = np.zeros(3)
    a[int(np.argmin(np.abs(t)))] = 1.0
    v = a - (a @ t) * t
    return v / np.linalg.norm(v)


def noise_sigma_mm(points_mm: np.ndarray) -> float:
    """Robust estimate of the per-coordinate noise of a sampled curve, mm.

    From third differences of the points as given, assumed about evenly
    spaced (a smooth curve's third differences are :math:`O(h^3)`; white noise of
    standard deviation :math:`\\sigma` gives variance :math:`20\\sigma^2`):
    :math:`\\hat\\sigma = 1.4826\\,\\mathrm{median}|\\Delta^3 x| / \\sqrt{20}`.
    """
    data = check_points(points_mm, dim=3, name="points_mm")
    step = np.linalg.norm(np.diff(data, axis=0), axis=1)
    if data.shape[0]:
        data = data[np.concatenate([[True], step > 1e-9 * max(step.sum(), 1e-300)])]
    if data.shape[0] < 8:
        raise DegenerateCurveError(f"curve has {data.shape[0]} distinct points; at least 8 are needed to estimate noise")
    d3 = np.diff(data, 3, axis=0)
    return float(1.4826 * np.median(np.abs(d3)) / np.sqrt(20.0))


def auto_smoothing_length_mm(points_mm: np.ndarray, *, reference_mm: float = 20.0,
                             reference_noise_mm: float = 0.15) -> float:
    """A smoothing length for :func:`frenet_frames` from the curve's noise and coiling.

    ``reference_mm`` suits ``reference_noise_mm`` of noise (tuned on 120-200 mm
    piece-wise clothoids, 200 points); the length grows as
    :math:`\\sigma^{0.4}` (the curvature's noise after smoothing falls as
    :math:`L_s^{-5/2}`) and is capped at 0.6 of the shortest coil wavelength
    :math:`2\\pi / \\sqrt{\\kappa^2 + \\tau^2}` (median), where the
    smoother keeps 89 % of the coil's curvature; clipped to [4 h, L / 3].
    """
    return _auto_smoothing(points_mm, reference_mm, reference_noise_mm, of_resampled=True)[0]


def _auto_smoothing(points_mm, reference_mm=20.0, reference_noise_mm=0.15, of_resampled=False, with_noise=False):
    """:func:`auto_smoothing_length_mm` and the frames it computed with that length (or ``None``).

    ``of_resampled``: the coiling is measured on the frames of ``points_mm``
    resampled once more, as :func:`auto_smoothing_length_mm` does; otherwise
    on ``frenet_frames(points_mm, smoothing_length_mm=length)`` itself, which
    is then returned so that callers need not smooth again. ``with_noise``: also
    :func:`noise_sigma_mm` of ``points_mm`` (mm), which it computed (the piece-wise fit's
    retry rule reads it too).
    """
    data = resample_curve(points_mm)
    L = float(arc_length(data)[-1])
    h = L / (data.shape[0] - 1)
    sigma = noise_sigma_mm(points_mm)
    Ls = reference_mm * (max(sigma, 1e-6) / reference_noise_mm) ** 0.4
    Ls = float(np.clip(Ls, 4 * h, L / 3))
    # the points frenet_frames would resample (those of points_mm are data: not resampled again)
    pts = resample_curve(data) if of_resampled else data
    for _ in range(2):
        fr = _frames_of(pts, Ls, None, None if of_resampled else h)
        w = np.median(np.hypot(fr.kappa, fr.tau * fr.tau_defined))
        cap = 0.6 * 2 * np.pi / w if w > 0 else np.inf
        if Ls <= cap:
            return (Ls, fr, sigma) if with_noise else (Ls, fr)
        Ls = float(np.clip(cap, 4 * h, L / 3))
    return (Ls, None, sigma) if with_noise else (Ls, None)


def frenet_frames(
    points_mm: np.ndarray,
    *,
    smoothing_length_mm: float | None = None,
    n: int | None = None,
    kappa_floor: float | None = None,
) -> FrenetFrames:
    """Resample, smooth, and compute T, N, B, curvature and torsion.

    Parameters
    ----------
    points_mm : (m, 3) float array
        Ordered centreline, base to tip, mm.
    smoothing_length_mm : float, optional, keyword-only
        Half-gain wavelength of the second-order Whittaker smoother, mm
        (module notes). 0: no smoothing; ``None``: chosen from the curve's
        noise and coiling (:func:`auto_smoothing_length_mm`).
    n : int, optional
        Number of resampled points (default: ``m``).
    kappa_floor : float, optional
        Curvature (1/mm) below which torsion is flagged undefined. Default:
        5 % of the 95th percentile of the curvature along the curve, and at
        least :math:`10^{-3}` rad per curve length.

    Returns
    -------
    FrenetFrames

    Raises
    ------
    DegenerateCurveError
        Fewer than 5 distinct points or zero length.
    """
    if smoothing_length_mm is None:
        smoothing_length_mm = auto_smoothing_length_mm(points_mm)
    return _frames_of(resample_curve(points_mm, n), smoothing_length_mm, kappa_floor)


@njit(cache=True)
def _gradient_rows(f, s, uniform, out):
    """``np.gradient(f, s, axis=0, edge_order=2)`` of an (n, 3) ``f`` (n >= 3) into ``out``: numpy's
    formulas and order of operations, element by element (the same bits); ``uniform``: numpy's
    branch for equal steps (every ``s[i + 1] - s[i]`` equal to the first)."""
    n = f.shape[0]
    if uniform:
        dx = s[1] - s[0]
        for i in range(1, n - 1):
            for c in range(3):
                out[i, c] = (f[i + 1, c] - f[i - 1, c]) / (2.0 * dx)
        a0, b0, c0 = -1.5 / dx, 2.0 / dx, -0.5 / dx
        a1, b1, c1 = 0.5 / dx, -2.0 / dx, 1.5 / dx
    else:
        for i in range(1, n - 1):
            dx1 = s[i] - s[i - 1]
            dx2 = s[i + 1] - s[i]
            a = -dx2 / (dx1 * (dx1 + dx2))
            b = (dx2 - dx1) / (dx1 * dx2)
            cc = dx1 / (dx2 * (dx1 + dx2))
            for c in range(3):
                out[i, c] = a * f[i - 1, c] + b * f[i, c] + cc * f[i + 1, c]
        dx1 = s[1] - s[0]
        dx2 = s[2] - s[1]
        a0 = -(2.0 * dx1 + dx2) / (dx1 * (dx1 + dx2))
        b0 = (dx1 + dx2) / (dx1 * dx2)
        c0 = -dx1 / (dx2 * (dx1 + dx2))
        dx1 = s[n - 2] - s[n - 3]
        dx2 = s[n - 1] - s[n - 2]
        a1 = dx2 / (dx1 * (dx1 + dx2))
        b1 = -(dx2 + dx1) / (dx1 * dx2)
        c1 = (2.0 * dx2 + dx1) / (dx2 * (dx1 + dx2))
    for c in range(3):
        out[0, c] = a0 * f[0, c] + b0 * f[1, c] + c0 * f[2, c]
        out[n - 1, c] = a1 * f[n - 3, c] + b1 * f[n - 2, c] + c1 * f[n - 1, c]


@njit(cache=True)
def _curve_derivatives(z):
    """The arc length of the (n, 3) curve ``z`` and its first three derivatives with respect to it.

    Returns ``s, d1, d2, d3, sp, T, cr, crn``: :func:`tendrilkit.geometry.arc_length`, three
    ``np.gradient(., s, axis=0, edge_order=2)``, the speed ``|d1|``, the tangent ``d1 / sp``,
    ``d1 x d2`` (``np.cross``) and its norm, in numpy's order of operations (a row's norm summed left to
    right, as ``np.linalg.norm(., axis=1)`` does): the same bits as those numpy steps, in one call
    instead of about forty (they were half the time of a curve's frames). ``d1`` etc. are left
    undefined (empty) when the steps are not all positive: the caller raises.
    """
    n = z.shape[0]
    s = np.empty(n)
    s[0] = 0.0
    for i in range(n - 1):
        e0 = z[i + 1, 0] - z[i, 0]
        e1 = z[i + 1, 1] - z[i, 1]
        e2 = z[i + 1, 2] - z[i, 2]
        v = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        s[i + 1] = v if i == 0 else s[i] + v
    d1 = np.empty((n, 3))
    d2 = np.empty((n, 3))
    d3 = np.empty((n, 3))
    sp = np.empty(n)
    T = np.empty((n, 3))
    cr = np.empty((n, 3))
    crn = np.empty(n)
    ok = s[n - 1] > 0
    for i in range(n - 1):
        if not s[i + 1] - s[i] > 0:
            ok = False
    if not ok or n < 3:
        return s, d1, d2, d3, sp, T, cr, crn, False
    h0 = s[1] - s[0]
    uniform = True
    for i in range(1, n - 1):
        if s[i + 1] - s[i] != h0:
            uniform = False
            break
    _gradient_rows(z, s, uniform, d1)
    _gradient_rows(d1, s, uniform, d2)
    _gradient_rows(d2, s, uniform, d3)
    for i in range(n):
        a0, a1, a2 = d1[i, 0], d1[i, 1], d1[i, 2]
        b0, b1, b2 = d2[i, 0], d2[i, 1], d2[i, 2]
        v = np.sqrt(a0 * a0 + a1 * a1 + a2 * a2)
        sp[i] = v
        T[i, 0] = a0 / v
        T[i, 1] = a1 / v
        T[i, 2] = a2 / v
        c0 = a1 * b2 - a2 * b1
        c1 = a2 * b0 - a0 * b2
        c2 = a0 * b1 - a1 * b0
        cr[i, 0] = c0
        cr[i, 1] = c1
        cr[i, 2] = c2
        crn[i] = np.sqrt(c0 * c0 + c1 * c1 + c2 * c2)
    return s, d1, d2, d3, sp, T, cr, crn, True


@njit(cache=True)
def _torsion_normals(defined, cr_d3, crn, d2, T, d2_T):
    """Torsion, the unit normals where ``defined`` (0 elsewhere) and the binormals ``T x N``, as numpy made them.

    ``cr_d3``: :math:`(r' \\times r'') \\cdot r'''` on the defined rows (in order); ``d2_T``:
    :math:`r'' \\cdot T` on every row. Torsion ``cr_d3 / |r' \\times r''|^2``; the normal
    :math:`r'' - (r'' \\cdot T) T` divided by its norm (summed left to right, as
    ``np.linalg.norm(., axis=1)``), the binormal in ``np.cross``'s order: the same bits as those
    numpy steps. (One compiled call: each loads its cache at a process's start, about 3 ms.)
    """
    n = T.shape[0]
    tau = np.zeros(n)
    N = np.zeros((n, 3))
    B = np.empty((n, 3))
    k = 0
    for i in range(n):
        if not defined[i]:
            continue
        tau[i] = cr_d3[k] / (crn[i] * crn[i])
        k += 1
        e = d2_T[i]
        v0 = d2[i, 0] - e * T[i, 0]
        v1 = d2[i, 1] - e * T[i, 1]
        v2 = d2[i, 2] - e * T[i, 2]
        nn = np.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
        N[i, 0] = v0 / nn
        N[i, 1] = v1 / nn
        N[i, 2] = v2 / nn
    for i in range(n):
        B[i, 0] = T[i, 1] * N[i, 2] - T[i, 2] * N[i, 1]
        B[i, 1] = T[i, 2] * N[i, 0] - T[i, 0] * N[i, 2]
        B[i, 2] = T[i, 0] * N[i, 1] - T[i, 1] * N[i, 0]
    return tau, N, B


def _frames_of(data: np.ndarray, smoothing_length_mm: float, kappa_floor: float | None,
               h: float | None = None) -> FrenetFrames:
    """:func:`frenet_frames` of points already resampled (``data``, :func:`resample_curve`'s); ``h``:
    their mean spacing (mm), if the caller has it."""
    m = data.shape[0]
    if h is None:
        h = arc_length(data)[-1] / (m - 1)
    lam = whittaker_lambda(smoothing_length_mm, h)
    z = _smooth_padded(data, lam, smoothing_length_mm, h)
    s, d1, d2, d3, sp, T, cr, crn, ok = _curve_derivatives(np.ascontiguousarray(z, dtype=float))
    if not ok:
        if not s[-1] > 0 or np.any(np.diff(s) <= 0):
            raise DegenerateCurveError("smoothed curve has repeated points; reduce smoothing_length_mm")
        raise ValueError("Shape of array too small to calculate a numerical gradient, "
                         "at least (edge_order + 1) elements are required.")  # numpy's message, as before
    kappa = crn / sp**3  # numpy's power (not a compiled one: its last bits differ)
    length = float(s[-1])
    if kappa_floor is None:
        kappa_floor = max(0.05 * float(np.percentile(kappa, 95)), 1e-3 / length)
    defined = kappa > kappa_floor
    # normal: r'' minus its tangential part; carried over where undefined. The dot products by
    # numpy's einsum (its order of summation is its own), the rest compiled
    tau, N, B = _torsion_normals(defined, np.einsum("ij,ij->i", cr[defined], d3[defined]), crn, d2, T,
                                 np.einsum("ij,ij->i", d2, T))
    undefined = ~defined
    if undefined.any():  # normals carried over there, and their binormals made again
        if defined.any():
            idx = np.flatnonzero(defined)
            nearest = idx[np.clip(np.searchsorted(idx, np.arange(m)), 0, idx.size - 1)]
            for i in np.flatnonzero(undefined):
                v = N[nearest[i]] - (N[nearest[i]] @ T[i]) * T[i]
                N[i] = v / np.linalg.norm(v) if np.linalg.norm(v) > 1e-9 else _perpendicular(T[i])
        else:
            p = _perpendicular(T[0])
            for i in range(m):
                v = p - (p @ T[i]) * T[i]
                N[i] = v / np.linalg.norm(v) if np.linalg.norm(v) > 1e-9 else _perpendicular(T[i])
        B[undefined] = np.cross(T[undefined], N[undefined])
    return FrenetFrames(
        data_mm=data, smooth_mm=z, s_mm=s, T=T, N=N, B=B, kappa=kappa, tau=tau,
        tau_defined=defined, kappa_floor=float(kappa_floor),
        smoothing_length_mm=float(smoothing_length_mm), lam=lam,
    )


@njit(cache=True)
def _integrate(s, k_step, t_step, F0, p0, exact_positions):
    """(P, T, N, B) from the frame ``F0`` (rows T, N, B) at ``p0``, the step values ``k_step``, ``t_step``.

    A step's rotation about the Darboux vector is, in the frame's own axes, a rotation about
    :math:`(\\tau, 0, \\kappa) / |\\omega|` that does not depend on the frame: its nine numbers
    are computed apart from the chain of frames, and each frame is the previous one times them (no
    renormalisation: the frame drifts from orthonormal by about 1e-15 over 200 steps). Positions by
    the trapezoid rule on the tangents, or (``exact_positions``) the integral of the rotating
    tangent over the step.
    """
    n = s.shape[0]
    T = np.empty((n, 3))
    N = np.empty((n, 3))
    B = np.empty((n, 3))
    P = np.empty((n, 3))
    t0, t1, t2 = F0[0, 0], F0[0, 1], F0[0, 2]
    n0, n1, n2 = F0[1, 0], F0[1, 1], F0[1, 2]
    b0, b1, b2 = F0[2, 0], F0[2, 1], F0[2, 2]
    p0_, p1_, p2_ = p0[0], p0[1], p0[2]
    T[0, 0], T[0, 1], T[0, 2] = t0, t1, t2
    N[0, 0], N[0, 1], N[0, 2] = n0, n1, n2
    B[0, 0], B[0, 1], B[0, 2] = b0, b1, b2
    P[0, 0], P[0, 1], P[0, 2] = p0_, p1_, p2_
    for i in range(n - 1):
        h = s[i + 1] - s[i]
        k = k_step[i]
        t = t_step[i]
        rate = np.sqrt(k * k + t * t)
        th = rate * h
        if th < 1e-12:
            a00, a01, a02, a10, a11, a12, a20, a21, a22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0
            dt, dn, db = h, 0.0, 0.0
        else:  # Rodrigues about the unit axis (ax, 0, az) in the frame's axes
            ax = t / rate
            az = k / rate
            ct = np.cos(th)
            st = np.sin(th)
            u = 1.0 - ct
            a00, a01, a02 = ct + ax * ax * u, az * st, ax * az * u
            a10, a11, a12 = -az * st, ct, ax * st
            a20, a21, a22 = ax * az * u, -ax * st, ct + az * az * u
            # the rotating tangent's integral over the step, in the frame's axes
            a3 = h - st / rate
            dt, dn, db = st / rate + a3 * ax * ax, u / rate * az, a3 * ax * az
        u0 = a00 * t0 + a01 * n0 + a02 * b0
        u1 = a00 * t1 + a01 * n1 + a02 * b1
        u2 = a00 * t2 + a01 * n2 + a02 * b2
        m0 = a10 * t0 + a11 * n0 + a12 * b0
        m1 = a10 * t1 + a11 * n1 + a12 * b1
        m2 = a10 * t2 + a11 * n2 + a12 * b2
        c0 = a20 * t0 + a21 * n0 + a22 * b0
        c1 = a20 * t1 + a21 * n1 + a22 * b1
        c2 = a20 * t2 + a21 * n2 + a22 * b2
        if exact_positions or th < 1e-12:
            p0_ += dt * t0 + dn * n0 + db * b0
            p1_ += dt * t1 + dn * n1 + db * b1
            p2_ += dt * t2 + dn * n2 + db * b2
        else:
            p0_ += 0.5 * h * (t0 + u0)
            p1_ += 0.5 * h * (t1 + u1)
            p2_ += 0.5 * h * (t2 + u2)
        t0, t1, t2, n0, n1, n2, b0, b1, b2 = u0, u1, u2, m0, m1, m2, c0, c1, c2
        T[i + 1, 0], T[i + 1, 1], T[i + 1, 2] = t0, t1, t2
        N[i + 1, 0], N[i + 1, 1], N[i + 1, 2] = n0, n1, n2
        B[i + 1, 0], B[i + 1, 1], B[i + 1, 2] = b0, b1, b2
        P[i + 1, 0], P[i + 1, 1], P[i + 1, 2] = p0_, p1_, p2_
    return P, T, N, B


def integrate_frenet(
    s_mm: np.ndarray,
    kappa: np.ndarray,
    tau: np.ndarray,
    T0: np.ndarray,
    N0: np.ndarray,
    B0: np.ndarray,
    p0: np.ndarray,
    *,
    step_values: bool = False,
    positions: str = "trapezoid",
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Rebuild a curve from curvature and torsion by integrating its Frenet frame.

    Parameters
    ----------
    s_mm : (n,) float array
        Increasing arc lengths, mm.
    kappa, tau : (n,) float arrays, or (n - 1,) with ``step_values``
        Curvature and torsion, 1/mm, at the samples (each step then uses the
        mean of its two ends, the midpoint value of a linear law), or, with
        ``step_values=True``, the mean value over each step.
    T0, N0, B0 : (3,) float arrays
        Initial frame (orthonormal, right-handed; re-orthonormalised here).
    p0 : (3,) float array
        Initial point, mm.
    step_values : bool, keyword-only
        See ``kappa``.
    positions : {"trapezoid", "exact"}, keyword-only
        ``trapezoid``: the paper's :math:`P_{i+1} = P_i + h (T_i + T_{i+1})/2`;
        ``exact``: the integral of the tangent over the step's rotation.

    Returns
    -------
    P, T, N, B : (n, 3) float arrays
        Points (mm) and frames.

    Notes
    -----
    Over a step of length :math:`h` with constant :math:`\\kappa, \\tau` the
    Frenet equations rotate the frame about the Darboux vector
    :math:`\\omega = \\tau T + \\kappa B` by the angle :math:`h|\\omega|`; each
    step applies that rotation exactly (Rodrigues' formula). With the
    midpoint (step-mean) values this is a second-order, norm-preserving
    integrator; the frame stays orthonormal to rounding. The paper's series
    update is the Taylor expansion of the same rotation (with three wrong
    coefficients in the reference, ``REFERENCE_NOTES.md``).

    Examples
    --------
    A circle of radius 10 mm:

    >>> s = np.linspace(0, 2 * np.pi * 10, 2001)
    >>> P, T, N, B = integrate_frenet(s, np.full(2001, 0.1), np.zeros(2001),
    ...     [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0])
    >>> bool(np.abs(P[-1]).max() < 1e-3)
    True
    """
    s = np.asarray(s_mm, dtype=float)
    if s.ndim != 1 or s.size < 2:
        raise ValueError(f"s_mm must have shape (n,) with n >= 2, got {s.shape}")
    if not np.all(np.isfinite(s)):
        raise ValueError("s_mm must be finite (no NaN or inf)")
    if np.any(np.diff(s) <= 0):
        raise ValueError("s_mm must be strictly increasing")
    k = np.asarray(kappa, dtype=float)
    t = np.asarray(tau, dtype=float)
    want = s.size - 1 if step_values else s.size
    for name, a in (("kappa", k), ("tau", t)):
        if a.shape != (want,):
            raise ValueError(f"{name} must have shape ({want},), got {a.shape}")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name} must be finite, got {int((~np.isfinite(a)).sum())} NaN or inf values")
    if not step_values:
        k = 0.5 * (k[1:] + k[:-1])
        t = 0.5 * (t[1:] + t[:-1])
    if positions not in ("trapezoid", "exact"):
        raise ValueError(f"positions must be 'trapezoid' or 'exact', got {positions!r}")
    F0 = _orthonormal_frame(T0, N0, B0)
    p = np.asarray(p0, dtype=float).reshape(3)
    return _integrate(s, np.ascontiguousarray(k), np.ascontiguousarray(t), F0, p, positions == "exact")


def _orthonormal_frame(T0, N0, B0) -> np.ndarray:
    T = np.asarray(T0, dtype=float).reshape(3)
    N = np.asarray(N0, dtype=float).reshape(3)
    if not np.linalg.norm(T) > 0:
        raise ValueError("T0 must be non-zero")
    T = T / np.linalg.norm(T)
    N = N - (N @ T) * T
    if np.linalg.norm(N) < 1e-9:
        N = _perpendicular(T)
    N = N / np.linalg.norm(N)
    B = np.cross(T, N)
    if np.asarray(B0, dtype=float).reshape(3) @ B < 0:
        # a left-handed input frame: keep T and B0's side, flip N
        N = -N
        B = -B
    return np.stack([T, N, B])
