"""Reading and writing meshes: the front of :mod:`hybridedit.fileio.formats`.

:func:`read_mesh` and :func:`write_mesh` deal in bare :class:`~hybridedit.core.mesh.Mesh`
objects; :func:`read_document` and :func:`write_document` keep everything else
the file holds (see :class:`hybridedit.fileio.document.Document`).
"""

from __future__ import annotations

import os

from .document import Document
from .formats import (SUPPORTED_EXTENSIONS, MeshFileError, read_document, write_document,
                       write_mesh_like)
from ..core.mesh import Mesh

__all__ = ["Document", "MeshFileError", "SUPPORTED_EXTENSIONS", "read_document", "read_mesh",
           "write_document", "write_mesh"]


def read_mesh(path: str | os.PathLike[str], *, progress=None) -> Mesh:
    """Read a mesh file's positions and triangles (see :func:`read_document`).

    Parameters
    ----------
    path : str or path-like
        ``.obj``, ``.ply`` (ascii and binary), ``.stl`` (ascii and binary),
        ``.off`` or ``.glb``, in any letter case.
    progress : callable(step, fraction), optional
        Told how far the reading is (see :func:`read_document`).

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64, ``faces`` (m, 3) int64 (0-based), ``name``
        the file's base name. Polygons are fan-triangulated; STL and glTF corners
        with exactly equal positions are welded (first-occurrence order); vertex
        and face order are otherwise kept as in the file.

    Raises
    ------
    MeshFileError
        For any problem with the file; the message starts with the file name.
    """
    return read_document(path, progress=progress).mesh


def write_mesh(path: str | os.PathLike[str], mesh: Mesh, *,
               like: str | os.PathLike[str] | None = None, progress=None) -> list[str]:
    """Write a mesh atomically, choosing the format by extension.

    Without ``like``: ``.obj`` and ``.off`` are ASCII with the shortest coordinates
    that read back exactly (``repr``), ``.ply`` is binary little-endian with double coordinates and
    ``.stl`` is binary (float32, per-face normals); vertex and face order are
    kept. With ``like`` (the file ``mesh`` was read from), the file's whole
    structure is written with ``mesh``'s positions, as :func:`write_document`.

    Parameters
    ----------
    path : str or path-like
        Target file; an existing file is replaced only once the new one is
        completely written.
    mesh : Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (m, 3) int64.
    like : str or path-like, optional
        The file ``mesh`` was read from; its triangulation must still be ``mesh``'s.
    progress : callable(step, fraction), optional
        Told how far the writing is (see :func:`write_document`).

    Returns
    -------
    list of str
        Notes: what a conversion could not carry, references not copied.

    Raises
    ------
    MeshFileError
        The extension is not supported (raised before touching the disk).
    hybridedit.fileio.atomic.WriteError
        The file could not be written; the message names the path and cause.
    """
    if not isinstance(mesh, Mesh):
        raise TypeError(f"write_mesh expects a Mesh, got {type(mesh).__name__}")
    return write_mesh_like(path, mesh, like, progress=progress)
