import sys

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from hybridedit.cage import qem
from hybridedit.cage.build import build_cage
from hybridedit.core.parallel import all_parallel as qem_all_parallel
from hybridedit.core.topology import is_closed_oriented

from shapes import bumpy_blob


@pytest.fixture(scope="module")
def big_blob():
    return bumpy_blob(5)  # 10,242 vertices, 20,480 faces


def _compact(v, f):
    used = np.zeros(len(v), dtype=bool)
    used[f.ravel()] = True
    return v[used], (np.cumsum(used) - 1)[f]


def test_a_small_surface_comes_back_unchanged(blob):
    v, f = qem.presimplify(blob.vertices, blob.faces, 100)
    assert np.array_equal(v, blob.vertices) and np.array_equal(f, blob.faces)


def test_one_core_does_not_split(big_blob, monkeypatch):
    monkeypatch.setattr(qem, "_cores", lambda: 1)
    v, f = qem.presimplify(big_blob.vertices, big_blob.faces, 1000, min_faces=0)
    assert len(f) == big_blob.n_faces


def test_the_halves_join_into_one_closed_surface_on_the_shape(big_blob):
    target = 1000
    v, f = qem.presimplify(big_blob.vertices, big_blob.faces, target, min_faces=0)
    assert f.dtype == np.int32
    # far fewer faces, at least the target with its margin
    assert qem.MARGIN * target * 0.95 <= len(f) < 0.5 * big_blob.n_faces
    cv, cf = _compact(v, f)
    # the cut is welded: every edge is used once each way, with no duplicate vertex left on it
    assert is_closed_oriented(cf, len(cv))
    t = trimesh.Trimesh(cv, cf, process=False)
    assert t.is_watertight and t.euler_number == 2 and t.volume > 0
    # the vertices stay on the shape
    d = cKDTree(big_blob.vertices).query(cv)[0]
    assert d.max() < 0.02 * big_blob.bbox_diagonal()


def test_the_cut_keeps_input_vertices_exactly(big_blob):
    v, f = qem.presimplify(big_blob.vertices, big_blob.faces, 1000, min_faces=0)
    cv, _ = _compact(v, f)
    exact = cKDTree(big_blob.vertices).query(cv)[0] == 0.0
    # the cut runs across the whole shape: many of its vertices were kept where they were
    assert exact.sum() > 50


@pytest.mark.parametrize("worker", [
    [sys.executable, "-c", "import sys; sys.exit(3)"],  # fails
    [sys.executable, "-c", "import sys; sys.stdout.buffer.write(b'garbage')"],  # bad output
    ["/nonexistent/python"],  # cannot start
    [""],  # no interpreter to start (an embedded Python)
])
def test_a_failing_worker_leaves_its_half_to_this_process(big_blob, monkeypatch, worker):
    good = qem.presimplify(big_blob.vertices, big_blob.faces, 1000, min_faces=0)
    monkeypatch.setattr(qem, "WORKER", worker)
    v, f = qem.presimplify(big_blob.vertices, big_blob.faces, 1000, min_faces=0)
    # the simplification is deterministic: the same surface either way
    assert np.array_equal(v, good[0]) and np.array_equal(f, good[1])


def test_a_worker_started_early_is_used_once_and_closed(big_blob):
    target = 1000
    plain = qem.presimplify(big_blob.vertices, big_blob.faces, target, min_faces=0)
    w = qem.HalfWorker()
    try:
        got = qem.presimplify(big_blob.vertices, big_blob.faces, target, min_faces=0, worker=w)
        assert w.used
        # used already: a second call starts its own
        again = qem.presimplify(big_blob.vertices, big_blob.faces, target, min_faces=0, worker=w)
    finally:
        w.close()
    for v, f in (got, again):
        assert np.array_equal(v, plain[0]) and np.array_equal(f, plain[1])


def test_an_unused_worker_closes_at_once():
    w = qem.HalfWorker()
    w.close()
    assert w.result() is None
    assert qem.start_worker(10, 1, 8) is None  # too small to split: no worker


def test_no_worker_for_a_surface_too_near_its_target_to_split(monkeypatch):
    monkeypatch.setattr(qem, "_cores", lambda: 2)
    m = 2 * qem.SPLIT_MIN_FACES
    near = int(0.5 * m / qem.MARGIN) + 1  # the halves would keep more than half the surface
    assert qem.will_split(m, near - 2) and not qem.will_split(m, near)
    assert qem.start_worker(m, near, m // 2) is None


def test_a_cage_built_from_halves_is_closed_and_of_the_asked_size(big_blob, monkeypatch):
    monkeypatch.setattr(qem, "SPLIT_MIN_FACES", 0)
    c = build_cage(big_blob, 0.05)
    target = round(0.05 * big_blob.n_vertices)
    assert abs(c.n_vertices - target) <= max(2, 0.02 * target)
    t = trimesh.Trimesh(c.vertices, c.faces, process=False)
    assert t.is_watertight and t.is_winding_consistent and t.volume > 0 and t.euler_number == 2
    d = cKDTree(big_blob.vertices).query(c.vertices)[0]
    assert d.max() < 0.05 * big_blob.bbox_diagonal()


def test_the_cage_build_reports_its_progress_in_steps(big_blob, monkeypatch):
    from hybridedit.cage.parts import REPAIR_SHARE, cage_parts
    from hybridedit.cage.simplify import HALVES_SHARE

    monkeypatch.setattr(qem, "SPLIT_MIN_FACES", 0)
    seen = []
    cage_parts(big_blob, 0.05, progress=seen.append)
    # the repair pass, the two halves, the whole: a time-left estimate has steps to go by
    assert seen == sorted(seen) and seen[-1] == 1.0
    assert REPAIR_SHARE in seen
    assert REPAIR_SHARE + (1 - REPAIR_SHARE) * HALVES_SHARE in seen


@pytest.mark.slow
@pytest.mark.parametrize("dtype", [np.int32, np.int64])
def test_the_cut_into_halves_is_the_faces_each_side_of_the_median_compacted(big_blob, dtype):
    v, f = big_blob.vertices, big_blob.faces.astype(dtype)
    axis = 0
    key = qem._face_keys(v, f, axis)
    with qem_all_parallel():
        assert np.array_equal(qem._face_keys(v, f, axis), key)
    assert np.array_equal(key, v[f[:, 0], axis] + v[f[:, 1], axis] + v[f[:, 2], axis])
    pivot = np.partition(key, len(f) // 2)[len(f) // 2]
    (v0, f0), (v1, f1) = qem._halves(v, f, key, pivot)
    for (vh, fh), side in (((v0, f0), key <= pivot), ((v1, f1), key > pivot)):
        want_v, want_f = _compact(v, f[side])
        assert fh.dtype == np.int32 and vh.dtype == np.float64
        assert np.array_equal(vh, want_v) and np.array_equal(fh, want_f)
    assert len(f0) + len(f1) == len(f) and len(f0) > len(f) // 2 and len(f1) > 0  # (ties go first)
