"""Synthetic experiments with exact ground truth (phantoms).

The paper's videos are not public, so tendrilkit makes its own: a tendril whose
centreline is integrated from curvature and torsion laws that are piece-wise
linear in arc length (so the true piece-wise clothoid and its breakpoints are
known), evolving over a 15-minute time-lapse from hanging almost straight to
curled, rendered as a 1.5 mm tube into the three views of the real IJCV25 rig
(:func:`tendrilkit.calibration.ijcv25_rig`, with a small lens distortion
added per view), in front of a white board with the world marker (id 815,
24 mm), a few other ArUco markers, the stem taped on the board with the node
that carries the tendril, leaves, a lighting gradient, blur, sensor noise and
video compression.

Four families, one per stimulation site, after the paper's Figure 1D:

- ``S1``: hardly responds (a slight bend near the base);
- ``S2``: curls in a plane at mid-length (curvature bump in the 2nd quarter);
- ``S3``: curls off-plane in the 3rd quarter (curvature and torsion bump: a
  loop whose projection crosses itself in the views);
- ``S4``: curls in a plane at the tip (curvature ramp in the last quarter, a
  spiral that does not overlap itself).

``seed=0`` gives each site's nominal design; other seeds vary the length
(120-200 mm), breakpoints, curl amounts, base position and tilt, the scene
layout, the lens distortion and the noise within the site's family. Every
design is checked (:func:`check_constraints`): the tendril stays in front of
the board (z >= 3 mm) and inside all three images with a 60 px margin, its
centroid is 100-150 mm from the world marker, it never touches leaves,
markers or the stem (except at its base) in any view, never touches itself
in 3D, and every marker is visible in all three views; a design that fails
is redrawn deterministically (``design_attempt`` in the ground truth).
Designs and scenes are accepted on a fixed grid of times (every 15 s of the
15 minutes), so a seed gives the same tendril, scene and marks whatever the
sequence length (unless a frame between those times breaks a constraint, when
the next design is drawn).

Geometry: the world frame is the world marker's (board z = 0, world +x down
in every view = gravity). The images span only about 150 mm along gravity,
so the tendril hangs from the node at an angle from the vertical that grows
with its length (18-30 degrees at 120 mm, 53-65 at 200 mm), tilted 7-14
degrees out of the board, and bends slightly (initial curvature at most
0.004 1/mm). The time-lapse is 15 minutes (``fps = n_frames / 900``; 60
frames: one every 15 s); the response is a smooth step from ``onset_s``
(about 3 min) to ``stable_s`` (about 12 min) with a slow wobble of a few per
cent, so no two frames are identical.

Layout (one concern per module):

- :mod:`~tendrilkit.phantom.design`: the site families, the response over
  time, the laws and the true centrelines (Frenet-Serret, DOP853);
- :mod:`~tendrilkit.phantom.projection`: the cameras and safe projections;
- :mod:`~tendrilkit.phantom.constraints`: what a design must meet, self-crossings;
- :mod:`~tendrilkit.phantom.scene`: board, stem, node, tape, leaves, markers;
- :mod:`~tendrilkit.phantom.marks`: ROI and keep-out box on frame 0;
- :mod:`~tendrilkit.phantom.make`: :func:`make_phantom` and :class:`Phantom`;
- :mod:`~tendrilkit.phantom.render`: the frames (:func:`render_view`);
- :mod:`~tendrilkit.phantom.experiment`: the experiment file's text, the
  ground-truth tables and :class:`GroundTruth`;
- :mod:`tendrilkit.phantom.scenes`: random scenes like real recordings
  (factors, geometry and clutter, rendering, their text).

Public API: :func:`make_phantom` (geometry and marks, no pixels),
:func:`render_view` (one frame of one view, no compression),
:func:`phantom_params_yaml` (the experiment file's text), and, from
:mod:`tendrilkit.io.phantom` (the only part that touches the disk),
:func:`write_phantom_experiment` (videos, experiment file, ground truth),
:func:`write_scene_experiment`, :func:`write_ground_truth`,
:func:`read_ground_truth` and :func:`find_ground_truth`. Nothing is cached
between calls; a phantom's arrays are read-only.
"""

from tendrilkit.io.phantom import (find_ground_truth, read_ground_truth, write_ground_truth, write_phantom_experiment,
                                   write_scene_experiment)
from tendrilkit.phantom.constraints import check_constraints, self_crossings
from tendrilkit.phantom.design import (DEFAULT_N_FRAMES, DEFAULT_OPTIONS, DICTIONARY, GENERATOR_VERSION, N_VIEWS, SITES,
                                       WORLD_MARKER_ID, WORLD_MARKER_MM, Design, PhantomError, response_profile,
                                       solve_frenet_serret)
from tendrilkit.phantom.experiment import GroundTruth, ground_truth_tables, phantom_params_yaml, rig_and_marks_yaml
from tendrilkit.phantom.make import Phantom, make_phantom
from tendrilkit.phantom.projection import phantom_cameras
from tendrilkit.phantom.render import render_tube_views, render_view
from tendrilkit.phantom.scene import MarkerSpec, Scene

__all__ = [
    "DEFAULT_N_FRAMES", "DEFAULT_OPTIONS", "DICTIONARY", "GENERATOR_VERSION", "N_VIEWS", "SITES", "WORLD_MARKER_ID",
    "WORLD_MARKER_MM", "Design", "GroundTruth", "MarkerSpec", "Phantom", "PhantomError", "Scene", "check_constraints",
    "find_ground_truth", "ground_truth_tables", "make_phantom", "phantom_cameras", "phantom_params_yaml",
    "read_ground_truth", "render_tube_views", "render_view", "response_profile", "rig_and_marks_yaml",
    "self_crossings", "solve_frenet_serret", "write_ground_truth", "write_phantom_experiment",
    "write_scene_experiment",
]
