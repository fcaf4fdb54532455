"""The up axis chosen for each shape, remembered in the user cache folder.

What the user chooses (View ▸ Up Axis) is kept in one small JSON file of the cache folder
(:func:`hybridedit.core.cache_dir.default_cache_dir`), keyed by the shape's vertices and faces
(:func:`shape_key`), so that a file opens the way it was last shown; a shape never chosen for
gets the guess of :func:`hybridedit.core.up_axis.guess_up_axis`.
"""

from __future__ import annotations

import json
from pathlib import Path

from ..core.cache_dir import default_cache_dir
from ..core.fingerprint import shape_digest
from ..core.mesh import Mesh
from ..core.up_axis import AXES, axis_vector, guess_up_axis
from .atomic import atomic_write

__all__ = ["FILE_NAME", "shape_key", "remembered_up_axis", "remember_up_axis", "up_axis_of"]

FILE_NAME = "up-axes.json"
"""The file in the cache folder that remembers the up axis chosen for each shape."""


def shape_key(mesh: Mesh) -> str:
    """Hex digest naming a shape by its vertices and faces (the key it is remembered under: the
    first 40 digits of :func:`hybridedit.core.fingerprint.shape_digest`)."""
    return shape_digest(mesh.vertices, mesh.faces)[:40]


def _read(folder: Path) -> dict:
    try:
        data = json.loads((folder / FILE_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}
    return data if isinstance(data, dict) else {}


def remembered_up_axis(key: str, *, folder: Path | None = None) -> str | None:
    """The up axis last chosen for the shape ``key`` (:func:`shape_key`), or None."""
    axis = _read(folder or default_cache_dir()).get(key)
    return axis if axis in AXES else None


def remember_up_axis(key: str, axis: str, *, folder: Path | None = None) -> bool:
    """Remember ``axis`` for the shape ``key``; False when the cache folder cannot be written."""
    axis_vector(axis)  # (checks the name)
    folder = folder or default_cache_dir()
    data = _read(folder)
    data[key] = axis
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with atomic_write(folder / FILE_NAME, "w") as fh:
            json.dump(data, fh, indent=0, sort_keys=True)
    except OSError:
        return False
    return True


def up_axis_of(mesh: Mesh, *, path: str | Path | None = None, key: str | None = None) -> tuple[str, bool]:
    """(axis, remembered): the axis chosen last for this shape, else the guess."""
    key = key or shape_key(mesh)
    got = remembered_up_axis(key)
    return (got, True) if got is not None else (guess_up_axis(mesh, path=path), False)
