"""The piece-wise clothoid fit of one centreline, and Table 3 of the paper.

:func:`fit_piecewise_clothoid` composes the parts (:mod:`tendrilkit.pwc`
notes): prepared signals, a segmentation per law (fixed penalties or the
automatic selection), continuity, refinement, rebuild and scores, returned as
a :class:`PWCFit`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from tendrilkit.frenet import FrenetFrames, _orthonormal_frame, noise_sigma_mm
from tendrilkit.pwc.laws import PiecewiseLinearLaw, join_segments
from tendrilkit.pwc.rebuild import FitScores, _rebuild, fit_scores
from tendrilkit.pwc.refine import _refine_laws
from tendrilkit.pwc.search import segment_penalty
from tendrilkit.pwc.selection import _auto_search, _mid_penalty, _preferred
from tendrilkit.pwc.signals import _prepare

__all__ = ["PWCFit", "fit_piecewise_clothoid", "penalty_table"]


@dataclass(frozen=True, eq=False)
class PWCFit:
    """A 3D piece-wise clothoid fitted to one centreline.

    Attributes
    ----------
    s_mm : (n,) float array
        Arc length of the smoothed data, mm (the fit's parameter).
    data_mm : (n, 3) float array
        The input resampled at uniform chord length: what the scores measure against.
    points_mm : (n, 3) float array
        The rebuilt piece-wise clothoid, registered onto ``data_mm``, mm.
    kappa_law, tau_law : PiecewiseLinearLaw
        The fitted laws (knots in mm along ``s_mm``, values 1/mm).
    kappa_fit, tau_fit : (n,) float arrays
        The laws at ``s_mm``.
    frames : FrenetFrames
        Smoothed curve, measured curvature and torsion, torsion flags.
    rotation : (3, 3) float array
    translation : (3,) float array
        Registration of the integrated curve (from the identity frame at the
        origin): ``points = P @ rotation.T + translation``.
    scores : FitScores
        R^2 and SSE (mm^2), entire / base quarter / tip quarter.
    penalty_kappa, penalty_tau : float
        Dimensionless penalties (module notes) for which the segmentations in
        ``bounds_kappa``, ``bounds_tau`` are optimal (for ``auto``: the
        geometric middle of the exact interval, or twice its lower end when
        that is unbounded).
    penalty_range_kappa, penalty_range_tau : (2,) float arrays
        The exact penalty interval of those segmentations.
    bounds_kappa, bounds_tau : (K + 1,) int arrays
        Sample boundaries of the penalty-optimal segmentations the fit started
        from (for ``auto``, the last path step taken). With ``refine`` the
        laws' knots are then moved (and, with insertions, added), so the
        laws' knots are the answer, not these.
    selection : str
        ``auto``, ``fixed`` or ``grid``.
    candidates : (m, 6) float array
        For ``auto``: every candidate evaluated, columns ``K_kappa, K_tau,
        R2, SSE_mm2, BIC, chosen``; empty otherwise.
    refined : bool
        Whether the knot values were adjusted on the 3D residuals.
    """

    s_mm: np.ndarray
    data_mm: np.ndarray
    points_mm: np.ndarray
    kappa_law: PiecewiseLinearLaw
    tau_law: PiecewiseLinearLaw
    kappa_fit: np.ndarray
    tau_fit: np.ndarray
    frames: FrenetFrames
    rotation: np.ndarray
    translation: np.ndarray
    scores: FitScores
    penalty_kappa: float
    penalty_tau: float
    penalty_range_kappa: np.ndarray
    penalty_range_tau: np.ndarray
    bounds_kappa: np.ndarray
    bounds_tau: np.ndarray
    selection: str
    candidates: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))
    refined: bool = False

    @property
    def n_segments_kappa(self) -> int:
        return self.kappa_law.n_segments

    @property
    def n_segments_tau(self) -> int:
        return self.tau_law.n_segments

    @property
    def r2(self) -> float:
        return self.scores.r2_entire

    @property
    def sse_mm2(self) -> float:
        return self.scores.sse_entire_mm2

    def segments(self) -> list[dict]:
        """Rows ``kind, segment, s0_mm, s1_mm, value_s0, value_s1`` (kappa then tau)."""
        rows = []
        for law in (self.kappa_law, self.tau_law):
            for i, (s0, s1, v0, v1) in enumerate(law.segments()):
                rows.append({"kind": law.kind, "segment": i, "s0_mm": s0, "s1_mm": s1,
                             "value_s0": v0, "value_s1": v1})
        return rows


def _finish(prep, law_k, law_t, *, bounds_k, bounds_t, pen_k, pen_t, rng_k, rng_t, selection,
            candidates, refined, positions):
    s, data, fr = prep.s, prep.data, prep.fr
    Fm = _orthonormal_frame(fr.T[0], fr.N[0], fr.B[0])
    pts, R, t = _rebuild(s, law_k, law_t, data, Fm, positions)  # rebuild_curve from that frame
    # report the registration from the identity frame at the origin
    R_id = R @ Fm.T
    t_id = t + R @ data[0]
    return PWCFit(
        s_mm=s, data_mm=data, points_mm=pts, kappa_law=law_k, tau_law=law_t,
        kappa_fit=law_k(s), tau_fit=law_t(s), frames=fr, rotation=R_id, translation=t_id,
        scores=fit_scores(pts, data, s), penalty_kappa=float(pen_k), penalty_tau=float(pen_t),
        penalty_range_kappa=np.asarray(rng_k, float), penalty_range_tau=np.asarray(rng_t, float),
        bounds_kappa=np.asarray(bounds_k), bounds_tau=np.asarray(bounds_t), selection=selection,
        candidates=candidates, refined=refined,
    )


def _check_options(selection, criterion, target_r2, max_segments, score, positions):
    if selection not in ("auto", "fixed"):
        raise ValueError(f"selection must be 'auto' or 'fixed', got {selection!r}")
    if criterion not in ("bic", "r2"):
        raise ValueError(f"criterion must be 'bic' or 'r2', got {criterion!r}")
    if not 0 < target_r2 < 1:
        raise ValueError(f"target_r2 must be in (0, 1), got {target_r2}")
    if max_segments < 1:
        raise ValueError(f"max_segments must be >= 1, got {max_segments}")
    if score not in ("l2", "l1"):
        raise ValueError(f"score must be 'l2' or 'l1', got {score!r}")
    if positions not in ("trapezoid", "exact"):
        raise ValueError(f"positions must be 'trapezoid' or 'exact', got {positions!r}")


def fit_piecewise_clothoid(
    points_mm: np.ndarray,
    *,
    selection: str = "auto",
    criterion: str = "bic",
    target_r2: float = 0.999,
    penalty_kappa: float = 0.01,
    penalty_tau: float = 0.01,
    score: str = "l2",
    smoothing_length_mm: float | None = None,
    min_segment_mm: float | None = None,
    max_segments: int = 10,
    refine: bool = True,
    positions: str = "trapezoid",
    n_points: int | None = None,
    lookahead: int = 1,
    insertions: bool = True,
    quick_iterations: int = 2,
    max_candidates: int = 40,
    retries: bool = True,
) -> PWCFit:
    """Fit a 3D piece-wise clothoid to an ordered centreline.

    Parameters
    ----------
    points_mm : (n, 3) float array
        Ordered centreline, base to tip, mm.
    selection : {"auto", "fixed"}, keyword-only
        ``auto``: the segmentations on both penalty paths, searched as in the
        module notes and chosen by ``criterion``; ``fixed``:
        ``penalty_kappa`` and ``penalty_tau``.
    criterion : {"bic", "r2"}, keyword-only
        ``bic``: least BIC of the 3D residuals (their SSE counted down to an
        rms of :data:`BIC_PRECISION_FRACTION` of the rms the target allows),
        then more segments only if ``target_r2`` is not reached; ``r2``: the
        fewest segments reaching ``target_r2`` (the paper's stopping rule).
        See the module notes.
    target_r2 : float
        R^2 of the 3D points to reach (paper: 0.999).
    penalty_kappa, penalty_tau : float
        Dimensionless penalties for ``fixed`` (fraction of the signal's
        variance a segment must explain).
    score : {"l2", "l1"}
        Segment score: least squares, or the paper's absolute error.
    smoothing_length_mm : float, optional
        Half-gain wavelength of the Whittaker smoother, mm
        (:mod:`tendrilkit.frenet`); default: chosen per curve from its noise
        and coiling (:func:`tendrilkit.frenet.auto_smoothing_length_mm`,
        about 20 mm for 0.15 mm noise).
    min_segment_mm : float, optional
        Shortest segment, mm (default: half the smoothing length; at least 3 samples).
    max_segments : int
        Most segments per law considered by ``auto``.
    refine : bool
        Fit the knots' values and inner positions on the registered 3D points
        (module notes); off: the paper's curvature/torsion-space fit.
    positions : {"trapezoid", "exact"}
        Position rule of the rebuild (:func:`tendrilkit.frenet.integrate_frenet`).
    n_points : int, optional
        Resample to this many points (default: as many as given).
    lookahead : int
        ``auto``: how many further segmentations of each path a step may jump to.
    insertions : bool
        ``auto`` with ``refine``: also try the knot asked for by the score test.
    quick_iterations : int
        ``auto``: Levenberg-Marquardt iterations when comparing candidates (the
        chosen one is then refined to convergence).
    max_candidates : int
        ``auto``: the search stops after this many candidates, evaluated or
        skipped as unable to win (a bound on the time per frame on hard, noisy
        curves; the skipped ones count as the evaluated did before they were
        skipped, so the fits are the same).
    retries : bool
        ``auto`` with ``refine``: when the search ends below ``target_r2``, or
        with an rms residual above :data:`RETRY_NOISE_RATIO` of the data's
        noise (at least :data:`RETRY_ALLOWANCE_FRACTION` of the residual the
        target allows, :func:`_retry_yardstick_mm`), search again with one
        more step of lookahead, then with half the smoothing length, and keep
        the preferred result.

    Returns
    -------
    PWCFit

    Raises
    ------
    DegenerateCurveError
        Too few distinct points, zero length.
    ValueError
        An option out of range (named).

    Examples
    --------
    A seeded piece-wise clothoid of 2 + 2 segments with 0.15 mm noise:

    >>> from tendrilkit.pwc.datasets import mean_distance_mm, random_pwc_curve
    >>> truth = random_pwc_curve(3)
    >>> fit = fit_piecewise_clothoid(truth.points_mm)
    >>> fit.n_segments_kappa, fit.n_segments_tau, round(fit.r2, 4)
    (2, 2, 0.9999)
    >>> round(mean_distance_mm(fit.points_mm, truth.dense_mm), 2)
    0.03
    """
    _check_options(selection, criterion, target_r2, max_segments, score, positions)
    prep = _prepare(points_mm, smoothing_length_mm, score, min_segment_mm, n_points)
    s, fr = prep.s, prep.fr
    if selection == "fixed":
        bk, _ = segment_penalty(prep.Ck, penalty_kappa)
        bt, _ = segment_penalty(prep.Ct, penalty_tau)
        law_k = join_segments(s, fr.kappa, bk, weights=prep.wk, kind="kappa")
        law_t = join_segments(s, fr.tau, bt, weights=prep.wt, kind="tau")
        if refine:
            law_k, law_t = _refine_laws(prep, law_k, law_t)[:2]
        return _finish(prep, law_k, law_t, bounds_k=bk, bounds_t=bt, pen_k=penalty_kappa,
                       pen_t=penalty_tau, rng_k=[penalty_kappa] * 2, rng_t=[penalty_tau] * 2,
                       selection="fixed", candidates=np.zeros((0, 6)), refined=refine, positions=positions)

    kw = dict(criterion=criterion, target_r2=target_r2, max_segments=max_segments, refine=refine,
              insertions=insertions, quick_iterations=quick_iterations, max_candidates=max_candidates)
    if criterion == "bic":
        kw["precision_mm"] = BIC_PRECISION_FRACTION * _allowed_rms_mm(prep.data, target_r2, prep.sst_mm2)
    memo: dict = {}  # the retry with more lookahead repeats the first steps: computed once
    res = _auto_search(prep, lookahead=lookahead, memo=memo, **kw)
    # read once: the retries' yardstick
    noise_mm = (_retry_yardstick_mm(points_mm, prep.data, target_r2, prep.noise_mm, prep.sst_mm2)
                if refine and retries else None)
    if refine and retries and _missed(res["best"], target_r2, noise_mm, s.size):
        # a search that misses the target, or leaves residuals well above the data's noise,
        # may have taken a wrong turn: look further along the paths, and smooth less
        # (short segments); keep the preferred result
        tries = [(prep, lookahead + 1, memo)]
        L_s = prep.fr.smoothing_length_mm
        if L_s > 8 * (s[-1] / (s.size - 1)):
            tries.append((_prepare(points_mm, 0.5 * L_s, score, min_segment_mm, n_points), lookahead, {}))
        for prep_, look, memo_ in tries:
            alt = _auto_search(prep_, lookahead=look, memo=memo_, **kw)
            if _preferred(alt["best"], res["best"], target_r2, criterion):
                res = alt
            if not _missed(res["best"], target_r2, noise_mm, s.size):
                break
    rk, rt = res["rk"], res["rt"]
    return _finish(res["prep"], res["lk"], res["lt"], bounds_k=res["bounds_k"], bounds_t=res["bounds_t"],
                   pen_k=_mid_penalty(*rk), pen_t=_mid_penalty(*rt), rng_k=rk, rng_t=rt,
                   selection="auto", candidates=res["candidates"], refined=refine, positions=positions)


#: ``auto`` searches again when the fit's rms residual exceeds this multiple of the yardstick
#: (:func:`_retry_yardstick_mm`): on noisy points their noise (:func:`tendrilkit.frenet.noise_sigma_mm`,
#: of the points as given; the residual is measured on them resampled, which averages some noise away:
#: on the seeded 0.15 mm curves a good fit leaves 0.7-0.9 of it, a search that took a wrong turn 1.2-4).
RETRY_NOISE_RATIO = 0.9

#: The yardstick's floor, as a fraction of the rms residual the target R^2 allows (about 0.6-0.8 mm
#: on a tendril 150-180 mm long). A reconstructed curve is already smoothed: its noise reads about
#: 0.0002 mm, below any fit's residual, and with the noise alone as yardstick the retry ran on every
#: frame of a pipeline (its cost nearly doubled). With the floor it runs where the first search left
#: more than about 0.03 mm: on the site phantoms' frames where it pays (first fits leaving 0.04-0.29 mm,
#: 15 frames of S3 brought closer to the truth by up to 0.21 mm) and on 5 % of the others; the seeded
#: noisy curves, whose noise is above the floor, retry as before (benchmarks/bench_pwc_retry.py:
#: 0.02 of the allowance retried on up to 60 % of a site's frames, 0.1 missed two that pay).
RETRY_ALLOWANCE_FRACTION = 0.05


def _retry_yardstick_mm(points_mm, data_mm, target_r2, noise_mm=None, sst_mm2=None):
    """The rms residual (mm) above which (:data:`RETRY_NOISE_RATIO` of it) a search is tried again.

    ``noise_mm``, ``sst_mm2``: the noise and ``data_mm``'s sum of squares about their mean, if already
    known. The larger of the noise of ``points_mm`` (as given) and
    :data:`RETRY_ALLOWANCE_FRACTION` of the rms residual the target R^2 allows on ``data_mm`` (n, 3)
    (the points resampled, what the fit's R^2 is measured on): :math:`\\sqrt{(1 - R^2_{target}) \\, SST / 3n}`.
    """
    noise_mm = noise_sigma_mm(points_mm) if noise_mm is None else noise_mm
    return max(noise_mm, RETRY_ALLOWANCE_FRACTION * _allowed_rms_mm(data_mm, target_r2, sst_mm2))


#: BIC compares the candidates' residuals down to this fraction of the rms the target R^2 allows
#: (:func:`_allowed_rms_mm`; the SSE in BIC floored at that rms): the precision the fit is asked for.
#: On smooth data (a reconstruction's curves, noise about 0.0002 mm) BIC had nothing to stop it and
#: added segments to follow the reconstruction's ripples, up to ``max_candidates``. At 1/50 (about
#: 0.013 mm rms on the site phantoms' tendrils) their fits come closer to the truth (240 frames of
#: S1-S4: median mean distance 0.0373 -> 0.0364 mm, worst 0.360 mm unchanged, no frame worse by
#: 0.01 mm; 5.6 segments instead of 7.3, CPU per fit -37 %); at 1/40 one frame was worse by
#: 0.011 mm, at 1/25 (a quarter of the frames) four by up to 0.03 mm. Noisy points (the seeded curves' 0.15 mm) never reach the floor: their fits are unchanged.
BIC_PRECISION_FRACTION = 0.02


def _allowed_rms_mm(data_mm, target_r2, sst_mm2=None):
    """The rms residual (mm) the target R^2 allows on ``data_mm`` (n, 3): :math:`\\sqrt{(1 - R^2) SST / 3n}`
    (``sst_mm2``: the SST, if already known)."""
    sst = float(np.sum((data_mm - data_mm.mean(axis=0)) ** 2)) if sst_mm2 is None else sst_mm2
    return float(np.sqrt((1.0 - target_r2) * sst / (3 * len(data_mm))))


def _missed(best, target_r2, yardstick_mm, n):
    """Did the search miss ``target_r2``, or leave residuals above ``yardstick_mm`` (:data:`RETRY_NOISE_RATIO`)?"""
    if best[3] < target_r2:
        return True
    return bool(np.sqrt(best[2] / (3 * n)) > RETRY_NOISE_RATIO * yardstick_mm)


def penalty_table(points_mm: np.ndarray, penalties: list[tuple[float, float]], **options) -> list[dict]:
    """Table 3 of the paper: segments, R^2 and SSE for given penalty pairs.

    ``options`` go to :func:`fit_piecewise_clothoid` (``selection="fixed"``;
    ``refine`` defaults to False, as in the paper). One row per pair:
    ``penalty_kappa, penalty_tau, n_kappa, n_tau, r2_entire, r2_base, r2_tip,
    sse_entire_mm2, sse_base_mm2, sse_tip_mm2``.
    """
    options = {"refine": False, **options, "selection": "fixed"}
    rows = []
    for pk, pt in penalties:
        f = fit_piecewise_clothoid(points_mm, penalty_kappa=pk, penalty_tau=pt, **options)
        sc = f.scores
        rows.append({"penalty_kappa": pk, "penalty_tau": pt, "n_kappa": f.n_segments_kappa,
                     "n_tau": f.n_segments_tau, "r2_entire": sc.r2_entire, "r2_base": sc.r2_base,
                     "r2_tip": sc.r2_tip, "sse_entire_mm2": sc.sse_entire_mm2,
                     "sse_base_mm2": sc.sse_base_mm2, "sse_tip_mm2": sc.sse_tip_mm2})
    return rows
