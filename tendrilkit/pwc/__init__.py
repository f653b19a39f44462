"""Piece-wise clothoid fit: segmentation of curvature and torsion, continuity, rebuild.

Paper: "Automatic Piece-Wise Fitting of Curvature & Torsion", "Three-dimensional
Reconstruction" and "Sensitivity of Fitting Parameters" (Fan et al., IJCV
2025); stages 8-9 of ``../shared/REFERENCE_NOTES.md``.

A segmentation is a cost x a search x a penalty:

cost
    :func:`line_costs` gives the cost of one straight line over every interval
    of samples ``[i, j)``, computed once per signal. ``score="l2"``: the
    weighted least-squares residual (prefix sums, :math:`O(n^2)`);
    ``score="l1"``: the paper's score, the same least-squares line scored by
    its sum of absolute residuals (the reference fits lines by least squares
    and scores them by absolute error; an exact least-absolute-deviation line
    per interval would cost a linear programme each), :math:`O(n^3)` compiled.
search
    :func:`segment_penalty` is the exact :math:`O(n^2)` prefix programme
    :math:`F_j = \\min_i F_i + C_{ij} + \\epsilon`; it has the same optimum as
    the paper's interval programme
    :math:`J(a, b) = \\min\\{\\epsilon + E(a, b), \\min_m J(a, m) + J(m, b)\\}`
    (:math:`O(n^3)`). :func:`penalty_path` runs one pass over segment counts
    (:math:`G_k(j)`, the best cost of ``j`` samples in ``k`` segments) and
    returns every segmentation that is optimal for some penalty: the lower
    convex envelope of :math:`G_k(n) + k \\epsilon`, with the exact penalty
    interval of each.
penalty
    Dimensionless. The signal :math:`y` (curvature or torsion, 1/mm) is
    centred and divided by its weighted standard deviation
    :math:`\\sigma` (or, for ``l1``, its mean absolute deviation), arc length by
    the curve length, and a segmentation's cost is divided by the total weight.
    The cost of a segmentation is then the *fraction of the signal's
    variance left unexplained* (``l2``), and the penalty :math:`\\epsilon` is the
    fraction of the variance a new segment must explain to be worth adding.
    Values do not depend on the unit of length, on the number of samples (for
    uniform sampling) or on the size of the signal: 0.01 means "a segment
    must explain 1 % of the variance". To keep an almost constant signal from
    being split on its noise, :math:`\\sigma^2` is floored at
    :math:`(10^{-2} \\text{ rad} / L)^2`.

Torsion samples are weighted by :math:`\\kappa^2` (torsion turns the shape in
proportion to the curvature, and is undefined where the curvature is zero, see
:mod:`tendrilkit.frenet`).

Continuity (:func:`join_segments`): adjacent lines are joined at their
intersection; a join that falls outside the span of its two segments (or
before the previous join; parallel lines never meet) *overshoots*, and the two
segments are merged, as the paper does. The values at the resulting knots are
then refitted by continuous piece-wise linear least squares, so the law is the
best continuous fit with those knots (the reference keeps the joined
polyline, which is not).

Rebuild (:func:`rebuild_curve`): the Frenet frame is integrated with exact
rotations per step (:func:`tendrilkit.frenet.integrate_frenet`) using the
laws' exact mean over each step, positions by the trapezoidal rule, then
registered rigidly onto the data (SVD, :func:`register_rigid`).

Selection of the penalties (:func:`fit_piecewise_clothoid`):

``selection="auto"`` (default)
    The candidates are the distinct continuous laws of the two penalty paths
    (every segmentation optimal for some penalty, up to ``max_segments``
    each). Starting from one segment each, a forward search moves to the next
    segmentation of either path while the criterion improves; each candidate
    is refined on the 3D points (below), warm-started from the current fit.
    The criterion is the Bayesian information criterion of the registered 3D
    residuals, :math:`3n \\ln(SSE / 3n) + p \\ln(3n)` with :math:`p = 2
    K_\\kappa + 2 K_\\tau + 6` (a value and a position per knot, the rigid
    registration), among fits that reach ``target_r2`` (below the target, the
    higher R^2 wins). BIC adds a segment only when it explains the shape
    beyond the noise. On smooth data (a reconstructed curve, already
    smoothed) there is no noise to stop it, and every segment would explain
    a little more of the reconstruction's own ripples: the SSE in BIC is
    floored at an rms of ``BIC_PRECISION_FRACTION`` (1/50) of the rms the
    target R^2 allows (:math:`\\sqrt{(1 - R^2) SST / 3n}`, about 0.7 mm on a
    150 mm tendril), the precision the fit is asked for; noisy points
    (the seeded curves' 0.15 mm) never reach the floor. The paper's target-R^2 rule alone (``criterion="r2"``:
    the fewest segments reaching ``target_r2``) stops at few segments on
    precise data (0.999 is about 1 mm rms on a 150 mm tendril) and at many on
    noisy data. tendrilkit's addition (``insertions=True``): each step may
    also add one knot to either law where a score test on the 3D residuals
    asks for it (the hinge whose Jacobian column best explains them), since
    curvature and torsion estimated from noisy points place knots poorly near
    the ends and where torsion is weak. A candidate that cannot win is not
    evaluated: with the SSE floored, its BIC is at least that of the floor
    with its segments, and a current fit reaching the target at or below that
    bound beats it (an exact bound: the same fits; on smooth curves it skips
    the candidates, and the score test, once the fit reaches the floor).
    A torsion path law starts the fit with its values within the range of the
    torsion where it is defined: where the curvature is about 0 the torsion
    has no weight, a segment's line is extrapolated there (to 7-10 /mm on the
    straight base of the S3 phantom), and from such a start the fit locked
    into a tight helix standing for the straight part.
    A search that ends below ``target_r2``, or whose rms residual exceeds
    0.9 of the data's noise (:func:`tendrilkit.frenet.noise_sigma_mm`; a good
    fit leaves 0.7-0.9 of it on the seeded curves, one that took a wrong turn
    1.2-4), searches again (``retries``). The noise counts as at least 1/20
    of the rms residual the target R^2 allows: a reconstructed curve is
    smooth (its noise reads about 0.0002 mm, below any fit's residual), and
    is searched again only when the first search left more than that.
``selection="fixed"``
    The given ``penalty_kappa``, ``penalty_tau`` (dimensionless, above).
:func:`grid_search_penalties`
    The paper's procedure: a grid over both penalties refined around the best
    cell until :math:`R^2 >` target (and SSE below a bound).

Refinement (``refine=True``, tendrilkit's addition): the knot values and the
inner knot positions of both laws are fitted by Levenberg-Marquardt to the
registered 3D points (analytic Jacobian, compiled). Each step stays within the
reach of the linear model: a knot value moves by at most the inverse width of
its two segments (at least :math:`1/L`; the value turns the frame by about a
radian), a knot by at most :math:`L/10`, and a longer component is clipped to
that; knots that would come closer than the minimum gap have their steps
shortened. (Raising the damping until the whole step fits instead made a
weakly determined tip value crawl at :math:`1/L` per iteration, and a search
compared candidates far from their optimum.) The forward search compares
candidates after ``quick_iterations``, refines the one it moves to for 10
iterations and the final one to convergence. A curvature bias of
:math:`10^{-3}` /mm moves the tip of a 150 mm tendril by about 10 mm, so laws
fitted in curvature space alone (the paper; ``refine=False``) are far less
accurate than the points they came from. With 0.15 mm noise on 120-200 mm
piece-wise clothoids the refined fit lies about 0.05 mm from the true curve
(curvature space alone: about 1 mm).

Scores (Tables 2-3): R^2 of the rebuilt, registered points against the data
about the data's mean, :math:`1 - SSE / \\sum |c_i - \\bar c|^2`, and SSE in
mm^2, for the entire curve, the base quarter and the tip quarter of its
length (each quarter about its own mean).

Modules (a segmentation = a cost x a search x a penalty, as in ruptures):

:mod:`~tendrilkit.pwc.costs`
    the cost of one line over every interval (:func:`line_costs`);
:mod:`~tendrilkit.pwc.search`
    the exact programmes (:func:`segment_penalty`, :func:`penalty_path`);
:mod:`~tendrilkit.pwc.laws`
    continuity and the laws (:func:`join_segments`, :class:`PiecewiseLinearLaw`);
:mod:`~tendrilkit.pwc.rebuild`
    integration, registration and scores (:func:`rebuild_curve`,
    :func:`register_rigid`, :func:`fit_scores`);
:mod:`~tendrilkit.pwc.refine`
    Levenberg-Marquardt on the 3D points and the knot score test;
:mod:`~tendrilkit.pwc.signals`
    a centreline's curvature and torsion prepared for the searches;
:mod:`~tendrilkit.pwc.selection`
    the automatic forward search along both penalty paths;
:mod:`~tendrilkit.pwc.fit`
    :func:`fit_piecewise_clothoid`, :class:`PWCFit`, :func:`penalty_table`;
:mod:`~tendrilkit.pwc.grid`
    the paper's grid search (:func:`grid_search_penalties`);
:mod:`~tendrilkit.pwc.datasets`
    seeded piece-wise clothoids with their ground truth (tests, benchmarks).
"""

from tendrilkit.pwc.costs import line_costs
from tendrilkit.pwc.fit import PWCFit, fit_piecewise_clothoid, penalty_table
from tendrilkit.pwc.grid import GridLevel, GridSearch, grid_search_penalties
from tendrilkit.pwc.laws import PiecewiseLinearLaw, join_segments
from tendrilkit.pwc.rebuild import FitScores, fit_scores, rebuild_curve, register_rigid
from tendrilkit.pwc.search import PenaltyPath, penalty_path, segment_penalty

__all__ = [
    "PiecewiseLinearLaw",
    "PenaltyPath",
    "PWCFit",
    "FitScores",
    "line_costs",
    "segment_penalty",
    "penalty_path",
    "join_segments",
    "register_rigid",
    "rebuild_curve",
    "fit_scores",
    "fit_piecewise_clothoid",
    "GridLevel",
    "GridSearch",
    "grid_search_penalties",
    "penalty_table",
]
