"""Skeleton graph, pruning and base-to-tip ordering through self-crossings
(paper: "Ordering the Points"; stages 3-4 of ``../shared/REFERENCE_NOTES.md``).

:func:`order_skeleton` turns the tendril's mask of one view into an ordered
centreline, base to tip:

1. **Skeleton.** The mask is cropped to its bounding box and thinned
   (:func:`skimage.morphology.skeletonize`'s thinning, pixel for pixel, by
   :func:`thinning.thin`, which visits only the pixels that can change;
   strip by strip with overlapping margins, :func:`thinning.thin_strips`);
   the tube width ``w`` is the mask's area over the skeleton's length.
2. **Graph.** The skeleton's pixel graph splits it into *branches* (pixel
   paths between endpoints and junction pixels; :func:`graph.skeleton_graph`:
   :class:`skan.Skeleton`'s graph and paths, built with scipy and a cached
   compiled walk, because skan's import and its uncached kernels cost 2-3 s of
   every process, 40 ms per frame of a 60-frame run). Spurs (a branch ending
   in an endpoint, attached to a junction, shorter than ``prune_px``) are
   removed, repeatedly. Junctions joined by a branch shorter than
   ``merge_width * w`` are one crossing (an X crossing thins to two Y
   junctions joined by a short branch); so are two junctions joined by a
   longer branch (up to 15 w) when their other branches continue straight
   through it (a shallow X crossing, whose middle is about
   ``w / tan(angle / 2)`` long). They are contracted into one node, and
   closed branches at a junction shorter than twice the merge length (pin
   holes) are dropped. Any other
   branch between two junctions (up to 15 w long) gets an optional *twin*:
   where the tendril runs along itself its two passes thin to one band, which
   the walk must take twice; the degrees' parity lets a complete walk use the
   twin only then.
3. **Walk.** From the endpoint nearest the base point, the walk follows
   branches; at a node with several unused branches it takes one (a
   *decision*) and every branch is used once: the tendril's centreline is an
   Euler trail of the graph (at an X crossing the tendril passes twice, in and
   out along opposite branches). Two rules pick the branch:

   - ``method="smooth"`` (default, any number of crossings): the turn of the
     tangent from the incoming branch to each candidate is measured; tangents
     are lines fitted (principal axis) to the ``tangent_window_px`` of
     skeleton just outside the junction zone (radius ``span/2 + zone_width *
     w`` around the crossing, grown along the branches to where the mask is a
     single tube again: inside, the skeleton bends toward the junction and
     says nothing about the tendril). A depth-first search tries candidates
     smoothest first and keeps, among the walks that use every branch, the
     one with the fewest twins (above) and then the smallest sum of turns
     (branch and bound); with one crossing that is the smoothest turn at it.
   - ``method="paper"`` (at most one crossing): the paper's sub-set cases.
     With a closed loop at the crossing and a tip branch (three sub-sets), the
     tip branch :math:`\\mathcal{S}_3` is the one whose far end is farthest
     from the crossing :math:`p_c` and comes last; the direction through the
     loop is chosen by the angle between lines fitted to the last :math:`N_1`
     skeleton points before :math:`p_c` and the first :math:`N_2` after it,

     .. math::

        \\alpha_j = \\operatorname{atan2}\\left(\\det[\\vec L_{N_1}; \\vec L_j],
        \\; \\vec L_{N_1} \\cdot \\vec L_j\\right), \\quad j = N_2, N_2^*,

     taking :math:`\\mathcal{S}_2` if :math:`|\\alpha_{N_2}| \\le
     |\\alpha_{N_2^*}|`. (The paper's equation compares the signed angles,
     which picks the right loop direction only for one sense of rotation; the
     magnitudes are what its text and figure describe.) :math:`N_1 = N_2 =`
     ``tangent_window_px`` points. The first complete walk in this
     preference is taken.

   Every decision is recorded (:class:`Decision`) and can be overridden:
   ``overrides`` entries ``{frame, view, junction, branch}`` force, at the
   ``junction``-th decision met (0-based) of that frame and view, the
   ``branch``-th candidate (0-based, candidates listed smoothest first).
4. **Centreline.** Along the walk, the skeleton inside every junction zone is
   replaced by a cubic Hermite bridge between the tangents of the branches
   just outside it (the skeleton bends toward the junction; the bridge
   follows the tendril). The ends are extended along their tangents to the
   mask boundary: the skeleton of a tube stops short of a cut end (the base at
   the keep-out box) by about the half-width; at the tip the extension stops
   ``tip_inset`` half-widths before the boundary (a disc-capped tube's
   skeleton reaches its true end). A walk that ends in a crossing (the tip
   crosses the tendril and stops a few pixels beyond it, a stub the pruning
   removed) continues along its tangent through the crossing to the end of
   the stub. The path is smoothed
   (Gaussian, ``smooth_px``) and resampled every pixel of arc length.

:func:`process_view` is segmentation (:func:`tendrilkit.segmentation.segment_view`)
followed by :func:`order_skeleton`.

Failures are named exceptions: :class:`~tendrilkit.exceptions.EmptySkeletonError`
(nothing to order), :class:`~tendrilkit.exceptions.AmbiguousOrderingError` (no
endpoint to start from, a walk that leaves a long part of the skeleton unused,
an override that does not fit, more than one crossing with ``method="paper"``).

The sub-package has one module per part of the method: ``results`` (the
dataclasses passed on), ``graph`` (thinning, the skeleton graph and its
surgery: pruning, merging, contracting crossings), ``tangents`` (branch
tangents and junction zones), ``walk`` (:func:`order_skeleton`: the walk
through the crossings), ``centreline`` (bridges, end extension, smoothing,
:func:`compare_centerlines`) and ``view`` (:func:`process_view`).
"""

from tendrilkit.skeleton.centreline import compare_centerlines
from tendrilkit.skeleton.results import Decision, OrderedCenterline, ViewCenterline
from tendrilkit.skeleton.view import process_view
from tendrilkit.skeleton.walk import order_skeleton

__all__ = ["Decision", "OrderedCenterline", "ViewCenterline", "compare_centerlines", "order_skeleton", "process_view"]
