"""Graph surgery of the skeleton stage on tiny hand-drawn skeletons (tendrilkit.skeleton._testdata)."""

from __future__ import annotations

import numpy as np
import pytest

from tendrilkit.skeleton._testdata import SPUR, TWO_LINES, X_AS_TWO_Y
from tendrilkit.skeleton.graph import _build_graph, _contract_junctions, _Graph, _keep_component, _merge_degree_two, _prune


def edges(g: _Graph) -> list[tuple[int, int, float]]:
    return [(u, v, round(length, 3)) for u, v, _, length in g.edges]


def test_graph_of_a_spur_on_a_line():
    g = _build_graph(SPUR)
    assert edges(g) == [(0, 1, 3.0), (2, 1, 7.0), (1, 3, 7.0)]
    assert np.array_equal(np.array(g.node_xy), [[7, 1], [7, 4], [0, 4], [14, 4]])
    assert g.node_junction == [False, True, False, False]
    assert g.degrees().tolist() == [1, 3, 1, 1]


def test_pruning_removes_the_spur_and_joins_the_line():
    g = _build_graph(SPUR)
    _prune(g, 5.0)
    assert edges(g) == [(2, 3, 14.0)]
    u, v, pts, _ = g.edges[0]
    assert pts.tolist() == [[float(x), 4.0] for x in range(15)]  # one path, end to end, through the old junction
    assert g.node_junction[1] is False


def test_pruning_keeps_a_spur_at_least_prune_px_long():
    g = _build_graph(SPUR)
    _prune(g, 3.0)  # the spur is 3 px: kept
    assert edges(g) == [(0, 1, 3.0), (2, 1, 7.0), (1, 3, 7.0)]


def test_x_crossing_thinned_to_two_junctions_is_contracted_into_one_node():
    g = _build_graph(X_AS_TWO_Y)
    assert edges(g) == [(0, 1, 5.657), (2, 3, 5.657), (1, 3, 2.0), (1, 4, 5.657), (3, 5, 5.657)]
    _contract_junctions(g, merge_len=3.0)
    assert edges(g) == [(0, 3, 5.657), (2, 3, 5.657), (3, 4, 5.657), (3, 5, 5.657)]
    assert g.degrees().tolist() == [1, 0, 1, 4, 1, 1]
    assert g.node_xy[3].tolist() == [5.0, 4.0]  # the mean of the two junctions
    assert g.node_span[3] == 2.0  # their distance
    assert g.node_junction[3] is True


def test_junctions_further_apart_than_merge_len_stay_two():
    g = _build_graph(X_AS_TWO_Y)
    _contract_junctions(g, merge_len=2.0)
    assert edges(g) == [(0, 1, 5.657), (2, 3, 5.657), (1, 3, 2.0), (1, 4, 5.657), (3, 5, 5.657)]


def test_pin_hole_at_a_contracted_junction_is_dropped():
    # junctions 1 and 3 are 1 px apart (one crossing); node 1 has a closed branch of 5.7 px (a pin hole in
    # the mask), the plain end node 0 a closed branch of the same length (not at a junction: kept)
    g = _Graph()
    for xy, junction in (([0, 0], False), ([5, 0], True), ([10, 0], False), ([6, 0], True), ([6, 5], False)):
        g.node_xy.append(np.array(xy, float))
        g.node_junction.append(junction)
        g.node_span.append(0.0)
    loop = np.array([[5, 0], [6, 1], [5, 2], [4, 1], [5, 0]], float)

    def seg(a, b):
        return np.array([g.node_xy[a], g.node_xy[b]])

    g.edges = [[0, 1, seg(0, 1), 5.0], [1, 1, loop, 4 * np.sqrt(2)], [1, 3, seg(1, 3), 1.0],
               [3, 2, seg(3, 2), 4.0], [3, 4, seg(3, 4), 5.0], [0, 0, loop - (5, 0), 4 * np.sqrt(2)]]
    _contract_junctions(g, merge_len=3.0)
    assert edges(g) == [(0, 3, 5.0), (3, 2, 4.0), (3, 4, 5.0), (0, 0, 5.657)]
    assert g.node_xy[3].tolist() == [5.5, 0.0] and g.node_span[3] == 1.0


def test_closed_branch_longer_than_twice_merge_len_is_kept():
    g = _Graph()
    for xy in ([0, 0], [5, 0], [10, 0], [6, 0], [6, 5]):
        g.node_xy.append(np.array(xy, float))
        g.node_junction.append(True)
        g.node_span.append(0.0)
    loop = np.array([[5, 0], [6, 1], [5, 2], [4, 1], [5, 0]], float)
    g.edges = [[0, 1, loop, 5.0], [1, 1, loop, 4 * np.sqrt(2)], [1, 3, loop, 1.0], [3, 2, loop, 4.0], [3, 4, loop, 5.0]]
    _contract_junctions(g, merge_len=2.5)  # 5.657 > 2 * 2.5
    assert edges(g) == [(0, 3, 5.0), (3, 3, 5.657), (3, 2, 4.0), (3, 4, 5.0)]


def test_merge_degree_two_joins_branches_in_order():
    g = _Graph()
    for xy in ([0, 0], [3, 0], [3, 4]):
        g.node_xy.append(np.array(xy, float))
        g.node_junction.append(False)
        g.node_span.append(0.0)
    g.edges = [[1, 0, np.array([[3, 0], [0, 0]], float), 3.0], [1, 2, np.array([[3, 0], [3, 4]], float), 4.0]]
    _merge_degree_two(g)
    assert edges(g) == [(0, 2, 7.0)]
    assert g.edges[0][2].tolist() == [[0, 0], [3, 0], [3, 4]]


def test_keep_component_of_the_start_node():
    g = _build_graph(TWO_LINES)
    assert edges(g) == [(0, 1, 9.0), (2, 3, 4.414)]
    dropped = _keep_component(g, 0)
    assert edges(g) == [(0, 1, 9.0)]
    assert round(dropped, 3) == 4.414
    g = _build_graph(TWO_LINES)
    assert round(_keep_component(g, 3), 3) == 9.0
    assert edges(g) == [(2, 3, 4.414)]


@pytest.mark.parametrize("module", ['tendrilkit.segmentation', 'tendrilkit.skeleton', 'tendrilkit.skeleton._testdata', 'tendrilkit.skeleton.centreline', 'tendrilkit.skeleton.graph', 'tendrilkit.skeleton.results', 'tendrilkit.skeleton.tangents', 'tendrilkit.skeleton.view', 'tendrilkit.skeleton.walk'])
def test_docstring_examples_run(module):
    """The Examples of the tendrilkit.skeleton docstrings (what ``pytest --doctest-modules`` runs)."""
    import doctest
    import importlib

    res = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert res.failed == 0, f"{res.failed} of {res.attempted} docstring example(s) of {module} failed"
