"""Rebuild a curve from its laws, register it rigidly onto the data, and score it (Tables 2-3).

Rebuild and scores of :mod:`tendrilkit.pwc` (notes): integration of the Frenet
frame with the laws' exact step means, rigid registration (SVD), R^2 and SSE
of the entire curve, the base quarter and the tip quarter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from tendrilkit.frenet import _integrate, _orthonormal_frame
from tendrilkit.geometry import rigid_fit, section_masks
from tendrilkit.pwc.laws import PiecewiseLinearLaw, _pwl_step_means

__all__ = ["FitScores", "register_rigid", "rebuild_curve", "fit_scores"]


@njit(cache=True)
def _registered_sse(s, k_step, t_step, data):
    P, _, _, _ = _integrate(s, k_step, t_step, np.eye(3), np.zeros(3), False)
    if not np.all(np.isfinite(P)):
        return np.inf
    R, t = rigid_fit(P, data)
    sse = 0.0
    for i in range(P.shape[0]):
        for c in range(3):
            v = R[c, 0] * P[i, 0] + R[c, 1] * P[i, 1] + R[c, 2] * P[i, 2] + t[c] - data[i, c]
            sse += v * v
    return sse


def register_rigid(P: np.ndarray, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rigid transform taking ``P`` onto ``Q`` in least squares (SVD, no scaling).

    Parameters
    ----------
    P, Q : (n, 3) float arrays
        Corresponding points, mm.

    Returns
    -------
    R : (3, 3) float array
        Proper rotation (det +1).
    t : (3,) float array
        Translation, mm: ``Q ~ P @ R.T + t``.

    Examples
    --------
    >>> import numpy as np
    >>> from scipy.spatial.transform import Rotation
    >>> P = np.random.default_rng(0).normal(size=(10, 3))
    >>> R = Rotation.from_rotvec([0.1, 0.2, 0.3]).as_matrix()
    >>> R_est, t = register_rigid(P, P @ R.T + [1.0, 2.0, 3.0])
    >>> bool(np.allclose(R_est, R)), t.round(6).tolist()
    (True, [1.0, 2.0, 3.0])
    """
    P = np.ascontiguousarray(P, dtype=float)
    Q = np.ascontiguousarray(Q, dtype=float)
    if P.ndim != 2 or P.shape[1] != 3 or P.shape != Q.shape:
        raise ValueError(f"P and Q must have the same shape (n, 3), got {P.shape} and {Q.shape}")
    if P.shape[0] < 3:
        raise ValueError(f"P must have at least 3 points, got {P.shape[0]}")
    if not (np.all(np.isfinite(P)) and np.all(np.isfinite(Q))):
        raise ValueError("P and Q must be finite (no NaN or inf)")
    return rigid_fit(P, Q)


def rebuild_curve(
    s_mm: np.ndarray,
    kappa_law: PiecewiseLinearLaw,
    tau_law: PiecewiseLinearLaw,
    data_mm: np.ndarray,
    *,
    frame0: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
    positions: str = "trapezoid",
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Integrate the laws from the data's base and register onto the data.

    Parameters
    ----------
    s_mm : (n,) float array
        Arc lengths of the data points, mm.
    kappa_law, tau_law : PiecewiseLinearLaw
    data_mm : (n, 3) float array
        The points to register onto, mm.
    frame0 : (T0, N0, B0), optional
        Initial frame (default: the identity; registration fixes the pose).
    positions : {"trapezoid", "exact"}

    Returns
    -------
    points_mm : (n, 3) float array
        Rebuilt and registered points, mm.
    R : (3, 3) float array
    t : (3,) float array
        The registration: ``points = P_integrated @ R.T + t``.
    """
    F0 = np.eye(3) if frame0 is None else _orthonormal_frame(*frame0)
    return _rebuild(s_mm, kappa_law, tau_law, data_mm, F0, positions)


def _rebuild(s_mm, kappa_law, tau_law, data_mm, F0, positions):
    """:func:`rebuild_curve` from the orthonormal frame ``F0`` (3, 3) (rows T, N, B)."""
    s = np.ascontiguousarray(s_mm, dtype=float)
    data = np.ascontiguousarray(data_mm, dtype=float)
    c = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    P, R, t = _rebuild_core(s, c(kappa_law.knots_mm), c(kappa_law.values), c(tau_law.knots_mm), c(tau_law.values),
                            F0, data[0].copy(), positions == "exact", data)
    return P @ R.T + t, R, t


@njit(cache=True)
def _rebuild_core(s, kk, vk, kt, vt, F0, p0, exact_positions, data):
    """The laws' step means, the integration from ``F0`` at ``p0`` and its registration onto ``data``:
    ``(P, R, t)``, the same steps as one call (each compiled function called from Python loads its
    numba cache at a process's start, about 3 ms: three of them were this)."""
    P, _, _, _ = _integrate(s, _pwl_step_means(s, kk, vk), _pwl_step_means(s, kt, vt), F0, p0, exact_positions)
    R, t = rigid_fit(P, data)
    return P, R, t


@dataclass(frozen=True, eq=False)
class FitScores:
    """R^2 (about the data's mean) and SSE (mm^2): entire, base quarter, tip quarter."""

    r2_entire: float
    r2_base: float
    r2_tip: float
    sse_entire_mm2: float
    sse_base_mm2: float
    sse_tip_mm2: float
    rmse_mm: float
    max_error_mm: float


def fit_scores(fitted_mm: np.ndarray, data_mm: np.ndarray, s_mm: np.ndarray) -> FitScores:
    """Scores of a fitted curve against the data (Tables 2-3).

    The base quarter holds the points with :math:`s \\le L/4`, the tip quarter
    those with :math:`s \\ge 3L/4`; each quarter's R^2 is about its own mean.
    """
    f = np.asarray(fitted_mm, dtype=float)
    d = np.asarray(data_mm, dtype=float)
    s = np.asarray(s_mm, dtype=float)
    if f.ndim != 2 or f.shape != d.shape or s.shape != (len(d),) or len(d) < 2:
        raise ValueError(f"fitted_mm, data_mm and s_mm must have shapes (n, 3), (n, 3), (n,) with n >= 2, "
                         f"got {f.shape}, {d.shape}, {s.shape}")
    if not (np.all(np.isfinite(f)) and np.all(np.isfinite(d)) and np.all(np.isfinite(s))):
        raise ValueError("fitted_mm, data_mm and s_mm must be finite (no NaN or inf)")
    err = np.sum((f - d) ** 2, axis=1)

    def r2sse(mask):
        sse = float(err[mask].sum())
        sst = float(np.sum((d[mask] - d[mask].mean(axis=0)) ** 2))
        return (1.0 - sse / sst if sst > 0 else float("nan")), sse

    quarter = section_masks(s)
    r2e, ssee = r2sse(quarter["entire"])
    r2b, sseb = r2sse(quarter["base"])
    r2t, sset = r2sse(quarter["tip"])
    return FitScores(r2e, r2b, r2t, ssee, sseb, sset, float(np.sqrt(err.mean())), float(np.sqrt(err.max())))


@njit(cache=True)
def _laws_sse(s, kk, vk, kt, vt, data):
    return _registered_sse(s, _pwl_step_means(s, kk, vk), _pwl_step_means(s, kt, vt), data)


def _law_sse(prep, law_k, law_t):
    """SSE (mm^2) of the laws integrated from the identity and registered onto ``prep.data``: one compiled call."""
    f = lambda a: np.ascontiguousarray(a, dtype=float)  # noqa: E731
    return float(_laws_sse(prep.s, f(law_k.knots_mm), f(law_k.values), f(law_t.knots_mm), f(law_t.values), prep.data))
