"""Seeded piece-wise clothoid curves returned with their ground truth (tests, benchmarks, notebooks).

As ruptures' ``datasets``: a generator that takes a seed and returns the data
with the truth it was made from. Seeds 0-9999 are for development; seeds from
10000 are kept for the final benchmark.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from tendrilkit.frenet import integrate_frenet

__all__ = ["TruthCurve", "random_pwc_curve", "mean_distance_mm"]


@dataclass(frozen=True, eq=False)
class TruthCurve:
    """A piece-wise clothoid sampled with noise.

    points_mm (n, 3): noisy samples; clean_mm (n, 3): the same without noise;
    dense_mm (m, 3): the true curve finely sampled; s_mm (n,): true arc length
    of the samples; kappa_knots/tau_knots: (s_mm, value) knot arrays.
    """

    points_mm: np.ndarray
    clean_mm: np.ndarray
    dense_mm: np.ndarray
    s_mm: np.ndarray
    kappa_knots: tuple[np.ndarray, np.ndarray]
    tau_knots: tuple[np.ndarray, np.ndarray]


def _knots(rng, length, k, min_gap):
    while True:
        inner = np.sort(rng.uniform(min_gap, length - min_gap, k - 1))
        if k == 1 or np.all(np.diff(np.concatenate([[0], inner, [length]])) >= min_gap):
            return np.concatenate([[0.0], inner, [length]])


def random_pwc_curve(seed: int, *, n: int = 200, noise_mm: float = 0.15) -> TruthCurve:
    """120-200 mm, 2-5 segments per law, kappa 0.01-0.1 1/mm, |tau| <= 0.05 1/mm.

    Examples
    --------
    >>> truth = random_pwc_curve(3)
    >>> truth.points_mm.shape, truth.kappa_knots[0].size - 1, truth.tau_knots[0].size - 1
    ((200, 3), 2, 2)
    """
    rng = np.random.default_rng(seed)
    length = rng.uniform(120, 200)
    kk = _knots(rng, length, int(rng.integers(2, 6)), 20.0)
    kt = _knots(rng, length, int(rng.integers(2, 6)), 20.0)
    vk = rng.uniform(0.01, 0.1, kk.size)
    vt = rng.uniform(-0.05, 0.05, kt.size)
    sd = np.linspace(0, length, 20001)
    P, *_ = integrate_frenet(sd, np.interp(sd, kk, vk), np.interp(sd, kt, vt),
                             [1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 0], positions="exact")
    s = np.linspace(0, length, n)
    idx = np.round(s / length * 20000).astype(int)
    clean = P[idx]
    return TruthCurve(clean + rng.normal(0, noise_mm, clean.shape), clean, P, s, (kk, vk), (kt, vt))


def mean_distance_mm(points_mm: np.ndarray, dense_mm: np.ndarray) -> float:
    """Mean distance from each point to the dense true curve (nearest vertex)."""
    d, _ = cKDTree(dense_mm).query(points_mm)
    return float(d.mean())
