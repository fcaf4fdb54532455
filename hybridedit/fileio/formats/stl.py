"""STL, ASCII or binary: corners welded for the engine, facets written back in order.

Corners with exactly equal positions become one engine vertex (first-occurrence
order), so the facet list is the engine's triangle list. Writing keeps the
format; a binary file keeps its 80-byte header, each facet's attribute bytes
and the normal of every facet whose corners did not move (the others are
recomputed), so an unedited binary file comes back byte for byte.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...core.face_geometry import face_normals
from ..document import Document, moved_vertices
from .common import _Bad, fan_triangles, _mesh, _snippet, _weld, _words

__all__ = ["StlNative", "read", "write"]

_STL_RECORD = np.dtype([("normal", "<f4", (3,)), ("corners", "<f4", (3, 3)), ("attr", "<u2")])


def _read_stl(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    size = len(data)
    count = int.from_bytes(data[80:84], "little") if size >= 84 else -1
    if size >= 84 and size == 84 + 50 * count:
        rec = np.frombuffer(data, _STL_RECORD, count, 84)
        return _weld(rec["corners"].reshape(-1, 3).astype(np.float64))
    if data.lstrip()[:5].lower() == b"solid" and b"\0" not in data:
        return _read_stl_ascii(data)
    if size < 84:
        raise _Bad("not an STL file (not ASCII, and too short for a binary STL header)")
    if size < 84 + 50 * count:
        raise _Bad(f"binary STL header says {_words(count, 'triangle')} but file ends after "
                   f"{(size - 84) // 50}")
    raise _Bad(f"binary STL header says {_words(count, 'triangle')} ({84 + 50 * count} bytes) "
               f"but the file has {size} bytes")


def _read_stl_ascii(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    tokens = data.lower().split()
    arr = np.array(tokens) if tokens else np.zeros(0, dtype="S1")
    vpos = np.flatnonzero(arr == b"vertex")
    if vpos.size == 0:
        if b"endsolid" not in arr:
            raise _Bad("not a valid ASCII STL file (no 'vertex' lines and no 'endsolid')")
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    if vpos[-1] + 3 >= len(arr):
        raise _Bad("file ends in the middle of a 'vertex' line")
    try:
        points = arr[vpos[:, None] + np.arange(1, 4)].astype(np.float64)
    except ValueError:
        for p in vpos:
            try:
                [float(x) for x in arr[p + 1: p + 4]]
            except ValueError:
                words = b" ".join(arr[p: p + 4].tolist())
                raise _Bad(f"cannot read vertex coordinates '{_snippet(words)}'") from None
        raise
    loops = np.flatnonzero(arr == b"loop")
    if loops.size == 0:
        if len(vpos) % 3:
            raise _Bad(f"{len(vpos)} vertices is not a whole number of triangles")
        counts = np.full(len(vpos) // 3, 3)
    else:
        owner = np.searchsorted(loops, vpos, side="right") - 1
        if owner.min() < 0:
            raise _Bad("'vertex' line outside of any 'outer loop'")
        counts = np.bincount(owner, minlength=len(loops))
        if counts.min() < 3:
            k = int(np.argmax(counts < 3))
            raise _Bad(f"facet {k} has {_words(int(counts[k]), 'vertex')}, need at least 3")
    corners = fan_triangles(counts, np.arange(len(vpos)))
    return _weld(points[corners.reshape(-1)])



@dataclass(eq=False)
class StlNative:
    """A binary file's header and records (None for ASCII), the ASCII solid's name,
    and the welded positions as read."""

    records: np.ndarray | None  # (m,) _STL_RECORD
    header: bytes
    name: str
    rest: np.ndarray  # (n, 3)


def read(data: bytes) -> Document:
    """Read an STL file into a :class:`Document` (raises _Bad for a bad file)."""
    vertices, faces = _read_stl(data)
    size = len(data)
    count = int.from_bytes(data[80:84], "little") if size >= 84 else -1
    extras: dict[str, int] = {}
    if size >= 84 and size == 84 + 50 * count:
        records = np.frombuffer(data, _STL_RECORD, count, 84).copy()
        header = data[:80]
        name = ""
        used = int(np.count_nonzero(records["attr"]))
        if used:
            extras["facet attribute values (colours)"] = used
    else:
        records, header = None, b""
        first = data.lstrip().split(b"\n", 1)[0].strip()
        name = first[5:].strip().decode("utf-8", "replace")
    native = StlNative(records=records, header=header, name=name, rest=vertices)
    return Document(mesh=_mesh(vertices, faces), format="stl", native=native, extras=extras)


def write(doc: Document) -> bytes:
    """Binary STL (ASCII when ``doc`` was read from an ASCII STL)."""
    mesh = doc.mesh
    nat = doc.native if isinstance(doc.native, StlNative) else None
    corners = mesh.vertices[mesh.faces]  # (m, 3, 3)
    if nat is not None and nat.records is None:
        normals = face_normals(mesh.vertices, mesh.faces)
        name = nat.name
        rows = np.concatenate([normals[:, None, :], corners], axis=1).reshape(-1, 12)
        facet = ("facet normal %r %r %r\n outer loop\n  vertex %r %r %r\n  vertex %r %r %r\n"
                 "  vertex %r %r %r\n endloop\nendfacet\n")
        body = "".join(facet % tuple(r) for r in rows.tolist())
        return f"solid {name}\n{body}endsolid {name}\n".encode("utf-8")
    if nat is not None and nat.records is not None and len(nat.records) == mesh.n_faces:
        rec = nat.records.copy()
        moved = moved_vertices(nat.rest, mesh.vertices)[mesh.faces].any(axis=1)
        rec["corners"][moved] = corners[moved]
        rec["normal"][moved] = face_normals(mesh.vertices, mesh.faces[moved])
        header = nat.header
    else:
        rec = np.zeros(mesh.n_faces, dtype=_STL_RECORD)
        rec["normal"] = face_normals(mesh.vertices, mesh.faces)
        rec["corners"] = corners
        # the header must not start with "solid", or readers may take it for ASCII
        header = b"binary STL written by hybridedit".ljust(80, b" ")
    return header + np.uint32(mesh.n_faces).astype("<u4").tobytes() + rec.tobytes()
