"""Per-view mask of the tendril (paper: "Pre-processing"; stage 2 of
``../shared/REFERENCE_NOTES.md``).

:func:`segment_view` works on the region of interest (ROI) only:

1. a grey image in which the tendril is dark: the blue channel (a green/brown
   tendril on a white board is dark in blue, the reference's default) or, with
   ``channel="hsv"``, :math:`g = \\min(V, 255 - S)` (dark *or* saturated pixels
   are low, the white board is high);
2. a threshold: Otsu's on the ROI, or a fixed grey level (pixels darker than
   it are tendril);
3. the keep-out box (between the tendril and the stem) painted background, so
   the stem cannot join the tendril's component;
4. a morphological opening with a disk (removes speckle and one-pixel bridges);
4b. faint pixels added (:func:`faint_pixels`): darker than their local
   background by a relative contrast, farther than ``local_margin_px`` from
   the pixels of steps 2-4 (a pale tendril that the threshold, pulled by a dark
   stem or leaf in the ROI, leaves with the board; dark tendrils keep their
   thresholded outline), keep-out box painted background, not opened; with
   ``local_exclude_dark``, a faint pixel's structure depth is taken beside
   the thresholded pixels, not over them (a pale tendril passing a leaf or
   the stem is kept there; on by default), except in faint regions it alone
   finds most of (a pale part of the object, the stem under translucent
   tape: :func:`tendrilkit.segmentation.faint.drop_unanchored`);
4c. with ``line_width_px`` (11 px by default; 0: off), light lines added
   (:func:`tendrilkit.segmentation.lines.light_line_pixels`): a thin line
   lighter than the dark pixels on both sides of it and darker than the
   board, a pale tendril in front of a leaf or a shoot, with a one-pixel rim
   of the object behind it cleared (:func:`tendrilkit.segmentation.lines.lines_in_front`:
   a line, not a part of the leaf's blob);
4d. with ``bridge_gap_px`` (off by default), line ends that face each other
   across a short gap joined (:func:`tendrilkit.segmentation.lines.bridge_line_gaps`):
   a line broken where it crosses another goes on straight through; the
   keep-out box painted background again;
5. connected components (8-connected); components under ``min_component_px``
   are dropped;
6. the tendril's component: on the first frame the component at, or nearest
   to, the base point (when several are about as near, as the stem and the
   tendril on both sides of the keep-out box are, the thinnest of them); on
   later frames the component whose centroid is nearest the previous frame's
   centroid (the paper's tracking).

No dialog or click anywhere: the ROI, keep-out box and base point come from the
experiment file.
"""

from __future__ import annotations

from tendrilkit.segmentation.component import TendrilMask, segment_view
from tendrilkit.segmentation.faint import faint_pixels
from tendrilkit.segmentation.foreground import (LabelledForeground, faint_options, foreground_roi, grey_image,
                                               label_foreground)
from tendrilkit.segmentation.lines import bridge_line_gaps, light_line_pixels

__all__ = ["TendrilMask", "LabelledForeground", "segment_view", "label_foreground", "grey_image", "foreground_roi",
           "faint_pixels", "faint_options", "light_line_pixels", "bridge_line_gaps"]
