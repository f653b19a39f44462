"""When does the automatic fit's retry pay? Every search always run, trigger rules compared (prints; not a test).

    .venv/bin/python benchmarks/bench_pwc_retry.py --runs /work/baseline7   # RUNS/S1..S4/curves.csv

``selection="auto"`` with ``retries`` (:func:`tendrilkit.pwc.fit_piecewise_clothoid`) searches
again, with one more step of lookahead and then with half the smoothing length, when the first
search misses the target R^2 or leaves an rms residual above ``RETRY_NOISE_RATIO`` of the noise
estimated from the points, the noise counted as at least ``RETRY_ALLOWANCE_FRACTION`` of the rms
residual the target R^2 allows. On a reconstruction's curves (smooth: the noise estimate reads
about 0.0002 mm) the noise alone fired on every frame (its rule is kept below). This runs, on each curve, the first search and both retries
unconditionally (CPU time of each), scores each result by ground truth (mean and max distance from
the fitted points to the true curve, mm) and replays the fit's retry logic under other triggers
and orders, so that every rule is measured on the same searches in one run:

- sites: the frames of ``RUNS/S?/curves.csv`` against ``TRUTH/S?/ground_truth/gt_curves.csv``
  (the true centreline at 10x its sampling, nearest vertex);
- bench: the seeded noisy ground-truth curves of ``bench_pwc.py`` (seeds 1000-1039, 5000-5099,
  2000-2199; development seeds only).

Per set and rule: mean of the per-frame mean distance / max of the per-frame max distance, CPU ms
per fit (searches only), share of fits that retried, and frames worse / better than today's rule
by more than ``--tol`` (sites) or 0.02 mm (bench, issue 17's rule). The first line checks that the
replayed rule of today gives what ``fit_piecewise_clothoid`` gives.
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core, as bench_pwc.py

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
from scipy.spatial import cKDTree  # noqa: E402

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import tendrilkit.pwc.fit as F  # noqa: E402
from tendrilkit.frenet import noise_sigma_mm  # noqa: E402
from tendrilkit.pwc.datasets import random_pwc_curve  # noqa: E402
from tendrilkit.pwc.selection import _mid_penalty, _preferred  # noqa: E402
from tendrilkit.pwc.signals import _prepare  # noqa: E402

TARGET_R2 = 0.999
SEARCH = dict(criterion="bic", target_r2=TARGET_R2, max_segments=10, refine=True, insertions=True,
              quick_iterations=2, max_candidates=40)  # fit_piecewise_clothoid's defaults
TODAY = "today (rms > 0.9 max(noise, 0.05 R2 allowance))"
BENCH_SEEDS = list(range(1000, 1040)) + list(range(5000, 5100)) + list(range(2000, 2200))


def _points(res) -> np.ndarray:
    rk, rt = res["rk"], res["rt"]
    return F._finish(res["prep"], res["lk"], res["lt"], bounds_k=res["bounds_k"], bounds_t=res["bounds_t"],
                     pen_k=_mid_penalty(*rk), pen_t=_mid_penalty(*rt), rng_k=rk, rng_t=rt, selection="auto",
                     candidates=res["candidates"], refined=True, positions="trapezoid").points_mm


def _distance(points_mm, dense_mm) -> tuple[float, float]:
    d, _ = cKDTree(dense_mm).query(points_mm)
    return float(d.mean()), float(d.max())


def _all_searches(P: np.ndarray, dense_mm: np.ndarray) -> dict:
    """The first search and both retries, each timed and scored; features of the first search."""
    n = len(P)
    c = time.process_time()
    prep = _prepare(P, None, "l2", None, n)
    memo: dict = {}
    search = {**SEARCH, "precision_mm": F.BIC_PRECISION_FRACTION * F._allowed_rms_mm(prep.data, TARGET_R2)}  # as the fit
    found = [F._auto_search(prep, lookahead=1, memo=memo, **search)]
    cpu = [time.process_time() - c]
    c = time.process_time()
    found.append(F._auto_search(prep, lookahead=2, memo=memo, **search))
    cpu.append(time.process_time() - c)
    L_s = prep.fr.smoothing_length_mm
    if L_s > 8 * (prep.s[-1] / (prep.s.size - 1)):  # as fit_piecewise_clothoid
        c = time.process_time()
        found.append(F._auto_search(_prepare(P, 0.5 * L_s, "l2", None, n), lookahead=1, memo={}, **search))
        cpu.append(time.process_time() - c)
    first = _points(found[0])
    e = np.sum((first - prep.data) ** 2, axis=1)
    w = max(3, int(round(L_s / (prep.s[-1] / (n - 1)))))
    fr = prep.fr
    return {
        "n": prep.s.size, "sigma": noise_sigma_mm(P), "h": float(prep.s[-1] / (n - 1)),
        # the rms residual the target R2 allows: the precision the fit is asked for
        "allow": float(np.sqrt((1 - TARGET_R2) * np.sum((prep.data - prep.data.mean(axis=0)) ** 2) / (3 * n))),
        "smooth_rms": float(np.sqrt(np.mean(np.sum((fr.data_mm - fr.smooth_mm) ** 2, axis=1)) / 3)),
        # rms of the worst window one smoothing length long, over the rms: residuals in one place
        "localisation": float(np.sqrt(np.convolve(e, np.ones(w) / w, mode="valid").max() / e.mean())),
        "best": [r["best"] for r in found], "cpu": cpu,
        "acc": [_distance(first, dense_mm)] + [_distance(_points(r), dense_mm) for r in found[1:]],
    }


def _replay(x: dict, trigger, order=(1, 2), second_only_if_unchanged=False):
    """fit_piecewise_clothoid's retry logic under ``trigger``: (mean, max distance), CPU s, retried."""
    best, i, cpu = x["best"][0], 0, x["cpu"][0]
    if trigger(x, best):
        for j in order:
            if j >= len(x["best"]) or (second_only_if_unchanged and j != order[0] and i != 0):
                continue
            cpu += x["cpu"][j]
            if _preferred(x["best"][j], best, TARGET_R2, "bic"):
                best, i = x["best"][j], j
            if not trigger(x, best):
                break
    return x["acc"][i], cpu, cpu > x["cpu"][0]


def _rms(x, b):
    return np.sqrt(b[2] / (3 * x["n"]))


def _rules() -> dict:
    today = lambda x, b: b[3] < TARGET_R2 or _rms(x, b) > F.RETRY_NOISE_RATIO * max(  # noqa: E731
        x["sigma"], F.RETRY_ALLOWANCE_FRACTION * x["allow"])
    noise = lambda x, b: b[3] < TARGET_R2 or _rms(x, b) > F.RETRY_NOISE_RATIO * x["sigma"]  # noqa: E731
    rules = {TODAY: (today, {}), "no retry": (lambda x, b: b[3] < TARGET_R2, {}),
             "rms > 0.9 noise (before issue 17's floor)": (noise, {})}
    for c in (1.3, 1.5, 2.0, 3.0):
        rules[f"rms > {c} smoother rms"] = ((lambda c: lambda x, b: b[3] < TARGET_R2
                                             or _rms(x, b) > c * x["smooth_rms"])(c), {})
    for c in (2.0, 2.5, 3.0):
        rules[f"today, localisation < {c}"] = ((lambda c: lambda x, b: b[3] < TARGET_R2 or (
            today(x, b) and x["localisation"] < c))(c), {})
    for c in (3.0, 4.0):
        rules[f"rms > {c} noise"] = ((lambda c: lambda x, b: b[3] < TARGET_R2
                                      or _rms(x, b) > c * x["sigma"])(c), {})
    for c in (0.02, 0.05, 0.1):
        rules[f"rms > 0.9 max(noise, {c} spacing)"] = ((lambda c: lambda x, b: b[3] < TARGET_R2 or _rms(x, b) > (
            F.RETRY_NOISE_RATIO * max(x["sigma"], c * x["h"])))(c), {})
    for c in (0.02, 0.05, 0.1, 0.2):
        rules[f"rms > 0.9 max(noise, {c} R2 allowance)"] = ((lambda c: lambda x, b: b[3] < TARGET_R2 or _rms(x, b) > (
            F.RETRY_NOISE_RATIO * max(x["sigma"], c * x["allow"])))(c), {})
    rules["today, half smoothing first"] = (today, {"order": (2, 1)})  # the retry's orders
    rules["today, 2nd retry if 1st kept"] = (today, {"second_only_if_unchanged": True})
    rules["today, 2nd retry if 1st kept, half smoothing first"] = (today, {"order": (2, 1),
                                                                           "second_only_if_unchanged": True})
    return rules


def _densify(X: np.ndarray, k: int = 10) -> np.ndarray:
    t = np.arange(len(X))
    u = np.linspace(0, len(X) - 1, (len(X) - 1) * k + 1)
    return np.column_stack([np.interp(u, t, X[:, j]) for j in range(3)])


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--runs", type=Path, help="a directory of reconstructions: RUNS/S?/curves.csv")
    ap.add_argument("--truth", type=Path, default=REPO / "data" / "phantoms", help="TRUTH/S?/ground_truth/gt_curves.csv")
    ap.add_argument("--sites", nargs="*", default=["S1", "S2", "S3", "S4"])
    ap.add_argument("--tol", type=float, default=0.01, help="sites: a frame worse / better by more than this, mm")
    args = ap.parse_args()
    sets: dict[str, list] = {}
    F.fit_piecewise_clothoid(random_pwc_curve(3).points_mm)  # numba's caches
    mismatch = 0
    for site in args.sites if args.runs else []:
        run, gt = args.runs / site / "curves.csv", args.truth / site / "ground_truth" / "gt_curves.csv"
        if not (run.exists() and gt.exists()):
            print(f"{site}: no {run} or {gt}")
            raise SystemExit(2)
        d = pd.read_csv(run).sort_values(["frame", "point"])
        truth = {f: _densify(g[["x_mm", "y_mm", "z_mm"]].to_numpy(float))
                 for f, g in pd.read_csv(gt).sort_values(["frame", "point"]).groupby("frame")}
        sets[site] = []
        for f, g in d.groupby("frame"):
            P = g[["x_mm", "y_mm", "z_mm"]].to_numpy(float)
            sets[site].append(_all_searches(P, truth[f]))
            fitted = _distance(F.fit_piecewise_clothoid(P, n_points=len(P)).points_mm, truth[f])
            mismatch += fitted != _replay(sets[site][-1], _rules()[TODAY][0])[0]
    sets["bench"] = []
    for seed in BENCH_SEEDS:
        tc = random_pwc_curve(seed)
        sets["bench"].append(_all_searches(tc.points_mm, tc.dense_mm))
        fitted = _distance(F.fit_piecewise_clothoid(tc.points_mm).points_mm, tc.dense_mm)
        mismatch += fitted != _replay(sets["bench"][-1], _rules()[TODAY][0])[0]
    print(f"replayed rule of today differs from fit_piecewise_clothoid on {mismatch} curve(s); "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores; CPU ms of the searches per fit")
    rules = _rules()
    for name, xs in sets.items():
        print(f"\n{name} ({len(xs)} curves): rule | mean/max distance to truth mm | CPU ms per fit | retried | "
              f"worse / better than today")
        base = [_replay(x, rules[TODAY][0])[0][0] for x in xs]
        tol = 0.02 if name == "bench" else args.tol
        gain = [(x["acc"][0][0] - b, x) for b, x in zip(base, xs)]
        print("  first-search rms / noise / R2 allowance / spacing, mm, of the curves the retry helps by more than "
              "tol: " + "; ".join(f"{_rms(x, x['best'][0]):.3f}/{x['sigma']:.3f}/{x['allow']:.2f}/{x['h']:.2f}"
                                  for g, x in gain if g > tol))
        print(f"  all curves: first-search rms median {np.median([_rms(x, x['best'][0]) for x in xs]):.4f}, "
              f"R2 allowance median {np.median([x['allow'] for x in xs]):.3f} min {min(x['allow'] for x in xs):.3f}")
        for rname, (trigger, kw) in rules.items():
            r = [_replay(x, trigger, **kw) for x in xs]
            mean = np.array([a[0][0] for a in r])
            change = mean - np.array(base)
            print(f"  {rname:52s} {mean.mean():.4f}/{max(a[0][1] for a in r):.3f} {1e3 * np.mean([a[1] for a in r]):6.1f} "
                  f"{100 * np.mean([a[2] for a in r]):4.0f} % {int(np.sum(change > tol)):3d} / {int(np.sum(change < -tol)):d}"
                  f" (worst {change.max():+.3f})")


if __name__ == "__main__":
    main()
