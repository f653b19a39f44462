"""Plausible ranges of the numbers tendrilkit accepts, in one place.

A value outside them is a mistake in the input (an experiment file, a
``curves.csv``), reported in one line with exit code 2, never a computation
that overflows or exhausts memory. The bounds are generous: far beyond any
real recording, far below what breaks the arithmetic.
"""

from __future__ import annotations

#: Largest experiment file read, bytes (a real one is a few kB).
MAX_EXPERIMENT_BYTES = 1_000_000
#: Largest number of YAML nodes an experiment file may expand to (aliases included).
MAX_YAML_NODES = 100_000
#: Focal lengths fx, fy, pixels: (0, 1e5]; and relative to the image width (see MIN/MAX_FOCAL_PER_WIDTH).
MAX_FOCAL_PX = 1e5
#: A focal length between these multiples of the image width (field of view about 1.4 to 136 degrees).
MIN_FOCAL_PER_WIDTH = 0.2
MAX_FOCAL_PER_WIDTH = 40.0
#: fy / fx between 1 / this and this (pixel aspect ratio).
MAX_ASPECT = 2.0
#: The principal point within this fraction of the width (height) from the image centre.
MAX_PRINCIPAL_OFFSET = 0.25
#: Pixel coordinates (principal point, marks), absolute value.
MAX_PIXEL = 1e5
#: Lens distortion coefficients, absolute value.
MAX_DIST_COEFF = 1e4
#: Distortion coefficient counts OpenCV supports (k1 k2 p1 p2 [k3 [k4 k5 k6 [s1 s2 s3 s4 [tauX tauY]]]]).
DIST_LENGTHS = (4, 5, 8, 12, 14)
#: Frames per second (1e-6: one frame in 11.6 days).
MIN_FPS = 1e-6
MAX_FPS = 1e6
#: Smallest world marker side, mm.
MIN_MARKER_MM = 0.1
#: Frame indices.
MAX_FRAME = 10**9
#: World lengths, mm (marker side, smoothing length, coordinates of a curves.csv).
MAX_LENGTH_MM = 1e6
#: Points of one curve (``points:`` of an experiment, rows of one frame of a curves.csv).
MAX_POINTS = 5000
#: Fewest points of a curve the piece-wise clothoid fit accepts (``fit`` and ``reconstruct`` alike).
MIN_FIT_POINTS = 8
#: Pixel distances and sizes of options (tolerances, radii, windows).
MAX_OPTION_PX = 1e4
#: Dimensionless weights and penalties.
MAX_WEIGHT = 1e9
