"""PLY through ``plyfile``: every element, property and type is kept.

Reading keeps the whole :class:`plyfile.PlyData` (elements, properties and
their types, comments, ``obj_info``, ASCII or binary and its byte order).
Writing gives it back with ``x y z`` replaced in their own type and ``nx ny nz``
recomputed from the deformed surface for every vertex a moved vertex touches.
A binary file is written by plyfile (or as one record array, below); an ASCII
file is given back line by line, only the rewritten vertices' lines changed and
their numbers written with the file's own precision (plyfile would write every
number with 18 digits, a float32 ``0.1`` as ``0.100000001490116119``).
Faces may be polygons (``vertex_indices`` or ``vertex_index``) and/or triangle
strips (``tristrips``, -1 restarting a strip).

plyfile reads and writes list properties one record at a time, which takes
seconds on a million faces; when every list of an element has the same length
the records are read memory-mapped (plyfile's ``known_list_len``) and written
here as one numpy record array after plyfile's own header.
"""

from __future__ import annotations

import copy
import io
import os
from dataclasses import dataclass

import numpy as np
import plyfile

from ..document import Document, Material, Texturing, moved_vertices
from ...core.normals import grouped_normals, vertex_normals
from ...core.row_copy import rows_into
from .common import TextPrecision, _Bad, _mesh, fan_triangles, _sample_rows, _truncated, _words

__all__ = ["PlyNative", "read", "write"]

_FACE_LISTS = ("vertex_indices", "vertex_index")
_COLOR = ("red", "green", "blue", "alpha")
_VERTEX_UV = (("s", "t"), ("u", "v"), ("texture_u", "texture_v"))


@dataclass(eq=False)
class PlyNative:
    """The file as plyfile read it, and the positions as read."""

    data: plyfile.PlyData
    rest: np.ndarray  # (n, 3) float64
    raw: bytes | None = None  # an ASCII file's bytes: written back line by line


def _plain_message(exc: plyfile.PlyParseError) -> str:
    """plyfile's error in this project's words."""
    if isinstance(exc, plyfile.PlyHeaderParseError):
        where = f" on header line {exc.line}" if exc.line else ""
        return f"not a valid PLY header ({exc.message}{where})"
    el, row = exc.element, exc.row
    if el is not None and exc.message == "early end-of-file":
        return f"header says {_words(el.count, el.name)} but file ends after {row}"
    what = f"{el.name} {row}" if el is not None else "data"
    prop = f", property '{exc.prop.name}'" if getattr(exc, "prop", None) is not None else ""
    return f"{what}{prop}: {exc.message} (the header's element counts may be wrong)"


def _read_plydata(path: str) -> plyfile.PlyData:
    """Read with memory-mapped uniform lists where they are, else plyfile's record loop."""
    last: Exception | None = None
    for k in (3, 4, None):
        known = {} if k is None else {name: {p: k for p in _FACE_LISTS}
                                      for name in ("face", "tristrips")}
        try:
            with open(path, "rb") as f:
                data = plyfile.PlyData.read(f, mmap="c", known_list_len=known)
                for el in data.elements:  # off the mapping, so the file can be replaced
                    if not _triangle_list(el):  # (converted straight off it by _faces)
                        el.data = np.array(el.data)
                rest = b"" if data.text else f.read()
        except plyfile.PlyElementParseError as exc:
            last = exc
            continue
        if rest.strip():
            raise _Bad(f"{len(rest)} unexpected bytes after the last element "
                       "(the header's element counts may be wrong)")
        if data.text:
            _check_ascii_records(path, data)
        return data
    assert last is not None
    raise last


def _check_ascii_records(path: str, data: plyfile.PlyData) -> None:
    """An ASCII file has one line per record: more lines than records is an error."""
    with open(path, "rb") as f:
        body = f.read().split(b"end_header", 1)[1]
    lines = sum(1 for line in body.splitlines() if line.strip())
    records = sum(el.count for el in data.elements)
    if lines > records:
        raise _Bad(f"{lines - records} unexpected lines after the last element "
                   "(the header's element counts may be wrong)")


def _triangle_list(el: plyfile.PlyElement) -> str | None:
    """The name of ``el``'s index list when ``el`` is a binary ``face`` element of triangles and
    nothing else, read memory-mapped (its only property a list of 3 integers); else None."""
    props = el.properties
    if el.name != "face" or len(props) != 1 or props[0].name not in _FACE_LISTS:
        return None
    col = getattr(el.data, "dtype", None)
    field = None if col is None or col.names is None else col.fields.get(props[0].name)
    if field is None or field[0].shape != (3,) or field[0].base.kind not in "iu":
        return None
    return props[0].name


def _mapped_triangles(face: plyfile.PlyElement, name: str) -> np.ndarray:
    """(m, 3) int64 triangles of a :func:`_triangle_list` element, cast in one pass straight off
    the file's mapping (no copy of its records, no int32 copy of the indices: half the new memory
    at 22M faces). The element then holds these same int64 triangles as its records (off
    the mapping; the writer casts them back to the file's index type)."""
    tri = np.empty((face.count, 3), dtype=np.int64)
    rows_into(face.data[name], tri)
    face.data = tri.view(np.dtype([(name, np.int64, (3,))])).reshape(face.count)
    return tri


def _list_values(el: plyfile.PlyElement, name: str) -> tuple[np.ndarray, np.ndarray]:
    """(counts, flat values) of the list property ``name`` of ``el``."""
    col = el.data[name]
    if col.dtype != object:  # memory-mapped uniform lists: a (count, k) array
        col2 = col.reshape(len(col), -1)
        return np.full(len(col2), col2.shape[1], dtype=np.int64), col2.reshape(-1)
    counts = np.fromiter((len(x) for x in col), dtype=np.int64, count=len(col))
    flat = np.concatenate(col) if len(col) else np.zeros(0, dtype=np.int64)
    return counts, flat


def _strip_triangles(counts: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """Triangles of triangle strips (-1 restarts a strip), (t, 3) int64.

    Every other triangle flips its first two corners so that all keep the
    strip's orientation; triangles with a repeated index are skipped.
    """
    if flat.size and flat.min() < -1:
        raise _Bad(f"tristrips index {int(flat.min())} is invalid (only -1 may be negative)")
    ends = np.cumsum(counts)[:-1]
    s = np.insert(flat, ends, -1) if ends.size else flat
    if len(s) < 3:
        return np.zeros((0, 3), dtype=np.int64)
    idx = np.arange(len(s))
    last_break = np.maximum.accumulate(np.where(s < 0, idx, -1))
    parity = (idx - last_break - 1)[:-2] % 2
    tri = np.stack([s[:-2], s[1:-1], s[2:]], axis=1)
    odd = parity == 1
    tri[odd] = tri[odd][:, [1, 0, 2]]
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    keep = (a >= 0) & (b >= 0) & (c >= 0) & (a != b) & (b != c) & (a != c)
    return tri[keep]


def _element(data: plyfile.PlyData, name: str) -> plyfile.PlyElement | None:
    found = [el for el in data.elements if el.name == name]
    if len(found) > 1:
        raise _Bad(f"PLY header has more than one '{name}' element")
    return found[0] if found else None


def _index_list(el: plyfile.PlyElement) -> str:
    names = [p.name for p in el.properties if p.name in _FACE_LISTS]
    if not names or not isinstance(el.ply_property(names[0]), plyfile.PlyListProperty):
        raise _Bad(f"PLY {el.name} element has no 'vertex_indices' list property")
    if np.dtype(el.ply_property(names[0]).val_dtype).kind == "f":
        raise _Bad(f"PLY {el.name} indices must be integers, not floating point")
    return names[0]


def _check_start(data: bytes) -> None:
    first = data[:1024].split(b"\n", 1)[0].strip()  # (not a split of the whole file)
    if first != b"ply":
        raise _Bad("not a PLY file (it does not start with a 'ply' line)")
    if b"end_header" not in data[:1 << 20]:
        raise _Bad("not a valid PLY header (no 'end_header' line)")


#: bytes of a PLY file the registry reads first (:func:`read` takes the rest itself when the
#: file is text); a header must end within them
HEAD_BYTES = 1 << 20


def _header(data: bytes) -> plyfile.PlyData:
    """The header of the PLY whose first bytes are ``data`` (plyfile's parse; _Bad if it fails)."""
    try:
        return plyfile.PlyData._parse_header(io.BytesIO(data))
    except plyfile.PlyParseError as exc:
        raise _Bad(_plain_message(exc)) from None


def _check_counts(data: bytes, header: plyfile.PlyData, size: int) -> None:
    """Refuse a header whose element counts need more than the file has after it.

    An ASCII record is one line; a binary record needs at least its scalar
    properties' bytes and each list's count. A header promising 10^12 faces in a
    small file is refused here, before plyfile allocates anything for them, with
    the message a truncated file gets ("header says N faces but file ends after K")
    where K is known. ``data`` is the whole file when it is text, else at least its
    header; ``size`` is the file's size in bytes.
    """
    end = data.index(b"end_header")
    newline = data.find(b"\n", end)
    body = memoryview(data)[newline + 1:] if newline >= 0 else memoryview(b"")
    if header.text:
        if sum(el.count for el in header.elements) <= bytes(body).count(b"\n") + 1:
            return
        lines = sum(1 for line in bytes(body).splitlines() if line.strip())
        for el in header.elements:
            if el.count > lines:
                raise _truncated(el.count, el.name, lines)
            lines -= el.count
        return
    # bytes left for this element (of the whole file: ``data`` may be its head only); whether earlier
    # records had fixed sizes
    left, exact = (size - (newline + 1) if newline >= 0 else 0), True
    for el in header.elements:
        lists = [p for p in el.properties if isinstance(p, plyfile.PlyListProperty)]
        each = sum(np.dtype(p.list_dtype()[0] if p in lists else p.dtype()).itemsize
                   for p in el.properties)
        if el.count * each > left:
            if exact and not lists:
                raise _truncated(el.count, el.name, left // each if each else 0)
            raise _Bad(f"header says {_words(el.count, el.name)} but the file has room for at most "
                       f"{left // each if each else 0:,} ({left:,} bytes left, at least {each} byte{'' if each == 1 else 's'} each; "
                       "the header's element counts are wrong)")
        left -= el.count * each
        exact = exact and not lists


def read(path: str, data: bytes) -> Document:
    """Read a PLY file into a :class:`Document` (raises _Bad for a bad file). ``data`` is the file
    or its first :data:`HEAD_BYTES` (a binary file's body is read memory-mapped by plyfile, and
    a text file is read whole here)."""
    _check_start(data)
    header = _header(data)
    size = os.path.getsize(path)
    if header.text and len(data) < size:
        with open(path, "rb") as f:
            data = f.read()
    _check_counts(data, header, size)
    try:
        ply = _read_plydata(path)
    except plyfile.PlyParseError as exc:
        raise _Bad(_plain_message(exc)) from None
    vertex, names = _vertex_element(ply)
    vertices = _xyz_records(vertex)
    if vertices is None:
        vertices = np.empty((vertex.count, 3))  # (one array, each column converted into it)
        with np.errstate(all="ignore"):
            for k, a in enumerate("xyz"):
                vertices[:, k] = vertex.data[a]
    faces, polygons = _faces(ply)
    colors = _colors(vertex, names)
    vertex_uv = next((pair for pair in _VERTEX_UV if all(a in names for a in pair)), ())
    face = _element(ply, "face")
    strips = _element(ply, "tristrips")
    polygons_kept = strips is None or not strips.count
    face_uv = bool(face is not None and face.count and polygons_kept and "texcoord" in
                   [p.name for p in face.properties])
    extras, files = _extras(ply, vertex, names, vertex_uv, face if face_uv else None)
    texturing = None
    if vertex_uv or face_uv or files:
        texturing = lambda: _texturing(ply, path, vertex_uv, face_uv, files, polygons, faces)  # noqa: E731
    return Document(mesh=_mesh(vertices, faces), format="ply",
                    native=PlyNative(data=ply, rest=vertices, raw=data if ply.text else None), polygons=polygons,
                    colors=colors, normals=all(n in names for n in ("nx", "ny", "nz")),
                    extras=extras, texturing=texturing)


def _vertex_element(ply: plyfile.PlyData) -> tuple[plyfile.PlyElement, list[str]]:
    """The ``vertex`` element and its property names, checked to have ``x y z`` numbers."""
    vertex = _element(ply, "vertex")
    if vertex is None:
        raise _Bad("PLY header has no 'vertex' element")
    names = [p.name for p in vertex.properties]
    for axis in "xyz":
        if axis not in names:
            raise _Bad(f"PLY vertex element has no '{axis}' property")
        if isinstance(vertex.ply_property(axis), plyfile.PlyListProperty):
            raise _Bad(f"PLY vertex property '{axis}' is a list, expected a number")
    return vertex, names


def _xyz_records(vertex: plyfile.PlyElement) -> np.ndarray | None:
    """The records of a ``vertex`` element of native float64 ``x y z`` and nothing else, seen as
    the (n, 3) float64 positions (the same memory: no second copy of 265 MB at 11M); else None."""
    d = vertex.data
    if getattr(d, "dtype", None) is None or d.dtype.names != ("x", "y", "z") or d.ndim != 1 \
            or not d.flags.c_contiguous or d.dtype.itemsize != 24:
        return None
    for offset, a in zip((0, 8, 16), "xyz"):
        t, at = d.dtype.fields[a][:2]
        if at != offset or t != np.dtype(np.float64) or not t.isnative:
            return None
    return d.view(np.float64).reshape(len(d), 3)


def _faces(ply: plyfile.PlyData) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray] | None]:
    """(m, 3) int64 triangles of the ``face`` polygons (fanned) and ``tristrips``, and the polygons
    (counts, flat indices) to carry over: None when all are triangles or there are strips."""
    parts = [np.zeros((0, 3), dtype=np.int64)]
    polygons = None
    face = _element(ply, "face")
    if face is not None and face.count and (name := _triangle_list(face)) is not None \
            and isinstance(face.data, np.memmap):
        parts.append(_mapped_triangles(face, name))
    elif face is not None and face.count:
        counts, flat = _list_values(face, _index_list(face))
        if counts.min() < 3:
            k = int(np.argmax(counts < 3))
            raise _Bad(f"face {k} has {_words(int(counts[k]), 'vertex')}, need at least 3"
                       + ("" if ply.text else " (the header's element counts may be wrong)"))
        flat = flat.astype(np.int64)
        parts.append(fan_triangles(counts, flat))
        if not np.all(counts == 3):
            polygons = (counts, flat)
    strips = _element(ply, "tristrips")
    if strips is not None and strips.count:
        name = _index_list(strips)
        counts, flat = _list_values(strips, name)
        flat = flat.astype(np.int64)
        code = np.dtype(strips.ply_property(name).val_dtype)
        if code.kind == "u":  # -1 stored as the largest unsigned value
            flat[flat == np.iinfo(code).max] = -1
        parts.append(_strip_triangles(counts, flat))
        polygons = None  # strips have no polygons to carry over
    return (parts[1] if len(parts) == 2 else np.concatenate(parts)), polygons  # (no copy of one part)


def _colors(vertex: plyfile.PlyElement, names: list[str]) -> np.ndarray | None:
    """(n, 4) float64 RGBA in [0, 1] from ``red green blue [alpha]`` (integers out of 255), or None."""
    if not all(c in names for c in _COLOR[:3]):
        return None
    cols = [vertex.data[c] for c in _COLOR if c in names]
    table = np.column_stack(cols).astype(np.float64)
    if np.dtype(vertex.data["red"].dtype).kind in "ui":
        table /= 255.0
    return table if table.shape[1] == 4 else np.column_stack([table, np.ones(len(table))])


def _extras(ply: plyfile.PlyData, vertex: plyfile.PlyElement, names: list[str], vertex_uv: tuple[str, ...],
            uv_faces: plyfile.PlyElement | None) -> tuple[dict[str, int], list[str]]:
    """What the file holds besides the surface, as a document's inventory, and the ``TextureFile``
    images its comments name (``vertex_uv``: the vertex properties of texture coordinates, if any;
    ``uv_faces``: the face element, when its ``texcoord`` lists are the texture coordinates)."""
    face_uv = uv_faces is not None
    standard = {"x", "y", "z", "nx", "ny", "nz", *_COLOR, *vertex_uv}
    extras: dict[str, int] = {}
    custom = [n for n in names if n not in standard]
    if custom:
        extras["custom vertex properties (" + ", ".join(custom) + ")"] = vertex.count
    for el in ply.elements:
        if el.name not in ("vertex", "face"):
            extras[f"'{el.name}' records"] = el.count
        elif el.name == "face":
            other = [p.name for p in el.properties if p.name not in _FACE_LISTS and
                     not (face_uv and p.name in ("texcoord", "texnumber"))]
            if other:
                extras["custom face properties (" + ", ".join(other) + ")"] = el.count
    if vertex_uv or face_uv:
        extras["texture coordinates"] = vertex.count if vertex_uv else uv_faces.count
    files = [c.split(None, 1)[1].strip() for c in ply.comments
             if c.split(None, 1)[:1] == ["TextureFile"] and len(c.split(None, 1)) == 2]
    if files:
        extras["texture files"] = len(files)
    if len(ply.comments) - len(files) + len(ply.obj_info):
        extras["header comments"] = len(ply.comments) - len(files) + len(ply.obj_info)
    return extras, files


def _texturing(ply: plyfile.PlyData, path: str, vertex_uv: tuple[str, str], face_uv: bool,
               files: list[str], polygons, triangles: np.ndarray) -> Texturing:
    """Texture coordinates (a face's ``texcoord`` list, as MeshLab writes them, or per-vertex
    ``u v`` / ``s t``) and the ``TextureFile`` images, with ``texnumber`` choosing a face's."""
    from pathlib import Path

    tex = Texturing()
    if face_uv:
        counts, values = _list_values(ply["face"], "texcoord")
        corners = polygons[0] if polygons is not None else np.full(len(counts), 3)
        if np.array_equal(counts, 2 * corners):
            tex.uv = values.astype(np.float64).reshape(-1, 2)
            tex.corner_uv = np.arange(len(tex.uv), dtype=np.int64)
    elif vertex_uv:
        v = ply["vertex"].data
        tex.uv = np.column_stack([v[vertex_uv[0]], v[vertex_uv[1]]]).astype(np.float64)
        tex.corner_uv = (polygons[1] if polygons is not None else triangles.reshape(-1)).astype(np.int64)
    folder = Path(path).parent
    for name in files:
        image = folder / name.replace("\\", "/")
        tex.materials.append(Material(Path(name).stem, image=image.read_bytes() if image.is_file() else None,
                                      image_name=Path(name).name))
    if tex.materials:
        face = ply["face"]
        if "texnumber" in [p.name for p in face.properties]:
            number = np.asarray(face.data["texnumber"], dtype=np.int64)
            tex.face_material = np.where((number >= 0) & (number < len(files)), number, -1)
        else:
            tex.face_material = np.zeros(face.count, dtype=np.int64)
    return tex


def _cast(values: np.ndarray, dtype: np.dtype) -> np.ndarray:
    if np.dtype(dtype).kind in "ui":
        info = np.iinfo(dtype)
        return np.clip(np.rint(values), info.min, info.max).astype(dtype)
    return values.astype(dtype)


def write(doc: Document) -> bytes:
    """The PLY bytes of ``doc``: its own elements with new positions, or a plain binary PLY
    (with its polygons, colours, normals, per-face ``texcoord`` lists as MeshLab writes
    them and a ``TextureFile`` comment for each texture image)."""
    nat = doc.native
    if not isinstance(nat, PlyNative):
        return _to_bytes(_plain(doc))
    V = doc.mesh.vertices
    moved = moved_vertices(nat.rest, V)
    if nat.raw is not None:
        return _write_text(doc, nat, moved)
    elements = []
    for el in nat.data.elements:
        if el.name == "vertex" and moved.any():
            rec = el.data.copy()
            for axis, name in enumerate("xyz"):
                rec[name][moved] = _cast(V[moved, axis], rec.dtype[name])
            names = rec.dtype.names
            if all(n in names for n in ("nx", "ny", "nz")):
                touched, normals = _touched_normals(doc, moved)
                for axis, name in enumerate(("nx", "ny", "nz")):
                    rec[name][touched] = _cast(normals[touched, axis], rec.dtype[name])
            el = copy.copy(el)
            el.data = rec
        elements.append(el)
    out = plyfile.PlyData(elements, text=nat.data.text, byte_order=nat.data.byte_order,
                          comments=nat.data.comments, obj_info=nat.data.obj_info)
    return _to_bytes(out)


def _touched_normals(doc: Document, moved: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(which vertices a moved vertex's faces touch, with a valid normal (n,), normals (n, 3))."""
    V, tri = doc.mesh.vertices, doc.mesh.faces
    touched = np.zeros(len(V), dtype=bool)
    touched[tri[moved[tri].any(axis=1)].ravel()] = True
    normals, valid = grouped_normals(V, tri, tri, len(V))
    return touched & valid, normals


def _write_text(doc: Document, nat: PlyNative, moved: np.ndarray) -> bytes:
    """An ASCII file given back line by line: the header and every record as they were, the
    lines of moved vertices (and of the vertices whose normals they change) rewritten with
    the file's own precision in the property's type (see
    :class:`~hybridedit.fileio.formats.common.TextPrecision`)."""
    if not moved.any():
        return nat.raw
    raw = nat.raw
    start = raw.find(b"\n", raw.index(b"end_header")) + 1
    lines = raw[start:].splitlines(keepends=True)
    records = [i for i, line in enumerate(lines) if line.strip()]
    first = 0
    for el in nat.data.elements:
        if el.name == "vertex":
            break
        first += el.count
    vertex = nat.data["vertex"]
    props = vertex.properties
    names = [p.name for p in props]
    has_normals = all(n in names for n in ("nx", "ny", "nz"))
    rewrite = moved.copy()
    touched = normals = None
    if has_normals:
        touched, normals = _touched_normals(doc, moved)
        rewrite |= touched

    def columns(words: list[bytes]) -> dict[str, int]:
        at, where = 0, {}
        for p in props:
            where[p.name] = at
            at += 1 + (int(words[at]) if isinstance(p, plyfile.PlyListProperty) else 0)
        return where

    def sample(axes: tuple[str, ...]) -> TextPrecision:
        rows = _sample_rows(vertex.count)
        toks = []
        for k in rows.tolist():
            words = lines[records[first + k]].split()
            where = columns(words)
            toks += [words[where[a]] for a in axes]
        return TextPrecision.of(toks)

    def number(style: TextPrecision, x: float, dtype: np.dtype) -> bytes:
        if dtype.kind in "ui":
            return b"%d" % int(_cast(np.array([x]), dtype)[0])
        return style.text(x, np.float32 if dtype.itemsize == 4 else np.float64)

    xyz, nxyz = sample(("x", "y", "z")), sample(("nx", "ny", "nz")) if has_normals else None
    types = {p.name: np.dtype(p.val_dtype) for p in props if not isinstance(p, plyfile.PlyListProperty)}
    V = doc.mesh.vertices
    for i in np.flatnonzero(rewrite).tolist():
        li = records[first + i]
        line = lines[li]
        body = line.rstrip(b"\r\n")
        words = body.split()
        where = columns(words)
        if moved[i]:
            for axis, name in enumerate("xyz"):
                words[where[name]] = number(xyz, V[i, axis], types[name])
        if touched is not None and touched[i]:
            for axis, name in enumerate(("nx", "ny", "nz")):
                words[where[name]] = number(nxyz, normals[i, axis], types[name])
        lines[li] = b" ".join(words) + line[len(body):]
    return raw[:start] + b"".join(lines)


def _plain(doc: Document) -> plyfile.PlyData:
    """A binary little-endian PLY of ``doc``: double x y z, float normals, uchar RGBA colours,
    its polygons as 'vertex_indices' (uchar count, int indices)."""
    mesh = doc.mesh
    fields = [("x", "<f8"), ("y", "<f8"), ("z", "<f8")]
    if doc.normals:
        fields += [("nx", "<f4"), ("ny", "<f4"), ("nz", "<f4")]
    if doc.colors is not None:
        fields += [(c, "u1") for c in _COLOR]
    rec = np.empty(mesh.n_vertices, dtype=fields)
    for axis, name in enumerate("xyz"):
        rec[name] = mesh.vertices[:, axis]
    if doc.normals:
        n = vertex_normals(mesh.vertices, mesh.faces)
        for axis, name in enumerate(("nx", "ny", "nz")):
            rec[name] = n[:, axis]
    if doc.colors is not None:
        for k, name in enumerate(_COLOR):
            rec[name] = np.clip(np.rint(doc.colors[:, k] * 255), 0, 255)
    if mesh.n_vertices > np.iinfo(np.int32).max:
        raise _Bad("too many vertices for 32-bit PLY face indices")
    counts, flat = doc.polygon_lists()
    tex = doc.textures()
    uv = None
    if tex is not None and tex.uv is not None and tex.corner_uv is not None:
        uv = np.where(tex.corner_uv[:, None] >= 0, tex.uv[np.maximum(tex.corner_uv, 0)], 0.0)
    images = [m for m in (tex.materials if tex is not None else []) if m.image is not None]
    numbered = len(images) > 1 and tex.face_material is not None
    fields = []
    if len(counts) and np.all(counts == counts[0]):
        k = int(counts[0])
        fields.append(("vertex_indices", "<i4", (k,)))
        fields += [("texcoord", "<f4", (2 * k,))] if uv is not None else []
        faces = np.empty(len(counts), dtype=fields + ([("texnumber", "<i4")] if numbered else []))
        faces["vertex_indices"] = flat.reshape(len(counts), -1)
        if uv is not None:
            faces["texcoord"] = uv.reshape(len(counts), -1)
    else:
        fields = [("vertex_indices", object)] + ([("texcoord", object)] if uv is not None else [])
        faces = np.empty(len(counts), dtype=fields + ([("texnumber", "<i4")] if numbered else []))
        cuts = np.cumsum(counts)[:-1]
        faces["vertex_indices"] = np.split(flat.astype(np.int32), cuts) if len(counts) else []
        if uv is not None:
            faces["texcoord"] = np.split(uv.astype(np.float32).reshape(-1), 2 * cuts) if len(counts) else []
    comments = ["written by hybridedit"]
    if images:  # MeshLab's convention: one TextureFile comment per image, texnumber per face
        names = [name for name in texture_file_names(tex.materials) if name is not None]
        comments += [f"TextureFile {name}" for name in names]
        if numbered:
            order = {id(m): k for k, m in enumerate(images)}
            number = np.array([order.get(id(m), -1) for m in tex.materials] + [-1])
            faces["texnumber"] = number[tex.face_material]
    return plyfile.PlyData(
        [plyfile.PlyElement.describe(rec, "vertex"),
         plyfile.PlyElement.describe(faces, "face", len_types={"vertex_indices": "u1", "texcoord": "u1"},
                                     val_types={"vertex_indices": "i4", "texcoord": "f4"})],
        text=False, byte_order="<", comments=comments)


def texture_file_names(materials: list[Material]) -> list[str | None]:
    """The file name a converted PLY gives each material's image (None for none)."""
    from .obj_materials import image_names

    return image_names(materials)


def converted_companions(doc: Document, target) -> list[tuple[object, bytes]]:
    """The texture images a converted PLY's ``TextureFile`` comments name, beside ``target``."""
    tex = doc.textures()
    if tex is None:
        return []
    return [(target.parent / name, m.image) for m, name in zip(tex.materials, texture_file_names(tex.materials))
            if name is not None]


def _uniform_record(el: plyfile.PlyElement, order: str) -> np.ndarray | None:
    """``el``'s records as one packed record array with list counts, when every list has
    one length; None otherwise."""
    fields, columns = [], []
    for p in el.properties:
        col = el.data[p.name]
        if isinstance(p, plyfile.PlyListProperty):
            if col.dtype == object:
                lengths = {len(x) for x in col}
                if len(lengths) > 1:
                    return None
                k = lengths.pop() if lengths else 0
                col = np.array(col.tolist()).reshape(len(col), k) if k else np.zeros((len(col), 0))
            else:
                col = col.reshape(len(col), -1)
                k = col.shape[1]
            len_t, val_t = p.list_dtype(order)
            fields += [(p.name + "\n", len_t), (p.name, val_t, (k,))]
            columns += [np.full(len(col), k), col]
        else:
            fields.append((p.name, p.dtype(order)))
            columns.append(col)
    rec = np.empty(el.count, dtype=fields)
    for (name, *_), col in zip(fields, columns):
        rec[name] = col
    return rec


def _to_bytes(ply: plyfile.PlyData) -> bytes:
    """Serialize ``ply``; binary elements with lists of one length go out as one array."""
    if ply.text:
        buf = io.BytesIO()
        ply.write(buf)
        return buf.getvalue()
    order = ply.byte_order
    parts = [(ply.header + "\n").encode("ascii")]
    for el in ply.elements:
        rec = _uniform_record(el, order)
        if rec is None:
            buf = io.BytesIO()  # ragged lists: plyfile's record-by-record writer
            plyfile.PlyData([el], text=False, byte_order=order).write(buf)
            body = buf.getvalue()
            parts.append(body[body.index(b"end_header\n") + len(b"end_header\n"):])
        else:
            parts.append(rec.tobytes())
    return b"".join(parts)
