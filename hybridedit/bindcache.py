"""On-disk cache of cages and bindings, keyed by the shape and the settings.

A cache file holds the cage (vertices, faces) and the binding matrix M of one
shape for one (cage size, truncation) setting. Its name is a hash of the shape's
vertices and faces, the settings and :data:`FORMAT`; the same key is stored
inside and checked on load, with the arrays' shapes and the rows of M summing
to 1, so a corrupt, truncated or stale file is detected and rebuilt, never
trusted. Files are written atomically.
"""

from __future__ import annotations

import hashlib
import io
import os
from pathlib import Path

import numpy as np
import scipy.sparse as sp

from .atomic import atomic_write
from .mesh import Mesh

#: Bump when the cage or binding algorithms change: old files stop matching.
FORMAT = "hybridedit-binding-3"  # 2: fast binding; 3: repair notes stored


def default_cache_dir() -> Path:
    """$HYBRIDEDIT_CACHE_DIR, else the user cache folder (e.g. ~/.cache/hybridedit)."""
    env = os.environ.get("HYBRIDEDIT_CACHE_DIR")
    if env:
        return Path(env)
    from platformdirs import user_cache_dir

    return Path(user_cache_dir("hybridedit", appauthor=False))


def cache_key(mesh: Mesh, cage_size: int | float, truncation: float, extra: str = "") -> str:
    """Hex digest naming the cage + binding of ``mesh`` for these settings."""
    h = hashlib.sha256()
    h.update(FORMAT.encode())
    h.update(repr((type(cage_size).__name__, cage_size, float(truncation), extra)).encode())
    h.update(np.int64(mesh.n_vertices).tobytes())
    h.update(np.ascontiguousarray(mesh.vertices, dtype="<f8").tobytes())
    h.update(np.ascontiguousarray(mesh.faces, dtype="<i8").tobytes())
    return h.hexdigest()


def _path(folder: Path, key: str) -> Path:
    return folder / f"{key[:40]}.npz"


def load(folder: Path, key: str, mesh: Mesh) -> tuple[Mesh, sp.csr_matrix, list[str]] | None:
    """The cached (cage, M, notes) for ``key``, or None when absent or not valid.

    An entry that fails any check (unreadable, another key, wrong shapes, a
    non-finite or out-of-range value, rows of M not summing to 1, a cage that
    is not a mesh) is deleted, so that it is rebuilt and stored again.
    """
    p = _path(folder, key)
    if not p.is_file():
        return None
    try:
        return _checked(p, key, mesh)
    except Exception:  # noqa: BLE001 -- whatever is wrong with the entry, it is not used
        discard(folder, key)
        return None


def discard(folder: Path, key: str) -> None:
    """Delete the entry for ``key`` (for instance when using it failed); best effort."""
    try:
        _path(folder, key).unlink()
    except OSError:
        pass


class _Invalid(Exception):
    pass


def _checked(p: Path, key: str, mesh: Mesh) -> tuple[Mesh, sp.csr_matrix, list[str]]:
    with np.load(p, allow_pickle=False) as z:
        if str(z["key"]) != key:
            raise _Invalid("another key")
        cv, cf = z["cage_vertices"], z["cage_faces"]
        shape = tuple(int(x) for x in z["shape"])
        M = sp.csr_matrix((z["data"], z["indices"], z["indptr"]), shape=shape)
        notes = [str(x) for x in z["notes"]] if "notes" in z.files else []
    cage = Mesh(cv, cf, name="cage")
    if cage.n_vertices < 4 or cage.n_faces < 4 or not np.all(np.isfinite(cage.vertices)):
        raise _Invalid("cage is not a finite mesh")
    if shape != (mesh.n_vertices, cage.n_vertices):
        raise _Invalid("shape")
    M.check_format(full_check=True)
    if not np.all(np.isfinite(M.data)):
        raise _Invalid("non-finite weights")
    if not np.allclose(np.asarray(M.sum(axis=1)).ravel(), 1.0, atol=1e-9):
        raise _Invalid("rows do not sum to 1")
    M.sort_indices()
    return cage, M, notes


def store(folder: Path, key: str, cage: Mesh, M: sp.csr_matrix, notes: list[str] | tuple = ()) -> Path | None:
    """Write (cage, M) and the repair notes made building them under ``key``;
    returns the file, or None if it cannot be written."""
    M = sp.csr_matrix(M)
    buf = io.BytesIO()
    np.savez(
        buf,
        key=np.array(key),
        cage_vertices=cage.vertices,
        cage_faces=cage.faces,
        shape=np.array(M.shape, dtype=np.int64),
        data=M.data,
        indices=M.indices,
        indptr=M.indptr,
        notes=np.array(list(notes), dtype=str),
    )
    p = _path(folder, key)
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with atomic_write(p, "wb") as fh:
            fh.write(buf.getvalue())
    except OSError:
        return None
    return p
