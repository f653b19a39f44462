"""Every named error of tendrilkit.

Two families:

- :class:`ExperimentError`: the user's input is wrong (experiment file, paths,
  videos, output folder). The command line prints its message as one line and
  exits with code 2.
- :class:`FrameError`: one frame cannot be processed (tendril lost, skeleton
  unusable, degenerate curve...). The pipeline records the frame as ``failed`` with
  the message and goes on with the next frame. A calibration that fails
  (no marker seen...) stops the run: it is an :class:`ExperimentError`.
"""


class TendrilkitError(Exception):
    """Base class of every tendrilkit error."""


class ExperimentError(TendrilkitError, ValueError):
    """A mistake in the user's input; the message is one line naming it."""


class OutputWriteError(TendrilkitError, OSError):
    """A result file cannot be written (disk full, quota, permissions); exit code 74."""


class FrameError(TendrilkitError):
    """A frame cannot be processed; the run records it and goes on."""


class FrameReadError(FrameError):
    """A frame of one view is missing or cannot be decoded."""


class TendrilLostError(FrameError):
    """No tendril component in the region of interest."""


class EmptySkeletonError(FrameError):
    """The tendril's mask thins to no usable skeleton."""


class AmbiguousOrderingError(FrameError):
    """The skeleton cannot be ordered from base to tip without guessing."""


class CorrespondenceError(FrameError):
    """The views' curves cannot be matched."""


class DegenerateCurveError(FrameError):
    """A curve too short, straight or repetitive for the requested computation."""
