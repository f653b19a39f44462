"""Tiny hand-drawn skeletons with known graphs, for the tests of the graph surgery.

Each is a literal bool image (``#`` a skeleton pixel), small enough to check
the expected graph by eye (in the style of skan's ``_testdata``).
"""

from __future__ import annotations

import numpy as np

__all__ = ["SPUR", "TWO_LINES", "X_AS_TWO_Y", "image"]


def image(rows: str) -> np.ndarray:
    """A bool image from lines of ``.`` and ``#``."""
    lines = [r.strip() for r in rows.strip().splitlines()]
    return np.array([[c == "#" for c in r] for r in lines], bool)


#: A straight branch 15 px long with a spur of 3 px up from its middle
#: (pruned below ``prune_px`` = 5: one branch of length 14 remains).
SPUR = image(
    """
    ...............
    .......#.......
    .......#.......
    .......#.......
    ###############
    ...............
    """
)

#: An X crossing thinned to two Y junctions joined by a 2 px branch
#: (contracted below ``merge_len`` = 3: one node with four branches).
X_AS_TWO_Y = image(
    """
    #.........#
    .#.......#.
    ..#.....#..
    ...#...#...
    ....###....
    ...#...#...
    ..#.....#..
    .#.......#.
    #.........#
    """
)

#: Two separate straight branches, 9 px and 5 px long.
TWO_LINES = image(
    """
    ..........
    ##########
    ..........
    ..........
    ......####
    .....#....
    """
)
