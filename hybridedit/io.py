"""Reading and writing triangle meshes in OBJ, PLY, STL and OFF format.

The parsers are written with numpy so that vertex order is kept exactly and so
that every problem with a file is reported as a :class:`MeshFileError` whose
message starts with the file name.
"""

from __future__ import annotations

import os
import re
import struct
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .atomic import atomic_write
from .mesh import Mesh, MeshError

__all__ = ["MeshFileError", "SUPPORTED_EXTENSIONS", "read_mesh", "write_mesh"]

SUPPORTED_EXTENSIONS = (".obj", ".off", ".ply", ".stl")


class MeshFileError(MeshError):
    """A mesh file is missing, unsupported or malformed.

    The message starts with the file name and says the problem plainly.
    """


class _Bad(Exception):
    """Internal: a problem in the file, described without the file name."""


# --------------------------------------------------------------------------- helpers


def _words(n: int, element: str) -> str:
    """'1 vertex', '500 vertices', '2 faces', "3 'edge' records"."""
    forms = {"vertex": ("vertex", "vertices"), "face": ("face", "faces"),
             "triangle": ("triangle", "triangles")}
    if element in forms:
        return f"{n} {forms[element][n != 1]}"
    return f"{n} '{element}' record" + ("" if n == 1 else "s")


def _truncated(count: int, element: str, complete: int) -> _Bad:
    return _Bad(f"header says {_words(count, element)} but file ends after {complete}")


def _snippet(line: bytes, limit: int = 60) -> str:
    text = line.decode("utf-8", "replace").strip()
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _fan(counts: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """Fan-triangulate polygons.

    Parameters
    ----------
    counts : (p,) int array
        Number of corners of each polygon, all >= 3.
    flat : (sum(counts),) int64 array
        The polygons' vertex indices, one after another.

    Returns
    -------
    (sum(counts) - 2 p, 3) int64 array
        Triangles (c0, c[j+1], c[j+2]) of each polygon, in polygon order.
    """
    counts = np.asarray(counts, dtype=np.int64)
    flat = np.asarray(flat, dtype=np.int64)
    if counts.size == 0:
        return np.zeros((0, 3), dtype=np.int64)
    if np.all(counts == 3):
        return flat.reshape(-1, 3)
    ntri = counts - 2
    first = np.repeat(np.cumsum(counts) - counts, ntri)
    j = np.arange(int(ntri.sum())) - np.repeat(np.cumsum(ntri) - ntri, ntri)
    return np.stack([flat[first], flat[first + j + 1], flat[first + j + 2]], axis=1)


def _weld(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge exactly equal positions of a triangle soup.

    Parameters
    ----------
    points : (3 m, 3) float64 array
        Corners of m triangles, three consecutive rows per triangle.

    Returns
    -------
    vertices : (n, 3) float64 array
        Distinct positions in order of first occurrence.
    faces : (m, 3) int64 array
    """
    if len(points) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    p = points + 0.0  # -0.0 becomes 0.0 so that both weld together
    bits = p.view(np.int64)
    order = np.lexsort((bits[:, 2], bits[:, 1], bits[:, 0]))  # stable
    ordered = bits[order]
    starts = np.ones(len(p), dtype=bool)
    starts[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    group = np.empty(len(p), dtype=np.int64)
    group[order] = np.cumsum(starts) - 1
    first = order[starts]  # first occurrence of each distinct position
    by_first = np.argsort(first)
    rank = np.empty_like(by_first)
    rank[by_first] = np.arange(len(first))
    return p[first[by_first]], rank[group].reshape(-1, 3)


def _validate(vertices: np.ndarray, faces: np.ndarray) -> None:
    """Check face indices, finiteness and that there is a face; raise _Bad if not."""
    n = len(vertices)
    if faces.size:
        bad = (faces < 0) | (faces >= n)
        if bad.any():
            value = int(faces.ravel()[int(np.argmax(bad.ravel()))])
            raise _Bad(f"face index {value} out of range (file has {_words(n, 'vertex')})")
    finite = np.isfinite(vertices).all(axis=1)
    if not finite.all():
        k = int((~finite).sum())
        first = int(np.argmin(finite))
        raise _Bad(f"{k} {'vertex has' if k == 1 else 'vertices have'} NaN or infinite "
                   f"coordinates (first is vertex {first}, counting from 0)")
    if len(faces) == 0:
        raise _Bad("file has no faces" if n else "file has no vertices and no faces")


# --------------------------------------------------------------------------- OBJ

_OBJ_V = (b"v ", b"v\t")
_OBJ_F = (b"f ", b"f\t")
_MARK = int(np.iinfo(np.int64).max)  # stands in for each line's "f" while parsing indices


def _numbers(text: bytes, dtype: type, expected: int) -> np.ndarray | None:
    """Parse whitespace-separated numbers in C.

    Returns a 1-d array of ``dtype``, or None unless every token is a number
    and there are exactly ``expected`` of them (the caller then falls back to
    a slower parser that can say which line is wrong).
    """
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # older numpy: partial parse
        try:
            vals = np.fromstring(text, dtype=dtype, sep=" ")
        except ValueError:
            return None
    return vals if vals.size == expected else None


_IS_SPACE = np.zeros(256, dtype=bool)
_IS_SPACE[list(b" \t\n\r\v\f")] = True


def _token_count(text: bytes) -> int:
    """Number of whitespace-separated tokens, like ``len(text.split())`` but without the list."""
    if not text:
        return 0
    space = _IS_SPACE[np.frombuffer(text, dtype=np.uint8)]
    return int(np.count_nonzero(space[:-1] & ~space[1:])) + int(not space[0])


def _widths(lines: list[bytes]) -> np.ndarray:
    """Number of whitespace-separated tokens of each line, (k,) int64."""
    return np.fromiter(map(len, map(bytes.split, lines)), dtype=np.int64, count=len(lines))


def _obj_line_number(lines: list[bytes], heads: tuple[bytes, ...], k: int) -> int:
    """1-based line number of the k-th (0-based) line starting with one of ``heads``."""
    seen = -1
    for i, line in enumerate(lines):
        if line[:2] in heads:
            seen += 1
            if seen == k:
                return i + 1
    return len(lines)


def _obj_vertices(lines: list[bytes]) -> np.ndarray:
    """x y z of every "v" line, (n, 3) float64; w and colour columns are ignored."""
    vlines = [line for line in lines if line[:2] in _OBJ_V]
    widths = _widths(vlines) - 1
    if widths.size and widths.min() < 3:
        k = int(np.argmax(widths < 3))
        raise _Bad(f"line {_obj_line_number(lines, _OBJ_V, k)}: vertex has "
                   f"{int(widths[k])} coordinates, expected 3 ('{_snippet(vlines[k])}')")
    if not vlines:
        return np.zeros((0, 3))
    if widths.min() == widths.max():
        w = int(widths[0])
        vals = _numbers(b"\n".join([line[1:] for line in vlines]), np.float64, w * len(vlines))
        if vals is not None:
            return np.ascontiguousarray(vals.reshape(-1, w)[:, :3])
    rows = [line.split()[1:4] for line in vlines]
    try:
        return np.array(rows).astype(np.float64)
    except ValueError:
        for k, row in enumerate(rows):
            try:
                [float(t) for t in row]
            except ValueError:
                raise _Bad(f"line {_obj_line_number(lines, _OBJ_V, k)}: cannot read "
                           f"vertex coordinates '{_snippet(vlines[k])}'") from None
        raise


def _obj_corners(lines: list[bytes]) -> tuple[np.ndarray, np.ndarray]:
    """Corner count of each "f" line, (p,) int64, and its vertex indices as written
    (1-based or negative), (sum of counts,) int64; "/t/n" parts are dropped."""
    flines = [line for line in lines if line[:2] in _OBJ_F]
    joined = b"\n".join(flines)
    if b"/" in joined:
        joined = re.sub(rb"/\S*", b"", joined)
    marked = (b"\n" + joined).replace(b"\nf", b"\n" + str(_MARK).encode())
    vals = _numbers(marked, np.int64, _token_count(marked))
    if vals is not None:
        is_mark = vals == _MARK
        starts = np.flatnonzero(is_mark)
        if len(starts) == len(flines):
            counts = np.diff(np.append(starts, len(vals))) - 1
            return counts, vals[~is_mark]
    # slow path, which can name the line that is wrong
    rows = [line.split()[1:] for line in joined.split(b"\n")] if flines else []
    counts = _widths([b" ".join(r) for r in rows])
    flat = [t for r in rows for t in r]
    try:
        return counts, (np.array(flat) if flat else np.zeros(0, "S1")).astype(np.int64)
    except ValueError:
        for k, row in enumerate(rows):
            try:
                [int(t) for t in row]
            except ValueError:
                raise _Bad(f"line {_obj_line_number(lines, _OBJ_F, k)}: cannot read "
                           f"face indices '{_snippet(flines[k])}'") from None
        raise


def _read_obj(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    if b"\0" in data:
        raise _Bad("not a text OBJ file (it contains binary data)")
    if b"\\" in data:  # line continuations
        data = re.sub(rb"\\[ \t]*(\r\n|\n|\r)", b" ", data)
    lines = data.splitlines()
    if data[:1] in (b" ", b"\t") or any(nl + ws in data for nl in (b"\n", b"\r")
                                         for ws in (b" ", b"\t")):
        lines = [line.lstrip() for line in lines]  # some lines are indented
    vertices = _obj_vertices(lines)
    nv = len(vertices)
    counts, idx = _obj_corners(lines)
    if counts.size and counts.min() < 3:
        k = int(np.argmax(counts < 3))
        raise _Bad(f"line {_obj_line_number(lines, _OBJ_F, k)}: face has "
                   f"{_words(int(counts[k]), 'vertex')}, need at least 3")
    face_of = np.repeat(np.arange(len(counts)), counts)

    if idx.size and idx.min() <= 0:
        if (idx == 0).any():
            k = int(face_of[int(np.argmax(idx == 0))])
            raise _Bad(f"line {_obj_line_number(lines, _OBJ_F, k)}: face index 0 is "
                       "invalid (OBJ indices start at 1)")
        # relative indices count back from the last vertex defined before the line
        defined, before = 0, []
        for line in lines:
            head = line[:2]
            if head in _OBJ_V:
                defined += 1
            elif head in _OBJ_F:
                before.append(defined)
        base = np.repeat(np.asarray(before, dtype=np.int64), counts)
        neg = idx < 0
        resolved = np.where(neg, base + idx + 1, idx)
        wrong = neg & (resolved < 1)
        if wrong.any():
            at = int(np.argmax(wrong))
            k = int(face_of[at])
            raise _Bad(f"line {_obj_line_number(lines, _OBJ_F, k)}: face index "
                       f"{int(idx[at])} out of range (only {_words(int(base[at]), 'vertex')} "
                       "defined before this line)")
        idx = resolved
    if idx.size and idx.max() > nv:
        at = int(np.argmax(idx > nv))
        k = int(face_of[at])
        raise _Bad(f"line {_obj_line_number(lines, _OBJ_F, k)}: face index {int(idx[at])} "
                   f"out of range (file has {_words(nv, 'vertex')})")
    return vertices, _fan(counts, idx - 1)


# --------------------------------------------------------------------------- PLY

_PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "i2", "int16": "i2", "ushort": "u2", "uint16": "u2",
    "int": "i4", "int32": "i4", "uint": "u4", "uint32": "u4",
    "int64": "i8", "uint64": "u8",
    "float": "f4", "float32": "f4", "double": "f8", "float64": "f8",
}
_STRUCT_CODES = {"i1": "b", "u1": "B", "i2": "h", "u2": "H", "i4": "i", "u4": "I",
                 "i8": "q", "u8": "Q", "f4": "f", "f8": "d"}
_PLY_FORMATS = {"ascii": "", "binary_little_endian": "<", "binary_big_endian": ">"}


@dataclass
class _Prop:
    name: str
    code: str  # numpy type code of the value(s), e.g. "f4"
    count_code: str | None = None  # numpy type code of a list's length; None if scalar


@dataclass
class _Element:
    name: str
    count: int
    props: list[_Prop] = field(default_factory=list)


@dataclass
class _Parsed:
    """Wanted values of one element: scalar columns and (counts, flat values) of lists."""

    scalars: dict[str, np.ndarray] = field(default_factory=dict)
    lists: dict[str, tuple[np.ndarray, np.ndarray]] = field(default_factory=dict)


def _ply_header(data: bytes) -> tuple[str, list[_Element], int]:
    """Format name, elements and byte offset of the body."""
    if not re.match(rb"ply[ \t]*(\r\n|\n|\r)", data):
        raise _Bad("not a PLY file (it does not start with a 'ply' line)")
    end = re.search(rb"(\n|\r)end_header[ \t]*(\r\n|\n|\r|$)", data)
    if end is None:
        raise _Bad("not a valid PLY header (no 'end_header' line)")
    try:
        header = data[: end.start()].decode("ascii")
    except UnicodeDecodeError:
        raise _Bad("not a valid PLY header (it contains non-ASCII bytes)") from None
    fmt: str | None = None
    elements: list[_Element] = []
    for raw in header.splitlines()[1:]:
        tok = raw.split()
        if not tok or tok[0] in ("comment", "obj_info"):
            continue
        bad = f"not a valid PLY header (bad line '{raw.strip()[:60]}')"
        if tok[0] == "format":
            if len(tok) < 2:
                raise _Bad(bad)
            if tok[1] not in _PLY_FORMATS:
                raise _Bad(f"unknown PLY format '{tok[1]}' (expected ascii, "
                           "binary_little_endian or binary_big_endian)")
            fmt = tok[1]
        elif tok[0] == "element":
            if len(tok) != 3 or not tok[2].isdigit():
                raise _Bad(bad)
            elements.append(_Element(tok[1], int(tok[2])))
        elif tok[0] == "property":
            if not elements:
                raise _Bad("not a valid PLY header (property before any element)")
            if len(tok) == 5 and tok[1] == "list":
                if tok[2] not in _PLY_TYPES or tok[3] not in _PLY_TYPES:
                    raise _Bad(f"not a valid PLY header (unknown type in '{raw.strip()[:60]}')")
                if _PLY_TYPES[tok[2]][0] == "f":
                    raise _Bad(f"not a valid PLY header (list length type must be an "
                               f"integer in '{raw.strip()[:60]}')")
                elements[-1].props.append(_Prop(tok[4], _PLY_TYPES[tok[3]], _PLY_TYPES[tok[2]]))
            elif len(tok) == 3:
                if tok[1] not in _PLY_TYPES:
                    raise _Bad(f"not a valid PLY header (unknown type in '{raw.strip()[:60]}')")
                elements[-1].props.append(_Prop(tok[2], _PLY_TYPES[tok[1]]))
            else:
                raise _Bad(bad)
        else:
            raise _Bad(bad)
    if fmt is None:
        raise _Bad("not a valid PLY header (no 'format' line)")
    return fmt, elements, end.end()


def _ply_binary(data: bytes, pos: int, el: _Element, order: str,
                wanted: set[str]) -> tuple[_Parsed, int]:
    """Parse one binary element starting at byte ``pos``; return values and the next offset."""
    out = _Parsed()
    if el.count == 0 or not el.props:
        return out, pos
    size = len(data)
    if all(p.count_code is None for p in el.props):
        dt = np.dtype([(f"p{i}", order + p.code) for i, p in enumerate(el.props)])
        if size - pos < el.count * dt.itemsize:
            raise _truncated(el.count, el.name, (size - pos) // dt.itemsize)
        rec = np.frombuffer(data, dt, el.count, pos)
        for i, p in enumerate(el.props):
            if p.name in wanted:
                out.scalars[p.name] = rec[f"p{i}"]
        return out, pos + el.count * dt.itemsize

    # Fast path: assume every list has the length found in the first record,
    # read all records with one structured dtype, then verify the lengths.
    fields, lengths, at, fast = [], [], pos, True
    for i, p in enumerate(el.props):
        if p.count_code is None:
            fields.append((f"p{i}", order + p.code))
            at += np.dtype(p.code).itemsize
            continue
        csize = np.dtype(p.count_code).itemsize
        k = int(np.frombuffer(data, order + p.count_code, 1, at)[0]) if at + csize <= size else -1
        at += csize + max(k, 0) * np.dtype(p.code).itemsize
        if k < 0 or at > size:  # let the slow path say what is wrong
            fast = False
            break
        fields += [(f"c{i}", order + p.count_code), (f"p{i}", order + p.code, (k,))]
        lengths.append((i, k))
    dt = np.dtype(fields) if fast else None
    if dt is not None and size - pos >= el.count * dt.itemsize:
        rec = np.frombuffer(data, dt, el.count, pos)
        if all(np.all(rec[f"c{i}"] == k) for i, k in lengths):
            for i, p in enumerate(el.props):
                if p.name not in wanted:
                    continue
                if p.count_code is None:
                    out.scalars[p.name] = rec[f"p{i}"]
                else:
                    k = dict(lengths)[i]
                    out.lists[p.name] = (np.full(el.count, k, dtype=np.int64),
                                         rec[f"p{i}"].reshape(-1))
            return out, pos + el.count * dt.itemsize

    # Slow path: list lengths vary (or the file is short); walk record by record.
    plan = []
    for p in el.props:
        vsize = np.dtype(p.code).itemsize
        cstruct = struct.Struct(order + _STRUCT_CODES[p.count_code]) if p.count_code else None
        plan.append((p, vsize, cstruct, p.name in wanted))
    scalars: dict[str, list[bytes]] = {p.name: [] for p, _, c, w in plan if w and c is None}
    lists: dict[str, tuple[list[int], list[bytes]]] = {
        p.name: ([], []) for p, _, c, w in plan if w and c is not None}
    for r in range(el.count):
        for p, vsize, cstruct, want in plan:
            if cstruct is None:
                if pos + vsize > size:
                    raise _truncated(el.count, el.name, r)
                if want:
                    scalars[p.name].append(data[pos: pos + vsize])
                pos += vsize
                continue
            if pos + cstruct.size > size:
                raise _truncated(el.count, el.name, r)
            k = cstruct.unpack_from(data, pos)[0]
            pos += cstruct.size
            if k < 0:
                raise _Bad(f"{el.name} {r}: negative list length {k}")
            end = pos + k * vsize
            if end > size:
                raise _truncated(el.count, el.name, r)
            if want:
                lists[p.name][0].append(k)
                lists[p.name][1].append(data[pos:end])
            pos = end
    for p, _, cstruct, want in plan:
        if not want:
            continue
        if cstruct is None:
            out.scalars[p.name] = np.frombuffer(b"".join(scalars[p.name]), order + p.code)
        else:
            ks, chunks = lists[p.name]
            out.lists[p.name] = (np.asarray(ks, dtype=np.int64),
                                 np.frombuffer(b"".join(chunks), order + p.code))
    return out, pos


def _ascii_ints(values: list[bytes] | np.ndarray, what: str) -> np.ndarray:
    arr = np.asarray(values) if len(values) else np.zeros(0, dtype="S1")
    try:
        return arr.astype(np.int64)
    except ValueError:
        for v in arr:
            try:
                int(v)
            except ValueError:
                raise _Bad(f"{what} '{_snippet(bytes(v))}' is not a whole number") from None
        raise


def _ascii_column(values: np.ndarray, prop: _Prop, element: str) -> np.ndarray:
    if prop.code[0] == "f":
        try:
            return values.astype(np.float64)
        except ValueError:
            for v in values:
                try:
                    float(v)
                except ValueError:
                    raise _Bad(f"{element} property '{prop.name}' has the value "
                               f"'{_snippet(bytes(v))}', which is not a number") from None
            raise
    return _ascii_ints(values, f"{element} property '{prop.name}' value")


def _ply_ascii(tokens: list[bytes], t: int, el: _Element,
               wanted: set[str]) -> tuple[_Parsed, int]:
    """Parse one ascii element starting at token ``t``; return values and the next token."""
    out = _Parsed()
    n = len(tokens)
    if el.count == 0 or not el.props:
        return out, t
    # Fast path: layout of the first record holds for all records.
    stride, layout = 0, []
    ok = True
    for p in el.props:
        if p.count_code is None:
            layout.append((p, stride, None))
            stride += 1
            continue
        if t + stride >= n:
            ok = False
            break
        try:
            k = int(tokens[t + stride])
        except ValueError:
            raise _Bad(f"{el.name} 0: list length '{_snippet(tokens[t + stride])}' is not a "
                       "whole number (the header's element counts may be wrong)") from None
        if k < 0:
            raise _Bad(f"{el.name} 0: negative list length {k}")
        layout.append((p, stride, k))
        stride += 1 + k
    if ok and n - t >= el.count * stride:
        block = np.array(tokens[t: t + el.count * stride]).reshape(el.count, stride)
        try:
            same = all(np.all(block[:, col].astype(np.int64) == k)
                       for _, col, k in layout if k is not None)
        except ValueError:
            same = False
        if same:
            for p, col, k in layout:
                if p.name not in wanted:
                    continue
                if k is None:
                    out.scalars[p.name] = _ascii_column(block[:, col], p, el.name)
                else:
                    vals = _ascii_column(block[:, col + 1: col + 1 + k].reshape(-1), p, el.name)
                    out.lists[p.name] = (np.full(el.count, k, dtype=np.int64), vals)
            return out, t + el.count * stride

    # Slow path: record by record.
    scalars: dict[str, list[bytes]] = {p.name: [] for p in el.props
                                       if p.name in wanted and p.count_code is None}
    lists: dict[str, tuple[list[int], list[bytes]]] = {
        p.name: ([], []) for p in el.props if p.name in wanted and p.count_code is not None}
    for r in range(el.count):
        for p in el.props:
            if t >= n:
                raise _truncated(el.count, el.name, r)
            if p.count_code is None:
                if p.name in scalars:
                    scalars[p.name].append(tokens[t])
                t += 1
                continue
            try:
                k = int(tokens[t])
            except ValueError:
                raise _Bad(f"{el.name} {r}: list length '{_snippet(tokens[t])}' is not a whole "
                           "number (the header's element counts may be wrong)") from None
            if k < 0:
                raise _Bad(f"{el.name} {r}: negative list length {k}")
            t += 1
            if t + k > n:
                raise _truncated(el.count, el.name, r)
            if p.name in lists:
                lists[p.name][0].append(k)
                lists[p.name][1].extend(tokens[t: t + k])
            t += k
    for p in el.props:
        if p.name in scalars:
            out.scalars[p.name] = _ascii_column(np.array(scalars[p.name]), p, el.name)
        elif p.name in lists:
            ks, vals = lists[p.name]
            arr = np.array(vals) if vals else np.zeros(0, dtype="S1")
            out.lists[p.name] = (np.asarray(ks, dtype=np.int64),
                                 _ascii_column(arr, p, el.name))
    return out, t


def _strip_triangles(counts: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """Triangles of triangle strips.

    Parameters
    ----------
    counts : (s,) int64 array
        Length of each strip record.
    flat : (sum(counts),) int64 array
        Strip indices; -1 restarts a strip.

    Returns
    -------
    (t, 3) int64 array
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


_PLY_WANTED = {"vertex": {"x", "y", "z"}, "face": {"vertex_indices", "vertex_index"},
               "tristrips": {"vertex_indices", "vertex_index"}}


def _read_ply(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    fmt, elements, pos = _ply_header(data)
    names = [el.name for el in elements]
    if "vertex" not in names:
        raise _Bad("PLY header has no 'vertex' element")
    for name in ("vertex", "face", "tristrips"):
        if names.count(name) > 1:
            raise _Bad(f"PLY header has more than one '{name}' element")
    vertex_el = elements[names.index("vertex")]
    for axis in "xyz":
        prop = next((p for p in vertex_el.props if p.name == axis), None)
        if prop is None:
            raise _Bad(f"PLY vertex element has no '{axis}' property")
        if prop.count_code is not None:
            raise _Bad(f"PLY vertex property '{axis}' is a list, expected a number")
    for name in ("face", "tristrips"):
        if name in names:
            el = elements[names.index(name)]
            listed = [p for p in el.props if p.name in _PLY_WANTED[name]]
            if not listed or listed[0].count_code is None:
                raise _Bad(f"PLY {name} element has no 'vertex_indices' list property")
            if listed[0].code[0] == "f":
                raise _Bad(f"PLY {name} indices must be integers, not floating point")

    parsed: dict[str, _Parsed] = {}
    if fmt == "ascii":
        tokens = data[pos:].split()
        t = 0
        for el in elements:
            parsed[el.name], t = _ply_ascii(tokens, t, el, _PLY_WANTED.get(el.name, set()))
        if t < len(tokens):
            raise _Bad(f"{len(tokens) - t} unexpected values after the last element "
                       "(the header's element counts may be wrong)")
    else:
        order = _PLY_FORMATS[fmt]
        for el in elements:
            parsed[el.name], pos = _ply_binary(data, pos, el, order,
                                               _PLY_WANTED.get(el.name, set()))
        rest = data[pos:]
        if rest.strip():
            raise _Bad(f"{len(rest)} unexpected bytes after the last element "
                       "(the header's element counts may be wrong)")

    v = parsed["vertex"].scalars
    if vertex_el.count == 0:
        vertices = np.zeros((0, 3))
    else:
        vertices = np.column_stack([v["x"], v["y"], v["z"]]).astype(np.float64)
    parts = [np.zeros((0, 3), dtype=np.int64)]
    no_list = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    if "face" in parsed:
        counts, flat = next(iter(parsed["face"].lists.values()), no_list)
        if counts.size and counts.min() < 3:
            k = int(np.argmax(counts < 3))
            raise _Bad(f"face {k} has {_words(int(counts[k]), 'vertex')}, need at least 3"
                       + ("" if fmt == "ascii" else " (the header's element counts may be wrong)"))
        parts.append(_fan(counts, flat.astype(np.int64)))
    if "tristrips" in parsed:
        el = elements[names.index("tristrips")]
        prop = next(p for p in el.props if p.name in _PLY_WANTED["tristrips"])
        counts, flat = next(iter(parsed["tristrips"].lists.values()), no_list)
        flat = flat.astype(np.int64)
        if prop.code[0] == "u":  # -1 stored as the largest unsigned value
            flat[flat == np.iinfo(prop.code).max] = -1
        parts.append(_strip_triangles(counts, flat))
    return vertices, np.concatenate(parts)


# --------------------------------------------------------------------------- STL

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
    corners = _fan(counts, np.arange(len(vpos)))
    return _weld(points[corners.reshape(-1)])


# --------------------------------------------------------------------------- OFF

_OFF_HEADER = re.compile(rb"(ST)?C?N?(4)?(n)?OFF")


def _off_vertices(vlines: list[bytes], numbers: list[int]) -> np.ndarray:
    """First three numbers of each line, (n, 3) float64; ``numbers`` are 0-based line numbers."""
    widths = _widths(vlines)
    if widths.size and widths.min() < 3:
        k = int(np.argmax(widths < 3))
        raise _Bad(f"line {numbers[k] + 1}: vertex has {int(widths[k])} coordinates, "
                   f"expected 3 ('{_snippet(vlines[k])}')")
    if not vlines:
        return np.zeros((0, 3))
    if widths.min() == widths.max():
        w = int(widths[0])
        vals = _numbers(b"\n".join(vlines), np.float64, w * len(vlines))
        if vals is not None:
            return np.ascontiguousarray(vals.reshape(-1, w)[:, :3])
    rows = [line.split()[:3] for line in vlines]
    try:
        return np.array(rows).astype(np.float64)
    except ValueError:
        for k, row in enumerate(rows):
            try:
                [float(x) for x in row]
            except ValueError:
                raise _Bad(f"line {numbers[k] + 1}: cannot read vertex coordinates "
                           f"'{_snippet(vlines[k])}'") from None
        raise


def _off_faces(flines: list[bytes], numbers: list[int]) -> np.ndarray:
    """Fan-triangulated faces, (m, 3) int64; colour values after the indices are ignored."""
    widths = _widths(flines)
    if flines and widths.min() == widths.max():
        w = int(widths[0])
        vals = _numbers(b"\n".join(flines), np.int64, w * len(flines))
        if vals is not None:
            table = vals.reshape(-1, w)
            c = int(table[0, 0])
            if c >= 3 and w >= 1 + c and np.all(table[:, 0] == c):
                return _fan(table[:, 0], table[:, 1: 1 + c].reshape(-1))
    # irregular rows (polygons of several sizes, float colours): one by one
    sizes: list[int] = []
    flat: list[int] = []
    for k, line in enumerate(flines):
        row = line.split()
        where = f"line {numbers[k] + 1}"
        try:
            c = int(row[0])
        except ValueError:
            raise _Bad(f"{where}: face size '{_snippet(row[0])}' is not a whole number") from None
        if c < 3:
            raise _Bad(f"{where}: face has {_words(c, 'vertex')}, need at least 3")
        if len(row) < 1 + c:
            raise _Bad(f"{where}: face says {c} vertices but lists {len(row) - 1}")
        try:
            flat.extend([int(t) for t in row[1: 1 + c]])
        except ValueError:
            raise _Bad(f"{where}: cannot read face indices '{_snippet(line)}'") from None
        sizes.append(c)
    return _fan(np.asarray(sizes, dtype=np.int64), np.asarray(flat, dtype=np.int64))


def _read_off(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    if b"\0" in data:
        raise _Bad("not a text OFF file (it contains binary data)")
    lines = data.splitlines()
    if b"#" in data:
        lines = [line.partition(b"#")[0] for line in lines]
    numbers = [i for i, line in enumerate(lines) if line.strip()]
    body = [lines[i] for i in numbers]
    if not body:
        raise _Bad("file has no vertices and no faces")
    first = body[0].split()
    header = _OFF_HEADER.fullmatch(first[0]) or _OFF_HEADER.fullmatch(first[0].upper())
    if header:
        if header.group(2) or header.group(3):
            raise _Bad(f"'{first[0].decode()}' files (homogeneous or n-dimensional "
                       "coordinates) are not supported")
        counts_tokens, at = first[1:], 1
        if not counts_tokens:
            if len(body) < 2:
                raise _Bad("file ends before the vertex and face counts")
            counts_tokens, at = body[1].split(), 2
    elif first[0].upper().endswith(b"OFF"):
        raise _Bad(f"unknown OFF header '{_snippet(first[0])}'")
    else:
        counts_tokens, at = first, 1
    try:
        if len(counts_tokens) not in (2, 3):
            raise ValueError
        nv, nf = int(counts_tokens[0]), int(counts_tokens[1])
        if nv < 0 or nf < 0:
            raise ValueError
    except ValueError:
        raise _Bad(f"line {numbers[at - 1] + 1}: expected 'vertices faces [edges]' counts, "
                   f"found '{_snippet(b' '.join(counts_tokens))}'") from None

    vlines = body[at: at + nv]
    if len(vlines) < nv:
        raise _truncated(nv, "vertex", len(vlines))
    vertices = _off_vertices(vlines, numbers[at: at + nv])
    at += nv
    flines = body[at: at + nf]
    if len(flines) < nf:
        raise _truncated(nf, "face", len(flines))
    if len(body) > at + nf:
        extra = len(body) - at - nf
        raise _Bad(f"{extra} unexpected line{'s' if extra != 1 else ''} after the last face "
                   f"(line {numbers[at + nf] + 1}; the header's counts may be wrong)")
    return vertices, _off_faces(flines, numbers[at: at + nf])


# --------------------------------------------------------------------------- reading

_READERS: dict[str, tuple[str, Callable[[bytes], tuple[np.ndarray, np.ndarray]]]] = {
    ".obj": ("OBJ", _read_obj),
    ".ply": ("PLY", _read_ply),
    ".stl": ("STL", _read_stl),
    ".off": ("OFF", _read_off),
}


def _extension(name: str) -> str:
    return os.path.splitext(name)[1].lower()


def _unsupported(name: str, ext: str, action: str) -> MeshFileError:
    supported = ", ".join(SUPPORTED_EXTENSIONS)
    if not ext:
        return MeshFileError(f"{name}: cannot {action} a file without an extension "
                             f"(use one of {supported})")
    return MeshFileError(f"{name}: unsupported file extension '{ext}' (use one of {supported})")


def read_mesh(path: str | os.PathLike[str]) -> Mesh:
    """Read a triangle mesh, choosing the format by extension.

    Supported: ``.obj``, ``.ply`` (ascii and binary), ``.stl`` (ascii and
    binary) and ``.off``, in any letter case.  Polygons are fan-triangulated;
    STL corners with exactly equal positions are welded (first-occurrence
    order).  Vertex and face order are otherwise kept as in the file.

    Parameters
    ----------
    path : str or path-like

    Returns
    -------
    Mesh
        ``vertices`` (n, 3) float64, ``faces`` (m, 3) int64 (0-based), ``name``
        the file's base name.

    Raises
    ------
    MeshFileError
        For any problem with the file; the message starts with the file name.
    """
    p = os.fspath(path)
    name = os.path.basename(p) or p
    ext = _extension(name)
    if ext not in _READERS:
        raise _unsupported(name, ext, "read")
    fmt, reader = _READERS[ext]
    try:
        with open(p, "rb") as f:
            data = f.read()
    except FileNotFoundError:
        raise MeshFileError(f"{name}: file not found ({os.path.abspath(p)})") from None
    except IsADirectoryError:
        raise MeshFileError(f"{name}: is a folder, not a file") from None
    except PermissionError:
        raise MeshFileError(f"{name}: permission denied") from None
    except OSError as exc:
        raise MeshFileError(f"{name}: cannot read file ({exc.strerror or exc})") from None
    if not data.strip():
        raise MeshFileError(f"{name}: file is empty")
    try:
        # NaN/inf (even signalling NaN in binary files) are reported by _validate
        with np.errstate(all="ignore"):
            vertices, faces = reader(data)
            _validate(vertices, faces)
        mesh = Mesh(vertices, faces)
    except (_Bad, MeshError) as exc:
        raise MeshFileError(f"{name}: {exc}") from None
    except (ValueError, IndexError, TypeError, KeyError, OverflowError, struct.error,
            UnicodeError) as exc:
        raise MeshFileError(f"{name}: not a valid {fmt} file ({type(exc).__name__}: {exc})") \
            from exc
    mesh.name = name
    return mesh


# --------------------------------------------------------------------------- writing

_ROWS_PER_CHUNK = 1 << 16


def _format_rows(fmt: str, values: np.ndarray) -> str:
    """Apply a %-format for one row to every row of a 2-d array, in chunks."""
    out = []
    for start in range(0, len(values), _ROWS_PER_CHUNK):
        chunk = values[start: start + _ROWS_PER_CHUNK]
        out.append((fmt * len(chunk)) % tuple(chunk.ravel().tolist()))
    return "".join(out)


def _obj_bytes(mesh: Mesh) -> bytes:
    head = f"# {mesh.n_vertices} vertices, {mesh.n_faces} faces\n"
    text = (head + _format_rows("v %.17g %.17g %.17g\n", mesh.vertices)
            + _format_rows("f %d %d %d\n", mesh.faces + 1))
    return text.encode("ascii")


def _off_bytes(mesh: Mesh) -> bytes:
    head = f"OFF\n{mesh.n_vertices} {mesh.n_faces} 0\n"
    text = (head + _format_rows("%.17g %.17g %.17g\n", mesh.vertices)
            + _format_rows("3 %d %d %d\n", mesh.faces))
    return text.encode("ascii")


def _ply_bytes(mesh: Mesh) -> bytes:
    if mesh.n_vertices > np.iinfo(np.int32).max:
        raise MeshError("too many vertices for 32-bit PLY face indices")
    header = (
        "ply\nformat binary_little_endian 1.0\ncomment written by hybridedit\n"
        f"element vertex {mesh.n_vertices}\n"
        "property double x\nproperty double y\nproperty double z\n"
        f"element face {mesh.n_faces}\n"
        "property list uchar int vertex_indices\nend_header\n"
    )
    faces = np.empty(mesh.n_faces, dtype=[("n", "u1"), ("i", "<i4", (3,))])
    faces["n"] = 3
    faces["i"] = mesh.faces
    return header.encode("ascii") + mesh.vertices.astype("<f8").tobytes() + faces.tobytes()


def _stl_bytes(mesh: Mesh) -> bytes:
    corners = mesh.vertices[mesh.faces]  # (m, 3, 3)
    normal = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    rec = np.zeros(mesh.n_faces, dtype=_STL_RECORD)
    rec["normal"] = normal
    rec["corners"] = corners
    # the header must not start with "solid", or readers may take it for ASCII
    header = b"binary STL written by hybridedit".ljust(80, b" ")
    return header + np.uint32(mesh.n_faces).astype("<u4").tobytes() + rec.tobytes()


_WRITERS: dict[str, Callable[[Mesh], bytes]] = {
    ".obj": _obj_bytes,
    ".ply": _ply_bytes,
    ".stl": _stl_bytes,
    ".off": _off_bytes,
}


def write_mesh(path: str | os.PathLike[str], mesh: Mesh) -> None:
    """Write a triangle mesh atomically, choosing the format by extension.

    ``.obj`` and ``.off`` are ASCII with repr-exact ``%.17g`` coordinates,
    ``.ply`` is binary little-endian with double coordinates and ``.stl`` is
    binary (float32, per-face normals).  Vertex and face order are kept.

    Parameters
    ----------
    path : str or path-like
        Target file; an existing file is replaced only once the new one is
        completely written.
    mesh : Mesh
        ``vertices`` (n, 3) float64 and ``faces`` (m, 3) int64.

    Raises
    ------
    MeshFileError
        The extension is not supported (raised before touching the disk).
    hybridedit.atomic.WriteError
        The file could not be written; the message names the path and cause.
    """
    p = os.fspath(path)
    name = os.path.basename(p) or p
    ext = _extension(name)
    if ext not in _WRITERS:
        raise _unsupported(name, ext, "write")
    if not isinstance(mesh, Mesh):
        raise TypeError(f"write_mesh expects a Mesh, got {type(mesh).__name__}")
    try:
        payload = _WRITERS[ext](mesh)
    except MeshError as exc:
        raise MeshFileError(f"{name}: {exc}") from None
    with atomic_write(p, "wb") as f:
        f.write(payload)
