"""Acquisition of the tendril's 3D curve from the base outward, scored on every view at once.

Used by :mod:`tendrilkit.multiview` on the first frame of a chunk and when
tracking is lost. No view's 2D ordering is used: the curve is grown in 3D from
the base point (triangulated from the marks) by a beam search,

1. *seeds*: directions on a sphere around the base; each is scored by the
   evidence of every view at 1-14 mm along it (the keep-out box hides the
   first millimetres in every view); the best few, at least 15 degrees
   apart, start a hypothesis each;
2. *growth*: every hypothesis is extended by a step of ``step_mm`` in the
   directions of a cone around its last direction; a step's cost is the mean
   over the views that see its end of the distance (pixels) of the
   projection to that view's skeleton, or a neutral cost where fewer than two
   views see it (then the evidence a few steps further on the same direction
   counts); bending and coming back within 1.2 mm of itself are penalised;
3. the ``beam`` best hypotheses (score = sum of step costs minus a reward per
   step, tips apart from each other or heading opposite ways) go on; a hypothesis with no acceptable
   step ends; the best-scoring one (the longest curve that the views explain)
   is the tendril, among those whose tip the views see (a curve that ends
   where two views' ROIs end has run onto something hanging in from outside:
   a second tendril, a petiole) unless none is half as long.

A view in which a place lies deep inside a dark region wider than a tendril
(a leaf or the stem over it, :data:`tendrilkit.mv_evidence.COVER_DEPTH_PX`) neither
sees nor contradicts it there: that part rests on the other views.

A stem stub between the ROI's edge and the keep-out box, or a leaf, ends
after a few millimetres and loses against the tendril; a crossing in one view
is decided by the others.

Tried and not kept (2026-11-30, ``benchmarks/rerun_multiview.py``, the same
harness on both sides): dropping from the beam the near copies of a better
hypothesis (a tip within 0.7-1.5 mm of its last four steps, heading the same
way) gained on dev seeds 0-27 (all three criteria 36.3 -> 39.9 % of 168
frames) but not on coil seeds 9510-9523 (29 -> 28 of 84 frames) nor on the
validation seeds 9900-9939 (34.6 -> 31.7 % of 240); fitting the best three
hypotheses that differ in 3D and keeping the one with the best precision x
coverage on every view: 36.3 -> 35.7 % on dev seeds 0-27.

Also tried and not kept (2026-11-30, issue 12; dev seeds 9980-9999, 120
frames, the same harness; before: all three 20.8 %, wrong start 12 frames,
``ok`` frames with max or an end over 2 mm 4). Careless base marks (blobs a
few pixels off in different directions) triangulate with a reprojection
error over 1 px (1.5-4.8 px on the careless scenes seen, under 0.8 px on the
others) to a point up to 2.4 mm from the base, mostly in depth; a point
1 mm beside the tendril puts the first step's midpoint on the board in two
views, every seed along the tendril ends there and the curve runs up the
stem (seed 9990). (a) Where the marks disagree by over 1 px, the first step
scored at its end only: all three 24.2 %, wrong start 6, ``ok`` off 4; but
site S3 with the marks that ``tendrilkit marks`` suggests for careless ones
(2.7 px apart) then had two frames doubtful
(``tests/test_preflight_marks.py``). Ungated: 22.5 %, ``ok`` off 6. (b) The
loose base point moved onto the axis, of the few the views agree on from
it, whose first 12 mm (fitted to every view's skeleton, extended straight
back into the keep-out box) pass nearest the marks: base within 2 mm 93.3
-> 99.2 % (seed 9986: 2.4 -> 0.2-0.8 mm), all three unchanged; on dev
seed 0 it moved a base 0.3 mm off to 2.3 mm (the first millimetres hardly
constrain depth) and frame 5 failed. (c) With (a) and (b), at most half
the beam per family of hypotheses sharing their node 8 steps back (the
other branch of a junction kept while it crosses a stretch the views see
badly; seed 9989's second tendril): mean <= 0.5 mm 69 -> 78 %, but all
three 23.3 -> 22.5 % and ``ok`` off 5 -> 9 (loops skipped by shortcuts the
views explain); 5 or 12 steps back, or all but two places per family: no
better.

Also tried and not kept (2026-11-30, issue 12; dev seeds 9240-9299, 360
frames, the same harness, with the covered gaps of ``bridge_gap``): where
no gap is found ahead of the tip, looking for it from 3 mm back along the
curve's earlier direction (the tip bent along the skeleton's spur where the
tendril enters a leaf): one frame more right on all three criteria (9282
frame 1), 5 already wrong frames changed (3 worse), for a cut-and-undo of
the curve in ``adjust_tip``; its first version cut 3 mm off free tips of
the site phantoms (a far end found on the tendril's own last millimetres).
A growth step ending on two views' dark pixels off their skeletons (the
blob where a tendril passes behind a shoot) costed by the evidence further
on, as a blind step, so that the hypothesis going straight through survives
the crossing: all three 37.2 -> 35.8 %, ``ok`` off 13 -> 15 (hypotheses
cutting through coils' blobs).
Of the 210 dev frames whose tip is still wrong after the covered gaps, 157
leave the truth (mostly in its first half: the beam takes a shoot, a
petiole, a second tendril or a coil's other pass at a crossing; in 7 of 10
such frames looked at no finished hypothesis of the beam follows the truth
5 mm further than the chosen one) and 50 stop where two views show the
board (pale tendrils the segmentation misses); none stops while two views
show the tendril going on.

Where the beam loses the truth (``benchmarks/diagnose_beam.py``, dev seeds
9240-9299, 360 frames, the acquisition alone from the cached evidence): the
chosen hypothesis follows the truth to within 2 mm of its end in 94 frames,
a finished one in 108. In the 266 others the hypothesis following the truth ended (no
acceptable step) in 123; it was dropped by the cell filter in 112 (71 to a
better sibling off the truth in the same cell, 41 to another hypothesis's
candidate), by the beam's rank in 29 (9th to 19th), by the per-parent limit
in 2; lost at a median 54 % of the tendril's length.
Tried and not kept (2026-11-30, issue 12, ``benchmarks/rerun_multiview.py
--no-fit`` on those seeds; before: all three 37.2 %, ``ok`` off 13, silent
0). Each keeps the straight-through branch alive more often but the final
choice then takes a wrong branch more often than it gains (seed 9273's
frames: a 270 mm curve onto other structures for the 186 mm tendril; gains on
9251, 9260, 9290, 9296 in all of them): (a) ``spread``: two more hypotheses
beyond the beam, each the one whose tip is farthest (at least 4 mm) from
every kept tip: 35.3 %, 0 frames gained, 7 lost; the beam-rank losses 29 ->
22, a finished hypothesis to the truth's end 108 -> 110. (b) The bending cost
measured from the last direction continued by the last turn (a tendril's
curvature goes on; a crossing shoot meets it at an angle): 32.8 % (14 gained,
30 lost, ``ok`` off 16); half the last turn: 32.5 %, silent 2; the mean turn
of the last two steps: 30.8 %, silent 3, ``ok`` off 28; the full turn with
twice the bending weight: 29.4 %, silent 1. The cone's rings are 13 degrees
apart: a hypothesis's turns jitter by as much, and continuing them runs it
off. (c) Per parent, its best child heading at least 30 degrees off its best
child kept in any cell (the branch at a junction, whose first tip is in the
same cell as the other's): 34.7 % (10 gained, 19 lost, ``ok`` off 14); 45
degrees: 34.2 %, ``ok`` off 19; validation seeds 9300-9339 (240 frames, the
re-run with the fit): all three 48.3 -> 47.1 % (6 gained, 9 lost), ``ok``
off 15 -> 13, silent 0 -> 0.

Why the truth-following hypothesis had no acceptable step (``benchmarks/diagnose_nostep.py``, the same
123 dev frames, main 45cdcbe): in 6 no hypothesis was on the truth from the first step, 15 lost it within
3 mm of its end; of the 102 others, the truth's next millimetres show the board in two views or more in 51
(pale tendrils the segmentation misses over 2-97 mm, median 15), in one view while two others see them on
their skeletons in 17 (a pale tendril beside a darker object, missed in that view over 3-29 mm: its board
vetoes every step), are dark but off the skeletons in 17 (the tendril merged with a stem's or a leaf's blob,
crossings), covered or outside the ROIs in 5, on two views' skeletons in 12 (coils' passes, the hypothesis
1-2 mm beside the truth). Where lost, the hypothesis ran a median 1.1 mm from the truth (65 of 102 over
1 mm; the views are 15 and 30 degrees apart: a millimetre in depth moves the others' projections by about
1.3 px, within ``ON_PX``), so the truth's next node lies past the cone although it turns under 10 degrees
there in 74. With a tolerance of 3 mm instead of 2 mm (``diagnose_beam``), the chosen hypothesis follows the
truth to its end in 122 frames (94), ``no step`` 135 of the 238 others. Validation seeds 1040-1079 (240
frames, totals): ``no step`` 91, 11 at the end; of 80: board in two views 35, covered 21, off the skeletons
14, one view's board 7, seen 3; 65 of the 80 in pale-tendril scenes.
Tried and not kept (``rerun_multiview.py --no-fit``, dev seeds 9240-9299; before: all three 37.2 %, within
0.5 mm 64.7 %, ``ok`` off 9): (a) one view showing the board does not veto a step where two others see new
skeleton pixels (the step costs as one no two views see, the view left out), at most 3 steps in a row:
all three 36.7 %, within 0.5 mm 60.0 % (0 frames gained, 2 lost); at most 1: 36.7 %, 61.9 % (2 gained,
4 lost); (b) a view showing the board on a light band across a dark object (:func:`light_band`) neither
sees nor contradicts a step: 35.6 %, ``ok`` off 15 (5 gained, 11 lost: seed 9273's beam walks across the
gaps between the stem and the leaves); also in a blind step's look ahead: 35.3 %. Each keeps the
truth-following hypothesis alive past a pale stretch in a few frames (gains on 9260 frames 0-1, 9251 frames
1-2) and lets wrong ones run on in more. The lever is the evidence: on the 13 dev scenes with such pale losses (78
frames), the pale segmentation options (``local_exclude_dark``, ``line_width_px`` 11) take the chosen
hypothesis to the truth's end in 16 frames (0 without), ``no step`` 71 -> 38 (board 51 -> 21, one board
17 -> 11); end to end (``--no-fit``) all three 6.4 -> 21.8 %, within 0.5 mm 67.9 -> 61.5 %, ``ok`` off 0 -> 2
(scenes chosen for their losses: not a general figure).
The final choice (issue 12, 2026-11-30, ``benchmarks/diagnose_choice.py`` on
dev seeds 9240-9299): the beam's choice is right on all three criteria in
119 of 360 frames (acquisition alone), another of its 8 best finished
hypotheses (tips 4 mm apart) while it is not in 35. ``grow_curve``'s
``candidates`` lists them for :func:`tendrilkit.multiview.reconstruct_multiview`,
which weighs their local kinks (6 listed): end to end (``rerun_multiview.py
--no-fit``) all three 37.2 -> 39.2 % (8 gained, 1 lost), mean <= 0.5 mm 64.7
-> 69.7 %, max <= 2 mm 53.1 -> 58.1 %, ``ok`` off 9 -> 9, silent 0 (the same
with the fit: ``ok`` 102 -> 101 frames, 90 -> 89 of them right on all three); validation seeds
1000-1039: all three 34.2 -> 34.2 % (3 gained, 3 lost), mean <= 0.5 mm 60.0
-> 62.1 %, ``ok`` off 6 -> 7; ``reconstruct_multiview`` 97 -> 118 ms per frame
(dev 9240-9269, half the frames acquired). With it, more diversity again: per kept
parent, its best child heading 30 degrees off its best kept one, two such
kept beyond the beam (the other branch of a junction): dev 38.6 % (19
gained, 14 lost), ``ok`` off 11: not kept. Tried and not kept: also preferring, among
the 8 fitted to the end, those with a free tip (at most one view's skeleton
1-3 mm straight on past the fitted tip): dev 136 of 360 right (18 gained, 1
lost), end to end (``rerun_multiview.py --no-fit``) all three 37.2 -> 41.9 %,
``ok`` off 9 -> 7; but on validation seeds 1000-1039 (``bench_generalize``,
240 frames) all three 34.2 -> 32.9 % (3 gained, 6 lost), mean <= 0.5 mm
60.0 -> 63.3 %, ``ok`` off 6 -> 7, and 236 against 97 ms per frame.

Why frames are wrong in the pale+kink configuration (issue 12, 2026-12-01; ``local_exclude_dark``,
``line_width_px`` 11, ``reconstruction.choice_candidates: 6``; dev seeds 1040-1079, 240 frames, all three 41.2 %;
the diagnose scripts with ``--set``). 130 of the 141 wrong frames were acquired (the previous frame not ``ok``:
40 of 170 acquired frames right, 59 of 70 tracked ones). The chosen hypothesis follows the truth to its end in
71 frames, a finished one in 77 (``diagnose_beam``); of the 169 others the truth-following hypothesis lost its
cell in 98 (58 to a sibling), had no step in 55, ranked beyond the beam in 12. In the 69 wrong acquired frames
lost at the cell filter the winner lay a median 2.2 mm from the truth and the truth's own child 1.8 mm (the
hypothesis had run beside the truth, in depth, before), half of them on unconfirmed steps (the neutral cost:
covered, pale). ``diagnose_nostep``'s board cause fell from 35 frames (the default segmentation, 0ae3e4c's
notes) to 2. Where the final curve leaves the truth (136 wrong frames not failed; what the views show of the
truth's next 1-3 mm there): covered or outside the ROIs in two views 40 (16 stop there: a coil or the tip over
a leaf, seeds 1065, 1071), dark but off the skeletons 40 (a pale tendril beside a darker shoot or leaf, the
merged blob's skeleton between them: seeds 1053, 1064, 1066, 1067), on two views' skeletons 31 (crossings: the
beam and the choice), one view's board 10, the truth's last 3 mm 10 (tips 2-4 mm off), the board 5: most of
the losses are evidence the segmentation does not give (the tendril over or beside a darker object). Within
0.5 mm fell with the pale options (67.1 -> 65.4 %; the options alone 26 frames lost, 12 gained): of the 23
frames lost, 19 are curves that had stopped 24-84 mm along the tendril (within 0.5 mm mean) and now run past
that point and leave the truth (off the skeletons 9, covered 3, crossings 4, board 3), 3 are seed 1068's (the
extension past a covered gap drifts in depth and stops, see (b) below), 1 a skeleton that now follows a shoot
beside the tendril (seed 1053).
Tried there and not kept (``rerun_multiview.py`` on those seeds, the same harness): (a) the beam's step cost
where three views see a place robust to one view (a merged blob's skeleton 4-5 px beside the tendril): the
worst view dropped, all three 41.2 -> 39.2 %, ``ok`` off 9 -> 18; the worst capped at ``ON_PX``: 39.2 %
(within 0.5 mm 65.4 -> 69.2 %), ``ok`` off 16 (wrong branches get cheaper too: the third view is what holds
the depth). (b) The tip's extension and the whole curve's refinement alternated (``multiview._fit``, up to 3
extensions while one gains 2 mm: the extension drifts 1.5-4 mm in depth past a covered gap and stops, seed
1068 frame 1 at 77 of 151 mm; refitted, it goes on to the tip): dev 1040-1079 41.2 -> 42.1 % (ends 46.7 ->
49.2 %, ``ok`` off 9 -> 12: curves now whole with the max 2.0-2.4 mm in the gap), dev 9240-9299 41.9 -> 43.1 %
(``ok`` off 13 -> 13); validation seeds 1140-1159 (``bench_generalize``, 120 frames) 35.0 -> 35.0 %, within
0.5 mm 66.7 -> 61.7 %, max 50.8 -> 45.8 %, ends 40.8 -> 43.3 %, silent 3 -> 5 (curves that had stopped short
run on onto other structures, two of them ``ok``). Only after a crossed gap: dev 1040-1079 41.7 % (``--no-fit``),
9240-9299 42.2 %, validation identical.
"""

from __future__ import annotations

import functools

import numpy as np

from numba import njit

from tendrilkit.camera import _project_brown
from tendrilkit.geometry import resample_polyline
from tendrilkit.mv_evidence import (COVER_DEPTH_PX, COVER_PX, SkeletonEvidence, _mark_point, _project_costs, mark_near,
                                    mark_near_rows, project_costs, skeleton_distance)

__all__ = ["point_costs", "grow_curve", "cone_directions", "claim", "advance", "runs_out", "bridge_gap", "light_band"]

#: The colour a hypothesis follows (``grow_curve``'s ``colour_px``): per view, the running mean of the chromaticity
#: (:attr:`SkeletonEvidence.skeleton_chroma`) at the skeleton pixels its steps land on, each step weighing
#: ``COLOUR_EMA`` (a tendril's colour changes slowly along it: younger towards the tip, shaded); a step whose
#: chromaticity differs from it by more than ``COLOUR_TOL`` (sum of the three channels' differences, the mean over the
#: views seeing it on their skeleton, two at least) pays ``colour_px`` per ``COLOUR_TOL`` beyond, up to ``COLOUR_CAP``
#: times: at a crossing, the branch of the tendril's colour wins over a shoot, a petiole or another tendril of
#: another colour. Measured 2026-12-02 (``rerun_multiview.py``, the same harness on both sides, ``colour_px`` 1):
#: dev seeds 1040-1079 (240 frames) all three criteria 48.3 -> 50.0 % (8 gained, 4 lost), mean within 0.5 mm
#: 72.9 -> 77.1 %; validation 1280-1319 47.5 -> 51.7 % (13 gained, 3 lost); coils seen end-on (dev 41-80) 15.4 -> 15.4 %;
#: held-out 10600-10639 (``bench_generalize``) 40.8 -> 42.9 % (8 gained, 3 lost); silent 0 throughout. Used as the
#: final choice's extra term instead (the chromaticity's largest jump along each finished candidate), it gained 2
#: frames of 236 at most: a candidate of the right branch is missing more often than chosen wrongly.
COLOUR_TOL = 0.06
COLOUR_EMA = 0.2
COLOUR_CAP = 2.0

#: A point's distance to a view's skeleton is capped at this (pixels).
CAP_PX = 10.0
#: The cost of a step no two views see (pixels).
NEUTRAL_PX = 2.5
#: A point within this of a view's skeleton is on it (pixels).
ON_PX = 2.5
#: A step costing more than this is not taken (pixels).
STOP_PX = 4.0
#: The cost of a step turning by the search cone's half-angle (pixels), growing with the square of the
#: angle: a fifth of ``ON_PX``, so the skeletons' bends are followed and ties are broken straight on.
TURN_PX = 0.5
#: The beam keeps, besides its best, the best child of a hypothesis heading more than this away from its best kept
#: child (degrees; :func:`_split_siblings`), up to :data:`SPLIT_EXTRA` such children a step: the branches of a
#: junction (the tendril going on, a second tendril or a shoot leaving it). Measured 2026-12-02 with
#: ``benchmarks/rerun_multiview.py`` (see the README).
SPLIT_DEG = 45.0
SPLIT_EXTRA = 4
#: A callable ``_TRACE(event, **values)`` that :func:`grow_curve` calls after every step's pruning (``"step"``: the
#: hypotheses, each candidate's hypothesis row ``own`` and tip ``pts``, the acceptable candidates best first
#: ``ranked``, those the cell filter keeps ``diverse``, those kept ``kept``; per candidate its ``cost``, ``ok``, the
#: evidence at its end and midpoint ``m_end``, ``m_mid``, ``vis``, ``confirmed``, ``contradicted``, ``tail``,
#: ``blind_tail``, the self-return penalty ``self_near``, ``dirs``; per view and end then midpoint ``d``, ``seen``,
#: ``bg``) and with its finished hypotheses (``"ends"``); ``None`` in use (``benchmarks/diagnose_beam.py`` and
#: ``diagnose_nostep.py`` set it).
_TRACE = None
#: Finished hypotheses whose tips lie closer than this are one candidate for the final choice (mm; ``grow_curve``'s
#: ``candidates``).
SAME_TIP_MM = 4.0
#: A place a view shows as board with dark pixels within this on both sides across the tendril's direction is a
#: light band across a dark object (a pale tendril over the stem or a leaf), not the open board (pixels).
BAND_PX = 6.0
#: The far end of a gap must lead on: the views see the tendril this far beyond it, straight on (mm).
LEAD_MM = np.array([1.5, 3.0])
#: A gap where the views see dark pixels off their skeletons (another thin structure crossing the tendril) is
#: at most this long (mm).
CROSSING_MM = 4.0
#: Places of a gap's far end refined at most (nearest first).
MAX_REFINED = 100
#: A gap longer than the caller's ``max_gap_mm`` (up to ``max_cover_gap_mm``) is crossed only along a chord that two
#: views or more show covered (deep inside a dark region wider than a tendril: a leaf over or under it, the stem) at
#: this fraction of its places at least, the tip's 1 mm steps up to the far end: the tendril can pass there unseen
#: (a leaf's semi-axes are 18-30 mm; dev seeds 9248, 9254, 9260: 17-25 mm covered in every view).
COVER_FRAC = 2.0 / 3.0


def point_costs(evidence: list[SkeletonEvidence], P_mm: np.ndarray, *, cap_px: float = CAP_PX, nearest: bool = False,
                covered: bool = False):
    """Distance to each view's skeleton of world points, and whether the view sees them.

    Parameters
    ----------
    evidence : list of SkeletonEvidence
    P_mm : (n, 3) float array
    cap_px : float

    Returns
    -------
    d : (V, n) float array
        Capped distance, pixels.
    seen : (V, n) bool array
        The view sees the place: inside its ROI, outside its keep-out box,
        and not covered by a leaf or the stem (``covered`` of
        :func:`tendrilkit.mv_evidence.skeleton_distance`).
    nearest : (V, n) int array
        With ``nearest``: the row of each view's ``skeleton_xy`` nearest the projection (-1: none).
    background : (V, n) bool array
        With ``nearest``: the view sees the place and shows the board there (it contradicts the point).
    covered : (V, n) bool array
        With ``covered`` (after the others): the view shows the place covered (:func:`_covered`).
    """
    P = np.asarray(P_mm, float).reshape(-1, 3)
    d = np.empty((len(evidence), len(P)))
    seen = np.empty((len(evidence), len(P)), bool)
    near = np.empty((len(evidence), len(P)), int)
    bg = np.empty((len(evidence), len(P)), bool)
    cov = np.empty((len(evidence), len(P)), bool)
    for v, ev in enumerate(evidence):
        # seen and not covered: a leaf or the stem covers the place in this view, the other views decide
        project_costs(ev, P, float(cap_px), d[v], seen[v], near[v], bg[v], cov[v])
    return (d, seen) + ((near, bg) if nearest else ()) + ((cov,) if covered else ())


def advance(evidence: list[SkeletonEvidence], A_mm: np.ndarray, B_mm: np.ndarray, *, fraction: float = 0.3) -> np.ndarray:
    """(V, n) whether the step from A to B (n, 3) moves in each image by ``fraction`` of its length seen face-on.

    A step along a view's line of sight moves its projection little: that view
    cannot confirm it (a curve running in depth where no view can see it).
    """
    A = np.asarray(A_mm, float).reshape(-1, 3)
    Bp = np.asarray(B_mm, float).reshape(-1, 3)
    L = np.linalg.norm(Bp - A, axis=1)
    out = np.empty((len(evidence), len(A)), bool)
    for v, ev in enumerate(evidence):
        cam = ev.camera
        z = Bp @ cam.R[2] + cam.t_mm[2]
        if cam.has_distortion and cam.dist.size > 5:  # OpenCV's longer models
            px = np.linalg.norm(cam.project(Bp) - cam.project(A), axis=1)
            out[v] = px >= fraction * L * cam.K[0, 0] / np.maximum(z, 1e-9)
        else:  # the same, the projections' rotation numpy's (Camera.project), the rest in one compiled call
            out[v] = _advances(Bp @ cam.R.T + cam.t_mm, A @ cam.R.T + cam.t_mm, z, L, cam.K, cam.dist,
                               cam.has_distortion, float(fraction))
    return out


@njit(cache=True)
def _advances(XB, XA, z, L, K, dist, distort, fraction):
    """:func:`advance` of one view from the camera-frame points ``XB``, ``XA`` (n, 3) of the steps' ends and
    starts, their depths ``z`` and lengths ``L`` (n,): the whole-array expressions it replaced, point by point
    in the same order (bit for bit)."""
    ub = _project_brown(XB, K, dist, distort)
    ua = _project_brown(XA, K, dist, distort)
    out = np.empty(len(L), np.bool_)
    for k in range(len(L)):
        dx = ub[k, 0] - ua[k, 0]
        dy = ub[k, 1] - ua[k, 1]
        px = np.sqrt(dx * dx + dy * dy)
        zk = z[k] if (z[k] > 1e-9 or np.isnan(z[k])) else 1e-9
        out[k] = px >= fraction * L[k] * K[0, 0] / zk
    return out


def _mean_seen(d: np.ndarray, seen: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n = seen.sum(axis=0)
    m = np.where(n > 0, (d * seen).sum(axis=0) / np.maximum(n, 1), NEUTRAL_PX)
    return m, n


def cone_directions(axis: np.ndarray, max_deg: float, rings: int = 4) -> np.ndarray:
    """Unit vectors (m, 3) on a cone of half-angle ``max_deg`` around ``axis`` (the axis first).

    The rings' angles and azimuths depend on ``max_deg`` and ``rings`` only
    (:func:`_cone_rings`, computed once); the cross products are written out
    (``np.cross``'s arithmetic, bit for bit, without its cost on 3-vectors):
    the multi-view tip's every step asks for a cone.
    """
    a = np.asarray(axis, float)
    a = a / np.linalg.norm(a)
    a0, a1, a2 = a
    if abs(a0) < 0.9:  # a x (1, 0, 0)
        p = np.array([a1 * 0.0 - a2 * 0.0, a2 * 1.0 - a0 * 0.0, a0 * 0.0 - a1 * 1.0])
    else:  # a x (0, 1, 0)
        p = np.array([a1 * 0.0 - a2 * 1.0, a2 * 0.0 - a0 * 0.0, a0 * 1.0 - a1 * 0.0])
    p /= np.linalg.norm(p)
    p0, p1, p2 = p
    q = np.array([a1 * p2 - a2 * p1, a2 * p0 - a0 * p2, a0 * p1 - a1 * p0])
    out = [a]
    for cos_th, sin_th, cos_az, sin_az in _cone_rings(float(max_deg), int(rings)):
        out.append(cos_th * a + sin_th * (cos_az * p + sin_az * q))
    return np.vstack(out)


@functools.lru_cache(maxsize=32)
def _cone_rings(max_deg: float, rings: int) -> tuple:
    """Per ring of :func:`cone_directions`: ``cos th, sin th`` and the azimuths' ``cos, sin`` as (n_az, 1) columns."""
    out = []
    for k in range(1, rings + 1):
        th = np.radians(max_deg * k / rings)
        n_az = max(6, int(round(2 * np.pi * np.sin(th) / np.radians(max_deg / rings))))
        az = 2 * np.pi * (np.arange(n_az) + 0.5 * (k % 2)) / n_az
        cos_az, sin_az = np.cos(az)[:, None], np.sin(az)[:, None]
        cos_az.flags.writeable = False
        sin_az.flags.writeable = False
        out.append((np.cos(th), np.sin(th), cos_az, sin_az))
    return tuple(out)


def _local_cone(max_deg: float, rings: int = 4) -> np.ndarray:
    return cone_directions(np.array([0.0, 0.0, 1.0]), max_deg, rings)


@njit(cache=True, error_model="numpy")
def _frames(axes):
    """Rotations (h, 3, 3) taking +z to each unit axis (h, 3) (compiled: numpy's cross products and norms, bit for
    bit)."""
    H = axes.shape[0]
    F = np.empty((H, 3, 3))
    for h in range(H):
        n = np.sqrt(axes[h, 0] * axes[h, 0] + axes[h, 1] * axes[h, 1] + axes[h, 2] * axes[h, 2])
        a0, a1, a2 = axes[h, 0] / n, axes[h, 1] / n, axes[h, 2] / n
        if abs(a0) < 0.9:
            b0, b1, b2 = 1.0, 0.0, 0.0
        else:
            b0, b1, b2 = 0.0, 1.0, 0.0
        p0 = a1 * b2 - a2 * b1
        p1 = a2 * b0 - a0 * b2
        p2 = a0 * b1 - a1 * b0
        m = np.sqrt(p0 * p0 + p1 * p1 + p2 * p2)
        p0, p1, p2 = p0 / m, p1 / m, p2 / m
        F[h, 0, 0], F[h, 1, 0], F[h, 2, 0] = p0, p1, p2
        F[h, 0, 1], F[h, 1, 1], F[h, 2, 1] = a1 * p2 - a2 * p1, a2 * p0 - a0 * p2, a0 * p1 - a1 * p0
        F[h, 0, 2], F[h, 1, 2], F[h, 2, 2] = a0, a1, a2
    return F


def claim(evidence: list[SkeletonEvidence], claims: list[np.ndarray] | None, P_mm: np.ndarray, *,
          radius_px: float = 4.0) -> list[np.ndarray]:
    """Skeleton pixels a curve explains: per view, a bool per row of ``skeleton_xy``.

    Parameters
    ----------
    evidence : list of SkeletonEvidence
    claims : list of (k_v,) bool arrays or None
        Pixels already claimed (copied, not changed); None: none.
    P_mm : (n, 3) float array
        Points of the curve, dense enough (spacing under ``radius_px`` in the images).
    radius_px : float

    Returns
    -------
    list of (k_v,) bool arrays
    """
    if claims is None:
        claims = [np.zeros(len(ev.skeleton_xy), bool) for ev in evidence]
    out = []
    P = np.asarray(P_mm, float).reshape(-1, 3)
    for ev, c in zip(evidence, claims):
        c = c.copy()
        mark_near(ev, c, ev.camera.project(P), radius_px)
        out.append(c)
    return out


@njit(cache=True)
def _nearest_distance(P, Q):
    """(n,) distance of each point P (n, 3) to the nearest of Q (m, 3), m >= 1.

    ``np.min(np.linalg.norm(P[:, None] - Q[None], axis=2), axis=1)`` without the (n, m, 3) arrays: the squares
    summed in order as numpy's reduction does, bit for bit.
    """
    out = np.empty(len(P))
    for i in range(len(P)):
        best = np.inf
        for j in range(len(Q)):
            a = P[i, 0] - Q[j, 0]
            b = P[i, 1] - Q[j, 1]
            c = P[i, 2] - Q[j, 2]
            d = np.sqrt(a * a + b * b + c * c)
            if d < best or np.isnan(d):
                best = d
                if np.isnan(d):
                    break
        out[i] = best
    return out


def _nodes_but_last(hyps: list, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The nodes of every hypothesis but its last ``k`` (those with more than ``k + 1`` nodes; none of the others),
    stacked (m, 3), and where each hypothesis's begin in the stack (len(hyps) + 1,)."""
    old = [h[0][:-k] if len(h[0]) > k + 1 else h[0][:0] for h in hyps]
    start = np.zeros(len(old) + 1, np.int64)
    start[1:] = np.cumsum([len(o) for o in old])
    return np.concatenate(old) if old else np.zeros((0, 3)), start


@njit(cache=True)
def _self_near(pts, width, old, start):
    """(n,) bool: each candidate ``pts`` (n, 3) lies within 1.2 mm of its hypothesis's nodes ``old[start[h]:start[h +
    1]]`` (the candidates of hypothesis ``h`` are the rows ``h * width`` to ``(h + 1) * width``; none without nodes):
    :func:`_nearest_distance`, per hypothesis."""
    out = np.zeros(len(pts), np.bool_)
    for h in range(len(start) - 1):
        if start[h + 1] > start[h]:
            dd = _nearest_distance(pts[h * width:(h + 1) * width], old[start[h]:start[h + 1]])
            for i in range(len(dd)):
                out[h * width + i] = dd[i] < 1.2
    return out


@njit(cache=True)
def _self_near_nodes(pts, width, nodes, k):
    """:func:`_self_near` of hypotheses with as many nodes each, ``nodes`` (h, m, 3): the candidates of hypothesis
    ``h`` (rows ``h * width`` to ``(h + 1) * width`` of ``pts``) against its nodes but the last ``k`` (none with
    ``k + 1`` nodes or fewer).

    Only the nodes that can lie within 1.2 mm are measured: a candidate ``r`` from its hypothesis's tip lies at
    least ``D - r`` from a node ``D`` from the tip (with a margin of 1e-6 mm over the roundings); the first within
    1.2 mm answers. The same answers as :func:`_nearest_distance`'s minimum under 1.2 (its distances, the same
    arithmetic); with a NaN among the nodes or the candidates, that minimum itself.
    """
    out = np.zeros(len(pts), np.bool_)
    m = nodes.shape[1]
    if m <= k + 1:
        return out
    n_old = m - k
    D = np.empty(n_old)
    for h in range(nodes.shape[0]):
        old = nodes[h, :n_old]
        t0, t1, t2 = nodes[h, m - 1, 0], nodes[h, m - 1, 1], nodes[h, m - 1, 2]
        finite = True
        for j in range(n_old):
            a = old[j, 0] - t0
            b = old[j, 1] - t1
            c = old[j, 2] - t2
            D[j] = np.sqrt(a * a + b * b + c * c)
            finite = finite and np.isfinite(D[j])
        for i in range(h * width, (h + 1) * width):
            a = pts[i, 0] - t0
            b = pts[i, 1] - t1
            c = pts[i, 2] - t2
            r = np.sqrt(a * a + b * b + c * c)
            if not (finite and np.isfinite(r)):
                out[i] = _nearest_distance(pts[i:i + 1], old)[0] < 1.2
                continue
            for j in range(n_old):
                if D[j] - r > 1.2 + 1e-6:
                    continue
                a = pts[i, 0] - old[j, 0]
                b = pts[i, 1] - old[j, 1]
                c = pts[i, 2] - old[j, 2]
                if np.sqrt(a * a + b * b + c * c) < 1.2:
                    out[i] = True
                    break
    return out


@njit(cache=True)
def _new_and_colour(d, seen, near, adv, claims, own, on_px, use_col, chroma, follow, new, step_col, dev, known):
    """One view's part of a growth step, for its ``n = len(adv)`` candidates (the first ``n`` of :func:`point_costs`'
    rows ``d``, ``seen``, ``near``; ``adv`` :func:`advance`'s row), in place: ``new`` (n,) on the view's skeleton
    (within ``on_px``) at a pixel the candidate's hypothesis (``own``) has not claimed (``claims`` (h, k)) and
    moving in the image; with ``use_col``, ``step_col`` (n, 3) the skeleton's chromaticity ``chroma`` there (NaN
    elsewhere, as given), ``known`` (n,) there and the hypothesis's colour ``follow`` (h, 3) known, and ``dev`` (n,)
    the sum of the three channels' absolute differences there (0 elsewhere): the whole-array expressions they
    replaced, point by point (``np.nan_to_num`` of the colour; the channels summed in order), bit for bit."""
    big = np.finfo(np.float64).max
    for i in range(len(adv)):
        j = near[i]
        on = seen[i] and d[i] <= on_px
        new[i] = on and not (j >= 0 and claims[own[i], j]) and adv[i]
        if use_col and on and j >= 0:
            f = follow[own[i]]
            for c in range(3):
                step_col[i, c] = chroma[j, c]
            if np.isfinite(f[0]):
                known[i] = True
                s = 0.0
                for c in range(3):
                    fc = f[c]
                    if np.isnan(fc):
                        fc = 0.0
                    elif fc == np.inf:
                        fc = big
                    elif fc == -np.inf:
                        fc = -big
                    a = abs(chroma[j, c] - fc)
                    s = a if c == 0 else s + a
                dev[i] = s
    return


@njit(cache=True)
def _step_view(Xc, XB, XA, z, L, K, dist, distort, fraction, xy, off, start, items, cell, reach, cap_px, centre,
               tangent, seen_px, near_fg, inside_px, cover_depth_px, cover_px, claims, own, on_px, use_col, chroma,
               follow, d, seen, near, bg, cov, new, step_col, dev, known):
    """One view's part of a growth step in one compiled call: :func:`tendrilkit.mv_evidence.project_costs` of the
    candidates' ends and midpoints (camera frame ``Xc``), :func:`advance` of the steps (``XB``, ``XA``, ``z``,
    ``L``) and :func:`_new_and_colour`, into the rows given; False, nothing written, where two skeleton pixels are
    equally near a point (the caller's path)."""
    if not _project_costs(Xc, K, dist, distort, xy, off, start, items, cell, reach, cap_px, centre, tangent, seen_px,
                          near_fg, inside_px, cover_depth_px, cover_px, d, seen, near, bg, cov):
        return False
    adv = _advances(XB, XA, z, L, K, dist, distort, fraction)
    _new_and_colour(d, seen, near, adv, claims, own, on_px, use_col, chroma, follow, new, step_col, dev, known)
    return True


def _step_fixed(ev: SkeletonEvidence):
    """What :func:`_step_view` reads of a view besides the step's points: ``(R.T, t, R[2], t[2], args)``, ``args``
    its arguments from ``K`` to ``cover_px``; None for OpenCV's longer distortion models (the general path)."""
    cam = ev.camera
    if cam.has_distortion and cam.dist.size > 5:
        return None
    start, items, cell = ev._grid
    return (cam.R.T, cam.t_mm, cam.R[2], cam.t_mm[2],
            (cam.K, cam.dist, cam.has_distortion, 0.3, ev.skeleton_xy, ev.offset_xy.astype(float), start, items, cell,
             ev._grid_reach, CAP_PX, ev.centre_xy, ev.tangent_xy, ev.seen, ev.near_foreground, ev.inside_px,
             COVER_DEPTH_PX, COVER_PX))


@njit(cache=True)
def _mark_projected(Xc, K, dist, distort, rows, xy, off, start, items, cell, radius, marked):
    """:func:`tendrilkit.mv_evidence.mark_near_rows` of the camera-frame points ``Xc`` (n, 3), projected as
    :meth:`~tendrilkit.camera.Camera.project` does (:func:`tendrilkit.camera._project_brown`), in one call."""
    p = _project_brown(Xc, K, dist, distort)
    for i in range(len(p)):
        _mark_point(p[i, 0], p[i, 1], xy, off, start, items, cell, radius, marked[rows[i]])


@njit(cache=True)
def _step_costs(d, seen, bg, new, neutral):
    """A growth step's costs from every view's rows (:func:`point_costs`' ``d``, ``seen``, ``bg`` (V, 2n): the
    candidates' ends, then their midpoints; ``new`` (V, n)): ``m_end``, ``m_mid`` (:func:`_mean_seen`), ``vis``,
    ``contradicted``, ``confirmed`` and ``cost`` as :func:`grow_curve`'s whole-array expressions had them (the
    views summed in order), bit for bit."""
    V, n2 = d.shape
    n = n2 // 2
    m = np.empty(n2)
    cnt = np.zeros(n2, np.int64)
    for i in range(n2):
        s = 0.0
        for v in range(V):
            x = d[v, i] * (1.0 if seen[v, i] else 0.0)
            s = x if v == 0 else s + x
            cnt[i] += seen[v, i]
        m[i] = s / max(cnt[i], 1) if cnt[i] > 0 else neutral
    vis = np.empty(n, np.bool_)
    contradicted = np.empty(n, np.bool_)
    confirmed = np.empty(n, np.bool_)
    cost = np.empty(n)
    for i in range(n):
        vis[i] = cnt[i] >= 2 and cnt[n + i] >= 2
        c = False
        k = 0
        for v in range(V):
            c = c or bg[v, i] or bg[v, n + i]
            k += new[v, i]
        contradicted[i] = c
        confirmed[i] = vis[i] and k >= 2 and not c
        h = 0.5 * (m[i] + m[n + i])
        cost[i] = h if (confirmed[i] or h >= neutral or np.isnan(h)) else neutral
    return m[:n], m[n:], vis, contradicted, confirmed, cost


@njit(cache=True)
def _step_finish(cost, use_col, dev, known, colour_px, tol, cap, turn, cone_deg, turn_px, self_near, confirmed, vis,
                 contradicted, own, h_score, h_tail, h_blind, neutral, stop_px, max_unseen):
    """The rest of a growth step's cost, per candidate, and what follows from it: the colour (per view ``dev``,
    ``known`` of :func:`_new_and_colour`, with ``use_col``), the bending (``turn`` degrees; none when empty), the
    self-return; the tails, acceptance ``ok``, ``score``, and per hypothesis whether it has an acceptable step
    (``has``). Returns ``(cost, tail, blind_tail, ok, score, has)``: :func:`grow_curve`'s whole-array expressions,
    point by point in the same order (the views summed in order; ``np.clip``, ``np.where``), bit for bit."""
    n = len(cost)
    out = cost.copy()
    tail = np.empty(n, np.int64)
    blind_tail = np.empty(n, np.int64)
    ok = np.empty(n, np.bool_)
    score = np.empty(n)
    has = np.zeros(len(h_score), np.bool_)
    V = dev.shape[0]
    for i in range(n):
        c = out[i]
        if use_col:
            s = 0.0
            k = 0.0
            for v in range(V):
                s = s + (dev[v, i] if known[v, i] else 0.0)
                k = k + (1.0 if known[v, i] else 0.0)
            off = s / max(k, 1.0) if k >= 2 else 0.0
            x = (off - tol) / tol
            if x < 0.0:
                x = 0.0
            if x > cap:
                x = cap
            c = c + colour_px * x
        if len(turn):
            t = turn[i] / cone_deg
            c = c + turn_px * (t * t)
        c = c + (5.0 if self_near[i] else 0.0)
        out[i] = c
        h = own[i]
        tail[i] = 0 if confirmed[i] else h_tail[h] + 1
        blind_tail[i] = 0 if (confirmed[i] or vis[i]) else h_blind[h] + 1
        ok[i] = c <= stop_px and blind_tail[i] <= max_unseen and tail[i] <= 3 * max_unseen and not contradicted[i]
        score[i] = h_score[h] + c - neutral
        if ok[i]:
            has[h] = True
    return out, tail, blind_tail, ok, score, has


@njit(cache=True)
def _per_parent(idx, own, n_parents, per_parent, beam):
    """The rows ``idx`` (best first) kept while their parent ``own[i]`` has fewer than ``per_parent`` kept, up to
    ``beam`` rows, in order."""
    return _per_parent_counted(idx, own, np.zeros(n_parents, np.int64), per_parent, beam)


@njit(cache=True)
def _per_parent_counted(idx, own, count, per_parent, most):
    """:func:`_per_parent` from the children each parent has kept already, ``count`` (updated in place): up to
    ``most`` rows more."""
    out = np.empty(min(len(idx), most), np.int64)
    k = 0
    for i in idx:
        if k == most:
            break
        if count[own[i]] < per_parent:
            out[k] = i
            k += 1
            count[own[i]] += 1
    return out[:k]


def _split_siblings(rows: np.ndarray, own: np.ndarray, dirs: np.ndarray, cos_max: float) -> np.ndarray:
    """``rows`` (kept candidates, increasing: best first) with, per parent, its best child heading another way.

    Parameters
    ----------
    rows : (k,) int array
        What :func:`_one_per_cell_and_way` keeps of the candidates (sorted best first).
    own : (n,) int array
        Each candidate's parent hypothesis.
    dirs : (n, 3) float array
        Their last steps' unit directions.
    cos_max : float
        The cosine of :data:`SPLIT_DEG`.

    Returns
    -------
    (k',) int array
        Increasing rows: ``rows`` and, for every parent whose best child is kept and that has no kept child heading
        more than :data:`SPLIT_DEG` away from it, its best child that does (after the kept one in rank), if any. At
        a junction the branches' first steps lie within a cell of each other and head within 90 degrees of each
        other: without it the branch that scores worse for a step or two (its next steps over a stretch the views
        see badly) loses its cell to its sibling and is gone from the beam.
    """
    return _siblings(rows, own, dirs, cos_max)[0]


def _siblings(rows: np.ndarray, own: np.ndarray, dirs: np.ndarray, cos_max: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`_split_siblings`'s rows and, apart, the rows it adds to ``rows`` (increasing), compiled but for the
    directions' products (numpy's, as before): the numpy expressions' rows (``np.unique``'s first rows per parent)."""
    rows = np.asarray(rows, np.int64)
    if len(rows) == 0:
        return rows, rows
    f = _first_kept(rows, own)
    return _split_rows(rows, own, f, np.einsum("ij,ij->i", dirs, dirs[np.maximum(f, 0)]) < cos_max)


@njit(cache=True)
def _first_kept(rows, own):
    """(n,) int: per candidate (parent ``own``), its parent's first row in ``rows`` (-1: none)."""
    first = np.full(own.max() + 1, -1, np.int64)
    for r in rows:
        if first[own[r]] < 0:
            first[own[r]] = r
    f = np.empty(len(own), np.int64)
    for i in range(len(own)):
        f[i] = first[own[i]]
    return f


@njit(cache=True)
def _split_rows(rows, own, f, away):
    """:func:`_siblings` from each candidate's parent's first kept row ``f`` and whether it heads ``away`` from it:
    ``(both, extra)``, the rows kept with those added and those added, increasing."""
    n = len(own)
    n_par = own.max() + 1
    kept = np.zeros(n, np.bool_)
    for r in rows:
        kept[r] = True
    split = np.zeros(n_par, np.bool_)  # the parents with a kept child the other way already
    for i in range(n):
        if f[i] >= 0 and away[i] and kept[i]:
            split[own[i]] = True
    taken = np.zeros(n_par, np.bool_)
    extra = np.empty(n, np.int64)
    k = 0
    for i in range(n):  # per parent its first such candidate
        if f[i] >= 0 and away[i] and not kept[i] and not split[own[i]] and i > f[i] and not taken[own[i]]:
            taken[own[i]] = True
            extra[k] = i
            k += 1
    extra = extra[:k]
    return np.sort(np.concatenate((rows, extra))), extra


def _sphere(n: int) -> np.ndarray:
    i = np.arange(n) + 0.5
    phi = np.arccos(1 - 2 * i / n)
    th = np.pi * (1 + 5 ** 0.5) * i
    return np.c_[np.cos(th) * np.sin(phi), np.sin(th) * np.sin(phi), np.cos(phi)]


def _seeds(evidence, base_mm, n_seeds: int) -> np.ndarray:
    dirs = _sphere(400)
    r = np.arange(1.0, 15.0)
    P = base_mm + (dirs[:, None, :] * r[None, :, None]).reshape(-1, 3)
    d, seen = point_costs(evidence, P)
    m, n = _mean_seen(d, seen)
    c = np.where(n >= 2, m, NEUTRAL_PX).reshape(len(dirs), len(r)) - NEUTRAL_PX
    score = c.sum(axis=1)
    order = np.argsort(score, kind="stable")
    chosen: list[int] = []
    for i in order:
        if score[i] >= 0:
            break
        if all(dirs[i] @ dirs[j] < np.cos(np.radians(15)) for j in chosen):
            chosen.append(int(i))
        if len(chosen) == n_seeds:
            break
    return dirs[chosen]


def _one_per_cell_and_way(P_mm: np.ndarray, dirs: np.ndarray, cell_mm: float) -> np.ndarray:
    """Rows to keep of candidates sorted best first: per cell, the best, and the best heading against it.

    Parameters
    ----------
    P_mm : (n, 3) float array
        Candidates' tips, best first.
    dirs : (n, 3) float array
        Their last steps' unit directions.
    cell_mm : float
        Side of the cubic cells.

    Returns
    -------
    (k,) int array
        Increasing rows: in each cell the first candidate and the first whose
        direction makes more than 90 degrees with it. Two passes of a coil over
        the same place in all views (a self-crossing seen face-on everywhere)
        run opposite ways there: the one going on and the one coming back do
        not compete for one cell. Directions within 90 degrees of each other
        still do (cells split by finer headings keep near copies of one path,
        which crowd out the other branches).
    """
    cell = np.floor(np.asarray(P_mm, float) / cell_mm).astype(np.int64)
    if len(cell) == 0:
        return np.zeros(0, int)
    # per row the first row of its cell (compiled: a hash of the cells, in one pass over the rows; the same groups
    # as the rows' np.unique(axis=0)), then the rows heading against it (numpy's products, as before)
    lead = _cell_leads(cell)
    against = np.einsum("ij,ij->i", dirs, dirs[lead]) < 0.0
    return _first_against(lead, against)


@njit(cache=True)
def _cell_leads(cell):
    """(n,) int: per row of ``cell`` (n, 3) int, the first row with the same three integers (itself if none before)."""
    n = len(cell)
    size = 1
    while size < 2 * n:
        size *= 2
    table = np.full(size, -1, np.int64)  # open addressing: a row per used slot
    lead = np.empty(n, np.int64)
    for i in range(n):
        a, b, c = cell[i, 0], cell[i, 1], cell[i, 2]
        k = ((a * 73856093) ^ (b * 19349663) ^ (c * 83492791)) & (size - 1)
        while True:
            j = table[k]
            if j < 0:
                table[k] = i
                lead[i] = i
                break
            if cell[j, 0] == a and cell[j, 1] == b and cell[j, 2] == c:
                lead[i] = j
                break
            k = (k + 1) & (size - 1)
    return lead


@njit(cache=True)
def _first_against(lead, against):
    """Increasing rows: each cell's first row (``lead[i] == i``) and its first row ``against`` it."""
    n = len(lead)
    taken = np.zeros(n, np.bool_)  # per first row: its cell's row against it found
    keep = np.zeros(n, np.bool_)
    for i in range(n):
        if lead[i] == i:
            keep[i] = True
        elif against[i] and not taken[lead[i]]:
            taken[lead[i]] = True
            keep[i] = True
    return np.flatnonzero(keep)


def grow_curve(evidence: list[SkeletonEvidence], base_mm: np.ndarray, *, step_mm: float = 2.0, beam: int = 8,
               n_seeds: int = 6, cone_deg: float = 40.0, max_length_mm: float = 400.0,
               max_unseen_steps: int = 6, candidates: int = 1, colour_px: float = 0.0):
    """Grow the tendril's 3D curve from the base by a beam search on every view's evidence.

    Parameters
    ----------
    evidence : list of SkeletonEvidence
        Every usable view (two or more).
    base_mm : (3,) float array
        The base point, world mm.
    step_mm : float
        Length of a growth step, mm.
    beam : int
        Hypotheses kept after every step (and up to :data:`SPLIT_EXTRA` more: a junction's other branches).
    n_seeds : int
        Starting directions.
    cone_deg : float
        Largest turn per step, degrees.
    max_length_mm : float
    max_unseen_steps : int
        Consecutive steps that fewer than two views see (keep-out box,
        occlusion) before a hypothesis ends; three times as many steps
        that the views see on pixels the curve explained already (passes
        running over each other in two views).
    candidates : int
        With more than one: the finished hypotheses the choice weighs, up to
        this many (see Returns).
    colour_px : float
        Cost (pixels, per step, up to :data:`COLOUR_CAP` times it) of a step
        onto a line of another colour than the one its hypothesis followed so
        far (every view's :attr:`SkeletonEvidence.skeleton_chroma` needed; 0:
        off); see :data:`COLOUR_TOL`.

    Returns
    -------
    (m, 3) float array
        The best hypothesis's nodes, ``step_mm`` apart, base first (at least
        the base and one step; trailing unseen steps removed).
    list of ((m, 3) float array, float)
        With ``candidates`` over one: nodes and score (lower is better) of
        the best hypothesis and of the next best, in score order, among the
        eligible ones (those the best is chosen from), each ending at least
        ``SAME_TIP_MM`` from every tip listed before it.
    """
    B = np.asarray(base_mm, float)
    seeds = _seeds(evidence, B, n_seeds)
    if len(seeds) == 0:
        none_ = np.vstack([B, B])  # nothing any two views agree on
        return none_ if candidates <= 1 else [(none_, 0.0)]
    # the hypotheses, a row each (they all have as many nodes): nodes (h, m, 3), score, unconfirmed tail, last
    # direction, blind tail and, per view, the colour (chromaticity) followed so far (h, V, 3; NaN: none seen yet);
    # claims: per view, the skeleton pixels each hypothesis explains (a row per hypothesis, a column per pixel)
    V = len(evidence)
    use_col = colour_px > 0 and all(ev.skeleton_chroma is not None for ev in evidence)
    H = len(seeds)
    nodes = np.broadcast_to(B, (H, 1, 3)).copy()
    h_score = np.zeros(H)
    h_tail = np.zeros(H, np.int64)
    lasts = np.array(seeds, float)
    h_blind = np.zeros(H, np.int64)
    h_col = np.full((H, V, 3), np.nan)
    claims = [np.zeros((len(seeds), len(ev.skeleton_xy)), bool) for ev in evidence]
    no_chroma = np.zeros((0, 3))
    # per view, what its compiled step reads (None: OpenCV's longer models, the general path)
    fixed = [_step_fixed(ev) for ev in evidence]
    f_claim = np.linspace(0, 1, 5)[:, None]
    split_cos = np.cos(np.radians(SPLIT_DEG))
    finished: list[tuple[np.ndarray, float, int]] = []
    look = np.array([2.0, 3.0, 4.0])
    cone = _local_cone(cone_deg, 3)
    narrow = _local_cone(20.0, 2)
    for _ in range(int(max_length_mm / step_mm)):
        H, m_nodes = nodes.shape[:2]
        first = m_nodes == 1
        local = narrow if first else cone
        dirs = np.einsum("hij,cj->hci", _frames(lasts), local).reshape(-1, 3)
        own = np.repeat(np.arange(H), len(local))
        tips_h = nodes[:, -1]
        A = tips_h[own]
        pts = A + step_mm * dirs
        N = len(pts)
        mids = pts - 0.5 * step_mm * dirs
        # per view, in one compiled call: point_costs of the ends and midpoints, new evidence (on its skeleton at a
        # pixel this hypothesis has not explained already, the step moving in its image: advance), the colour there
        # and its difference to the hypothesis's
        P2 = np.vstack([pts, mids])
        L = np.linalg.norm(pts - A, axis=1)
        d = np.empty((V, 2 * N))
        seen = np.empty((V, 2 * N), bool)
        near = np.empty((V, 2 * N), np.int64)
        bg = np.empty((V, 2 * N), bool)
        cov = np.empty(2 * N, bool)
        new = np.empty((V, N), bool)
        step_col = np.full((V, N, 3), np.nan)
        col_dev = np.zeros((V, N))
        col_known = np.zeros((V, N), bool)
        for v, ev in enumerate(evidence):
            chroma = ev.skeleton_chroma if use_col else no_chroma
            done = False
            if fixed[v] is not None:  # (the rotations numpy's, as there)
                RT, t, R2, t2, args = fixed[v]
                done = _step_view(P2 @ RT + t, pts @ RT + t, A @ RT + t, pts @ R2 + t2, L, *args, claims[v], own,
                                  ON_PX, use_col, chroma, h_col[:, v], d[v], seen[v], near[v], bg[v], cov, new[v],
                                  step_col[v], col_dev[v], col_known[v])
            if not done:  # OpenCV's longer models, or two skeleton pixels equally near a point (the k-d tree's)
                project_costs(ev, P2, CAP_PX, d[v], seen[v], near[v], bg[v], cov)
                _new_and_colour(d[v], seen[v], near[v], advance([ev], A, pts)[0], claims[v], own, ON_PX, use_col,
                                chroma, h_col[:, v], new[v], step_col[v], col_dev[v], col_known[v])
        m_end, m_mid, vis, contradicted, confirmed, cost = _step_costs(d, seen, bg, new, NEUTRAL_PX)
        blind = ~vis
        if blind.any():  # fewer than two views see it: the evidence further along the direction
            ahead = pts[blind][:, None, :] + step_mm * (look[None, :, None] - 1) * dirs[blind][:, None, :]
            da, sa = point_costs(evidence, ahead.reshape(-1, 3))
            ma, na = _mean_seen(da, sa)
            cost[blind] = 0.5 * (NEUTRAL_PX + np.where(na >= 2, ma, NEUTRAL_PX).reshape(-1, len(look)).mean(axis=1))
        # bending (after the first step): the turn from the hypothesis's last direction, degrees
        turn = (np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", dirs, lasts[own]), -1, 1))) if not first
                else np.zeros(0))
        # self-avoidance: a candidate within 1.2 mm of its hypothesis's nodes but the last five
        self_near = _self_near_nodes(pts, len(local), nodes, 5)
        # a step onto a line of another colour than its hypothesis's so far (a shoot, another tendril); the bending
        # and self-return costs; steps no two views see (keep-out box, occlusion): at most max_unseen_steps in a row;
        # steps the views see on pixels the curve explained already (passes over each other in two views): three
        # times more
        cost, tail, blind_tail, ok, score, has = _step_finish(
            cost, use_col, col_dev, col_known, float(colour_px), COLOUR_TOL, COLOUR_CAP, turn, float(cone_deg),
            TURN_PX, self_near, confirmed, vis, contradicted, own, h_score, h_tail, h_blind, NEUTRAL_PX, STOP_PX,
            int(max_unseen_steps))
        for h in np.flatnonzero(~has).tolist():
            finished.append((nodes[h].copy(), float(h_score[h]), int(h_tail[h])))
        idx = np.flatnonzero(ok)
        idx = idx[np.argsort(score[idx], kind="stable")]
        ranked = idx
        # diversity: per cell of 1.5 steps the best hypothesis and the best heading against it, at most two
        # children per parent, so that the branches of a crossing both stay in the beam; and besides the beam, up to
        # SPLIT_EXTRA children heading over SPLIT_DEG away from their parent's best kept one (a junction's branches)
        rows = _one_per_cell_and_way(pts[idx], dirs[idx], 1.5 * step_mm)
        both, extra = _siblings(rows, own[idx], dirs[idx], split_cos)  # rank order
        diverse = idx[both]  # (the trace's)
        split = idx[extra]
        count = np.zeros(H, np.int64)  # children kept per parent, the beam's and then the split's
        idx = _per_parent_counted(idx[rows], own, count, 2, beam)
        if len(split):  # the junctions' other branches besides the beam, not instead of its best
            idx = np.concatenate((idx, _per_parent_counted(split, own, count, 2, SPLIT_EXTRA)))
        if _TRACE is not None:
            hyps = [(nodes[h], float(h_score[h]), int(h_tail[h]), lasts[h], h, int(h_blind[h]), h_col[h])
                    for h in range(H)]
            _TRACE("step", hyps=hyps, own=own, pts=pts, ranked=ranked, diverse=diverse, kept=idx, cost=cost, ok=ok,
                   m_end=m_end, m_mid=m_mid, vis=vis, confirmed=confirmed, contradicted=contradicted,
                   blind_tail=blind_tail, tail=tail, self_near=self_near, dirs=dirs, d=d, seen=seen, bg=bg)
        # claim what each kept hypothesis explained two steps back (all at once: one projection per view)
        par = own[idx]
        claims = [c[par] for c in claims]  # each kept candidate starts from its parent's claims
        if m_nodes >= 3 and len(idx):
            a, b = nodes[par, -3], nodes[par, -2]
            P = (a[:, None, :] + f_claim[None] * (b - a)[:, None, :]).reshape(-1, 3)
            rows = np.repeat(np.arange(len(idx), dtype=np.int64), len(f_claim))
            for v, ev in enumerate(evidence):
                if fixed[v] is not None:  # projected and marked in one compiled call (Camera.project's arithmetic)
                    RT, t, _, _, args = fixed[v]
                    _mark_projected(P @ RT + t, args[0], args[1], args[2], rows, args[4], args[5], args[6], args[7],
                                    args[8], 4.0, claims[v])
                else:
                    mark_near_rows(ev, claims[v], rows, ev.camera.project(P), 4.0)
        follow = h_col[par]
        if use_col:  # each kept step's views that see it on their skeleton update its colour (a running mean)
            sc = step_col.transpose(1, 0, 2)[idx]
            h_col = np.where(np.isfinite(sc), np.where(np.isfinite(follow), (1.0 - COLOUR_EMA) * follow
                                                       + COLOUR_EMA * sc, sc), follow)
        else:
            h_col = follow
        grown = np.empty((len(idx), m_nodes + 1, 3))
        grown[:, :m_nodes] = nodes[par]
        grown[:, m_nodes] = pts[idx]
        nodes, h_score, h_tail, lasts, h_blind = grown, score[idx], tail[idx], dirs[idx], blind_tail[idx]
        if not len(idx):
            break
    finished.extend((nodes[h], float(h_score[h]), int(h_tail[h])) for h in range(len(nodes)))

    return _best_finished(evidence, finished, step_mm, candidates)



def _best_finished(evidence: list[SkeletonEvidence], finished: list, step_mm: float, candidates: int):
    """:func:`grow_curve`'s result from its finished hypotheses ``(nodes, score, unconfirmed tail)``: each without
    its unconfirmed tail, the best-scoring one among those whose tip the views see (not run out of two views'
    ROIs) and at least half as long as the longest (all of them if none is), and with ``candidates`` over one the
    next best ones, tips ``SAME_TIP_MM`` apart (see :func:`grow_curve`'s Returns)."""
    def trimmed(h):
        nodes, score, tail = h
        keep = len(nodes) - tail
        return nodes[:max(keep, 2)], score

    ends = [trimmed(h) for h in finished]
    cut = runs_out(evidence, [np.asarray(n, float) for n, _ in ends], step_mm)
    length = np.array([len(n) for n, _ in ends], float)
    inside = [e for e, c, n in zip(ends, cut, length) if not c and n >= 0.5 * length.max()]
    best = min(inside or ends, key=lambda t: t[1])
    if _TRACE is not None:
        _TRACE("ends", ends=ends, cut=cut, best=best)
    if candidates <= 1:
        return np.asarray(best[0], float)
    listed = [best]
    for e in sorted(inside or ends, key=lambda t: t[1]):
        if len(listed) == candidates:
            break
        if all(np.linalg.norm(np.asarray(e[0][-1]) - np.asarray(o[0][-1])) >= SAME_TIP_MM for o in listed):
            listed.append(e)
    return [(np.asarray(n, float), float(sc)) for n, sc in listed]


def light_band(evidence: list[SkeletonEvidence], A_mm: np.ndarray, P_mm: np.ndarray, *,
               reach_px: float = BAND_PX) -> np.ndarray:
    """(V, n) whether each point lies, in each view, on a light band across a dark object (dark on both sides).

    A pale tendril over a darker object (the stem, a leaf) looks like the
    board there: the object's pixels are cut by a light band, the tendril
    itself. A place the view shows as board is such a band when dark pixels
    (``near_foreground``) lie within ``reach_px`` of it on both sides across
    the line from A to it (the tendril's direction); a free tip over the
    open board has board on both sides, a tendril along an edge on one.

    Parameters
    ----------
    evidence : list of SkeletonEvidence
    A_mm : (3,) or (n, 3) float array
        Where the line comes from (the tip), world mm.
    P_mm : (n, 3) float array
        The points, world mm.
    reach_px : float

    Returns
    -------
    (V, n) bool array
        False where the point does not project on the view's crop.
    """
    P = np.asarray(P_mm, float).reshape(-1, 3)
    A0 = np.asarray(A_mm, float).reshape(-1, 3)
    k = np.arange(1.0, reach_px + 1e-9)
    out = np.zeros((len(evidence), len(P)), bool)
    for v, ev in enumerate(evidence):
        uA, uP = ev.camera.project(A0), ev.camera.project(P)
        t = uP - uA
        t = t / np.maximum(np.linalg.norm(t, axis=1, keepdims=True), 1e-9)
        # the samples ``k`` px across the line on either side (the normal (-t_y, t_x)), on near_foreground
        out[v] = _band(uP, t, k, ev.near_foreground, ev.offset_xy.astype(float))
    return out


@njit(cache=True)
def _band(uP, t, k, mask, off):
    """(n,) bool: :func:`light_band` of one view from the points ``uP`` (n, 2) and the unit directions ``t`` (n, 2):
    ``mask`` (:func:`_on_crop_mask`'s nearest pixel) at ``uP + (sign * k) * (-t_y, t_x)`` holds for some ``k`` on
    both sides (``sign`` 1 and -1); the whole-array expressions it replaced, point by point (bit for bit)."""
    h, w = mask.shape
    out = np.zeros(len(uP), np.bool_)
    for i in range(len(uP)):
        both = True
        for sign in (1.0, -1.0):
            hit = False
            for j in range(len(k)):
                s = sign * k[j]
                qx = uP[i, 0] + s * (-t[i, 1]) - off[0]
                qy = uP[i, 1] + s * t[i, 0] - off[1]
                if not (np.isfinite(qx) and np.isfinite(qy)):
                    continue
                rx = np.rint(qx)
                ry = np.rint(qy)
                if rx >= 0 and ry >= 0 and rx < w and ry < h and mask[int(ry), int(rx)]:
                    hit = True
                    break
            if not hit:
                both = False
                break
        out[i] = both
    return out


def _on_crop_mask(mask: np.ndarray, offset_xy: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """``mask`` (a view's crop) at full-image pixels ``xy`` (..., 2), nearest pixel; False off the crop or NaN."""
    q = np.asarray(xy, float) - offset_xy
    good = np.all(np.isfinite(q), axis=-1)
    xi = np.rint(np.where(good, q[..., 0], -1.0)).astype(np.int64)
    yi = np.rint(np.where(good, q[..., 1], -1.0)).astype(np.int64)
    h, w = mask.shape
    good &= (xi >= 0) & (yi >= 0) & (xi < w) & (yi < h)
    out = np.zeros(good.shape, bool)
    out[good] = mask[yi[good], xi[good]]
    return out


def _covered(evidence: list[SkeletonEvidence], P_mm: np.ndarray, known: np.ndarray | None = None) -> np.ndarray:
    """(V, n) whether each view shows each point covered (:func:`tendrilkit.mv_evidence.skeleton_distance`'s
    ``covered``: deep inside a dark region wider than a tendril, off the skeleton); ``known``: these, read by
    :func:`point_costs` (``covered=True``) at the same points, returned as they are."""
    if known is not None:
        return known
    P = np.asarray(P_mm, float).reshape(-1, 3)
    return np.array([skeleton_distance(ev, ev.camera.project(P), outside_px=CAP_PX, index=True)[5] for ev in evidence])


def bridge_gap(evidence: list[SkeletonEvidence], curve_mm: np.ndarray, tangent: np.ndarray, *,
               max_gap_mm: float, cone_deg: float = 30.0, step_mm: float = 1.0,
               coarse_px: float = 6.0, max_cover_gap_mm: float | None = None) -> np.ndarray | None:
    """Where the tendril comes out again after a part that two views do not see on their skeletons (None: nowhere).

    A tendril under a leaf in every view, or under leaves, has a gap in
    which no two views see it; a pale tendril over the stem looks like the
    board where it crosses it (a light band across the stem,
    :func:`light_band`); where another thin structure crosses it the views
    see dark pixels off its skeleton. Past the gap the views see it again.
    Straight chords from the tip within ``cone_deg`` of its tangent are
    followed in steps of ``step_mm`` up to ``max_gap_mm``:

    - 1-3 mm ahead of the tip, two views or more must not see the tendril
      (covered by something wider than a tendril, outside their ROIs, or a
      light band across a dark object), and fewer than two show the open
      board (a free tip ends there); or, counting as not seeing it too, views
      that see dark pixels off their skeletons there (another thin structure
      crossing it) and views that see it on their skeletons (the extension
      stopped where a third showed the board: a pale tendril lost at a
      crossing in that view): then the gap is at most ``CROSSING_MM``;
    - a chord ends where two views show the open board on it (the tendril
      cannot pass there unseen; one view may, a pale tendril looking like
      the board; a light band across a dark object does not end it);
    - beyond ``max_gap_mm`` (up to ``max_cover_gap_mm``: a long leaf over or
      under the tendril) a chord goes on only where two views show it covered
      at ``COVER_FRAC`` of its places up to there at least;
    - its places that two views see within ``coarse_px`` of skeleton pixels
      the curve has not explained are refined on a finer cone, nearest
      first; a refined place is a far end if two views or more see it within
      ``ON_PX`` of their skeletons and every other view cannot see it
      (covered, outside its ROI): two views alone agree on ghosts (any pixel
      of one view's skeleton has an epipolar line that meets the other's
      somewhere), so a third view that sees the place must confirm it. It
      must lie within the cone and lead on: two views (and every view that
      sees them) have the tendril ``LEAD_MM`` beyond it straight on, within
      ``2 ON_PX`` (not a stub of the object crossed). Of the far ends within
      a step of the nearest, the one nearest the views' skeletons there and
      ahead wins.

    Parameters
    ----------
    evidence : list of SkeletonEvidence
    curve_mm : (m, 3) float array
        The curve so far, base first, its tip last: the skeleton pixels it
        explains (:func:`claim`) are not a far end.
    tangent : (3,) float array
        Direction of the curve at the tip.
    max_gap_mm, cone_deg, step_mm, coarse_px : float
    max_cover_gap_mm : float, optional
        Longest gap along a chord two views show covered (None: ``max_gap_mm``).

    Returns
    -------
    (3,) float array or None
        The gap's far end, world mm.
    """
    curve = np.asarray(curve_mm, float)
    tip = curve[-1]
    t = np.asarray(tangent, float) / max(np.linalg.norm(tangent), 1e-12)
    # the tip must end in a place two views do not see on their skeletons (not on the open board: a free tip)
    near_dirs = cone_directions(t, 30.0, 2)
    Q = (tip + near_dirs[:, None, :] * np.array([1.0, 2.0, 3.0])[None, :, None]).reshape(-1, 3)
    d_q, seen_q, _, bg_q = point_costs(evidence, Q, nearest=True)
    band_q = bg_q & light_band(evidence, tip, Q)
    open_q = bg_q & ~band_q
    absent = ~seen_q | band_q  # covered, outside the ROI, or a light band across a dark object
    free = open_q.sum(axis=0) < 2
    if not np.any((absent.sum(axis=0) >= 2) & free):
        # or dark but off the skeleton (another thin structure crossing it): a crossing is short
        dark = np.array([_on_crop_mask(ev.foreground, ev.offset_xy, ev.camera.project(Q)) for ev in evidence])
        # or two views see it on their skeletons a little further (the extension stopped where a third showed the
        # board: a pale tendril lost at a crossing in that view)
        on_q = seen_q & (d_q <= ON_PX) & ~bg_q
        if not np.any(((absent | (dark & (d_q > ON_PX)) | on_q).sum(axis=0) >= 2) & free):
            return None
        max_gap_mm = max_cover_gap_mm = min(max_gap_mm, CROSSING_MM)
    long_mm = max(max_gap_mm, max_cover_gap_mm if max_cover_gap_mm is not None else max_gap_mm)
    claims = claim(evidence, None, resample_polyline(curve, step=0.25))
    dirs = cone_directions(t, cone_deg, 8)
    r = np.arange(step_mm, long_mm + 1e-9, step_mm)
    P = (tip + dirs[:, None, :] * r[None, :, None]).reshape(-1, 3)
    d, seen, near, bg, cov = point_costs(evidence, P, nearest=True, covered=True)
    new = seen & (d <= coarse_px)
    for v, c in enumerate(claims):
        new[v] &= ~((near[v] >= 0) & c[np.maximum(near[v], 0)])
    shape = (len(dirs), len(r))
    hit = (new.sum(axis=0) >= 2).reshape(shape)
    cols = np.flatnonzero(bg.sum(axis=0) >= 2)  # light bands matter only where two views show the board
    if len(cols):
        bg[:, cols] &= ~light_band(evidence, tip, P[cols])
    blocked = (bg.sum(axis=0) >= 2).reshape(shape)
    far_ok = r <= max_gap_mm + 1e-9
    if not far_ok.all():  # beyond max_gap_mm: only along a chord two views show covered up to there
        cov2 = (_covered(evidence, P, cov).sum(axis=0) >= 2).reshape(shape)
        before = np.c_[np.zeros(len(dirs)), np.cumsum(cov2, axis=1)[:, :-1]] / np.maximum(np.arange(len(r)), 1)
        blocked |= ~far_ok[None, :] & (before < COVER_FRAC)  # the share of the chord's places before each one
    # along each chord: the hits before anything blocks it, nearest first (the first may be a stub of the object
    # the tendril crosses: a few more places are refined, each more than a step from those refined already)
    first_block = np.where(blocked.any(axis=1), blocked.argmax(axis=1), len(r))
    kk, jj = np.nonzero(hit & (np.arange(len(r))[None, :] < first_block[:, None]))
    if not len(kk):
        return None
    order = np.lexsort((kk, jj))
    kk, jj = kk[order], jj[order]
    # the places refined: in that order, each at least 1.5 steps from those before it, up to MAX_REFINED (computed
    # at once; the loop below stops early on the nearest gap found, and the places' distances only grow)
    tried = _apart(tip + r[jj][:, None] * dirs[kk], 1.5 * step_mm, MAX_REFINED)
    best = None  # the nearest gap found so far, mm
    found: list[tuple[float, float, np.ndarray]] = []  # (gap, mean distance to the skeletons, place)
    for k, j in zip(kk[tried].tolist(), jj[tried].tolist()):
        if best is not None and r[j] - 2 * step_mm > best:
            break
        centre = dirs[k]
        fine_dirs = cone_directions(centre, np.degrees(np.arctan2(2.0 * step_mm, r[j])), 3)
        rr = r[j] + np.arange(-1.0, 1.01, 0.25) * step_mm
        F = (tip + fine_dirs[:, None, :] * rr[None, :, None]).reshape(-1, 3)
        df, sf, nf, bf = point_costs(evidence, F, nearest=True)
        on = sf & (df <= ON_PX) & ~bf.any(axis=0)
        for v, c in enumerate(claims):
            on[v] &= ~((nf[v] >= 0) & c[np.maximum(nf[v], 0)])
        # two views or more on their skeletons, and every view that sees the place too: not a ghost of two views
        good = (on.sum(axis=0) >= 2) & np.all(on | ~sf, axis=0)
        # within the cone (the finer cone around a chord reaches beyond it near the tip)
        gap_f = np.linalg.norm(F - tip, axis=1)
        good &= ((F - tip) @ t >= np.cos(np.radians(cone_deg)) * gap_f) & (gap_f >= step_mm)
        if good.any():  # and the tendril leads on from there straight on (not a stub of the object it crossed)
            g = np.flatnonzero(good)
            u = (F[g] - tip) / np.linalg.norm(F[g] - tip, axis=1, keepdims=True)
            ahead = (F[g][:, None, :] + u[:, None, :] * LEAD_MM[None, :, None]).reshape(-1, 3)
            da, sa, _, ba = point_costs(evidence, ahead, nearest=True)
            on_a = sa & (da <= 2 * ON_PX) & ~ba
            lead = ((on_a.sum(axis=0) >= 2) & np.all(on_a | ~sa, axis=0)).reshape(len(g), len(LEAD_MM)).all(axis=1)
            good[g] = lead
            # the distance to the skeletons at the place and ahead of it (a place off in depth leads off them)
            ahead_cost = ((np.minimum(da, 2 * ON_PX) * sa).sum(axis=0) / np.maximum(sa.sum(axis=0), 1)).reshape(
                len(g), len(LEAD_MM)).mean(axis=1)
        if not good.any():
            continue
        cost = (df * sf).sum(axis=0) / np.maximum(sf.sum(axis=0), 1)
        cost[g] += ahead_cost
        for i in np.flatnonzero(good):
            found.append((float(gap_f[i]), float(cost[i]), F[i]))
        best = min(f[0] for f in found) if found else None
    if not found:
        return None
    # the nearest places (within a step of the nearest) and among them the one nearest the views' skeletons there and
    # ahead
    near_ones = [f for f in found if f[0] <= best + step_mm]
    return min(near_ones, key=lambda f: (f[1], f[0]))[2]


@njit(cache=True)
def _apart(H, min_mm, most):
    """Rows of ``H`` (n, 3) taken in order, each unless one taken before lies nearer than ``min_mm`` (the distance of
    :func:`_nearest_distance`), at most ``most``."""
    out = np.empty(min(len(H), most), np.int64)
    taken = np.empty((min(len(H), most), 3))
    k = 0
    for i in range(len(H)):
        if k == most:
            break
        if k > 0 and _nearest_distance(H[i:i + 1], taken[:k])[0] < min_mm:
            continue
        out[k] = i
        taken[k] = H[i]
        k += 1
    return out[:k]


def runs_out(evidence: list[SkeletonEvidence], curves: list[np.ndarray], step_mm: float) -> np.ndarray:
    """(n,) bool: whether each curve ends where two views or more stop seeing (the edge of their ROIs).

    The place ``1.5 step_mm`` beyond the tip, straight on. The marks put the
    tendril inside every ROI, so its tip is a free end that the views see; a
    curve that ends at the ROIs' edges has run onto something that hangs in
    from outside (a second tendril, a petiole, the stem).
    """
    out = np.zeros(len(curves), bool)
    P = []
    for X in curves:
        t = X[-1] - X[-2] if len(X) >= 2 else np.zeros(3)
        P.append(X[-1] + 1.5 * step_mm * t / max(np.linalg.norm(t), 1e-9))
    P = np.asarray(P).reshape(-1, 3)
    n_seen = np.zeros(len(curves), int)
    for ev in evidence:
        n_seen += skeleton_distance(ev, ev.camera.project(P))[2]
    out[:] = n_seen < 2
    return out
