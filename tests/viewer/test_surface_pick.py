"""The surface a selection gesture takes (:mod:`hybridedit.viewer.model.surface_pick`): one part's seen
surface grown through its thickness, never another part that only overlaps it on screen."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from hybridedit.deform.skeleton import edge_graph
from hybridedit.viewer.model.surface_pick import surface_under, thickness

RING = 16


def tube(length: int = 7, radius: float = 1.0, offset=(0.0, 0.0, 0.0)):
    """(points, edges, outward normals) of an open tube along z: rings of RING points one apart."""
    t = np.linspace(0, 2 * np.pi, RING, endpoint=False)
    pts = np.array([[radius * np.cos(a), radius * np.sin(a), z] for z in range(length) for a in t]) + offset
    at = lambda z, k: RING * z + k % RING  # noqa: E731
    e = [[at(z, k), at(z, k + 1)] for z in range(length) for k in range(RING)]
    e += [[at(z, k), at(z + 1, k)] for z in range(length - 1) for k in range(RING)]
    normals = (pts - offset) * [1, 1, 0] / radius
    return pts, np.array(e), normals


def two_tubes(gap: float = 6.0):
    """A tube (radius 1, along z) and another ``gap`` behind it along -y (on screen from +y, one over the
    other), joined on the surface only round their far ends (as a hind leg is to a front leg)."""
    p1, e1, n1 = tube()
    p2, e2, n2 = tube(offset=(0.0, -gap, 0.0))
    n = len(p1)
    bridge = np.array([[RING * 6 + 12, n + RING * 6 + 4]])
    return np.vstack([p1, p2]), np.vstack([e1, e2 + n, bridge]), np.vstack([n1, n2]), n


def test_thickness_is_a_tubes_diameter_and_moves_with_it():
    p, _, n = tube(radius=1.5)
    t = thickness(p, n)
    assert np.all((t > 0.85 * 3.0) & (t <= 3.0 + 1e-9))
    R = Rotation.from_rotvec([0.3, -1.1, 0.7]).as_matrix()
    assert np.allclose(thickness(p @ R.T + [4.0, -2.0, 9.0], n @ R.T), t)


def test_a_limb_seen_from_the_front_is_taken_whole_and_the_one_behind_it_not():
    P, E, N, n = two_tubes()
    seen = np.zeros(len(P), dtype=bool)
    seen[:n] = P[:n, 1] >= 0  # the front half of the front tube; the back tube is hidden behind it
    took = surface_under(np.ones(len(P), dtype=bool), seen, edge_graph(P, E), thickness(P, N))
    assert took[:n].all() and not took[n:].any()


def test_only_the_hits_are_taken():
    P, E, N, n = two_tubes()
    hits = P[:, 2] <= 3.5  # the gesture covers half the tube's length
    seen = hits & (P[:, 1] >= 0) & (np.arange(len(P)) < n)
    took = surface_under(hits, seen, edge_graph(P, E), thickness(P, N))
    assert not (took & ~hits).any()
    assert took[:n][hits[:n]].all()
    assert not surface_under(hits, np.zeros(len(P), dtype=bool), edge_graph(P, E), thickness(P, N)).any()


def test_a_sliver_of_another_part_seen_beside_is_left_out_two_parts_alike_are_both_taken():
    P, E, N, n = two_tubes()
    g, t = edge_graph(P, E), thickness(P, N)
    seen = np.zeros(len(P), dtype=bool)
    seen[:n] = P[:n, 1] >= 0
    sliver = np.flatnonzero((np.arange(len(P)) >= n) & (P[:, 0] > 0.9) & (P[:, 2] < 2))  # peeks out beside it
    seen[sliver] = True
    took = surface_under(np.ones(len(P), dtype=bool), seen, g, t)
    assert took[:n].all() and not took[n:].any()
    both = seen.copy()
    both[n:] = P[n:, 1] >= -6.0  # the second tube as much in sight as the first
    took = surface_under(np.ones(len(P), dtype=bool), both, g, t)
    assert took.all()


@pytest.mark.parametrize("grow", [0.3, 1.2])
def test_the_growth_stops_at_the_parts_thickness(grow):
    P, E, N, n = two_tubes()
    seen = np.zeros(len(P), dtype=bool)
    seen[:n] = P[:n, 1] >= 0
    took = surface_under(np.ones(len(P), dtype=bool), seen, edge_graph(P, E), thickness(P, N), grow=grow)
    back = np.arange(len(P)) < n
    back &= P[:, 1] < -0.95  # the far side of the front tube
    assert took[back].all() == (grow >= 1.0)


def test_edge_graph_counts_each_edge_once():
    P = np.array([[0.0, 0, 0], [3, 4, 0], [3, 0, 0]])
    g = edge_graph(P, np.array([[0, 1], [1, 0], [0, 1], [1, 2]]))
    assert g[0, 1] == g[1, 0] == 5.0 and g[1, 2] == 4.0 and g.nnz == 4


def test_a_part_seen_as_much_but_behind_is_left_out_with_the_depth():
    P, E, N, n = two_tubes()
    g, t = edge_graph(P, E), thickness(P, N)
    seen = np.zeros(len(P), dtype=bool)
    seen[:n] = P[:n, 1] >= 0
    seen[n:] = (P[n:, 1] >= -6.0) & (P[n:, 0] > -0.5)  # the tube behind peeks out nearly as much
    depth = -P[:, 1]  # seen from +y: the second tube 6 behind the first
    took = surface_under(np.ones(len(P), dtype=bool), seen, g, t, depth=depth)
    assert took[:n].all() and not took[n:].any()
    level = np.zeros(len(P))  # the same two side by side at one depth: both are taken
    assert surface_under(np.ones(len(P), dtype=bool), seen, g, t, depth=level)[n:].any()
