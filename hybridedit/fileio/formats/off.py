"""OFF (with its C, N and ST variants): vertex lines rewritten, everything else kept.

Reading keeps the file's lines. Writing rewrites the line of each vertex that
moved, with the file's own precision (see :class:`~hybridedit.fileio.formats.common.TextPrecision`) (and, in NOFF files, recomputes the normal of every vertex a moved vertex
touches); colours, texture coordinates, face lines with their colours, comments
and blank lines are kept as they are.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

import numpy as np

from ..document import Document, moved_vertices
from ...core.normals import grouped_normals, vertex_normals
from .common import _ROWS_PER_CHUNK, TextPrecision, _Bad, _sample_rows, _mesh, fan_triangles, _float_chunks, _format_rows, _numbers, _snippet, _token_rows, _truncated, _widths, _words
from .reporting import report
from .text_format import counted_lines

__all__ = ["OffNative", "read", "write"]

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
    return _token_rows(rows, np.float64, vlines, numbers, "vertex coordinates").reshape(-1, 3)


def _off_faces(flines: list[bytes], numbers: list[int]) -> tuple[np.ndarray, np.ndarray]:
    """Corner counts (p,) and indices (sum,) of the faces; colour values after them are ignored."""
    widths = _widths(flines)
    if flines and widths.min() == widths.max():
        w = int(widths[0])
        vals = _numbers(b"\n".join(flines), np.int64, w * len(flines))
        if vals is not None:
            table = vals.reshape(-1, w)
            c = int(table[0, 0])
            if c >= 3 and w >= 1 + c and np.all(table[:, 0] == c):
                return table[:, 0].copy(), table[:, 1: 1 + c].reshape(-1)
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
    return np.asarray(sizes, dtype=np.int64), np.asarray(flat, dtype=np.int64)


def read(data: bytes) -> Document:
    """Read an OFF file into a :class:`Document` (raises _Bad for a bad file)."""
    if b"\0" in data:
        raise _Bad("not a text OFF file (it contains binary data)")
    original = lines = data.splitlines()
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
    v_lines = np.asarray(numbers[at: at + nv], dtype=np.int64)
    at += nv
    flines = body[at: at + nf]
    if len(flines) < nf:
        raise _truncated(nf, "face", len(flines))
    if len(body) > at + nf:
        extra = len(body) - at - nf
        raise _Bad(f"{extra} unexpected line{'s' if extra != 1 else ''} after the last face "
                   f"(line {numbers[at + nf] + 1}; the header's counts may be wrong)")
    counts, flat = _off_faces(flines, numbers[at: at + nf])
    kind = first[0].upper().decode("ascii", "replace") if header else ""
    return _document(original, data, kind, vertices, v_lines, vlines, flines, counts, flat)


@dataclass(eq=False)
class OffNative:
    """The file's lines and where its vertices are."""

    lines: list[bytes]
    newline: bytes
    final_newline: bool
    v_lines: np.ndarray  # (n,) line of each vertex
    normal_columns: bool  # NOFF: x y z nx ny nz ...
    rest: np.ndarray  # (n, 3)


def _document(original: list[bytes], data: bytes, kind: str, vertices: np.ndarray,
              v_lines: np.ndarray, vlines: list[bytes], flines: list[bytes],
              counts: np.ndarray, flat: np.ndarray) -> Document:
    has_n, has_c, has_st = "N" in kind[:-3], "C" in kind[:-3], kind.startswith("ST")
    colors = None
    extras: dict[str, int] = {}
    widths = _widths(vlines)
    if has_c and len(vlines) and widths.min() == widths.max():
        start = 6 if has_n else 3
        k = int(widths[0]) - start - (2 if has_st else 0)
        if k in (3, 4):
            table = np.array([line.split()[start: start + k] for line in vlines], dtype=np.float64)
            if table.max(initial=0.0) > 1.0:
                table /= 255.0
            colors = table if k == 4 else np.column_stack([table, np.ones(len(table))])
    if has_st:
        extras["texture coordinates"] = len(vlines)
    fwidths = _widths(flines)
    if len(flines) and np.any(fwidths > counts + 1):
        extras["face colours"] = int(np.count_nonzero(fwidths > counts + 1))
    newline = b"\r\n" if b"\r\n" in data[:65536] else b"\n"
    native = OffNative(lines=original, newline=newline, final_newline=data[-1:] in (b"\n", b"\r"),
                       v_lines=v_lines, normal_columns=has_n, rest=vertices)
    polygons = None if (counts.size and np.all(counts == 3)) else (counts, flat)
    return Document(mesh=_mesh(vertices, fan_triangles(counts, flat)), format="off", native=native,
                    polygons=polygons, colors=colors, normals=has_n, extras=extras)


def write(doc: Document) -> bytes:
    """The OFF text of ``doc``: its own lines with new positions, or a plain (C)(N)OFF."""
    nat = doc.native
    if not isinstance(nat, OffNative):
        return _plain(doc)
    V = doc.mesh.vertices
    moved = moved_vertices(nat.rest, V)
    rewrite = moved.copy()
    normals = None
    if nat.normal_columns and moved.any():
        tri = doc.mesh.faces
        rewrite[tri[moved[tri].any(axis=1)].ravel()] = True
        normals, valid = grouped_normals(V, tri, tri, len(V))
    out = list(nat.lines)
    style = precision(nat)
    for i in np.flatnonzero(rewrite).tolist():
        li = nat.v_lines[i]
        text, hash_, comment = out[li].partition(b"#")
        words = text.split()
        if moved[i]:
            words[:3] = [style.text(x) for x in V[i].tolist()]
        if normals is not None and valid[i]:
            words[3:6] = [b"%.7g" % x for x in normals[i].tolist()]
        out[li] = b" ".join(words) + ((b" " + hash_ + comment) if hash_ else b"")
    text = nat.newline.join(out)
    return text + nat.newline if nat.final_newline else text


def precision(nat: OffNative) -> TextPrecision:
    """How the file writes its vertex coordinates (from up to 2,000 of its vertex lines)."""
    lines = [nat.lines[i].partition(b"#")[0] for i in nat.v_lines[_sample_rows(len(nat.v_lines))].tolist()]
    return TextPrecision.of([t for line in lines for t in line.split()[:3]])


def _plain(doc: Document) -> bytes:
    """OFF, with N when ``doc`` had normals and C when it has colours; polygons kept."""
    mesh = doc.mesh
    counts, flat = doc.polygon_lists()
    starts = np.append(np.cumsum(counts) - counts, len(flat))
    columns, fmt = [mesh.vertices], "%r %r %r"  # shortest exact
    kind = "OFF"
    if doc.colors is not None:
        kind = "C" + kind
    if doc.normals:
        kind = kind[:-3] + "N" + "OFF" if kind != "OFF" else "NOFF"
        columns.append(vertex_normals(mesh.vertices, mesh.faces))
        fmt += " %.7g %.7g %.7g"
    if doc.colors is not None:
        columns.append(doc.colors)
        fmt += " %.6g %.6g %.6g %.6g"
    parts: list = [f"{kind}\n{mesh.n_vertices} {len(counts)} 0\n".encode("ascii")]
    if len(columns) == 1:  # positions alone: compiled
        parts += _float_chunks(b"", mesh.vertices)
    else:
        parts.append(_format_rows(fmt + "\n", np.column_stack(columns)).encode("ascii"))
    for start in range(0, len(counts), _ROWS_PER_CHUNK):  # compiled, a chunk at a time (for the progress)
        stop = min(start + _ROWS_PER_CHUNK, len(counts))
        parts.append(counted_lines(counts[start:stop], flat[starts[start]:starts[stop]]))
        report(stop / len(counts))
    return b"".join(parts)
