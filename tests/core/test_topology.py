"""Tests for hybridedit.core.topology: one answer to closedness, degeneracy, welding and parts."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from hybridedit.core.topology import (DEGENERATE_RATIO, check_closed, connected_parts, degenerate_faces, edge_balance,
                                 edge_index,
                                 edge_face_counts, group_rows, is_closed_oriented, weld)


def box():
    b = trimesh.creation.box()
    return np.asarray(b.vertices, dtype=float), np.asarray(b.faces, dtype=np.int64)


def test_a_closed_box_is_closed_and_oriented():
    v, f = box()
    check_closed(f)
    assert is_closed_oriented(f, len(v))
    keys, bal = edge_balance(f, len(v))
    assert len(keys) == 18 and not bal.any()
    edges, counts = edge_face_counts(f, len(v))
    assert len(edges) == 18 and np.all(counts == 2) and np.all(edges[:, 0] < edges[:, 1])


@pytest.fixture(params=[10**9, 0], ids=["serial", "parallel"])
def twin(request, monkeypatch):
    from hybridedit.core.parallel import THRESHOLDS

    monkeypatch.setitem(THRESHOLDS, "faces", request.param)


def test_open_flipped_duplicated_and_nonmanifold_are_not_closed_oriented(twin):
    v, f = box()
    with pytest.raises(ValueError, match="unbalanced"):
        check_closed(f[1:])
    assert not is_closed_oriented(f[1:], len(v))  # a hole
    flipped = f.copy()
    flipped[0] = flipped[0, ::-1]
    assert not is_closed_oriented(flipped, len(v))
    assert not is_closed_oriented(np.vstack([f, f[:1]]), len(v))  # a duplicate face
    # a balanced non-manifold surface: closed for mean value coordinates, not a clean manifold
    two = np.vstack([f, f + 8])
    two[two == 8] = 0  # two boxes sharing a vertex: still manifold edges
    assert is_closed_oriented(two, 16)
    fin = np.vstack([f, [[0, 1, 2], [0, 2, 1]]])  # a zero-volume pair on existing edges
    check_closed(fin)
    assert not is_closed_oriented(fin, len(v))
    with pytest.raises(ValueError, match="repeated vertex"):
        check_closed([[0, 0, 1]])
    with pytest.raises(ValueError, match="no faces"):
        check_closed(np.zeros((0, 3), int))


def test_edge_face_counts_with_repeated_indices():
    edges, counts = edge_face_counts([[0, 0, 1], [0, 1, 2]], 3)
    assert edges.tolist() == [[0, 1], [0, 2], [1, 2]]
    assert counts.tolist() == [2, 1, 1]  # (0, 0, 1) uses its edge once


def test_one_degenerate_rule():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [2, 0, 0], [0.5, 1e-13, 0], [0.5, 1e-11, 0],
                  [np.nan, 0, 0]], float)
    f = np.array([[0, 1, 2],  # fine
                  [0, 0, 1],  # repeated index
                  [0, 1, 3],  # collinear
                  [0, 3, 4],  # height 1e-13 over a longest edge of 2: below the ratio
                  [0, 3, 5],  # height 1e-11 over 2: above it
                  [0, 1, 6]])  # not finite
    assert degenerate_faces(v, f).tolist() == [False, True, True, True, False, True]
    # the rule is relative: scaling the shape changes nothing
    for s in (1e-9, 1e9):
        assert degenerate_faces(v * s, f).tolist() == [False, True, True, True, False, True]
    assert DEGENERATE_RATIO == 1e-12
    assert degenerate_faces(v, np.zeros((0, 3), int)).shape == (0,)


def test_weld_merges_coincident_referenced_vertices_only():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 0, 0], [0, 1, 1e-12], [5, 5, 5]], float)
    f = np.array([[0, 1, 2], [0, 3, 4]])
    vw, fw, remap, merged = weld(v, f, 0.0)
    assert merged == 1 and len(vw) == 4  # exact duplicates only; vertex 5 is unreferenced
    assert remap.tolist() == [0, 1, 2, 1, 3, -1]
    assert np.array_equal(vw[fw], v[f])  # exact welding moves nothing
    vw, fw, remap, merged = weld(v, f, 1e-9)
    assert merged == 2 and remap[4] == remap[2]


def test_connected_parts_number_by_first_vertex_and_skip_unreferenced():
    v, f = box()
    faces = np.vstack([f + 9, f])  # vertex 8 unreferenced, the second box listed first
    count, labels = connected_parts(faces, 17)
    assert count == 2
    assert np.all(labels[:8] == 0) and labels[8] == -1 and np.all(labels[9:] == 1)
    assert connected_parts(np.zeros((0, 3), int), 4) == (0, pytest.approx(-np.ones(4)))


def test_group_rows_in_order_of_first_occurrence():
    keys = np.array([[3, 1], [1, 2], [3, 1], [0, 0], [1, 2]])
    first, group = group_rows(keys)
    assert first.tolist() == [0, 1, 3] and group.tolist() == [0, 1, 0, 2, 1]


def test_the_parallel_and_serial_degenerate_tests_agree():
    from hybridedit.core.parallel import THRESHOLDS, all_parallel
    from hybridedit.core.topology import _degenerate

    s = trimesh.creation.icosphere(subdivisions=6)
    v = np.asarray(s.vertices).copy()
    f = np.asarray(s.faces, dtype=np.int64).copy()
    assert len(f) >= THRESHOLDS["faces"]
    f[::1000, 1] = f[::1000, 0]  # repeated indices
    v[f[5::1000, 2]] = v[f[5::1000, 0]]  # collapsed corners
    serial = np.zeros(len(f), dtype=bool)
    _degenerate.serial(v, f, DEGENERATE_RATIO, serial)
    with all_parallel():  # (whatever the machine's load)
        parallel = degenerate_faces(v, f)
    assert np.array_equal(parallel, serial) and serial.sum() >= 2 * (len(f) // 1000)


def _unique_edges_by_sorting(f, n):
    a, b = f.ravel(), f[:, [1, 2, 0]].ravel()
    code, inverse = np.unique(np.minimum(a, b) * n + np.maximum(a, b), return_inverse=True)
    return np.stack([code // n, code % n], axis=1), inverse.ravel()


@pytest.mark.parametrize("seed", range(40))
def test_edge_index_is_what_sorting_the_edge_keys_gives(seed):
    # random faces: repeated indices (self-loops), duplicates, unused vertices, and
    # every few seeds one vertex in every face (a bucket sorted the other way)
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 50))
    f = rng.integers(0, n, size=(int(rng.integers(1, 150)), 3))
    if seed % 4 == 0:
        f[:, 1] = n - 1
    edges, inverse = edge_index(f, n + 3)
    want_e, want_i = _unique_edges_by_sorting(f, n + 3)
    assert np.array_equal(edges, want_e)
    assert np.array_equal(inverse, want_i)
    assert np.array_equal(edges[inverse], np.sort(np.stack([f.ravel(), f[:, [1, 2, 0]].ravel()], 1), axis=1))


@pytest.mark.parametrize("seed", range(0, 40, 3))
def test_edges_and_vertices_by_first_use_are_np_uniques_by_first_occurrence(seed):
    from hybridedit.core.topology import edges_by_first_use, vertices_by_first_use

    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 50))
    f = rng.integers(0, n, size=(int(rng.integers(1, 150)), 3))  # (self-loops, duplicates: as above)
    a, b = f.ravel(), f[:, [1, 2, 0]].ravel()
    code, first, inverse = np.unique(np.minimum(a, b) * n + np.maximum(a, b), return_index=True,
                                     return_inverse=True)
    rank = np.empty(len(code), dtype=np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(code))
    want = np.empty((len(code), 2), dtype=np.int64)
    want[rank] = np.stack([code // n, code % n], axis=1)
    edges, face_edges, first_use = edges_by_first_use(f, n)
    assert np.array_equal(edges, want)
    assert np.array_equal(face_edges, rank[inverse.ravel()].reshape(-1, 3))
    assert np.array_equal(first_use, np.sort(first))
    used, first = np.unique(f.ravel(), return_index=True)
    by_use = np.argsort(first, kind="stable")
    got_used, got_first = vertices_by_first_use(f, n + 2)
    assert np.array_equal(got_used, used[by_use]) and np.array_equal(got_first, first[by_use])


def test_edge_index_of_a_fan_and_of_nothing():
    k = 300  # the centre's bucket is longer than an insertion sort is for
    fan = np.stack([np.zeros(k, dtype=np.int64), np.arange(k, 0, -1), np.arange(k + 1, 1, -1)], axis=1)
    edges, inverse = edge_index(fan, k + 2)
    want_e, want_i = _unique_edges_by_sorting(fan, k + 2)
    assert np.array_equal(edges, want_e) and np.array_equal(inverse, want_i)
    e0, i0 = edge_index(np.zeros((0, 3), dtype=np.int64), 5)
    assert e0.shape == (0, 2) and i0.shape == (0,)


def test_incidence_is_a_stable_sort_of_the_rows_by_key():
    """The incidence (a counting sort) gives what sorting the rows by key gave, repeated corners
    included, with int32 rows."""
    from hybridedit.core.topology import incidence

    rng = np.random.default_rng(3)
    n = 300
    faces = rng.integers(0, n, (900, 3))
    faces[5] = [7, 7, 9]  # a corner repeated
    ptr, rows = incidence(faces, n)
    order = np.argsort(faces.ravel(), kind="stable")
    assert rows.dtype == np.int32 and np.array_equal(rows, np.repeat(np.arange(len(faces)), 3)[order])
    assert np.array_equal(ptr, np.r_[0, np.cumsum(np.bincount(faces.ravel(), minlength=n))])


def _rim_by_definition(f, n):
    """oriented_rim's rule from a set of directed edges."""
    from collections import Counter

    if len(f) == 0 or (f < 0).any() or (f == np.roll(f, -1, axis=1)).any():
        return None
    use = Counter((int(a), int(b)) for t in f for a, b in zip(t, np.roll(t, -1)))
    if max(use.values()) > 1:
        return None
    rim = np.zeros(n, dtype=bool)
    for a, b in use:
        if (b, a) not in use:
            rim[a] = True
    return rim


def test_the_oriented_rim_is_its_rule_on_open_flipped_and_broken_grids(twin):
    from hybridedit.core.topology import oriented_rim

    rng = np.random.default_rng(1)
    k = 6  # a k x k grid of vertices, two triangles a cell
    cells = [(i * k + j, i * k + j + 1, (i + 1) * k + j + 1, (i + 1) * k + j) for i in range(k - 1) for j in range(k - 1)]
    grid = np.array([t for a, b, c, d in cells for t in ((a, b, c), (a, c, d))], dtype=np.int64)
    cases = [grid, grid[rng.permutation(len(grid))[:30]], np.vstack([grid, grid[:1]]),
             np.vstack([grid[1:], grid[:1, ::-1]]), np.vstack([grid, [[3, 3, 4]]]), np.vstack([grid, [[-1, 3, 4]]]),
             grid[:0]]
    for f in cases:
        want = _rim_by_definition(f, k * k + 2)  # (two vertices no face uses)
        got = oriented_rim(f, k * k + 2)
        assert (got is None) == (want is None)
        if want is not None:
            assert np.array_equal(got, want)
    assert oriented_rim(grid, k * k).sum() == 4 * (k - 1)  # the grid's border
