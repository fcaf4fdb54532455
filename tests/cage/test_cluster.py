"""The clustering first pass (hybridedit.cage.cluster): a closed surface stays closed, thin parts keep
their two sides, and the cage it leads to edits as well as quadric collapses alone."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

import hybridedit as he
from hybridedit.cage import cluster
from hybridedit.cage.cluster import cluster_surface, clustered_size, clusters_first
from hybridedit.binding.truncation import MAX_ROW
from hybridedit.core.face_geometry import signed_volume
from hybridedit.core.topology import check_closed
from support.edits import canonical_edit


def _slab(thickness: float) -> trimesh.Trimesh:
    """A closed 1 x 1 x ``thickness`` box, finely triangulated (about 100K faces)."""
    box = trimesh.creation.box(extents=(1.0, 1.0, thickness))
    v, f = box.vertices, box.faces
    for _ in range(7):
        v, f = trimesh.remesh.subdivide(v, f)
    return trimesh.Trimesh(v, f, process=False)


def test_a_sphere_stays_closed_and_keeps_its_volume():
    s = trimesh.creation.icosphere(6)  # 40,962 vertices
    v, f = cluster_surface(s.vertices, s.faces, 4000)
    assert 2800 < len(v) < 5600
    check_closed(f)  # every edge used as often each way
    assert signed_volume(v, f) == pytest.approx(s.volume, rel=0.01)
    assert np.abs(np.linalg.norm(v, axis=1) - 1.0).max() < 0.01  # the points on the sphere


def test_the_two_sides_of_a_part_thinner_than_a_cell_stay_apart():
    slab = _slab(0.004)
    v, f = cluster_surface(slab.vertices, slab.faces, 2000)  # cells about 0.03 wide, 8 slabs thick
    check_closed(f)
    top, bottom = v[:, 2] > 0.0, v[:, 2] < 0.0
    assert top.sum() > 500 and bottom.sum() > 500  # each side its own vertices
    assert signed_volume(v, f) == pytest.approx(0.004, rel=0.05)


def test_a_surface_the_target_would_hardly_simplify_comes_back_as_it_is():
    s = trimesh.creation.icosphere(3)
    v, f = cluster_surface(s.vertices, s.faces, len(s.vertices) // 2 + 1)
    assert len(v) == len(s.vertices) and np.array_equal(f, s.faces)
    assert f.dtype == np.int32


def test_only_big_surfaces_far_above_their_cage_are_clustered_first():
    assert clusters_first(cluster.CLUSTER_MIN_FACES, 1000)
    assert not clusters_first(cluster.CLUSTER_MIN_FACES - 1, 1000)
    assert not clusters_first(cluster.CLUSTER_MIN_FACES, cluster.CLUSTER_MIN_FACES // 4)


def test_a_big_cage_is_clustered_to_near_its_size_a_small_one_to_a_finer_grid():
    for t in (10, 2_000, 9_999, 10_000, 20_000, 33_333, 34_000, 138_371, 553_385):
        k = clustered_size(t)
        assert k >= cluster.CLUSTER_FACTOR * t - 1  # never coarser than the factor says
        assert k >= min(cluster.FLOOR_FACTOR * t, cluster.CLUSTER_FLOOR)  # nor than the floor
        assert k <= max(cluster.CLUSTER_FACTOR * t, cluster.FLOOR_FACTOR * t)
    assert clustered_size(2_000) == cluster.FLOOR_FACTOR * 2_000  # a small part's cage: 5x
    assert clustered_size(138_371) == int(cluster.CLUSTER_FACTOR * 138_371)  # the 2.77M armadillo's: 1.5x


@pytest.mark.slow
def test_the_armadillo_cage_made_through_clusters_edits_as_well(armadillo_path, monkeypatch):
    """The 43K armadillo's 5% cage with the first pass forced: a binding as sparse, exact at rest and at
    the constraints, and an edge error within 1.05x of the cage of quadric collapses alone."""
    mesh = he.read_mesh(armadillo_path)
    handle, roi, T = canonical_edit(mesh)
    diag = mesh.bbox_diagonal()
    errors = []
    for threshold in (2**62, 0):
        monkeypatch.setattr(cluster, "CLUSTER_MIN_FACES", threshold)
        rig = he.build_rig(mesh, cage_size=0.05)
        nnz = np.diff(rig.M.indptr)
        assert nnz.max() <= MAX_ROW
        assert np.allclose(np.asarray(rig.M.sum(axis=1)).ravel(), 1.0)  # partition of unity
        ed = he.HybridEditor(rig)
        assert np.abs(ed.deformed_vertices - mesh.vertices).max() <= 1e-12 * diag
        ed.set_selection(handle, roi=roi)
        for _ in range(3):
            V = ed.drag(transform=T)
        fixed = np.setdiff1d(np.arange(mesh.n_vertices), np.union1d(roi, handle))
        assert np.abs(V[fixed] - mesh.vertices[fixed]).max() <= 1e-12 * diag
        assert np.abs(V[handle] - he.apply_transform(T, mesh.vertices[handle])).max() <= 1e-9 * diag
        errors.append(he.rrms_edge_error(mesh.vertices, V, mesh.edges()))
    assert errors[1] <= 1.05 * errors[0], errors
