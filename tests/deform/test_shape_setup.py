"""An editor's set-up of a shape: made once, then read from the cache beside the rig's entry."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import hybridedit as he
from hybridedit.binding import cache as bindcache
from hybridedit.deform import shape_setup as S

from shapes import bumpy_blob


@pytest.fixture(scope="module")
def blob():
    return bumpy_blob(3)


def _equal(a: S.ShapeSetup, b: S.ShapeSetup) -> bool:
    return all(np.array_equal(x, y) and x.dtype == y.dtype for x, y in zip(a.arrays().values(), b.arrays().values()))


def test_a_cached_open_makes_nothing_the_cache_holds(blob, tmp_path, monkeypatch):
    first = he.HybridEditor(blob, 80, cache=tmp_path)
    assert not first.cache_hit and not first.setup_cached
    S.wait_for_stores()  # (written in the background)
    assert list(tmp_path.glob(f"*.{S.KIND}.npz"))

    def rebuilt(*args, **kwargs):
        raise AssertionError("rebuilt on a cached open")

    # everything an open derives from the shape, the cage and the binding
    monkeypatch.setattr(S, "make_shape_setup", rebuilt)
    monkeypatch.setattr(S, "residual_setup", rebuilt)
    monkeypatch.setattr(S, "dominant_cage_vertex", rebuilt)
    import hybridedit.binding.rig as rig_module

    monkeypatch.setattr(rig_module, "NearestPoints", rebuilt)
    monkeypatch.setattr(rig_module, "nearest_points", rebuilt)
    monkeypatch.setattr(rig_module, "cage_and_binding", rebuilt)
    again = he.HybridEditor(blob, 80, cache=tmp_path)
    assert again.cache_hit and again.setup_cached
    # and the editor is the same: same rest pose, same drag
    x = blob.vertices[:, 0]
    for ed in (first, again):
        ed.set_selection(np.flatnonzero(x > 1.4), roi=np.flatnonzero(x > 0.5))
        ed.drag(translate=(0, 0.4, 0))
    assert np.array_equal(first.deformed_vertices, again.deformed_vertices)


def test_the_cached_setup_reads_back_equal_to_the_made_one(blob, tmp_path):
    rig = he.build_rig(blob, cage_size=80, cache=tmp_path)
    made = S.shape_setup(rig)
    read = S.shape_setup(he.build_rig(blob, cage_size=80, cache=tmp_path))
    assert not made.from_cache and read.from_cache
    assert _equal(made, read) and _equal(made, S.make_shape_setup(rig))


def test_a_damaged_setup_is_refused_and_made_again(blob, tmp_path):
    rig = he.build_rig(blob, cage_size=80, cache=tmp_path)
    made = S.shape_setup(rig)
    S.wait_for_stores()
    (path,) = tmp_path.glob(f"*.{S.KIND}.npz")
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.warns(bindcache.CacheEntryDiscarded):
        again = S.shape_setup(rig)
    assert not again.from_cache and _equal(made, again)
    assert S.shape_setup(rig).from_cache  # stored again (a read waits for this process's write)


def test_a_setup_that_does_not_fit_its_rig_is_refused(blob, tmp_path):
    rig = he.build_rig(blob, cage_size=80, cache=tmp_path)
    arrays = S.make_shape_setup(rig).arrays()
    arrays["nearest"] = arrays["nearest"] + blob.n_vertices  # (checksummed as written: only the check sees it)
    bindcache.store_arrays(tmp_path, rig.cache_key, S.KIND, arrays)
    with pytest.warns(bindcache.CacheEntryDiscarded, match="nearest out of range"):
        setup = S.shape_setup(rig)
    assert not setup.from_cache and setup.nearest.max() < blob.n_vertices


def test_without_the_cache_nothing_is_stored(blob, tmp_path, monkeypatch):
    monkeypatch.setenv("HYBRIDEDIT_CACHE_DIR", str(tmp_path))
    rig = he.build_rig(blob, cage_size=80)
    assert rig.cache_key is None
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        S.shape_setup(rig)
    assert not list(tmp_path.iterdir())


def test_discarding_an_entry_discards_its_setup(blob, tmp_path):
    rig = he.build_rig(blob, cage_size=80, cache=tmp_path)
    S.shape_setup(rig)
    bindcache.discard(tmp_path, rig.cache_key)
    assert not list(tmp_path.glob("*.npz"))


def test_an_open_makes_no_laplacian_rows_and_a_selection_only_its_own(blob, monkeypatch):
    from hybridedit.core.cotangent_laplacian import ShapeLaplacian

    asked = []
    rows = ShapeLaplacian.rows
    monkeypatch.setattr(ShapeLaplacian, "rows", lambda self, index: asked.append(len(index)) or rows(self, index))
    ed = he.HybridEditor(blob, 80)
    assert asked == []  # (the region step's matrix is made by the selection that solves with it)
    x = blob.vertices[:, 0]
    ed.set_selection(np.flatnonzero(x > 1.4), roi=np.flatnonzero(x > 0.5))
    assert asked and sum(asked) < blob.n_vertices


def test_an_earlier_versions_setup_is_deleted_when_this_one_is_written(blob, tmp_path):
    rig = he.build_rig(blob, cage_size=80, cache=tmp_path)
    bindcache.store_arrays(tmp_path, rig.cache_key, "setup1", {"residual": np.zeros((1, 3))})
    assert list(tmp_path.glob("*.setup1.npz"))
    S.shape_setup(rig)
    S.wait_for_stores()
    assert not list(tmp_path.glob("*.setup1.npz")) and list(tmp_path.glob(f"*.{S.KIND}.npz"))


def _nearest_by_brute_force(points, queries):
    d = ((queries[:, None, :] - points[None, :, :]) ** 2).sum(axis=2)
    return np.argmin(d, axis=1)


def test_a_cold_builds_tree_serves_the_setup_once_then_a_tree_is_made(blob, monkeypatch):
    """The shape's k-d tree a cold build started beside the cage gives the set-up its nearest
    vertices (no second tree); asked again, the rig makes one of its own."""
    import hybridedit.binding.rig as rig_module

    rig = he.build_rig(blob, cage_size=80)
    made = []
    real = rig_module.nearest_points
    monkeypatch.setattr(rig_module, "nearest_points", lambda *a: made.append(1) or real(*a))
    setup = S.make_shape_setup(rig)
    want = _nearest_by_brute_force(blob.vertices, rig.cage.vertices)
    assert np.array_equal(setup.nearest, want) and setup.nearest.dtype == np.int64 and not made
    again = S.make_shape_setup(rig)
    assert made == [1] and _equal(setup, again)


def test_a_rig_given_its_cage_and_binding_makes_its_tree_at_the_setup(blob):
    rig = he.build_rig(blob, cage_size=80)
    given = he.build_rig(blob, cage=rig.cage, binding=rig.M)
    assert "_shape_tree" not in given.__dict__
    assert np.array_equal(S.make_shape_setup(given).nearest, _nearest_by_brute_force(blob.vertices, rig.cage.vertices))


def test_a_binding_with_repeated_entries_still_gets_its_dominant_vertices(blob):
    """The top-k's first vertex stands for the dominant one only on rows without repeats; a
    binding given with an entry split in three is summed first, as the rule says."""
    import scipy.sparse as sp

    from hybridedit.binding.bind import dominant_cage_vertex

    rig = he.build_rig(blob, cage_size=80)
    M = rig.M
    a, b = M.indptr[0], M.indptr[1]
    vals = M.data[a:b]
    s = int(np.argmin(np.abs(vals)))  # row 0's smallest entry gets two more copies of 0.99 x its largest
    extra = np.full(2, 0.99 * np.abs(vals).max())
    data = np.concatenate([M.data[:a + s + 1], extra, M.data[a + s + 1:]])
    indices = np.concatenate([M.indices[:a + s + 1], [M.indices[a + s]] * 2, M.indices[a + s + 1:]])
    indptr = M.indptr + np.where(np.arange(len(M.indptr)) >= 1, 2, 0)
    split = sp.csr_matrix((data, indices, indptr), shape=M.shape)
    assert not split.has_canonical_format
    assert dominant_cage_vertex(split)[0] == M.indices[a + s] != dominant_cage_vertex(M)[0]
    given = he.build_rig(blob, cage=rig.cage, binding=split)
    assert np.array_equal(S.make_shape_setup(given).dominant, dominant_cage_vertex(split))


def test_a_cold_rig_pickles_and_copies_without_its_pending_tree(blob):
    import copy
    import pickle

    rig = he.build_rig(blob, cage_size=80)
    assert "_shape_tree" in rig.__dict__
    for other in (pickle.loads(pickle.dumps(rig)), copy.copy(rig)):
        assert "_shape_tree" not in other.__dict__
        assert _equal(S.make_shape_setup(other), S.make_shape_setup(rig))
