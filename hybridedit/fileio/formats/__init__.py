"""Mesh files in and out: one module per format behind one reader/writer registry.

:func:`read_document` reads a file into a :class:`hybridedit.fileio.document.Document`
(the engine's mesh plus everything else the file holds); :func:`write_document`
writes one back. Written to its own format, a document keeps the file's
structure with only the positions (and normals) changed; written to another
format, it carries what that format can hold (polygons, vertex colours,
normals) and the returned note names the rest.
"""

from __future__ import annotations

import os
import struct
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import partial
from pathlib import Path

import numpy as np

from ..atomic import atomic_write
from ..document import Document
from ...core.mesh import Mesh, MeshError
from . import glb, glb_morphs, obj, obj_materials, off, ply, stl, usd_shapes
from .common import MeshFileError, _Bad, _validate
from .reporting import reporting, span

__all__ = ["FORMATS", "Format", "MeshFileError", "POSE_FORMATS", "PoseFormat", "SUPPORTED_EXTENSIONS",
           "conversion_note", "read_document", "write_document"]


@dataclass(frozen=True)
class Format:
    """A registered file format.

    Attributes
    ----------
    name : str
        As shown to users ("OBJ").
    read : callable (path, data) -> Document
        Raises ``_Bad`` (a message without the file name) for a bad file.
    write : callable (Document) -> bytes
        Gives the document's own structure back when it was read in this
        format (its ``native`` record is this module's).
    convert : callable (Document, target Path) -> bytes
        A file of this format holding what it can of a document read in another.
    companions : callable (Document, target Path) -> list of (Path, bytes)
        Files a converted document needs beside ``target`` (a material library,
        texture images).
    holds : frozenset of {"polygons", "colors", "normals", "uv", "materials", "textures"}
        What this format can carry over from a document read in another one
        ("textures": the images of the materials, without the rest of them).
    head : int
        Bytes of the file ``read`` is given (it reads what else it needs itself); 0: the
        whole file.
    """

    name: str
    read: Callable[[str, bytes], Document]
    write: Callable[[Document], bytes]
    convert: Callable[[Document, Path], bytes]
    companions: Callable[[Document, Path], list[tuple[Path, bytes]]]
    holds: frozenset[str]
    head: int = 0


def _none(doc: Document, target: Path) -> list[tuple[Path, bytes]]:
    return []


FORMATS: dict[str, Format] = {
    ".obj": Format("OBJ", lambda path, data: obj.read(data, path), obj.write, obj.write_converted,
                   obj_materials.converted_companions,
                   frozenset({"polygons", "colors", "normals", "uv", "materials", "textures"})),
    ".off": Format("OFF", lambda path, data: off.read(data), off.write, lambda doc, target: off.write(doc),
                   _none, frozenset({"polygons", "colors", "normals"})),
    ".ply": Format("PLY", ply.read, ply.write, lambda doc, target: ply.write(doc), ply.converted_companions,
                   frozenset({"polygons", "colors", "normals", "uv", "textures"}), head=ply.HEAD_BYTES),
    ".stl": Format("STL", lambda path, data: stl.read(data), stl.write, lambda doc, target: stl.write(doc),
                   _none, frozenset()),
    ".glb": Format("glTF binary", glb.read, glb.write, lambda doc, target: glb.write(doc), _none,
                   frozenset({"colors", "normals", "uv", "materials", "textures"})),
}



@dataclass(frozen=True)
class PoseFormat:
    """A file format that holds a mesh at rest and poses of it (:func:`hybridedit.save_poses`).

    Attributes
    ----------
    name : str
        As shown to users ("USD").
    write : callable (Document, poses, names, *, normals, sparse) -> bytes
        The file of the document's mesh at rest (its ``mesh.vertices``) with ``poses`` ((k, n, 3)
        float64, finite) named ``names`` (k str, unique); raises ``_Bad`` (a message without the
        file name) when it cannot.
    holds : frozenset of str
        What it carries over of a document (as :attr:`Format.holds`).
    """

    name: str
    write: Callable[..., bytes]
    holds: frozenset[str]


_USD_HOLDS = frozenset({"polygons", "colors", "normals", "uv"})

#: the formats of :func:`hybridedit.save_poses`, by extension: glTF morph targets and USD blend shapes
POSE_FORMATS: dict[str, PoseFormat] = {
    ".glb": PoseFormat("glTF binary", glb_morphs.write, FORMATS[".glb"].holds),
    ".gltf": PoseFormat("glTF", glb_morphs.write_gltf, FORMATS[".glb"].holds),
    ".usda": PoseFormat("USD", partial(usd_shapes.write, suffix=".usda"), _USD_HOLDS),
    ".usdc": PoseFormat("USD", partial(usd_shapes.write, suffix=".usdc"), _USD_HOLDS),
    ".usd": PoseFormat("USD", partial(usd_shapes.write, suffix=".usd"), _USD_HOLDS),
}

#: What each inventory entry of a document (``Document.extras``) is, for the formats that hold it.
_CARRIED = {
    "texture coordinates": "uv",  # OBJ vt, OFF ST, PLY texcoord / u v
    "primitives with texture coordinates": "uv",  # glTF
    "material libraries": "materials", "material references": "materials", "materials": "materials",
    "embedded images": "textures", "texture files": "textures",
}

SUPPORTED_EXTENSIONS = tuple(FORMATS)


def extension(path: str | os.PathLike[str]) -> str:
    """The lower-case extension of ``path`` ('.obj'), '' for none."""
    return os.path.splitext(os.fspath(path))[1].lower()


def unsupported(name: str, ext: str, action: str) -> MeshFileError:
    """The error for a file whose extension is not a registered format."""
    supported = ", ".join(SUPPORTED_EXTENSIONS)
    if not ext:
        return MeshFileError(f"{name}: cannot {action} a file without an extension "
                             f"(use one of {supported})")
    return MeshFileError(f"{name}: unsupported file extension '{ext}' (use one of {supported})")


def _named(path: str | os.PathLike[str], doing: str) -> tuple[str, str, str]:
    """(the path as a string, its base name, its extension) of a file to read or write (``doing``);
    MeshFileError, before the disk is touched, when no format has that extension."""
    p = os.fspath(path)
    name = os.path.basename(p) or p
    ext = extension(name)
    if ext not in FORMATS:
        raise unsupported(name, ext, doing)
    return p, name, ext


def read_document(path: str | os.PathLike[str], *,
                  progress: Callable[[str, float], None] | None = None) -> Document:
    """Read a mesh file, choosing the format by extension (any letter case).

    Parameters
    ----------
    path : str or path-like
    progress : callable(step, fraction), optional
        Told how far the reading is (step ``"reading NAME"``, fraction 0 to 1);
        an exception it raises (a cancel) goes to the caller.

    Returns
    -------
    Document
        ``mesh``: ``vertices`` (n, 3) float64 and ``faces`` (m, 3) int64 (polygons
        fan-triangulated; STL and glTF corners with equal positions welded), named
        after the file's base name; everything else the file holds beside it.

    Raises
    ------
    MeshFileError
        For any problem with the file; the message starts with the file name.
    """
    p, name, ext = _named(path, "read")
    fmt = FORMATS[ext]
    step = f"reading {name}"
    tell = None if progress is None else (lambda fraction: progress(step, fraction))
    if tell is not None:
        tell(0.0)  # (before the bytes are read: a big file takes a while on a slow disk)
    try:
        with open(p, "rb") as f:
            data = f.read(fmt.head) if fmt.head else f.read()  # (a binary PLY's body: memory-mapped later)
    except FileNotFoundError:
        raise MeshFileError(f"{name}: file not found ({os.path.abspath(p)})") from None
    except IsADirectoryError:
        raise MeshFileError(f"{name}: is a folder, not a file") from None
    except PermissionError:
        raise MeshFileError(f"{name}: permission denied") from None
    except OSError as exc:
        raise MeshFileError(f"{name}: cannot read file ({exc.strerror or exc})") from None
    if not data or data.isspace():  # (not data.strip(): a copy of the whole file)
        raise MeshFileError(f"{name}: file is empty")
    try:
        # NaN/inf (even signalling NaN in binary files) are reported by _validate
        with np.errstate(all="ignore"), reporting(tell):
            doc = fmt.read(p, data)
            _validate(doc.mesh.vertices, doc.mesh.faces)
    except (_Bad, MeshError) as exc:
        raise MeshFileError(f"{name}: {exc}") from None
    except (ValueError, IndexError, TypeError, KeyError, OverflowError, struct.error,
            UnicodeError) as exc:
        raise MeshFileError(f"{name}: not a valid {fmt.name} file ({type(exc).__name__}: {exc})") \
            from exc
    doc.mesh.name = name
    doc.path = Path(p)
    if tell is not None:
        tell(1.0)
    return doc


def conversion_note(doc: Document, ext: str) -> str | None:
    """One line naming what of ``doc`` a file of extension ``ext`` cannot hold, or None."""
    fmt = FORMATS[ext]
    if not doc.format or FORMATS.get("." + doc.format) is fmt:
        return None
    return lost_note(doc, fmt.name, fmt.holds)


def lost_note(doc: Document, name: str, holds: frozenset[str]) -> str | None:
    """One line naming what of ``doc`` (read from a file) a file of format ``name`` holding ``holds``
    (as :attr:`Format.holds`) cannot hold, or None."""
    if not doc.format:
        return None
    lost = []
    counts, _ = doc.polygon_lists()
    tex = doc.textures() if any(_CARRIED.get(k) for k in doc.extras) else None
    if doc.polygons is not None and "polygons" not in holds:
        lost.append(f"polygons ({len(counts):,}; written as {doc.mesh.n_faces:,} triangles)")
    if doc.colors is not None and "colors" not in holds:
        lost.append(f"vertex colours ({doc.mesh.n_vertices:,})")
    if doc.normals and "normals" not in holds:
        lost.append("vertex normals")
    carried = set()
    if tex is not None:
        carried = {"uv"} if tex.uv is not None and tex.corner_uv is not None else set()
        if tex.materials:
            carried |= {"materials", "textures"} if any(m.image is not None for m in tex.materials) \
                else {"materials"}
    for what, count in doc.extras.items():
        kind = _CARRIED.get(what)
        if kind is None or kind not in carried or kind not in holds:
            kept = kind == "materials" and "textures" in holds and "textures" in carried
            lost.append(f"{what} ({count:,}{'; their texture images are kept' if kept else ''})")
    if not lost:
        return None
    src = FORMATS["." + doc.format].name
    return f"{name} cannot hold everything from the {src} file; not written: " + ", ".join(lost)


def write_document(path: str | os.PathLike[str], doc: Document, *,
                   progress: Callable[[str, float], None] | None = None) -> list[str]:
    """Write ``doc`` atomically, choosing the format by extension.

    In the format it was read from, the file's own structure comes back with
    the new positions (see each format module); in another format, what it can
    hold. An OBJ written into another folder than the one it was read from
    takes its material libraries and their images along (copied to the same
    relative place; an existing file there is never replaced: an identical one
    is left as it is, a different one too, with a note).

    Parameters
    ----------
    path : str or path-like
        Target file; an existing file is replaced only once the new one is
        completely written.
    doc : Document
    progress : callable(step, fraction), optional
        Told how far the writing is (step ``"writing NAME"``, fraction 0 to 1);
        an exception it raises (a cancel) goes to the caller, and the target is
        left as it was.

    Returns
    -------
    list of str
        Notes for the user: what a conversion could not carry, references
        that could not be copied.

    Raises
    ------
    MeshFileError
        The extension is not supported (raised before touching the disk), or
        the document cannot be written in that format.
    hybridedit.fileio.atomic.WriteError
        The file could not be written; the message names the path and cause.
    """
    p, name, ext = _named(path, "write")
    if not isinstance(doc, Document):
        raise TypeError(f"write_document expects a Document, got {type(doc).__name__}")
    fmt = FORMATS[ext]
    notes = []
    same = FORMATS.get("." + doc.format) is fmt
    note = conversion_note(doc, ext)
    if note:
        notes.append(note)
    step = f"writing {name}"
    tell = None if progress is None else (lambda fraction: progress(step, fraction))
    if tell is not None:
        tell(0.0)
    payload, beside = _file_bytes(fmt, doc, same, Path(p), name, tell)
    made = _new_companions(beside, notes)
    copies = _obj_copies(doc, Path(p), notes) if same and ext == ".obj" else []
    _write_files(p, payload, copies, made)
    if tell is not None:
        tell(1.0)
    return notes


def _file_bytes(fmt: Format, doc: Document, same: bool, target: Path, name: str,
                tell) -> tuple[bytes, list[tuple[Path, bytes]]]:
    """The file's bytes (the document's own structure in its own format, else a conversion) and
    the companion files a conversion needs beside ``target``; nothing is written yet."""
    try:
        with reporting(tell), span(0.0, 0.9):  # making the file's bytes; then writing them
            payload = fmt.write(doc) if same else fmt.convert(replace(doc, native=None), target)
        beside = [] if same else fmt.companions(doc, target)
    except (_Bad, MeshError) as exc:
        raise MeshFileError(f"{name}: {exc}") from None
    return payload, beside


def _new_companions(beside: list[tuple[Path, bytes]], notes: list[str]) -> list[tuple[Path, bytes]]:
    """Of a converted document's material library and images, those to write: not there yet (an
    existing file is kept, with a note in ``notes`` when it differs or is a folder)."""
    made: list[tuple[Path, bytes]] = []
    for dst, content in beside:
        if dst.is_dir():
            notes.append(f"{dst.name} not written: {dst} is a folder")
        elif dst.exists() and dst.read_bytes() != content:
            notes.append(f"{dst} kept as it is: it differs from the {dst.suffix[1:]} file this conversion "
                         "makes, and an existing file is never replaced (the output refers to it)")
        elif not dst.exists():
            made.append((dst, content))
    return made


def _obj_copies(doc: Document, target: Path, notes: list[str]) -> list[tuple[Path, Path]]:
    """The (source, destination) copies of the files an OBJ refers to that an OBJ written to
    ``target`` needs beside it; decided before anything is written (an existing file is kept,
    with a note in ``notes`` when it differs or is a folder)."""
    copies: list[tuple[Path, Path]] = []
    found, more = obj_materials.companions(doc, doc.path, target)
    notes += more
    for src, dst in found:
        if dst.is_dir():
            notes.append(f"{src.name} not copied: {dst} is a folder")
        elif dst.exists() and not obj_materials.same_content(src, dst):
            notes.append(f"{dst} kept as it is: it differs from {src}, and an existing file is "
                         "never replaced by a copy (the output refers to it; copy it by hand if needed)")
        elif not dst.exists():
            copies.append((src, dst))
    return copies


def _write_files(path: str, payload: bytes, copies: list[tuple[Path, Path]],
                 made: list[tuple[Path, bytes]]) -> None:
    """The file, then the copies it refers to, then the companions made for it, each atomically."""
    with atomic_write(path, "wb") as f:
        f.write(payload)
    for src, dst in copies:
        dst.parent.mkdir(parents=True, exist_ok=True)
        with atomic_write(dst, "wb") as f:
            f.write(src.read_bytes())
    for dst, content in made:
        with atomic_write(dst, "wb") as f:
            f.write(content)


def write_mesh_like(path: str | os.PathLike[str], mesh: Mesh,
                    like: str | os.PathLike[str] | None, *, progress=None) -> list[str]:
    """Write ``mesh``; with ``like``, as the document read from that file with ``mesh``'s
    positions (its triangulation must be the file's). ``progress(step, fraction)`` is told
    how far the reading of ``like`` and the writing are."""
    if like is None:
        return write_document(path, Document.from_mesh(mesh), progress=progress)
    doc = read_document(like, progress=progress)
    if doc.mesh.n_vertices != mesh.n_vertices or not np.array_equal(doc.mesh.faces, mesh.faces):
        raise MeshFileError(f"{doc.mesh.name}: the file changed since the mesh was read from it; "
                            "cannot write the mesh in its structure")
    return write_document(path, doc.with_vertices(mesh.vertices), progress=progress)
