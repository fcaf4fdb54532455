"""On-disk cache of cages and bindings, keyed by the shape and the settings.

A cache file holds the cage (vertices, faces) and the binding matrix M of one
shape for one (cage size, truncation) setting. Its name is a hash of the shape's
vertices and faces, the settings and :data:`FORMAT`; the same key is stored
inside and checked on load. Every entry also carries a SHA-256 checksum of its
whole payload (key, versions, every array's dtype, shape and bytes) and the
versions of the libraries that wrote it (:func:`writer_versions`: hybridedit and
fast-simplification, which make the cage). On load the checksum is recomputed
and the versions compared before anything else, then the arrays' shapes and the
rows of M summing to 1 are checked: a corrupt, truncated, tampered (a cage
shifted on disk passes every structural check, not the checksum) or stale file
is discarded with a note (a :class:`CacheEntryDiscarded` warning) and rebuilt,
never used. Files are written atomically, and read memory-mapped (:func:`read_entry_file`).
Beside an entry, companions (:func:`store_arrays`) keep what is derived from it, checked the same
way (an editor's set-up: :mod:`hybridedit.deform.shape_setup`).
"""

from __future__ import annotations

import hashlib
import json
import os
import warnings
from functools import lru_cache
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from ..fileio.atomic import atomic_write
from ..core.fingerprint import shape_bytes
from ..core.mesh import Mesh

#: Bump when the cage or binding algorithms change: old files stop matching.
FORMAT = "hybridedit-binding-11"

#: the arrays of an entry, in the order the checksum reads them
PAYLOAD = ("cage_vertices", "cage_faces", "shape", "data", "indices", "indptr", "notes", "links")


class CacheEntryDiscarded(UserWarning):
    """A cache entry failed its checks (checksum, versions, structure): it was deleted and is rebuilt."""


@lru_cache(maxsize=1)
def writer_versions() -> str:
    """The versions of what makes an entry's content, as stored in it (JSON text):
    hybridedit's and fast-simplification's (the cage's simplification)."""
    from importlib.metadata import PackageNotFoundError, version

    from .. import __version__

    def v(name: str) -> str:
        try:
            return version(name)
        except PackageNotFoundError:
            return "none"

    return json.dumps({"hybridedit": __version__, "fast-simplification": v("fast-simplification")},
                      sort_keys=True)


def checksum(key: str, versions: str, arrays: dict[str, np.ndarray], names: tuple[str, ...] = PAYLOAD) -> str:
    """SHA-256 hex digest of an entry's payload: its key, versions and the arrays ``names`` (by
    default the :data:`PAYLOAD` of a cage and binding; each one's name, dtype, shape and the
    SHA-256 of its bytes, the large ones digested side by side on two threads)."""
    digests = _digests([arrays[name] for name in names])
    h = hashlib.sha256()
    h.update(FORMAT.encode() + b"\0" + key.encode() + b"\0" + versions.encode() + b"\0")
    for name, digest in zip(names, digests):
        a = arrays[name]
        h.update(f"{name}:{a.dtype.str}:{a.shape}\0".encode() + digest)
    return h.hexdigest()


#: arrays are digested in pieces of this many bytes, side by side on two threads
DIGEST_PIECE = 1 << 25


def _digests(arrays: list[np.ndarray]) -> list[bytes]:
    """SHA-256 of each array's bytes; an array larger than :data:`DIGEST_PIECE` is digested
    in pieces (its digest: the SHA-256 of theirs). hashlib lets go of the GIL on large buffers,
    so two threads hash two pieces at once, whatever the sizes of the arrays (a binding's weights
    are most of an entry), reading a memory-mapped entry from disk as they go."""
    from concurrent.futures import ThreadPoolExecutor

    def raw(a: np.ndarray):
        a = np.ascontiguousarray(a)
        return memoryview(a).cast("B") if a.dtype.kind != "U" and a.size else memoryview(a.tobytes())

    views = [raw(a) for a in arrays]
    pieces = [(k, start) for k, v in enumerate(views) for start in range(0, max(len(v), 1), DIGEST_PIECE)]

    def one(piece: tuple[int, int]) -> bytes:
        k, start = piece
        return hashlib.sha256(views[k][start:start + DIGEST_PIECE]).digest()

    if sum(len(v) for v in views) < 2**24:
        digests = [one(p) for p in pieces]
    else:
        with ThreadPoolExecutor(max_workers=2) as pool:
            digests = list(pool.map(one, pieces))
    out: list[list[bytes]] = [[] for _ in views]
    for (k, _), d in zip(pieces, digests):
        out[k].append(d)
    return [d[0] if len(d) == 1 else hashlib.sha256(b"".join(d)).digest() for d in out]


def read_entry_file(path: Path) -> dict[str, np.ndarray]:
    """Every array of an ``.npz`` written by :func:`store` or :func:`store_arrays`, the large ones
    memory-mapped (copy-on-write: writable, never written back) rather than copied into memory,
    so a cached 11M-vertex shape opens without reading its binding twice.

    Raises
    ------
    ValueError, OSError, zipfile.BadZipFile
        Not such a file (a compressed or object member, a truncated file).
    """
    import struct
    import zipfile

    out = {}
    with zipfile.ZipFile(path) as zf, open(path, "rb") as fh:
        size = os.fstat(fh.fileno()).st_size
        for info in zf.infolist():
            name = info.filename.removesuffix(".npy")
            if info.compress_type != zipfile.ZIP_STORED:
                raise ValueError(f"member {name} is compressed")
            fh.seek(info.header_offset)
            local = fh.read(30)
            if len(local) != 30 or local[:4] != b"PK\x03\x04":
                raise ValueError(f"member {name}: no local header")
            name_len, extra_len = struct.unpack("<HH", local[26:30])
            fh.seek(info.header_offset + 30 + name_len + extra_len)
            version = np.lib.format.read_magic(fh)
            shape, fortran, dtype = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                                     else np.lib.format.read_array_header_2_0)(fh)
            if dtype.hasobject:
                raise ValueError(f"member {name} holds objects")
            offset, count = fh.tell(), int(np.prod(shape, dtype=np.int64))
            if offset + count * dtype.itemsize > size:
                raise ValueError(f"member {name} runs past the end of the file")
            # small, or not on a multiple of 64 bytes (an array the kernels see unaligned would be
            # compiled for again, and read slower): read
            if count * dtype.itemsize < 2**16 or offset % 64:
                a = np.frombuffer(fh.read(count * dtype.itemsize), dtype=dtype, count=count).copy()
                out[name] = a.reshape(shape, order="F" if fortran else "C")
            else:
                mm = np.memmap(path, dtype=dtype, mode="c", offset=offset, shape=shape,
                               order="F" if fortran else "C")
                out[name] = np.asarray(mm)
    return out


def cache_key(mesh: Mesh, cage_size: int | float, truncation: float, extra: str = "") -> str:
    """Hex digest naming the cage + binding of ``mesh`` for these settings: the format, the settings,
    then the shape's :func:`~hybridedit.core.fingerprint.shape_bytes` (the vertices and faces each
    digested in pieces, :func:`_digests`)."""
    h = hashlib.sha256()
    h.update(FORMAT.encode())
    h.update(repr((type(cage_size).__name__, cage_size, float(truncation), extra)).encode())
    count, vertices, faces = shape_bytes(mesh.vertices, mesh.faces)
    h.update(count)
    for digest in _digests([vertices, faces]):
        h.update(digest)
    return h.hexdigest()


def _path(folder: Path, key: str) -> Path:
    return folder / f"{key[:40]}.npz"


def load(folder: Path, key: str, mesh: Mesh) -> tuple[Mesh, sp.csr_matrix, list[str], np.ndarray] | None:
    """The cached (cage, M, notes, links) for ``key``, or None when absent or not valid (``links``: the
    cage's extra ARAP edges, :func:`hybridedit.cage.links.cage_links`, (k, 2) int64).

    An entry that fails any check (unreadable, another key, a checksum that does
    not match its payload, written by other library versions, wrong shapes, a
    non-finite or out-of-range value, rows of M not summing to 1, a cage that is
    not a mesh) is deleted with a :class:`CacheEntryDiscarded` warning saying
    why, so that it is rebuilt and stored again.
    """
    p = _path(folder, key)
    if not p.is_file():
        return None
    try:
        return _checked(p, key, mesh)
    except Exception as e:  # noqa: BLE001 -- whatever is wrong with the entry, it is not used
        discard(folder, key)
        why = str(e) if isinstance(e, _Invalid) else f"unreadable: {type(e).__name__}: {str(e)[:60]}"
        warnings.warn(f"hybridedit: cache entry {p.name} not used ({why}); it is rebuilt",
                      CacheEntryDiscarded, stacklevel=2)
        return None


def discard(folder: Path, key: str) -> None:
    """Delete the entry for ``key`` (for instance when using it failed) and its companions; best effort."""
    for p in [_path(folder, key), *folder.glob(f"{key[:40]}.*.npz")]:
        try:
            p.unlink()
        except OSError:
            pass


class _Invalid(Exception):
    pass


def _checked(p: Path, key: str, mesh: Mesh) -> tuple[Mesh, sp.csr_matrix, list[str], np.ndarray]:
    z = read_entry_file(p)
    if "key" not in z or str(z["key"]) != key:
        raise _Invalid("another key")
    if "checksum" not in z or "versions" not in z:
        raise _Invalid("no checksum")
    versions = str(z["versions"])
    arrays = {name: z[name] for name in PAYLOAD}
    if checksum(key, versions, arrays) != str(z["checksum"]):
        raise _Invalid("checksum mismatch: the file was changed after it was written")
    if versions != writer_versions():
        raise _Invalid(f"written by {_versions_text(versions)}, this is {_versions_text(writer_versions())}")
    cv, cf = arrays["cage_vertices"], arrays["cage_faces"]
    shape = tuple(int(x) for x in arrays["shape"])
    M = sp.csr_matrix((arrays["data"], arrays["indices"], arrays["indptr"]), shape=shape)
    notes = [str(x) for x in arrays["notes"]]
    cage = Mesh(cv, cf, name="cage")
    if cage.n_vertices < 4 or cage.n_faces < 4 or not np.all(np.isfinite(cage.vertices)):
        raise _Invalid("cage is not a finite mesh")
    if shape != (mesh.n_vertices, cage.n_vertices):
        raise _Invalid("shape")
    from ..core.csr_checks import csr_check  # (numba: not at import)

    fault, columns_sorted = csr_check(M.indptr, M.indices, M.data, n_columns=cage.n_vertices, row_sum=1.0)
    if fault:
        raise _Invalid(f"binding: {fault}")
    links = np.asarray(arrays["links"], dtype=np.int64).reshape(-1, 2)
    if links.size and (links.min() < 0 or links.max() >= cage.n_vertices):
        raise _Invalid("links out of range")
    if columns_sorted:
        M.has_sorted_indices = True  # (found by the check: no second pass to find it out)
    else:
        M.sort_indices()
    return cage, M, notes, links


def _versions_text(versions: str) -> str:
    try:
        return ", ".join(f"{k} {v}" for k, v in sorted(json.loads(versions).items()))
    except (ValueError, AttributeError):
        return repr(versions)


def store(folder: Path, key: str, cage: Mesh, M: sp.csr_matrix, notes: list[str] | tuple = (),
          links: np.ndarray | None = None) -> Path | None:
    """Write (cage, M), the repair notes made building them and the cage's links (computed here when
    not given: they take a while on a cage of many pieces) under ``key``, with the payload's checksum
    and the writing versions; returns the file, or None if it cannot be written."""
    if links is None:
        from ..cage.links import cage_links

        links = cage_links(cage)
    M = sp.csr_matrix(M)
    arrays = {
        "cage_vertices": np.ascontiguousarray(cage.vertices),
        "cage_faces": np.ascontiguousarray(cage.faces),
        "shape": np.array(M.shape, dtype=np.int64),
        "data": M.data,
        "indices": M.indices,
        "indptr": M.indptr,
        "notes": np.array(list(notes), dtype=str),
        "links": np.ascontiguousarray(links, dtype=np.int64).reshape(-1, 2),
    }
    return _write_entry(_path(folder, key), key, key, arrays, PAYLOAD)


def _write_entry(p: Path, key: str, digest_key: str, arrays: dict[str, np.ndarray],
                 names: tuple[str, ...]) -> Path | None:
    """``arrays`` with ``key``, the writing versions and the checksum of ``names`` under
    ``digest_key``, written atomically to ``p``; None if it cannot be written."""
    versions = writer_versions()
    digest = checksum(digest_key, versions, arrays, names)
    members = {"key": np.array(key), "versions": np.array(versions), "checksum": np.array(digest), **arrays}
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        with atomic_write(p, "wb") as fh:  # (straight into the file: no second copy in memory)
            _savez_aligned(fh, members)
    except OSError:
        return None
    return p


#: the zip "extra field" id of padding (as Android's zipalign writes it)
_PAD_ID = 0xD935


def _savez_aligned(fh, members: dict[str, np.ndarray]) -> None:
    """What ``np.savez(fh, **members)`` writes (an uncompressed ``.npz`` that ``np.load`` reads),
    with each array's data starting on a multiple of 64 bytes of the file: each member's local
    header carries a padding extra field. A memory-mapped array is then as aligned as one in
    memory (:func:`read_entry_file`); numba compiles its kernels for aligned arrays."""
    import struct
    import zipfile

    with zipfile.ZipFile(fh, "w", compression=zipfile.ZIP_STORED, allowZip64=True) as zf:
        for name, value in members.items():
            a = np.asanyarray(value)
            info = zipfile.ZipInfo(name + ".npy", date_time=(1980, 1, 1, 0, 0, 0))
            info.compress_type = zipfile.ZIP_STORED
            big = a.nbytes > 2**31 - 2**20  # (zipfile then adds a 20-byte zip64 field to the header)
            start = fh.tell() + 30 + len(info.filename.encode()) + 4 + (20 if big else 0)
            pad = -start % 64
            info.extra = struct.pack("<HH", _PAD_ID, pad) + bytes(pad)
            with zf.open(info, "w", force_zip64=big) as out:
                np.lib.format.write_array(out, a, allow_pickle=False)


# ------------------------------------------------------------------ companion entries

def _companion_path(folder: Path, key: str, kind: str) -> Path:
    return folder / f"{key[:40]}.{kind}.npz"


def store_arrays(folder: Path, key: str, kind: str, arrays: dict[str, np.ndarray]) -> Path | None:
    """Write named arrays derived from the entry ``key`` (e.g. what an editor prepares from a
    shape, its cage and binding) as the companion ``kind`` of that entry, with their checksum and
    the writing versions, atomically; returns the file, or None if it cannot be written.

    ``kind`` names the content and its version (a new way of deriving the arrays takes a new
    ``kind``, so old files stop matching)."""
    names = tuple(sorted(arrays))
    arrays = {n: np.ascontiguousarray(arrays[n]) for n in names}
    return _write_entry(_companion_path(folder, key, kind), key, key + "/" + kind, arrays, names)


def load_arrays(folder: Path, key: str, kind: str, names: tuple[str, ...]) -> dict[str, np.ndarray] | None:
    """The arrays ``names`` of the companion ``kind`` of entry ``key`` (:func:`store_arrays`), or
    None when absent. One that is unreadable, holds other arrays, was written by other versions
    or fails its checksum is deleted with a :class:`CacheEntryDiscarded` warning (the caller
    derives the arrays again); what the arrays must satisfy beyond that is the caller's check."""
    p = _companion_path(folder, key, kind)
    if not p.is_file():
        return None
    try:
        z = read_entry_file(p)
        if "key" not in z or str(z["key"]) != key:
            raise _Invalid("another key")
        if sorted(set(z) - {"key", "versions", "checksum"}) != sorted(names):
            raise _Invalid("other arrays")
        versions = str(z["versions"])
        arrays = {n: z[n] for n in sorted(names)}
        if checksum(key + "/" + kind, versions, arrays, tuple(sorted(names))) != str(z["checksum"]):
            raise _Invalid("checksum mismatch: the file was changed after it was written")
        if versions != writer_versions():
            raise _Invalid(f"written by {_versions_text(versions)}, this is {_versions_text(writer_versions())}")
        return arrays
    except Exception as e:  # noqa: BLE001 -- whatever is wrong with the file, it is not used
        discard_arrays(folder, key, kind)
        why = str(e) if isinstance(e, _Invalid) else f"unreadable: {type(e).__name__}: {str(e)[:60]}"
        warnings.warn(f"hybridedit: cache file {p.name} not used ({why}); it is made again",
                      CacheEntryDiscarded, stacklevel=2)
        return None


def discard_arrays(folder: Path, key: str, kind: str) -> None:
    """Delete the companion ``kind`` of entry ``key``; best effort."""
    try:
        _companion_path(folder, key, kind).unlink()
    except OSError:
        pass
