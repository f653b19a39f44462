"""A phantom experiment made from a site and a seed: :func:`make_phantom` and :class:`Phantom`.

Designs are drawn (:mod:`~tendrilkit.phantom.design`) until one meets the
constraints (:mod:`~tendrilkit.phantom.constraints`) and leaves room for the
scene (:mod:`~tendrilkit.phantom.scene`); then the marks
(:mod:`~tendrilkit.phantom.marks`). Nothing is cached between calls: the
same arguments give the same phantom (about 1 s for 60 frames), whose arrays
are read-only, so one phantom can be shared by any number of readers.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from tendrilkit.phantom.constraints import check_constraints, self_crossings
from tendrilkit.phantom.design import (_MAX_ATTEMPTS, _N_REFERENCE, DEFAULT_N_FRAMES, DEFAULT_OPTIONS, SITES,
                                       Design, PhantomError, centrelines, read_only, draw_design, response_profile)
from tendrilkit.phantom.marks import keep_out_box, roi_box
from tendrilkit.phantom.projection import phantom_cameras
from tendrilkit.phantom.scene import Reject, Scene, build_scene

@dataclass(frozen=True, eq=False)
class Phantom:
    """A synthetic experiment: geometry, scene, marks and ground truth (no pixels).

    Attributes
    ----------
    site : str
    seed : int
    n_frames : int
    fps : float
        Frames per second as written in the experiment file.
    time_s : (n_frames,) float array
        ``frame / fps``.
    cameras : list of Camera
        The true cameras (IJCV25 rig poses, per-view distortion).
    s_mm : (n_pts,) float array
        Arc length of the dense centreline samples (every 0.25 mm or less).
    curves_mm : (n_frames, n_pts, 3) float array
        True centrelines, world mm, base (point 0) to tip.
    projections_px : (n_frames, n_views, n_pts, 2) float array
        The centrelines projected with distortion.
    kappa, tau : tuple of tendrilkit.pwc.PiecewiseLinearLaw
        Curvature and torsion laws (1/mm), one per frame, with the same
        breakpoints in every frame.
    response : (n_frames,) float array
        Fraction of the final curl reached (with wobble).
    design : Design
        The draw of the site's family.
    scene : Scene
    views : list of dict
        Per view: ``roi`` [x, y, w, h], ``keep_out`` [x, y, w, h],
        ``base_point`` [x, y] (pixels, whole numbers), as a user marks them on
        frame 0.
    hidden_base_mm : (n_views,) float array
        Length of tendril hidden by each view's keep-out box (frame 0).
    crossings : list of list of list
        Per frame and view, the :func:`self_crossings` of the projection.
    options : dict
        The resolved options.

    Notes
    -----
    The arrays are read-only. The renderer keeps each view's static layers
    (board, scene, lighting, noise; about 40 MB a view) in the phantom's
    private ``_layers`` the first time the view is drawn
    (:func:`tendrilkit.phantom.render.static_layers`): they are freed with
    the phantom, no clearing needed.
    """

    site: str
    seed: int
    n_frames: int
    fps: float
    time_s: np.ndarray
    cameras: list
    s_mm: np.ndarray
    curves_mm: np.ndarray
    projections_px: np.ndarray
    kappa: tuple
    tau: tuple
    response: np.ndarray
    design: Design
    scene: Scene
    views: list
    hidden_base_mm: np.ndarray
    crossings: list
    options: dict = field(default_factory=dict)
    _layers: dict = field(default_factory=dict, init=False, repr=False)

    @property
    def name(self) -> str:
        return f"phantom-{self.site}" if self.seed == 0 else f"phantom-{self.site}-seed{self.seed}"

    @property
    def length_mm(self) -> float:
        return float(self.s_mm[-1])

    @property
    def diameter_mm(self) -> float:
        return float(self.options["diameter_mm"])

    @property
    def laws(self) -> pd.DataFrame:
        """The laws as the ``gt_laws.csv`` table (see :meth:`laws_table`)."""
        return self.laws_table()

    def laws_table(self) -> pd.DataFrame:
        """``gt_laws.csv``: frame, kind, segment, s0_mm, s1_mm, value_s0, value_s1 (1/mm)."""
        rows = []
        for f in range(self.n_frames):
            for law in (self.kappa[f], self.tau[f]):
                k, v = law.knots_mm, law.values
                for i in range(len(k) - 1):
                    rows.append((f, law.kind, i, k[i], k[i + 1], v[i], v[i + 1]))
        return pd.DataFrame(rows, columns=["frame", "kind", "segment", "s0_mm", "s1_mm", "value_s0", "value_s1"])


def _resolve_options(options: dict) -> dict:
    unknown = sorted(set(options) - set(DEFAULT_OPTIONS))
    if unknown:
        raise PhantomError(f"unknown phantom option(s) {', '.join(unknown)}; expected {', '.join(DEFAULT_OPTIONS)}")
    out = dict(DEFAULT_OPTIONS)
    out.update(options)
    if not out["duration_s"] > 0:
        raise PhantomError(f"duration_s: expected > 0, got {out['duration_s']}")
    if not 0.3 <= out["diameter_mm"] <= 5.0:
        raise PhantomError(f"diameter_mm: expected 0.3-5 mm, got {out['diameter_mm']}")
    return out


def _fps(n_frames: int, duration_s: float) -> float:
    return float(f"{n_frames / duration_s:.7g}")


def make_phantom(site: str, *, n_frames: int = DEFAULT_N_FRAMES, seed: int = 0, **options) -> Phantom:
    """Generate the geometry, scene and marks of a phantom experiment.

    Parameters
    ----------
    site : {"S1", "S2", "S3", "S4"}
        Stimulation site (the family of shapes, see the module docstring).
    n_frames : int, keyword-only
        Frames of the time-lapse (default 60, one per 15 s over 15 minutes).
    seed : int, keyword-only
        0: the site's nominal design; others: variants (length, breakpoints,
        curl, base, tilt, layout, noise).
    **options
        See :data:`DEFAULT_OPTIONS`.

    Returns
    -------
    Phantom

    Raises
    ------
    PhantomError
        Unknown site or option, or no design of the family meets the
        constraints within 60 attempts.
    """
    if site not in SITES:
        raise PhantomError(f"site: expected one of {', '.join(SITES)}, got {site!r}")
    if int(n_frames) < 1:
        raise PhantomError(f"n_frames: expected at least 1, got {n_frames}")
    n_frames, seed = int(n_frames), int(seed)
    opts = _resolve_options(options)
    fps = _fps(n_frames, opts["duration_s"])
    time_s = np.arange(n_frames) / fps
    cams = phantom_cameras(seed, distortion=bool(opts["distortion"]))
    diameter = float(opts["diameter_mm"])
    # designs are accepted on a fixed reference grid (every 15 s over the duration), so
    # the design and the scene of a seed do not depend on the sequence length
    ref_t = np.linspace(0.0, float(opts["duration_s"]), _N_REFERENCE)
    reasons = []
    for attempt in range(_MAX_ATTEMPTS):
        design = draw_design(site, seed, attempt, opts)
        # cheap screen on the first and the stable frames, then the reference grid, then the frames
        probe_t = np.array([0.0, design.stable_s, ref_t[-1]])
        s, probe, _, _ = centrelines(design, probe_t)
        bad = check_constraints(probe, s, cams, site, time_s=probe_t, stable_s=design.stable_s, diameter_mm=diameter)
        if not bad:
            s, ref, _, _ = centrelines(design, ref_t)
            bad = check_constraints(ref, s, cams, site, time_s=ref_t, stable_s=design.stable_s, diameter_mm=diameter)
        if not bad:
            s, curves, kappa, tau = centrelines(design, time_s)
            bad = check_constraints(curves, s, cams, site, time_s=time_s, stable_s=design.stable_s,
                                    diameter_mm=diameter)
        if bad:
            reasons.append(bad[0])
            continue
        try:
            scene = build_scene(design, cams, ref, seed, attempt, diameter)
        except Reject as e:
            reasons.append(str(e))
            continue
        break
    else:
        common = max(set(reasons), key=reasons.count)
        raise PhantomError(f"site {site}, seed {seed}: no design met the constraints in {_MAX_ATTEMPTS} attempts "
                           f"(most often: {common})")
    proj = np.stack([np.stack([cam.project(c) for cam in cams]) for c in curves])
    views, hidden = [], []
    for v, cam in enumerate(cams):
        ko, h = keep_out_box(cam, np.concatenate([curves[:1], ref[::6]]), s, scene, diameter)
        bp = np.round(proj[0, v, 0]).astype(int)
        views.append({"view": v + 1, "roi": roi_box(cam, np.concatenate([ref, curves]), diameter), "keep_out": ko,
                      "base_point": [int(bp[0]), int(bp[1])]})
        hidden.append(h)
    if max(hidden) > 2.0:
        warnings.warn(f"phantom {site} seed {seed}: the keep-out box hides {max(hidden):.2f} mm of the tendril "
                      f"in view {int(np.argmax(hidden)) + 1} (target 1.5 mm)", stacklevel=2)
    coarse = slice(None, None, 4)
    crossings = [[self_crossings(proj[f, v][coarse], s[coarse]) for v in range(len(cams))] for f in range(n_frames)]
    ph = Phantom(site=site, seed=seed, n_frames=n_frames, fps=fps, time_s=read_only(time_s), cameras=cams,
                 s_mm=read_only(s), curves_mm=read_only(curves), projections_px=read_only(proj), kappa=kappa, tau=tau,
                 response=read_only(response_profile(time_s, design.onset_s, design.stable_s, design.wobble)),
                 design=design, scene=scene, views=views, hidden_base_mm=read_only(np.array(hidden)),
                 crossings=crossings, options=opts)
    return ph


