"""Poses as assets: a mesh at rest and poses of it in one file, glTF morph targets or USD blend shapes.

:func:`save_poses` checks what it is given, picks the format by the file's extension from
:data:`hybridedit.fileio.formats.POSE_FORMATS` (:mod:`.formats.glb_morphs`, :mod:`.formats.usd_shapes`)
and writes the file atomically. Every pose is stored once, as its difference from the rest, on the
one mesh (no repeated topology); the file opens at rest, every weight 0.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable

import numpy as np

from ..core.mesh import Mesh
from .atomic import atomic_write
from .document import Document
from .formats import POSE_FORMATS, MeshFileError, conversion_note, lost_note
from .formats.common import _Bad
from .formats.usd_shapes import MISSING

__all__ = ["POSE_EXTENSIONS", "save_poses"]

POSE_EXTENSIONS = tuple(POSE_FORMATS)
"""The extensions :func:`save_poses` writes: ``.glb``, ``.gltf``, ``.usda``, ``.usdc``, ``.usd``."""


@runtime_checkable
class _Posed(Protocol):
    """An editor as a pose (:class:`hybridedit.HybridEditor`): its current shape."""

    @property
    def deformed_vertices(self) -> np.ndarray: ...


def save_poses(path: str | os.PathLike[str], source: Any, poses: Sequence[Any], *,
               names: Sequence[str] | None = None, normals: bool = True, sparse: bool = True) -> list[str]:
    """Write a mesh at rest and poses of it to one file, as glTF morph targets or USD blend shapes.

    The format is chosen by the extension (any letter case):

    - ``.glb`` (``.gltf``: the same, its buffer inline): the rest mesh with everything the
      document has that glTF holds (texture coordinates, vertex colours, materials and their
      texture images; a document read from a .glb: that whole file), and on it one morph target per
      pose: POSITION and NORMAL deltas (float32), the names in ``mesh.extras.targetNames``
      (three.js, Babylon.js, Unity's glTFast and Blender import them as blend shapes / shape keys).
    - ``.usda`` (text), ``.usdc`` and ``.usd`` (binary): a ``UsdGeomMesh`` with the document's
      polygons, normals, texture coordinates (``primvars:st``) and colours
      (``primvars:displayColor``), one ``UsdSkelBlendShape`` per pose (``offsets``,
      ``normalOffsets``), bound through a one-joint skeleton whose animation gives every weight 0.
      Needs usd-core: ``pip install 'hybridedit[usd]'``.

    The file opens at rest (every weight 0). A pose that moves a part of the mesh stores only
    that part (a sparse accessor; ``pointIndices``); one that moves nothing stores nothing.

    Parameters
    ----------
    path : str or path-like
        The file to write; an existing one is replaced only once the new one is complete.
    source : Document, HybridEditor or Mesh
        The rest: a document (:func:`hybridedit.read_document`) and its ``mesh.vertices`` (n, 3),
        an editor (the document it was opened from, :meth:`~hybridedit.HybridEditor.from_file`;
        else its mesh) or a bare mesh.
    poses : sequence of (n, 3) float arrays, HybridEditors or Meshes
        The poses, each of the rest's n vertices: positions, an editor's current pose
        (``deformed_vertices``) or a mesh of the same triangles.
    names : sequence of str, optional
        A name for each pose, all different; default ``pose_1``, ``pose_2``, ... glTF keeps them
        as given; USD names each blend shape a valid identifier made of its name (``"arm up"`` ->
        ``arm_up``), the name as given its display name.
    normals : bool, default True
        Store how each pose changes the normals (NORMAL deltas, ``normalOffsets``), so that a client
        shades a posed mesh as it is; False makes a file of poses that move the whole mesh about
        half as large, and clients then shade poses with the rest's normals.
    sparse : bool, default True
        Store a pose that moves a part of the mesh as that part only, where that is smaller; False
        stores every vertex of every pose (for a client without sparse accessors).

    Returns
    -------
    list of str
        Notes for the user: what of the document the format cannot hold (USD: materials and
        their images).

    Raises
    ------
    MeshFileError
        One line naming the file: an extension that holds no poses, no poses, a pose of another
        shape or with a non-finite coordinate, names not one a pose or not unique, usd-core
        missing; raised before the disk is touched.
    hybridedit.fileio.atomic.WriteError
        The file could not be written; the message names the path and cause.

    Examples
    --------
    >>> import tempfile, numpy as np, hybridedit as he
    >>> rest = he.Mesh(np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0]]), [[0, 1, 2]])
    >>> lifted = rest.vertices + [0.0, 0.0, 0.5]
    >>> he.save_poses(tempfile.mkdtemp() + "/lifted.glb", rest, [lifted], names=["lifted"])
    []

    Poses made with an editor, kept as they are reached:

    >>> ed = he.open("scan.obj")  # doctest: +SKIP
    >>> ed.set_selection(hand, roi=arm)  # doctest: +SKIP
    >>> up = ed.drag(translate=(0, 0.2, 0)).copy()  # doctest: +SKIP
    >>> he.save_poses("scan_poses.glb", ed, [up, wave], names=["arm up", "wave"])  # doctest: +SKIP
    """
    p = os.fspath(path)
    name = os.path.basename(p) or p
    ext = os.path.splitext(name)[1].lower()
    if ext not in POSE_FORMATS:
        raise MeshFileError(f"{name}: cannot write poses to a file of extension '{ext or 'none'}' "
                            f"(use one of {', '.join(POSE_EXTENSIONS)})")
    fmt = POSE_FORMATS[ext]
    if fmt.name == "USD":
        _need_usd(name)
    doc = _rest_document(source)
    if isinstance(poses, np.ndarray) and poses.ndim == 2:
        poses = [poses]  # (one pose given bare)
    poses = list(poses)
    if not poses:
        raise MeshFileError(f"{name}: no poses to write")
    labels = _names(name, names, len(poses))
    stacked = _poses(name, doc.mesh, poses, labels)
    try:
        payload = fmt.write(doc, stacked, labels, normals=bool(normals), sparse=bool(sparse))
    except _Bad as exc:
        raise MeshFileError(f"{name}: {exc}") from None
    with atomic_write(p, "wb") as f:
        f.write(payload)
    note = conversion_note(doc, ".glb") if ext in (".glb", ".gltf") else lost_note(doc, fmt.name, fmt.holds)
    return [note] if note else []


def _need_usd(name: str) -> None:
    """MeshFileError when usd-core is not installed."""
    try:
        import pxr.Usd  # noqa: F401
    except ImportError:
        raise MeshFileError(f"{name}: {MISSING}") from None


def _rest_document(source: Any) -> Document:
    """The document of a Document, an editor (its file's, else its mesh's) or a Mesh."""
    if isinstance(source, Document):
        return source
    if isinstance(source, Mesh):
        return Document.from_mesh(source)
    if isinstance(source, _Posed) and isinstance(getattr(source, "mesh", None), Mesh):
        doc = getattr(source, "document", None)
        return doc if isinstance(doc, Document) else Document.from_mesh(source.mesh)
    raise TypeError(f"save_poses: the rest must be a Document, an editor or a Mesh, not {type(source).__name__}")


def _poses(name: str, rest: Mesh, poses: list[Any], labels: list[str]) -> np.ndarray:
    """(k, n, 3) float64 of the poses, or MeshFileError naming the first that is not one."""
    out = np.empty((len(poses), rest.n_vertices, 3))
    for k, (pose, label) in enumerate(zip(poses, labels)):
        which = f"pose {k + 1} ({label!r})"
        if isinstance(pose, _Posed):
            pose = pose.deformed_vertices
        elif isinstance(pose, Mesh):
            if not np.array_equal(pose.faces, rest.faces):
                raise MeshFileError(f"{name}: {which} is a mesh of other triangles than the rest's")
            pose = pose.vertices
        try:
            V = np.asarray(pose, dtype=np.float64)
        except (TypeError, ValueError):
            raise MeshFileError(f"{name}: {which} is not an array of positions ({type(pose).__name__})") from None
        if V.shape != rest.vertices.shape:
            raise MeshFileError(f"{name}: {which} has shape {V.shape}; the rest mesh's is {rest.vertices.shape}")
        bad = ~np.isfinite(V).all(axis=1)
        if bad.any():
            raise MeshFileError(f"{name}: {which} has non-finite coordinates ({int(bad.sum()):,} vertices, "
                                f"the first {int(np.argmax(bad))})")
        out[k] = V
    return out


def _names(name: str, names: Sequence[str] | None, k: int) -> list[str]:
    """The poses' names, ``pose_1``... by default; MeshFileError when not k unique strings."""
    if names is None:
        return [f"pose_{i + 1}" for i in range(k)]
    if isinstance(names, str):
        names = [names]
    labels = list(names)
    if len(labels) != k:
        raise MeshFileError(f"{name}: {len(labels)} names for {k} poses")
    if not all(isinstance(n, str) for n in labels):
        raise MeshFileError(f"{name}: pose names must be strings")
    seen: set[str] = set()
    for n in labels:
        if n in seen:
            raise MeshFileError(f"{name}: pose names must be unique; {n!r} is given twice")
        seen.add(n)
    return labels
