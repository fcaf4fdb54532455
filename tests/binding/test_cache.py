import json

import numpy as np
import pytest

from hybridedit import HybridEditor, Mesh
from hybridedit.binding import cache as bindcache
from shapes import bumpy_blob

#: a cage and binding entry (a companion, such as an editor's set-up, has a longer name)
ENTRY = "?" * 40 + ".npz"


@pytest.fixture
def shape():
    return bumpy_blob(3)


def test_second_build_comes_from_the_cache(tmp_path, shape):
    a = HybridEditor(shape, 80, cache=tmp_path)
    assert not a.cache_hit
    assert len(list(tmp_path.glob(ENTRY))) == 1
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
    (f,) = tmp_path.glob(ENTRY)
    if damage == "truncate":
        f.write_bytes(f.read_bytes()[:300])
    elif damage == "garbage":
        f.write_bytes(b"\x00not a zip" * 50)
    else:  # a valid file of another shape under this name: the stored key differs
        other = bumpy_blob(2)
        key = bindcache.cache_key(other, 40, 0.03)
        bindcache.store(tmp_path / "x", key, HybridEditor(other, 40).cage, HybridEditor(other, 40).M)
        (g,) = (tmp_path / "x").glob(ENTRY)
        f.write_bytes(g.read_bytes())
    with pytest.warns(bindcache.CacheEntryDiscarded):
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


def _rewrite_entry(path, resign=True, **changes):
    """Rewrite an entry with some arrays changed (a valid zip); ``resign``: with the checksum
    recomputed, as a writer that knew the format would, so that only the later checks can
    catch the change."""
    with np.load(path, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files}
    arrays.update(changes)
    if resign:
        arrays["checksum"] = np.array(bindcache.checksum(str(arrays["key"]), str(arrays["versions"]), arrays))
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)


@pytest.mark.parametrize("damage", ["nan_cage", "inf_weight", "shape", "bad_faces"])
def test_entries_failing_any_check_are_discarded_and_rebuilt(tmp_path, shape, damage):
    a = HybridEditor(shape, 80, cache=tmp_path)
    (f,) = tmp_path.glob(ENTRY)
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
    with pytest.warns(bindcache.CacheEntryDiscarded):
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

    from hybridedit.binding import cache as bindcache
    from hybridedit.binding.rig import build_rig

    shape = bumpy_blob(2)
    first = build_rig(shape, cage_size=40, cache=tmp_path)
    assert not first.cache_hit and len(list(tmp_path.glob(ENTRY))) == 1
    real_load = bindcache.load

    def stale(folder, key, mesh):
        cage, M, notes, links = real_load(folder, key, mesh)
        return cage, sp.hstack([M, sp.csr_matrix((M.shape[0], 1))]).tocsr(), notes, links

    monkeypatch.setattr(bindcache, "load", stale)
    again = build_rig(shape, cage_size=40, cache=tmp_path)
    assert not again.cache_hit and again.M.shape == first.M.shape  # rebuilt, and stored again
    monkeypatch.setattr(bindcache, "load", real_load)
    assert build_rig(shape, cage_size=40, cache=tmp_path).cache_hit


# --------------------------------------------------------------------------- checksum and versions


def test_the_cage_links_are_kept_with_the_entry(tmp_path):
    """A cage of many pieces: its links are stored with the entry and come back equal to the ones
    computed from the cage (a reopen does not search among the pieces again)."""
    from hybridedit.binding import cache as bindcache
    from hybridedit.cage.links import cage_links
    from hybridedit.binding.rig import build_rig

    a, b = bumpy_blob(2), bumpy_blob(2)
    inner = Mesh(0.4 * a.vertices, a.faces)  # a piece inside another: tied to it
    shape = Mesh(np.vstack([b.vertices, inner.vertices]), np.vstack([b.faces, inner.faces + b.n_vertices]))
    built = build_rig(shape, cage_size=60, cache=tmp_path)
    key = bindcache.cache_key(shape, 60, 0.03)
    cage, _, _, links = bindcache.load(tmp_path, key, shape)
    assert len(links) > 0 and np.array_equal(links, cage_links(cage)) and np.array_equal(links, built.links)
    again = build_rig(shape, cage_size=60, cache=tmp_path)
    assert again.cache_hit and np.array_equal(again.links, built.links)


def _shifted(f, by=0.1):
    with np.load(f) as z:
        return z["cage_vertices"] + np.array([by, 0.0, 0.0])


def _flip_byte(f):
    """Flip one byte inside the binding's weights, the zip itself left valid (its CRC recomputed)."""
    with np.load(f) as z:
        data = z["data"].copy()
    raw = data.view(np.uint8)
    raw[raw.size // 2] ^= 0x01
    _rewrite_entry(f, resign=False, data=data)


def _flip_byte_raw(f):
    """Flip one byte of the file on disk, as a bad sector would."""
    b = bytearray(f.read_bytes())
    b[len(b) // 2] ^= 0xFF
    f.write_bytes(bytes(b))


def _other_version(f):
    with np.load(f) as z:
        versions = json.loads(str(z["versions"]))
    versions["hybridedit"] = "0.0.1"
    _rewrite_entry(f, resign=True, versions=np.array(json.dumps(versions, sort_keys=True)))


TAMPER = {
    "shifted cage": lambda f: _rewrite_entry(f, resign=False, cage_vertices=_shifted(f)),
    "truncated file": lambda f: f.write_bytes(f.read_bytes()[: f.stat().st_size * 2 // 3]),
    "flipped byte in a weight": _flip_byte,
    "flipped byte on disk": _flip_byte_raw,
    "another version": _other_version,
    "no checksum": lambda f: _strip(f, "checksum"),
}


def _strip(f, name):
    with np.load(f, allow_pickle=False) as z:
        arrays = {k: z[k] for k in z.files if k != name}
    with open(f, "wb") as fh:
        np.savez(fh, **arrays)


@pytest.mark.parametrize("case", list(TAMPER))
def test_a_tampered_entry_is_discarded_with_a_note_and_rebuilt(tmp_path, shape, case):
    """Each tamper case: the entry is not used (a note says why), the rebuilt editor's
    output is the clean one exactly, and the entry written again is a hit next time."""
    clean = HybridEditor(shape, 80, cache=tmp_path)
    handle = np.flatnonzero(shape.vertices[:, 0] > 0.6)
    roi = np.flatnonzero(shape.vertices[:, 0] > 0.0)
    clean.set_selection(handle, roi=roi)
    want = clean.pose(translate=(0.0, 0.3, 0.0)).copy()
    (f,) = tmp_path.glob(ENTRY)
    TAMPER[case](f)
    with pytest.warns(bindcache.CacheEntryDiscarded, match="rebuilt") as rec:
        again = HybridEditor(shape, 80, cache=tmp_path)
    print(f"{case}: {rec[0].message}")
    assert not again.cache_hit
    assert any("not used" in n and "rebuilt" in n for n in again.notes)  # a note the window and CLI show
    assert np.array_equal(again.cage.vertices, clean.cage.vertices) and (again.M != clean.M).nnz == 0
    again.set_selection(handle, roi=roi)
    assert np.array_equal(again.pose(translate=(0.0, 0.3, 0.0)), want)
    assert HybridEditor(shape, 80, cache=tmp_path).cache_hit  # stored again, correctly


def test_only_the_checksum_catches_a_shifted_cage(tmp_path, shape):
    """A cage shifted on disk is a valid mesh, so every structural check passes it: re-signed,
    it loads (and would move the output by the shift); unsigned, the checksum refuses it."""
    HybridEditor(shape, 80, cache=tmp_path)
    (f,) = tmp_path.glob(ENTRY)
    key = bindcache.cache_key(shape, 80, 0.03)
    clean_cage = bindcache.load(tmp_path, key, shape)[0].vertices
    _rewrite_entry(f, resign=True, cage_vertices=_shifted(f, 0.1))
    cage, _, _, _ = bindcache.load(tmp_path, key, shape)
    assert np.allclose(cage.vertices - clean_cage, [0.1, 0, 0])
    _rewrite_entry(f, resign=False, cage_vertices=_shifted(f, 0.1))
    with pytest.warns(bindcache.CacheEntryDiscarded, match="checksum"):
        assert bindcache.load(tmp_path, key, shape) is None


def test_an_entry_records_its_writers_versions_and_checksum(tmp_path, shape):
    HybridEditor(shape, 80, cache=tmp_path)
    (f,) = tmp_path.glob(ENTRY)
    with np.load(f) as z:
        versions = json.loads(str(z["versions"]))
        arrays = {k: z[k] for k in z.files}
    import hybridedit

    assert versions["hybridedit"] == hybridedit.__version__
    assert versions["fast-simplification"] not in ("", "none")
    assert str(arrays["checksum"]) == bindcache.checksum(str(arrays["key"]), str(arrays["versions"]), arrays)
    assert len(str(arrays["checksum"])) == 64  # SHA-256


def test_an_entry_is_read_memory_mapped_and_equal_to_what_was_stored(tmp_path):
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=5)  # 10K vertices: M is mapped, not read
    mesh = Mesh(np.asarray(s.vertices), np.asarray(s.faces))
    built = HybridEditor(mesh, 200, cache=tmp_path)
    (f,) = tmp_path.glob(ENTRY)
    z = bindcache.read_entry_file(f)
    with np.load(f) as ref:
        assert sorted(z) == sorted(ref.files)
        assert all(np.array_equal(z[k], ref[k]) and z[k].dtype == ref[k].dtype for k in ref.files)

    def mapped(a):
        while a is not None and not isinstance(a, np.memmap):
            a = a.base
        return a is not None

    assert mapped(z["data"]) and mapped(z["indices"]) and z["data"].flags.writeable
    # mapped arrays start on a multiple of 64 bytes, as in memory: the kernels see aligned arrays
    assert all(z[k].flags.aligned for k in z)
    assert all(z[k].ctypes.data % 64 == 0 for k in z if mapped(z[k]))
    again = HybridEditor(mesh, 200, cache=tmp_path)
    assert again.cache_hit and (again.M != built.M).nnz == 0
    assert np.array_equal(again.cage.vertices, built.cage.vertices)


@pytest.mark.parametrize("cut", [0.3, 0.7, 0.999])
def test_a_truncated_mapped_entry_is_refused(tmp_path, cut):
    import trimesh

    s = trimesh.creation.icosphere(subdivisions=5)
    mesh = Mesh(np.asarray(s.vertices), np.asarray(s.faces))
    HybridEditor(mesh, 200, cache=tmp_path)
    (f,) = tmp_path.glob(ENTRY)
    data = f.read_bytes()
    f.write_bytes(data[: int(len(data) * cut)])
    with pytest.warns(bindcache.CacheEntryDiscarded):
        again = HybridEditor(mesh, 200, cache=tmp_path)
    assert not again.cache_hit


def test_large_arrays_are_digested_in_pieces_and_any_piece_counts(monkeypatch):
    import hashlib

    monkeypatch.setattr(bindcache, "DIGEST_PIECE", 1024)
    a = np.arange(1000, dtype=np.float64)  # 8,000 bytes: 8 pieces
    small = np.arange(10, dtype=np.int64)
    digest, small_digest = bindcache._digests([a, small])
    raw = a.tobytes()
    pieces = b"".join(hashlib.sha256(raw[s:s + 1024]).digest() for s in range(0, len(raw), 1024))
    assert digest == hashlib.sha256(pieces).digest()
    assert small_digest == hashlib.sha256(small.tobytes()).digest()  # one piece: its own digest
    for at in (0, 1500, 7999):  # a change in any piece changes the digest
        b = a.copy()
        b.view(np.uint8)[at] ^= 1
        assert bindcache._digests([b, small])[0] != digest
    monkeypatch.setattr(bindcache, "DIGEST_PIECE", 1 << 25)
    assert bindcache._digests([a])[0] == hashlib.sha256(raw).digest()
    big = np.arange(4_500_000, dtype=np.float64)  # over 16 MB: the pieces go to two threads
    raw = big.tobytes()
    piece = 1 << 25
    want = hashlib.sha256(b"".join(hashlib.sha256(raw[s:s + piece]).digest() for s in range(0, len(raw), piece)))
    assert bindcache._digests([small, big]) == [hashlib.sha256(small.tobytes()).digest(), want.digest()]
