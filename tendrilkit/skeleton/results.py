"""Results of the skeleton stage: the ordered centreline of a view and its decisions."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Decision", "OrderedCenterline", "ViewCenterline"]


@dataclass(frozen=True, eq=False)
class Decision:
    """One choice of branch at a junction.

    Attributes
    ----------
    frame, view : int
        Frame (0-based) and view (1-based).
    junction : int
        Index of this decision among the decisions of the walk, in the order
        met (0-based); the ``junction`` of an override.
    junction_xy : (2,) float array
        Centre of the junction (crossing), full-image pixels.
    candidates : tuple of (int, float)
        ``(branch_id, angle_deg)`` for every unused branch leaving the
        junction, smoothest first: ``angle_deg`` is the signed turn from the
        incoming tangent to the branch's tangent (degrees, positive
        counter-clockwise in image axes). ``branch_id`` indexes
        :attr:`OrderedCenterline.branches_xy`; a closed branch (loop) leaving
        and returning to the junction appears twice, the reversed direction as
        ``-1 - branch_id``.
    chosen : int
        Index of the chosen candidate (the ``branch`` of an override).
    method : str
        ``smooth``, ``paper`` or ``override``.
    """

    frame: int
    view: int
    junction: int
    junction_xy: np.ndarray
    candidates: tuple
    chosen: int
    method: str

    def as_dict(self) -> dict:
        """Plain data (for JSON/CSV), e.g. to write the decisions of a run."""
        return {
            "frame": int(self.frame),
            "view": int(self.view),
            "junction": int(self.junction),
            "junction_x_px": float(self.junction_xy[0]),
            "junction_y_px": float(self.junction_xy[1]),
            "candidates": [[int(b), round(float(a), 2)] for b, a in self.candidates],
            "chosen": int(self.chosen),
            "method": self.method,
        }


@dataclass(frozen=True, eq=False)
class OrderedCenterline:
    """The ordered 2D centreline of one view.

    Attributes
    ----------
    points_xy : (n, 2) float array
        Full-image pixels (distorted, as observed), base (row 0) to tip, about
        one pixel apart.
    decisions : tuple of Decision
        Every branch choice of the walk, in the order met.
    n_crossings : int
        Junctions the walk passes more than once (self-crossings; a tip
        touching the tendril counts, and a band where the tendril runs along
        itself, walked twice between two junctions, counts once).
    width_px : float
        Tube width estimated from the skeleton's distance transform.
    branches_xy : tuple of (k, 2) float arrays
        The pruned skeleton's branches (full-image pixels), indexed by the
        ``branch_id`` of the decisions.
    unused_px : float
        Skeleton length the walk left out (0 for a complete walk).
    """

    points_xy: np.ndarray
    decisions: tuple
    n_crossings: int
    width_px: float
    branches_xy: tuple
    unused_px: float


@dataclass(frozen=True, eq=False)
class ViewCenterline:
    """Result of :func:`process_view` for one view and frame.

    Attributes
    ----------
    points_xy : (n, 2) float array
        Ordered centreline base to tip, full-image (distorted) pixels.
    centroid_xy : (2,) float array
        Centroid of the tendril's mask (the next frame's tracking point).
    decisions : tuple of Decision
    n_crossings : int
    area_px : int
        Pixels of the tendril's mask.
    width_px : float
        Estimated tube width, pixels.
    """

    points_xy: np.ndarray
    centroid_xy: np.ndarray
    decisions: tuple
    n_crossings: int
    area_px: int
    width_px: float
