import numpy as np
import pytest

from hybridedit import HybridEditor, bindcache

from shapes import bumpy_blob


@pytest.fixture
def shape():
    return bumpy_blob(3)


def test_second_build_comes_from_the_cache(tmp_path, shape):
    a = HybridEditor(shape, 80, cache=tmp_path)
    assert not a.cache_hit
    assert len(list(tmp_path.glob("*.npz"))) == 1
    b = HybridEditor(shape, 80, cache=tmp_path)
    assert b.cache_hit
    assert np.array_equal(a.cage.vertices, b.cage.vertices) and np.array_equal(a.cage.faces, b.cage.faces)
    assert (a.M != b.M).nnz == 0


def test_other_settings_or_shape_miss(tmp_path, shape):
    HybridEditor(shape, 80, cache=tmp_path)
    assert not HybridEditor(shape, 81, cache=tmp_path).cache_hit
    assert not HybridEditor(shape, 80, truncation=0.05, cache=tmp_path).cache_hit
    moved = shape.copy(shape.vertices + [0, 0, 1e-9])
    assert not HybridEditor(moved, 80, cache=tmp_path).cache_hit


@pytest.mark.parametrize("damage", ["truncate", "garbage", "swap"])
def test_damaged_cache_files_are_rebuilt(tmp_path, shape, damage):
    a = HybridEditor(shape, 80, cache=tmp_path)
    (f,) = tmp_path.glob("*.npz")
    if damage == "truncate":
        f.write_bytes(f.read_bytes()[:300])
    elif damage == "garbage":
        f.write_bytes(b"\x00not a zip" * 50)
    else:  # a valid file of another shape under this name: the stored key differs
        other = bumpy_blob(2)
        key = bindcache.cache_key(other, 40, 0.03)
        bindcache.store(tmp_path / "x", key, HybridEditor(other, 40).cage, HybridEditor(other, 40).M)
        (g,) = (tmp_path / "x").glob("*.npz")
        f.write_bytes(g.read_bytes())
    b = HybridEditor(shape, 80, cache=tmp_path)
    assert not b.cache_hit
    assert (a.M != b.M).nnz == 0
    assert HybridEditor(shape, 80, cache=tmp_path).cache_hit  # rewritten correctly


def test_unwritable_cache_folder_is_not_fatal(tmp_path, shape):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    ed = HybridEditor(shape, 80, cache=blocker / "sub")
    assert not ed.cache_hit and ed.M.shape[0] == shape.n_vertices


def test_repair_notes_survive_the_cache(tmp_path):
    shape = bumpy_blob(3)
    f = shape.faces.copy()
    f[::7] = f[::7, ::-1]  # inconsistent orientation: repaired on the cage's copy
    bad = shape.copy()
    bad.faces = f
    a = HybridEditor(bad, 80, cache=tmp_path)
    assert any("re-oriented" in n for n in a.notes)
    b = HybridEditor(bad, 80, cache=tmp_path)
    assert b.cache_hit and b.notes == a.notes


def _rewrite_entry(path, **changes):
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(changes)
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


@pytest.mark.parametrize("damage", ["nan_cage", "inf_weight", "shape", "bad_faces"])
def test_entries_failing_any_check_are_discarded_and_rebuilt(tmp_path, shape, damage):
    a = HybridEditor(shape, 80, cache=tmp_path)
    (f,) = tmp_path.glob("*.npz")
    with np.load(f) as z:
        cv, data, cf = z["cage_vertices"].copy(), z["data"].copy(), z["cage_faces"].copy()
    if damage == "nan_cage":
        cv[3, 1] = np.nan
        _rewrite_entry(f, cage_vertices=cv)
    elif damage == "inf_weight":
        data[0] = np.inf
        _rewrite_entry(f, data=data)
    elif damage == "shape":
        _rewrite_entry(f, shape=np.array([shape.n_vertices + 1, len(cv)]))
    else:
        cf[0, 0] = len(cv) + 5
        _rewrite_entry(f, cage_faces=cf)
    key = bindcache.cache_key(shape, 80, 0.03)
    assert bindcache.load(tmp_path, key, shape) is None
    assert not f.exists()  # discarded, not tried again on every run
    b = HybridEditor(shape, 80, cache=tmp_path)
    assert not b.cache_hit and np.all(np.isfinite(b.cage.vertices))
    assert (a.M != b.M).nnz == 0
    assert HybridEditor(shape, 80, cache=tmp_path).cache_hit


def test_an_entry_that_fails_when_used_is_discarded_and_rebuilt(tmp_path, monkeypatch):
    """An entry can pass the loader's checks and still not serve (here: a binding of
    the wrong width, as a stale format would give): it is deleted and rebuilt."""
    import scipy.sparse as sp

    from hybridedit import bindcache
    from hybridedit.rig import build_rig

    shape = bumpy_blob(2)
    first = build_rig(shape, cage_size=40, cache=tmp_path)
    assert not first.cache_hit and len(list(tmp_path.glob("*.npz"))) == 1
    real_load = bindcache.load

    def stale(folder, key, mesh):
        cage, M, notes = real_load(folder, key, mesh)
        return cage, sp.hstack([M, sp.csr_matrix((M.shape[0], 1))]).tocsr(), notes

    monkeypatch.setattr(bindcache, "load", stale)
    again = build_rig(shape, cage_size=40, cache=tmp_path)
    assert not again.cache_hit and again.M.shape == first.M.shape  # rebuilt, and stored again
    monkeypatch.setattr(bindcache, "load", real_load)
    assert build_rig(shape, cage_size=40, cache=tmp_path).cache_hit
