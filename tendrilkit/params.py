"""Reading and validating experiment files (``../shared/EXPERIMENT_FORMAT.md``).

:func:`load_experiment` returns an :class:`Experiment` whose paths are absolute.
Every mistake raises :class:`~tendrilkit.exceptions.ExperimentError` with one
line naming the file, the key, the value and what was expected. Unknown keys
are errors, and so are a key given twice, a file over 1 MB and numbers
outside their plausible ranges (:mod:`tendrilkit.limits`); the YAML is read
by :mod:`tendrilkit.safe_yaml`.

Required keys are exactly those of EXPERIMENT_FORMAT.md. The optional sections
``segmentation``, ``skeleton``, ``ordering``, ``correspondence``,
``reconstruction``, ``triangulation``, ``smoothing``, ``fit`` and ``calibration`` hold tendrilkit's
own choices; each key is documented in the classes below. A key that is a
stage function's option takes its default from that function's signature
(:func:`tendrilkit.options.stage_default`); :func:`tendrilkit.options.stage_options`
hands the options to the stages.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)

from tendrilkit import limits as L
from tendrilkit.exceptions import ExperimentError
from tendrilkit.options import stage_default
from tendrilkit.safe_yaml import parse_yaml, read_experiment_text, short_repr  # noqa: F401 - re-exported

SITES = ("S1", "S2", "S3", "S4")


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def example_experiment_data() -> dict:
    """A minimal valid experiment mapping (two views; paths need not exist): for examples and tests."""
    return {
        "name": "example", "stimulation_site": "S1", "fps": 1.0, "reference_view": 1,
        "videos": ["v1.mp4", "v2.mp4"],
        "marker": {"dictionary": "DICT_ARUCO_ORIGINAL", "id": 0, "length_mm": 24.0},
        "cameras": [{"view": v, "fx": 1000.0, "fy": 1000.0, "cx": 320.0, "cy": 240.0} for v in (1, 2)],
        "views": [{"view": v, "roi": [0, 0, 640, 480], "base_point": [320.0, 400.0]} for v in (1, 2)],
    }


PositiveFloat = Annotated[float, Field(gt=0)]
NonNegFloat = Annotated[float, Field(ge=0)]
#: A pixel distance or size of an option (tolerance, radius, window).
OptionPx = Annotated[float, Field(ge=0, le=L.MAX_OPTION_PX)]
Weight = Annotated[float, Field(ge=0, le=L.MAX_WEIGHT)]
Pixel = Annotated[float, Field(ge=-L.MAX_PIXEL, le=L.MAX_PIXEL)]
PixelInt = Annotated[int, Field(ge=-int(L.MAX_PIXEL), le=int(L.MAX_PIXEL))]
FrameIndex = Annotated[int, Field(ge=0, le=L.MAX_FRAME)]


class FrameRange(_Strict):
    """0-based frame selection, ``stop`` exclusive (``null``: to the end)."""

    start: int = Field(0, ge=0, le=L.MAX_FRAME)
    stop: int | None = Field(None, ge=1, le=L.MAX_FRAME)
    step: int = Field(1, ge=1, le=L.MAX_FRAME)

    @model_validator(mode="after")
    def _order(self) -> "FrameRange":
        if self.stop is not None and self.stop <= self.start:
            raise ValueError(f"expected stop ({self.stop}) greater than start ({self.start})")
        return self


class CameraIntrinsics(_Strict):
    """Pinhole intrinsics of one view, pixels; ``dist`` in OpenCV order.

    ``fx``, ``fy`` in (0, 1e5] px, ``cx``, ``cy`` within 1e5 px (and, once the
    videos are open, plausible for the image size: :func:`check_against_images`);
    ``dist``: 4, 5, 8, 12 or 14 coefficients (OpenCV's ``k1, k2, p1, p2[, k3[,
    k4, k5, k6[, s1, s2, s3, s4[, tauX, tauY]]]]``; 4 are completed with
    ``k3 = 0``), each within 1e4.
    """

    view: int = Field(ge=1, le=100)
    fx: float = Field(gt=0, le=L.MAX_FOCAL_PX)
    fy: float = Field(gt=0, le=L.MAX_FOCAL_PX)
    cx: Pixel
    cy: Pixel
    dist: list[Annotated[float, Field(ge=-L.MAX_DIST_COEFF, le=L.MAX_DIST_COEFF)]] = Field(
        default_factory=lambda: [0.0] * 5, max_length=14)

    @field_validator("fx", "fy", mode="before")
    @classmethod
    def _placeholder(cls, v):
        if v == 0:
            raise ValueError("a placeholder: calibrate this camera with `python -m tendrilkit intrinsics BOARD_VIDEO "
                             "--board ... --view N --write EXPERIMENT.yaml` (expected the focal length in px, > 0)")
        return v

    @field_validator("dist")
    @classmethod
    def _dist(cls, v: list[float]) -> list[float]:
        if len(v) not in L.DIST_LENGTHS:
            raise ValueError("expected 4, 5, 8, 12 or 14 coefficients in OpenCV's order (k1, k2, p1, p2, k3, ...)")
        return list(v) + [0.0] * (5 - len(v)) if len(v) < 5 else list(v)


class Marker(_Strict):
    """The ArUco marker that defines the world frame."""

    dictionary: str
    id: int = Field(ge=0, le=100_000)
    length_mm: float = Field(ge=L.MIN_MARKER_MM, le=L.MAX_LENGTH_MM)

    @field_validator("dictionary")
    @classmethod
    def _dictionary(cls, v: str) -> str:
        import cv2

        if not v.startswith("DICT_") or not isinstance(getattr(cv2.aruco, v, None), int):
            raise ValueError("expected a cv2.aruco predefined dictionary name such as DICT_ARUCO_ORIGINAL")
        return v

    @model_validator(mode="after")
    def _id_in_dictionary(self) -> "Marker":
        import cv2

        n = int(cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary)).bytesList.shape[0])
        if self.id >= n:
            raise ValueError(f"marker.id: {self.dictionary} holds ids 0..{n - 1}, got {self.id}")
        return self


class ViewMarks(_Strict):
    """What a user marks on the first frame of one view (pixels).

    ``roi`` and ``base_point`` are required, except when the file is loaded
    with ``marks_optional=True`` (the ``marks`` and ``check`` commands, which
    suggest them); ``keep_out`` is optional (none: no keep-out box).
    """

    view: int = Field(ge=1, le=100)
    roi: tuple[PixelInt, PixelInt, PixelInt, PixelInt] | None = None
    keep_out: tuple[PixelInt, PixelInt, PixelInt, PixelInt] | None = None
    base_point: tuple[Pixel, Pixel] | None = None

    @field_validator("roi", "keep_out")
    @classmethod
    def _box(cls, v):
        if v is not None and (v[2] <= 0 or v[3] <= 0):
            raise ValueError("expected [x, y, w, h] with positive width and height")
        return v


class Extrinsics(_Strict):
    """Camera poses from the authors' files instead of marker detection."""

    format: Literal["ijcv25"]
    files: list[Path] = Field(max_length=100)


class Segmentation(_Strict):
    """Per-view segmentation of the tendril (paper: Pre-processing); see
    :func:`tendrilkit.segmentation.segment_view`.

    ``channel``: ``blue`` (dark tendril in the blue channel on a white board,
    the reference's default) or ``hsv`` (grey = min(V, 255 - S): dark or
    saturated pixels are tendril); ``threshold``: ``otsu`` (Otsu's threshold on
    the ROI) or a fixed grey level 0-255 (pixels darker than it are tendril);
    ``opening_radius_px``: radius of the disk of the morphological opening (0:
    none; the reference opens with radius 5, which erases tendrils thinner than
    11 px); ``min_component_px``: components smaller than this are dropped.
    Faint pixels (a pale tendril the threshold misses, under uneven light) are
    added where the grey level is below its local background (a median over
    ``background_px`` pixels) by more than ``local_contrast`` (relative, 0:
    off), ``local_noise_k`` times the ROI's relative noise and half the
    deepest such darkness within ``local_window_px``, farther than
    ``local_margin_px`` from the thresholded pixels (see
    :func:`tendrilkit.segmentation.faint_pixels`); ``local_exclude_dark``:
    that deepest darkness is taken beside the thresholded pixels (a leaf, the
    stem), not over them, so a pale tendril running beside them is kept (true
    by default). ``line_width_px`` (11 by default; 0: off): light lines up to this wide, lighter than the
    dark pixels on both sides and darker than the board, are added (a pale
    tendril in front of a leaf; :func:`tendrilkit.segmentation.light_line_pixels`);
    ``bridge_gap_px`` (0: off): line ends up to this far apart facing each
    other across a crossing are joined (:func:`tendrilkit.segmentation.bridge_line_gaps`).
    The first frame takes the component at or nearest the base point, later
    frames the component nearest the previous centroid.
    """

    channel: Literal["blue", "hsv"] = Field(default_factory=lambda: stage_default("segmentation", "channel"))
    threshold: Literal["otsu"] | Annotated[int, Field(ge=0, le=255)] = Field(
        default_factory=lambda: stage_default("segmentation", "threshold"))
    opening_radius_px: int = Field(default_factory=lambda: stage_default("segmentation", "opening_radius_px"), ge=0, le=1000)
    min_component_px: int = Field(default_factory=lambda: stage_default("segmentation", "min_component_px"), ge=0, le=10**9)
    local_contrast: float = Field(default_factory=lambda: stage_default("segmentation", "local_contrast"), ge=0, lt=1)
    local_noise_k: float = Field(default_factory=lambda: stage_default("segmentation", "local_noise_k"), ge=0, le=100)
    background_px: int = Field(default_factory=lambda: stage_default("segmentation", "background_px"), ge=4, le=10**4)
    local_window_px: int = Field(default_factory=lambda: stage_default("segmentation", "local_window_px"), ge=1, le=1000)
    local_margin_px: int = Field(default_factory=lambda: stage_default("segmentation", "local_margin_px"), ge=0, le=1000)
    local_exclude_dark: bool = Field(default_factory=lambda: stage_default("segmentation", "local_exclude_dark"))
    line_width_px: int = Field(default_factory=lambda: stage_default("segmentation", "line_width_px"), ge=0, le=99)
    bridge_gap_px: int = Field(default_factory=lambda: stage_default("segmentation", "bridge_gap_px"), ge=0, le=99)

    @field_validator("line_width_px")
    @classmethod
    def _line_width(cls, v: int) -> int:
        if 0 < v < 3:
            raise ValueError(f"expected 0 (off) or 3-99 px, got {v}")
        return v


class Skeleton(_Strict):
    """Skeleton graph and centreline geometry; see :func:`tendrilkit.skeleton.order_skeleton`.

    ``prune_px``: spurs (endpoint-to-junction branches) shorter than this are
    removed; ``merge_width``: junctions joined by a branch shorter than this
    many tube widths are one crossing (an X crossing thins to two Y
    junctions); ``smooth_px``: Gaussian smoothing of the ordered pixel path
    (sigma, pixels of arc length); ``tip_inset``: the tip end of the path is
    extended along its tangent to the mask boundary less this many
    half-widths (1: a round tip; the base end always goes to the boundary,
    where the keep-out box cuts the tendril).
    """

    prune_px: OptionPx = Field(default_factory=lambda: stage_default("ordering", "prune_px"))
    merge_width: float = Field(default_factory=lambda: stage_default("ordering", "merge_width"), ge=0, le=1000)
    smooth_px: OptionPx = Field(default_factory=lambda: stage_default("ordering", "smooth_px"))
    tip_inset: float = Field(default_factory=lambda: stage_default("ordering", "tip_inset"), ge=0, le=1000)


class OrderingOverride(_Strict):
    """Force a decision: at the ``junction``-th decision (0-based, in the order
    met) of ``frame`` (0-based) and ``view`` (1-based), take the ``branch``-th
    candidate (0-based, candidates listed smoothest first), as recorded in the
    frame's ordering decisions."""

    frame: FrameIndex
    view: int = Field(ge=1, le=100)
    junction: int = Field(ge=0, le=10**6)
    branch: int = Field(ge=0, le=10**6)


class Ordering(_Strict):
    """Base-to-tip ordering through self-crossings; see :mod:`tendrilkit.skeleton`.

    ``method``: ``smooth`` (any number of crossings: the walk through every
    branch with the smallest total turn of the tangent at the junctions,
    tangents fitted over ``tangent_window_px`` of skeleton outside the
    junction zone) or ``paper`` (the paper's two/three sub-set cases, one
    crossing at most);
    ``zone_width``: radius of the junction zone beyond half the crossing's
    span, in tube widths (the skeleton there is replaced by a smooth bridge);
    ``max_unused_fraction``: a frame whose walk leaves more of the skeleton
    unused fails (AmbiguousOrderingError); ``overrides``: decisions forced by
    the user, ``{frame, view, junction, branch}`` entries.
    """

    method: Literal["smooth", "paper"] = Field(default_factory=lambda: stage_default("ordering", "method"))
    tangent_window_px: float = Field(default_factory=lambda: stage_default("ordering", "tangent_window_px"), gt=0,
                                     le=L.MAX_OPTION_PX)
    zone_width: float = Field(default_factory=lambda: stage_default("ordering", "zone_width"), ge=0, le=1000)
    max_unused_fraction: float = Field(default_factory=lambda: stage_default("ordering", "max_unused_fraction"), ge=0, le=1)
    overrides: list[OrderingOverride] = Field(default_factory=lambda: list(stage_default("ordering", "overrides")),
                                              max_length=100_000)


class Correspondence(_Strict):
    """Matching of the ordered curves across views (:mod:`tendrilkit.correspondence`).

    ``method``: ``epipolar`` (tendrilkit's default: a monotone matching
    minimising the epipolar distance, refined on the depth with every view
    at once; measured better on the phantoms) or ``frechet`` (the paper:
    homography of the marker's plane to the reference view and discrete
    Fréchet coupling). ``max_distance_px`` (epipolar only): the largest
    distance, pixels, of a point's epipolar line / reprojection to another
    view's curve for a match; raise it when the calibration is poor.
    ``depth_smoothing`` (epipolar only): weight of the smoothness of the
    depths along the curve relative to a typical point's own evidence; where
    the curve runs along the epipolar lines of every view the depth is
    interpolated from its neighbours whatever the weight.
    """

    method: Literal["epipolar", "frechet"] = "epipolar"
    max_distance_px: float = Field(default_factory=lambda: stage_default("correspondence", "max_distance_px"), gt=0,
                                   le=L.MAX_OPTION_PX)
    depth_smoothing: Weight = Field(default_factory=lambda: stage_default("correspondence", "depth_smoothing"))


class Reconstruction(_Strict):
    """How the 3D centreline is made (:mod:`tendrilkit.multiview`).

    ``method``: ``multiview`` (default: one 3D curve from the base fitted to
    every view's evidence at once, tracked from frame to frame, acquired
    afresh from the base when tracking is lost) or ``chain`` (each view
    segmented and ordered on its own, the 2D curves matched by
    ``correspondence.method`` and triangulated: the paper's method); ``chunk_frames`` (multiview): processed
    frames per chunk: each chunk starts by acquiring the curve, then tracks
    it, so results do not depend on the number of workers; ``segment_mm``
    (multiview): node spacing of the 3D curve, mm; ``choice_candidates``
    (multiview): how many of an acquisition's best finished hypotheses its
    final choice weighs by their local kink (6; 1: the beam's own choice, the
    default before 2026-12-01); ``front_line_contrast`` (multiview): a thin
    line inside a wide dark region (a leaf, the stem), lighter than the region
    around it in some colour channel by at least this fraction of the board's
    level there, is evidence of the tendril in front of that object
    (:func:`tendrilkit.mv_evidence.front_line_pixels`; 0.09; 0: off, the
    default before 2026-12-02); ``colour_px`` (multiview): an acquisition's
    cost, pixels per step, of a step onto a line of another colour
    (chromaticity) than the one its hypothesis followed so far: at a crossing
    the branch of the tendril's own colour wins over a shoot, a petiole or
    another tendril (:func:`tendrilkit.mv_acquire.grow_curve`; 1; 0: off, the
    default before 2026-12-02).
    """

    method: Literal["chain", "multiview"] = "multiview"
    chunk_frames: int = Field(30, ge=1)
    front_line_contrast: float = Field(0.09, ge=0, lt=1)
    segment_mm: float = Field(default_factory=lambda: stage_default("multiview", "segment_mm"), gt=0.1, le=10.0)
    choice_candidates: int = Field(default_factory=lambda: stage_default("multiview", "choice_candidates"), ge=1, le=20)
    colour_px: float = Field(default_factory=lambda: stage_default("multiview", "colour_px"), ge=0, le=20)


class Triangulation(_Strict):
    """N-view triangulation (:mod:`tendrilkit.triangulation`).

    ``refine``: Gauss-Newton refinement of the reprojection error of the
    matched points after the linear solution; ``to_curves``: then move each
    point to minimise the distance of its projections to every view's
    skeleton (across the curves, the paper's Table 1 measure). Off by
    default: with the epipolar matching it lowers that measure little (a
    miscalibrated rig leaves a residual no point can remove) and lets the
    ends slide along the curve; it rescues the Fréchet matching.
    ``base_from_marks``: the keep-out box hides the first millimetres of the
    tendril in every view; the ``base_point`` marks of the views are
    triangulated and, when they agree (reprojection within
    ``correspondence.max_distance_px``) and lie within 10 mm of the curve's
    first point without folding back, the curve is extended to them.
    """

    refine: bool = Field(default_factory=lambda: stage_default("triangulation", "refine"))
    to_curves: bool = False
    base_from_marks: bool = True


class Smoothing(_Strict):
    """Smoothing of the 3D curve before Frenet frames (:mod:`tendrilkit.frenet`).

    ``length_mm``: the half-gain wavelength of the second-order Whittaker
    smoother, mm (features shorter than about this are smoothed away; the
    lambda follows from it and the point spacing), or ``null`` (default) to
    choose it per curve from the curve's noise and coiling
    (:func:`tendrilkit.frenet.auto_smoothing_length_mm`: about 20 mm for
    0.15 mm noise on 120-200 mm tendrils at 200 points). The curvature and
    torsion it gives only place the piece-wise fit's knots; the knots are then
    fitted on the 3D points, so a strong smoothing costs little accuracy.
    """

    length_mm: Annotated[float, Field(gt=0, le=L.MAX_LENGTH_MM)] | None = Field(
        default_factory=lambda: stage_default("fit", "smoothing_length_mm"))


class Fit(_Strict):
    """Piece-wise clothoid fit (paper: Automatic Piece-Wise Fitting), :mod:`tendrilkit.pwc`.

    ``selection``: ``auto`` (the exact penalty paths of curvature and torsion,
    searched from one segment each under ``criterion``) or ``fixed``
    (``penalty_kappa`` and ``penalty_tau``); ``criterion``: ``bic`` (least
    Bayesian information criterion of the 3D residuals among the fits that
    reach ``target_r2``) or ``r2`` (the fewest segments reaching
    ``target_r2``, the paper's rule); ``target_r2``: R^2 of the 3D points
    about their mean; ``penalty_kappa``, ``penalty_tau``: dimensionless, the
    fraction of the signal's variance a new segment must explain (0.01 = 1 %);
    ``score``: ``l2`` (least squares) or ``l1`` (the paper's absolute error of
    the least-squares line); ``max_segments``: most segments per law for
    ``auto``; ``refine``: fit the knots' values and positions on the 3D points
    (tendrilkit's addition; off = the paper's curvature-space fit).
    """

    selection: Literal["auto", "fixed"] = Field(default_factory=lambda: stage_default("fit", "selection"))
    criterion: Literal["bic", "r2"] = Field(default_factory=lambda: stage_default("fit", "criterion"))
    target_r2: float = Field(default_factory=lambda: stage_default("fit", "target_r2"), gt=0, lt=1)
    penalty_kappa: Weight = Field(default_factory=lambda: stage_default("fit", "penalty_kappa"))
    penalty_tau: Weight = Field(default_factory=lambda: stage_default("fit", "penalty_tau"))
    score: Literal["l2", "l1"] = Field(default_factory=lambda: stage_default("fit", "score"))
    max_segments: int = Field(default_factory=lambda: stage_default("fit", "max_segments"), ge=1, le=1000)
    refine: bool = Field(default_factory=lambda: stage_default("fit", "refine"))


class Calibration(_Strict):
    """Marker calibration: ``bundle_adjust`` refines the rig with every
    marker that two or more views see (world marker fixed);
    ``max_corner_rms_px``: a calibration whose marker corners reproject, in
    some view, further than this (root mean square over the corners of every
    marker the view sees, pixels) has failed: the run stops with exit code 2
    naming the view and the figure (wrong intrinsics, a video of another
    size...); ``null`` accepts any calibration (the command line's
    ``--accept-calibration``); ``corner_refine``: how each marker's corners
    are measured: ``grid`` (default: one homography fitted to every
    black-white edge of the marker's cells, after ``edges``; a tighter rig,
    see the README) or ``edges`` (a straight line fitted to each side's
    sub-pixel edge points); ``average_frames``: the markers are static, so
    their corners are averaged over this many consecutive video frames from
    ``frames.start`` (fewer when the video ends), which averages out sensor
    noise, flicker and compression (1: the first frame alone)."""

    bundle_adjust: bool = True
    corner_refine: Literal["edges", "grid"] = "grid"
    average_frames: int = Field(5, ge=1, le=100)
    max_corner_rms_px: Annotated[float, Field(gt=0, le=L.MAX_OPTION_PX)] | None = 1.5


def folder_name_problem(name: str) -> str | None:
    """Why ``name`` cannot be an experiment's output folder name (None: it can).

    A name is one safe path component: 1-100 characters, none of
    ``/ \\ : * ? " < > |`` nor a control character, no surrounding spaces,
    not starting with a dot (so neither ``.`` nor ``..``).
    """
    if not isinstance(name, str) or not name:
        return "expected a non-empty text usable as a folder name"
    bad = set('/\\:*?"<>|') & set(name)
    if bad or name.strip() != name:
        return f"expected a name usable as a folder name (no {''.join(sorted(bad)) or 'surrounding spaces'})"
    if any(ord(c) < 32 or ord(c) == 127 for c in name):
        return "expected a name usable as a folder name (no control characters)"
    if name.startswith("."):
        return "expected a name usable as a folder name (not '.', '..' or starting with a dot)"
    if len(name) > 100:
        return "expected a name usable as a folder name (at most 100 characters)"
    return None


class Verification(_Strict):
    """Limits of the per-frame checks against every view and the neighbouring
    frames (:class:`tendrilkit.verify.Thresholds`, same names; the defaults and
    why are documented there). A reconstructed frame failing one is
    ``doubtful``."""

    tolerance_px: PositiveFloat = 2.0
    min_on_tendril_frac: float = Field(0.95, ge=0, le=1)
    max_off_tendril_px: PositiveFloat = 5.0
    max_skeleton_mean_px: PositiveFloat = 1.0
    coverage_tolerance_px: PositiveFloat = 4.0
    min_coverage_frac: float = Field(0.75, ge=0, le=1)
    max_tip_continuation_px: PositiveFloat = 8.0
    min_base_on_tendril_frac: float = Field(0.5, ge=0, le=1)
    max_base_px: PositiveFloat = 25.0
    min_tip_border_px: NonNegFloat = 5.0
    max_line_width_mm: PositiveFloat = 2.5
    max_length_change_pct: NonNegFloat = 5.0
    length_rate_pct_per_min: NonNegFloat = 1.0
    max_shape_change_mm: NonNegFloat = 3.0
    shape_rate_mm_per_min: NonNegFloat = 100.0
    min_pwc_r2: float = Field(0.5, le=1)
    max_tip_wide_frac: float = Field(0.5, ge=0, le=1)
    max_wide_run_px: PositiveFloat = 80.0
    min_self_distance_frac: NonNegFloat = 1.0
    max_beyond_tip_px: NonNegFloat = 10.0
    min_tip_object_px: NonNegFloat = 30.0
    max_world_marker_px: PositiveFloat = 0.5
    min_junction_turn_deg: float = Field(60.0, ge=0, le=180)
    min_junction_line_px: NonNegFloat = 15.0
    max_distal_widening: PositiveFloat = 1.5
    max_tip_tone_frac: float = Field(0.05, ge=0, le=1)
    max_off_colour_run_px: PositiveFloat = 100.0
    max_open_tip_px: NonNegFloat = 3.0
    max_unseen_detour_mm: PositiveFloat = 3.0
    max_lone_tip_px: NonNegFloat = 3.0
    max_bypass_px: NonNegFloat = 40.0


class Analysis(_Strict):
    """Which frames the sequence analyses and the paper's tables use:
    ``ok`` frames only, or also ``doubtful`` ones (``include_doubtful``)."""

    include_doubtful: bool = False


class Experiment(_Strict):
    """A validated experiment; every path is absolute."""

    name: str = Field(min_length=1, max_length=100)
    stimulation_site: Literal["S1", "S2", "S3", "S4"] | None = None
    videos: list[Path] = Field(min_length=1, max_length=100)
    fps: float = Field(ge=L.MIN_FPS, le=L.MAX_FPS)
    reference_view: int = Field(ge=1, le=100)
    frames: FrameRange = Field(default_factory=FrameRange)
    cameras: list[CameraIntrinsics] = Field(min_length=1, max_length=100)
    marker: Marker
    views: list[ViewMarks] = Field(min_length=1, max_length=100)
    points: int = Field(200, ge=10, le=L.MAX_POINTS)
    extrinsics: Extrinsics | None = None
    segmentation: Segmentation = Field(default_factory=Segmentation)
    skeleton: Skeleton = Field(default_factory=Skeleton)
    ordering: Ordering = Field(default_factory=Ordering)
    correspondence: Correspondence = Field(default_factory=Correspondence)
    reconstruction: Reconstruction = Field(default_factory=Reconstruction)
    triangulation: Triangulation = Field(default_factory=Triangulation)
    smoothing: Smoothing = Field(default_factory=Smoothing)
    fit: Fit = Field(default_factory=Fit)
    calibration: Calibration = Field(default_factory=Calibration)
    verification: Verification = Field(default_factory=Verification)
    analysis: Analysis = Field(default_factory=Analysis)

    source: Path | None = Field(None, exclude=True)

    @field_validator("name")
    @classmethod
    def _name(cls, v: str) -> str:
        problem = folder_name_problem(v)
        if problem:
            raise ValueError(problem)
        return v

    @model_validator(mode="after")
    def _counts(self, info: ValidationInfo) -> "Experiment":
        n = len(self.videos)
        if n < 2:
            raise ValueError(f"videos: expected at least 2 views, got {n}")
        for key, items in (("cameras", self.cameras), ("views", self.views)):
            if len(items) != n:
                raise ValueError(f"{key}: expected one entry per video ({n}), got {len(items)}")
            got = [it.view for it in items]
            if got != list(range(1, n + 1)):
                raise ValueError(f"{key}: expected view numbers {list(range(1, n + 1))} in order, got {got}")
        if self.reference_view > n:
            raise ValueError(f"reference_view: expected 1..{n}, got {self.reference_view}")
        if self.extrinsics is not None and len(self.extrinsics.files) != n:
            raise ValueError(f"extrinsics.files: expected one file per video ({n}), got {len(self.extrinsics.files)}")
        if not (info.context or {}).get("marks_optional"):
            for i, m in enumerate(self.views):
                for key in ("roi", "base_point"):
                    if getattr(m, key) is None:
                        raise ValueError(f"views[{i}].{key}: required key is missing (`python -m tendrilkit marks "
                                         f"EXPERIMENT.yaml` suggests the marks of every view)")
        return self

    @model_validator(mode="after")
    def _ignored(self) -> "Experiment":
        """Warn of an option the chosen reconstruction does not read (a batch would otherwise ignore it silently)."""
        if self.correspondence.method != "epipolar" and self.reconstruction.method == "multiview":
            warnings.warn(f"correspondence.method: {self.correspondence.method} is read only with "
                          "reconstruction.method: chain; the multiview reconstruction (the default) ignores it",
                          UserWarning, stacklevel=2)
        return self

    @property
    def n_views(self) -> int:
        return len(self.videos)


def _loc(loc: tuple) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


def _lookup(data: Any, loc: tuple) -> tuple[bool, Any]:
    cur = data
    for part in loc:
        try:
            cur = cur[part]
        except (KeyError, IndexError, TypeError):
            return False, None
    return True, cur


_SHAPES = {
    "roi": "4 numbers [x, y, w, h]",
    "keep_out": "4 numbers [x, y, w, h]",
    "base_point": "2 numbers [x, y]",
    "dist": "4, 5, 8, 12 or 14 coefficients in OpenCV's order (k1, k2, p1, p2, k3, ...)",
}


def _user_loc(loc: tuple, data: Any) -> tuple:
    """The part of a pydantic error location that names the user's keys.

    pydantic inserts tags such as ``constrained-int`` or ``literal['otsu']``
    for union members; they are dropped.
    """
    out: list = []
    cur = data
    for i, part in enumerate(loc):
        if isinstance(part, int) and isinstance(cur, (list, tuple)):
            out.append(part)
            cur = cur[part] if part < len(cur) else None
        elif isinstance(part, str) and isinstance(cur, dict) and part in cur:
            out.append(part)
            cur = cur[part]
        elif isinstance(part, str) and ("[" in part or "-" in part or part in ("int", "float", "str", "bool", "tuple", "list", "dict", "none")):
            continue
        else:  # a key absent from the data (missing, or under a missing parent)
            out.extend(loc[i:])
            break
    return tuple(out)


def _format_error(err: dict, data: Any) -> str:
    loc = _user_loc(tuple(err["loc"]), data)
    key = _loc(loc) or "(top level)"
    kind = err["type"]
    found, value = _lookup(data, loc)
    if kind == "extra_forbidden":
        return f"unknown key {key!r}"
    if kind in ("missing", "too_long") and loc and isinstance(loc[-1], int) or kind == "too_long":
        parent = loc[:-1] if loc and isinstance(loc[-1], int) else loc
        _, pvalue = _lookup(data, parent)
        hint = _SHAPES.get(str(parent[-1]) if parent else "", "a different number of items")
        return f"{_loc(parent)}: expected {hint} (got {short_repr(pvalue)})"
    if kind == "missing":
        hint = " (`python -m tendrilkit marks EXPERIMENT.yaml` suggests the marks of every view)" if key == "views" else ""
        return f"{key}: required key is missing{hint}"
    msg = err["msg"]
    if msg.startswith("Value error, "):
        msg = msg[len("Value error, "):]
    shown = short_repr(value) if found else "nothing"
    if kind == "value_error" and (msg.startswith(tuple(f"{k}:" for k in ("videos", "cameras", "views", "reference_view", "extrinsics.files", "marker.id")))
                                  or msg.startswith("views[")):
        return msg
    return f"{key}: {msg.lower() if msg[:1].isupper() and not msg[:2].isupper() else msg} (got {shown})"


def _lenient(data: dict) -> dict:
    """``marks_optional``: missing ``views`` entries and placeholder intrinsics (``fx: 0``) stand in."""
    data = dict(data)
    videos = data.get("videos")
    n = len(videos) if isinstance(videos, list) else 0
    if "views" not in data or data["views"] is None:
        data["views"] = [{"view": i + 1} for i in range(n)]
    cams = data.get("cameras")
    if isinstance(cams, list):
        fixed = []
        for c in cams:
            if isinstance(c, dict):
                c = dict(c)
                for k in ("fx", "fy"):
                    if c.get(k) in (0, None):
                        c[k] = 1.0  # a placeholder of `init`; marks and suggestions never use intrinsics
            fixed.append(c)
        data["cameras"] = fixed
    return data


def parse_experiment(data: Any, *, source: Path | None = None, marks_optional: bool = False) -> Experiment:
    """Validate an already-parsed experiment mapping; paths resolve against ``source``'s folder.

    ``marks_optional``: the ``views:`` marks (``roi``, ``base_point``, and the
    whole section) may be missing and the intrinsics may be ``init``'s
    placeholders (``fx: 0``); for the ``marks`` command, which suggests them.
    ``reconstruct`` and the others load strictly.
    """
    where = f"{source}: " if source is not None else ""
    if data is None:
        raise ExperimentError(f"{where}the experiment file is empty")
    if not isinstance(data, dict):
        raise ExperimentError(f"{where}expected a mapping of keys (name:, videos:, ...) at the top level, got {type(data).__name__}")
    if marks_optional:
        data = _lenient(data)
    try:
        exp = Experiment.model_validate(data, context={"marks_optional": marks_optional})
    except ValidationError as e:
        errors = e.errors()
        first = _format_error(errors[0], data)
        # a union (e.g. threshold: 'otsu' or 0-255) reports one error per member: say all of them
        key = first.split(":")[0]
        alts = [m for m in (_format_error(x, data) for x in errors[1:]) if m.split(":")[0] == key]
        if alts:
            reasons = [first.split(": ", 1)[1].rsplit(" (got ", 1)[0]] + [a.split(": ", 1)[1].rsplit(" (got ", 1)[0] for a in alts]
            first = f"{key}: {' or '.join(dict.fromkeys(reasons))} (got {first.rsplit(' (got ', 1)[1]}"
        raise ExperimentError(f"{where}{first}") from None
    base = source.parent if source is not None else Path.cwd()

    def _abs(p: Path) -> Path:
        return p if p.is_absolute() else (base / p).resolve()

    update: dict[str, Any] = {"videos": [_abs(p) for p in exp.videos], "source": source}
    if exp.extrinsics is not None:
        update["extrinsics"] = exp.extrinsics.model_copy(update={"files": [_abs(p) for p in exp.extrinsics.files]})
    return exp.model_copy(update=update)


def with_overrides(exp: Experiment, overrides: dict | None) -> Experiment:
    """The experiment with some sections changed, validated again.

    Parameters
    ----------
    exp : Experiment
    overrides : dict or None
        Section name -> dict of keys to change in that section (merged into
        it), or -> a value replacing the key whole, e.g.
        ``{"reconstruction": {"method": "chain"}, "correspondence": {"method": "frechet"}}``.

    Returns
    -------
    Experiment
        A new experiment (``exp`` itself when there is nothing to change), with ``exp``'s source.

    Raises
    ------
    ValueError
        The changed experiment does not validate (a programming mistake of the caller).
    """
    if not overrides:
        return exp
    data = exp.model_dump()
    for key, value in overrides.items():
        if isinstance(value, dict) and isinstance(data.get(key), dict):
            data[key] = {**data[key], **value}
        else:
            data[key] = value
    try:
        new = Experiment.model_validate(data)
    except ValidationError as e:
        raise ValueError(f"overrides {overrides!r} do not validate: {e}") from None
    return new.model_copy(update={"source": exp.source})


def load_experiment(path: str | Path, *, check_files: bool = True, marks_optional: bool = False) -> Experiment:
    """Read and validate an experiment YAML file.

    Parameters
    ----------
    path : str or Path
        The experiment file; relative paths inside it are relative to it.
    check_files : bool, keyword-only
        Also check that every video and extrinsics file exists.
    marks_optional : bool, keyword-only
        See :func:`parse_experiment` (the ``marks`` command).

    Raises
    ------
    ExperimentError
        With one line naming the file, the key, the value and what was expected.
    """
    path = Path(path)
    if not path.exists():
        raise ExperimentError(f"{path}: experiment file not found")
    if path.is_dir():
        raise ExperimentError(f"{path}: expected an experiment YAML file, got a folder")
    if not path.is_file():  # a device or a pipe: never read without end
        raise ExperimentError(f"{path}: expected an experiment YAML file, got a special file")
    text = read_experiment_text(path)
    data = parse_yaml(text, source=path)
    exp = parse_experiment(data, source=path.resolve(), marks_optional=marks_optional)
    if check_files:
        for i, v in enumerate(exp.videos):
            if not v.exists():
                raise ExperimentError(f"{path}: videos[{i}]: file not found: {v}")
        for i, v in enumerate(exp.videos):
            for j in range(i):
                if _same_file(v, exp.videos[j]):
                    raise ExperimentError(f"{path}: videos[{i}]: the same file as videos[{j}] ({v.name}); "
                                          f"expected one recording per view")
        if exp.extrinsics is not None:
            for i, f in enumerate(exp.extrinsics.files):
                if not f.exists():
                    raise ExperimentError(f"{path}: extrinsics.files[{i}]: file not found: {f}")
    return exp


def _same_file(a: Path, b: Path) -> bool:
    try:
        return a == b or a.samefile(b)
    except OSError:
        return False


def experiment_to_dict(exp: Experiment) -> dict:
    """The resolved experiment (defaults filled in) as plain data, for provenance."""
    return exp.model_dump(mode="json")


def views_yaml_snippet(exp: Experiment) -> str:
    """The ``views:`` section of an experiment as YAML, to paste into a params file."""
    lines = ["views:"]
    for m in exp.views:
        parts = [f"view: {m.view}", f"roi: {list(m.roi)}"]
        if m.keep_out is not None:
            parts.append(f"keep_out: {list(m.keep_out)}")
        parts.append(f"base_point: {[round(float(c), 1) for c in m.base_point]}")
        lines.append("  - {" + ", ".join(parts) + "}")
    return "\n".join(lines)


def load_intrinsics_file(path: str | Path) -> list[CameraIntrinsics]:
    """The ``cameras:`` entries of a YAML file (an intrinsics file of
    ``python -m tendrilkit intrinsics --write``, or an experiment file)."""
    import yaml

    path = Path(path)
    if not path.is_file():
        raise ExperimentError(f"{path}: intrinsics file not found")
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as e:
        raise ExperimentError(f"{path}: cannot read the intrinsics file ({e.__class__.__name__})") from None
    cams = data.get("cameras") if isinstance(data, dict) else None
    if not isinstance(cams, list) or not cams:
        raise ExperimentError(f"{path}: expected a cameras: list (written by `python -m tendrilkit intrinsics --write`)")
    out = []
    for i, c in enumerate(cams):
        try:
            out.append(CameraIntrinsics.model_validate(c))
        except ValidationError as e:
            raise ExperimentError(f"{path}: {_format_error(e.errors()[0], {'cameras': cams}).replace('(top level)', f'cameras[{i}]')}") from None
    return out
