"""OBJ: every line that is not a position or a normal passes through unchanged.

No library round-trips OBJ exactly, so this reader/writer is ours. Reading keeps
the file's lines; writing gives them back in order with each moved vertex's
``v`` line rewritten with the file's own precision (its colour or ``w`` kept; see
:class:`~hybridedit.fileio.formats.common.TextPrecision`) and each ``vn`` that a moved
vertex touches recomputed from the deformed surface, grouped as the faces
reference it (a normal shared by all corners of a vertex stays smooth; corner
normals split at hard edges stay split; a ``vn`` an exporter shared between
vertices gets a new line where their normals now differ, and only then are
those faces' normal indices changed). Faces with their corner counts and
``v/vt/vn`` indices, ``vt``, ``mtllib``, ``usemtl``, ``o``, ``g``, ``s``,
comments and every other statement are kept byte for byte.
"""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..document import Document, Material, Texturing, moved_vertices
from ...core.normals import grouped_normals, vertex_normals
from .obj_materials import read_mtl
from .common import _ROWS_PER_CHUNK, TextPrecision, _Bad, _sample_rows, _shortest_rows, _mesh, fan_triangles, _format_rows, _numbers, _snippet, _token_count, _token_rows, _widths, _words
from .reporting import report, span
from .text_format import face_lines
from .text_scan import BLANK, COMMENT, CR, CRLF, F, LF, OTHER, V, VN, VT, face_corners, gather, line_spans, token_counts

_MARK = int(np.iinfo(np.int64).max)  # stands in for each line's "f" while parsing indices



# kinds of line (see :func:`~hybridedit.fileio.formats.text_scan.line_spans`)
_V, _VN, _F, _COMMENT, _BLANK, _OTHER, _VT = V, VN, F, COMMENT, BLANK, OTHER, VT


def _texts(data: bytes, lo: np.ndarray, hi: np.ndarray) -> list[bytes]:
    """``[data[a:b] for a, b in zip(lo, hi)]`` ((k,) int64 each)."""
    return [data[a:b] for a, b in zip(lo.tolist(), hi.tolist())]


def _obj_vertices(data: bytes, heads: np.ndarray, ends: np.ndarray,
                  line_at: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
    """x y z of every "v" line (``data[heads[i]:ends[i]]``, (n,) int64 each, at 0-based line
    numbers ``line_at``), (n, 3) float64, and the colours when every line has ``v x y z r g b``
    ((n, 3) float64, else None); a ``w`` column is ignored."""
    b = np.frombuffer(data, dtype=np.uint8)
    widths = token_counts(b, heads + 1, ends)
    if widths.size and widths.min() < 3:
        k = int(np.argmax(widths < 3))
        raise _Bad(f"line {line_at[k] + 1}: vertex has "
                   f"{int(widths[k])} coordinates, expected 3 ('{_snippet(data[heads[k]:ends[k]])}')")
    if not len(heads):
        return np.zeros((0, 3)), None
    if widths.min() == widths.max():
        w = int(widths[0])
        vals = _numbers(gather(b, heads + 1, ends), np.float64, w * len(heads))
        if vals is not None:
            table = vals.reshape(-1, w)
            colors = np.ascontiguousarray(table[:, 3:6]) if w == 6 else None
            return np.ascontiguousarray(table[:, :3]), colors
    return _vertices_slowly(_texts(data, heads, ends), line_at), None


def _vertices_slowly(vlines: list[bytes], line_at: np.ndarray) -> np.ndarray:
    """x y z of the "v" lines ``vlines`` (at 0-based line numbers ``line_at``) in Python, (n, 3)
    float64; raises _Bad naming the first line that is not numbers."""
    rows = [line.split()[1:4] for line in vlines]
    return _token_rows(rows, np.float64, vlines, line_at, "vertex coordinates").reshape(-1, 3)


def _obj_faces(data: bytes, heads: np.ndarray, ends: np.ndarray, line_at: np.ndarray,
               want_normals: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Corner counts (p,) int64, vertex indices as written (sum of counts,) int64 and, when
    ``want_normals`` and every corner is in the common form, normal indices as written (0 for
    none; else None: :func:`_corner_normal_refs` reads them) of the "f" lines
    ``data[heads[i]:ends[i]]`` (at 0-based line numbers ``line_at``): compiled
    (:func:`~hybridedit.fileio.formats.text_scan.face_corners`), or :func:`_obj_corners` for a
    file it does not read."""
    got = face_corners(np.frombuffer(data, dtype=np.uint8), heads + 1, ends, want_normals)
    if isinstance(got, int):
        counts, idx = _obj_corners(_texts(data, heads, ends), line_at)
        return counts, idx, None
    return got


def _obj_corners(flines: list[bytes], line_at: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Corner count of each "f" line (``flines``, at 0-based line numbers ``line_at``), (p,) int64,
    and its vertex indices as written (1-based or negative), (sum of counts,) int64; "/t/n" parts
    are dropped."""
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
    return counts, _token_rows(rows, np.int64, flines, line_at, "face indices")



def _resolve(idx: np.ndarray, counts: np.ndarray, before: np.ndarray, f_rows: np.ndarray,
             what: str) -> np.ndarray:
    """1-based absolute indices from OBJ's 1-based or negative (relative) ones.

    ``before`` is, for each face line (at 0-based line numbers ``f_rows``), how many ``what``
    records precede it.
    """
    face_of = np.repeat(np.arange(len(counts)), counts)
    if (idx == 0).any():
        k = int(face_of[int(np.argmax(idx == 0))])
        raise _Bad(f"line {f_rows[k] + 1}: face index 0 is "
                   "invalid (OBJ indices start at 1)")
    base = np.repeat(np.asarray(before, dtype=np.int64), counts)
    neg = idx < 0
    resolved = np.where(neg, base + idx + 1, idx)
    wrong = neg & (resolved < 1)
    if wrong.any():
        at = int(np.argmax(wrong))
        k = int(face_of[at])
        raise _Bad(f"line {f_rows[k] + 1}: face index "
                   f"{int(idx[at])} out of range (only {_words(int(base[at]), what)} "
                   "defined before this line)")
    return resolved


def _defined_before(kinds: np.ndarray, kind: int, f_rows: np.ndarray) -> np.ndarray:
    """For each face line (at ``f_rows``), how many lines of ``kind`` come before it, (p,) int64."""
    return np.cumsum(kinds == kind)[f_rows]


def _corner_normal_refs(flines: list[bytes], n_corners: int) -> np.ndarray:
    """The ``vn`` index as written (1-based or negative; 0 for none) of every corner of the
    face lines ``flines``."""
    refs: list[int] = []
    for line in flines:
        for tok in line.split()[1:]:
            parts = tok.split(b"/")
            refs.append(int(parts[2]) if len(parts) > 2 and parts[2] else 0)
    out = np.asarray(refs, dtype=np.int64)
    if len(out) != n_corners:  # cannot happen after _obj_corners succeeded
        raise _Bad("cannot read the face normal indices")
    return out


_EXTRA_NAMES = {
    b"vt": "texture coordinates", b"mtllib": "material libraries", b"usemtl": "material references",
    b"o": "object names", b"g": "group names", b"s": "smoothing groups",
    b"l": "line elements", b"p": "point elements",
}


class FileLines:
    """A text's lines without their line ends (``bytes.splitlines`` of it), kept as the text and
    each line's span: a ``bytes`` object is made only for a line asked for.

    Parameters
    ----------
    text : bytes
    starts, ends : (k,) int64 arrays
        Line ``i`` is ``text[starts[i]:ends[i]]``.
    newline : bytes
        The line end the text is written back with.
    uniform : bool
        Whether every line of ``text`` that has a line end has ``newline`` (then the text between
        two lines is kept as it is in :meth:`joined`).
    """

    def __init__(self, text: bytes, starts: np.ndarray, ends: np.ndarray, newline: bytes, uniform: bool):
        self.text, self.starts, self.ends = text, starts, ends
        self.newline, self.uniform = newline, uniform

    def __len__(self) -> int:
        return len(self.starts)

    def __getitem__(self, i: int) -> bytes:
        return self.text[self.starts[i]:self.ends[i]]

    def __iter__(self):
        return iter(self.text.splitlines())

    def pick(self, rows: np.ndarray) -> list[bytes]:
        """Lines ``rows`` ((r,) int), in that order."""
        return _texts(self.text, self.starts[rows], self.ends[rows])

    def joined(self, rows: np.ndarray, new: list[bytes], added_at: int, added: list[bytes],
               final_newline: bool) -> bytes:
        """The text of the lines with lines ``rows`` ((r,) int64, ascending) replaced by ``new``
        (r texts) and the lines ``added`` inserted before line ``added_at`` (>= 1), joined by
        :attr:`newline` (one more at the end when ``final_newline``): the text between replaced
        lines is kept as it is, unless its line ends are not all :attr:`newline` (then it is made
        of every line, as they all change)."""
        if not self.uniform:
            out = self.text.splitlines()
            for i, line in zip(rows.tolist(), new):
                out[i] = line
            out[added_at:added_at] = added
            text = self.newline.join(out)
            return text + self.newline if final_newline else text
        if added:  # they follow line added_at - 1, in its text
            tail = self.newline + self.newline.join(added)
            j = int(np.searchsorted(rows, added_at - 1))
            if j < len(rows) and rows[j] == added_at - 1:
                new = new[:j] + [new[j] + tail] + new[j + 1:]
            else:
                rows = np.insert(rows, j, added_at - 1)
                new = new[:j] + [self[added_at - 1] + tail] + new[j:]
        gaps = [self.text[a:b] for a, b in zip(np.r_[0, self.ends[rows]].tolist(),
                                               np.r_[self.starts[rows], len(self.text)].tolist())]
        pieces: list[bytes] = [b""] * (2 * len(rows) + 1)
        pieces[0::2] = gaps  # (the last one with the final line end, if the text has one)
        pieces[1::2] = new
        return b"".join(pieces)


@dataclass(eq=False)
class ObjNative:
    """What :func:`write` needs to give an OBJ file back (see the module docstring)."""

    lines: FileLines  # the file's lines without line ends (continuations joined)
    kinds: np.ndarray  # (k,) int8 kind of each line (_V, _VN, ...; from its stripped text)
    newline: bytes
    final_newline: bool
    v_lines: np.ndarray  # (n,) line of each vertex
    vn_lines: np.ndarray  # (k,) line of each normal
    rest: np.ndarray  # (n, 3) positions as read
    corner_vn: np.ndarray | None  # (sum of counts,) 0-based normal of each face corner, -1 none
    counts: np.ndarray  # (p,) corners of each face
    f_lines: np.ndarray  # (p,) line of each face
    vn_relative: bool  # some face refers to its normals by negative (relative) indices

    def statements(self) -> tuple[np.ndarray, list[bytes]]:
        """The lines that are no ``v``, ``vn``, ``f``, comment or blank line (``vt``, ``usemtl``,
        ``mtllib``, ...): their 0-based line numbers (r,) int64 and texts as in the file."""
        rows = np.flatnonzero((self.kinds == _OTHER) | (self.kinds == _VT))
        return rows, self.lines.pick(rows)


def _uniform(endings: np.ndarray, newline: bytes) -> bool:
    """Whether every line end counted in ``endings`` ((3,) int64: LF, CR, CRLF) is ``newline``."""
    kind = {b"\n": LF, b"\r": CR, b"\r\n": CRLF}[newline]
    return int(endings.sum()) == int(endings[kind])


def _extras(data: bytes, heads: np.ndarray, ends: np.ndarray, kinds: np.ndarray) -> dict[str, int]:
    """How many lines of each statement other than v, vn and f the file has, by name
    (:data:`_EXTRA_NAMES`), in the order of their first line (``vt`` lines counted without
    reading them)."""
    other = np.flatnonzero(kinds == _OTHER)
    first: dict[bytes, int] = {}
    counter: Counter = Counter()
    for i, line in zip(other.tolist(), _texts(data, heads[other], ends[other])):
        if line.strip():
            head = line.split(None, 1)[0]
            counter[head] += 1
            first.setdefault(head, i)
    vt = np.flatnonzero(kinds == _VT)
    if vt.size:
        counter[b"vt"] += int(vt.size)
        first[b"vt"] = min(first.get(b"vt", len(kinds)), int(vt[0]))
    extras: dict[str, int] = {}
    for head in sorted(counter, key=first.__getitem__):
        name = _EXTRA_NAMES.get(head, "other statements")
        extras[name] = extras.get(name, 0) + counter[head]
    return extras


def read(data: bytes, path: str | None = None) -> Document:
    """Parse an OBJ file into a :class:`Document` (raises _Bad for a bad file); its texture
    coordinates and materials are read only when asked for (:meth:`Document.textures`)."""
    if b"\0" in data:
        raise _Bad("not a text OBJ file (it contains binary data)")
    if b"\\" in data:  # line continuations
        data = re.sub(rb"\\[ \t]*(\r\n|\n|\r)", b" ", data)
    b = np.frombuffer(data, dtype=np.uint8)
    starts, ends, heads, kinds, endings, _ = line_spans(b)  # (heads: after an indentation)
    v_lines = np.flatnonzero(kinds == _V)
    vn_lines = np.flatnonzero(kinds == _VN)
    f_lines = np.flatnonzero(kinds == _F)
    # progress between the passes, by their shares of the time (a 2.7M-vertex file: the line scan,
    # the numbers of the v lines, the faces)
    report(0.3)
    vertices, colors = _obj_vertices(data, heads[v_lines], ends[v_lines], v_lines)
    report(0.85)
    nv = len(vertices)
    counts, idx, refs = _obj_faces(data, heads[f_lines], ends[f_lines], f_lines, bool(len(vn_lines)))
    report(0.95)
    if counts.size and counts.min() < 3:
        k = int(np.argmax(counts < 3))
        raise _Bad(f"line {f_lines[k] + 1}: face has "
                   f"{_words(int(counts[k]), 'vertex')}, need at least 3")
    if idx.size and idx.min() <= 0:
        idx = _resolve(idx, counts, _defined_before(kinds, _V, f_lines), f_lines, "vertex")
    if idx.size and idx.max() > nv:
        at = int(np.argmax(idx > nv))
        k = int(np.repeat(np.arange(len(counts)), counts)[at])
        raise _Bad(f"line {f_lines[k] + 1}: face index {int(idx[at])} "
                   f"out of range (file has {_words(nv, 'vertex')})")
    flat = idx - 1
    del idx

    corner_vn = None
    vn_relative = False
    if len(vn_lines):
        if refs is None:
            refs = _corner_normal_refs(_texts(data, heads[f_lines], ends[f_lines]), len(flat))
        vn_relative = bool(refs.min() < 0)
        if vn_relative:
            rel = refs < 0
            resolved = _resolve(np.where(rel, refs, 1), counts,
                                _defined_before(kinds, _VN, f_lines), f_lines, "normal")
            refs = np.where(rel, resolved, refs)
        if refs.max() > len(vn_lines):
            raise _Bad(f"a face refers to normal {int(refs.max())} but the file has "
                       f"{len(vn_lines)}")
        corner_vn = refs - 1  # -1: no normal
    extras = _extras(data, heads, ends, kinds)
    del heads
    newline = b"\r\n" if b"\r\n" in data[:65536] else (b"\r" if b"\r" in data[:65536] and
                                                        b"\n" not in data[:65536] else b"\n")
    lines = FileLines(data, starts, ends, newline, _uniform(endings, newline))
    native = ObjNative(lines=lines, kinds=kinds, newline=newline, final_newline=data[-1:] in (b"\n", b"\r"),
                       v_lines=v_lines, vn_lines=vn_lines, rest=vertices, corner_vn=corner_vn,
                       counts=counts, f_lines=f_lines, vn_relative=vn_relative)
    rgba = None
    if colors is not None:
        rgba = np.column_stack([colors, np.ones(nv)])
    mesh = _mesh(vertices, fan_triangles(counts, flat))
    polygons = None if (counts.size and np.all(counts == 3)) else (counts, flat)
    texturing = None
    if "texture coordinates" in extras or "material references" in extras:
        folder = Path(path).parent if path else None
        texturing = lambda: read_texturing(native, folder)  # noqa: E731 -- read on demand
    return Document(mesh=mesh, format="obj", native=native, polygons=polygons, colors=rgba,
                    normals=bool(len(vn_lines)), extras=extras, texturing=texturing)


def read_texturing(nat: ObjNative, folder: Path | None) -> Texturing | None:
    """The ``vt`` coordinates of every face corner, and each face's material (``usemtl``, with
    ``Kd``, ``d`` and the ``map_Kd`` image of the ``mtllib`` libraries found in ``folder``)."""
    heads = [(i, line.lstrip()) for i, line in zip(*map(list, nat.statements()))
             if line.lstrip()[:2] in (b"vt", b"us", b"mt")]
    vt = [(i, w) for i, w in ((i, line.split()) for i, line in heads) if w and w[0] == b"vt"]
    use = [(i, w) for i, w in ((i, line.split()) for i, line in heads) if w and w[0] == b"usemtl"]
    libs = [w for _, line in heads for w in [line.split()] if w and w[0] == b"mtllib"]
    uv = corner_uv = None
    if vt:
        uv = np.array([[float(x) for x in (w[1:3] + [b"0"])[:2]] for _, w in vt])
        refs = []
        for line in nat.lines.pick(nat.f_lines):
            for tok in line.split()[1:]:
                parts = tok.split(b"/")
                refs.append(int(parts[1]) if len(parts) > 1 and parts[1] else 0)
        corner = np.asarray(refs, dtype=np.int64)
        if corner.size and corner.min() < 0:
            before = np.searchsorted(np.array([i for i, _ in vt]), nat.f_lines)
            corner = np.where(corner < 0, np.repeat(before, nat.counts) + corner + 1, corner)
        corner_uv = np.where((corner >= 1) & (corner <= len(uv)), corner - 1, -1)
    library = {}
    for words in libs:
        for name in words[1:]:
            library.update(read_mtl(folder / name.decode("utf-8", "replace")) if folder is not None else {})
    materials: list[Material] = []
    face_material = None
    if use:
        names = [(b" ".join(w[1:])).decode("utf-8", "replace") for _, w in use]
        order = list(dict.fromkeys(names))
        materials = [library.get(name) or Material(name) for name in order]
        which = np.array([order.index(name) for name in names] + [-1])
        at = np.searchsorted(np.array([i for i, _ in use]), nat.f_lines) - 1
        face_material = which[at]  # -1 (the last entry) before the first usemtl
    if uv is None and not materials:
        return None
    return Texturing(uv=uv, corner_uv=corner_uv, materials=materials, face_material=face_material)


def _normal_line(n: np.ndarray) -> bytes:
    return b"vn %.7g %.7g %.7g" % tuple(n.tolist())


def write(doc: Document) -> bytes:
    """The OBJ text of ``doc``: its own lines with new positions, or a plain OBJ."""
    nat = doc.native
    if not isinstance(nat, ObjNative):
        return _plain(doc)  # a bare mesh (write_converted for a document from another format)
    V = doc.mesh.vertices
    moved = moved_vertices(nat.rest, V)
    out = _Edited(nat.lines)
    rows = np.flatnonzero(moved)
    # progress: the moved vertices' lines, their normals, then joining the text (shares at 2.7M)
    with span(0.0, 0.6):
        style = precision(nat) if len(rows) else None
        texts: list[bytes] = []
        for start in range(0, len(rows), _ROWS_PER_CHUNK):
            chunk = rows[start:start + _ROWS_PER_CHUNK]
            xyz = V[chunk].ravel().tolist()  # (flat: a list per row made the collector run)
            for line, x, y, z in zip(nat.lines.pick(nat.v_lines[chunk]), xyz[0::3], xyz[1::3], xyz[2::3]):
                texts.append(b" ".join([b"v", style.text(x), style.text(y), style.text(z), *line.split()[4:]]))
            report((start + _ROWS_PER_CHUNK) / len(rows))
        out.replace(nat.v_lines[rows], texts)
    if nat.corner_vn is not None and moved.any():
        _write_normals(doc, nat, V, moved, out)
    report(0.7)
    text = out.joined(nat.final_newline)
    report(1.0)
    return text


class _Edited:
    """The file's lines with some replaced, for :func:`write`: many at once (:meth:`replace`, the
    moved vertices'), others one by one (``out[i] = line``), and new ones inserted
    (:meth:`insert`); reading line ``i`` gives its new text, if it has one."""

    def __init__(self, lines: FileLines):
        self.lines = lines
        self.rows, self.texts = np.zeros(0, dtype=np.int64), []
        self.new: dict[int, bytes] = {}
        self.added_at, self.added = 1, []

    def __len__(self) -> int:
        return len(self.lines)

    def replace(self, rows: np.ndarray, texts: list[bytes]) -> None:
        """Lines ``rows`` ((r,) int64, ascending) become ``texts`` (r texts); before any
        ``out[i] = line``."""
        self.rows, self.texts = rows, texts

    def __getitem__(self, i: int) -> bytes:
        i = int(i)
        if i in self.new:
            return self.new[i]
        j = int(np.searchsorted(self.rows, i))
        if j < len(self.rows) and self.rows[j] == i:
            return self.texts[j]
        return self.lines[i]

    def __setitem__(self, i: int, line: bytes) -> None:
        self.new[int(i)] = line

    def insert(self, at: int, lines: list[bytes]) -> None:
        """Put ``lines`` before line ``at`` (>= 1)."""
        self.added_at, self.added = at, lines

    def joined(self, final_newline: bool) -> bytes:
        """The text of the file (see :meth:`FileLines.joined`)."""
        rows, texts = self.rows, self.texts
        if self.new:  # merged into the lines replaced at once, in order
            keys = np.array(sorted(self.new), dtype=np.int64)
            at = np.searchsorted(rows, keys)
            hit = np.zeros(len(keys), dtype=bool)
            if len(rows):
                hit = rows[np.minimum(at, len(rows) - 1)] == keys
            texts = list(texts)
            for k, j in zip(keys[hit].tolist(), at[hit].tolist()):
                texts[j] = self.new[k]
            miss = keys[~hit]
            if miss.size:
                every = np.concatenate([rows, miss])
                order = np.argsort(every, kind="stable")
                texts = texts + [self.new[k] for k in miss.tolist()]
                rows, texts = every[order], [texts[j] for j in order.tolist()]
        return self.lines.joined(rows, texts, self.added_at, self.added, final_newline)


def precision(nat: ObjNative) -> TextPrecision:
    """How the file writes its ``v`` coordinates (from up to 2,000 of its lines spread over it)."""
    lines = nat.lines.pick(nat.v_lines[_sample_rows(len(nat.v_lines))])
    return TextPrecision.of([t for line in lines for t in line.split()[1:4]])


#: A recomputed normal closer than this (radians) to its line's keeps the line.
_SAME_NORMAL = 1e-6


def _write_normals(doc: Document, nat: ObjNative, V: np.ndarray, moved: np.ndarray, out: _Edited) -> None:
    """Recompute, in ``out``, the ``vn`` lines that moved vertices touch.

    A normal is recomputed over the corners that share its ``vn`` index at one
    vertex. Files that share one ``vn`` between vertices (exporters write each
    distinct normal once: every corner of a flat side shares one) get, where
    those vertices' normals no longer agree, a new ``vn`` line for each further
    normal (after the last ``vn`` line, or at the end of a file that refers to
    normals by relative indices) and those corners are pointed at it.
    """
    counts, flat = doc.polygon_lists()
    n = max(len(V), 1)
    has = nat.corner_vn >= 0
    key = np.where(has, nat.corner_vn * n + flat, -1)  # (normal, vertex) of each polygon corner
    pairs, corner_pair = np.unique(key[has], return_inverse=True)
    group = np.full(len(key), -1, dtype=np.int64)
    group[has] = corner_pair
    tri = doc.mesh.faces
    tri_group = fan_triangles(counts, group)
    normals, valid = grouped_normals(V, tri, tri_group, len(pairs))
    touched_tri = moved[tri].any(axis=1)
    touched = np.zeros(len(pairs), dtype=bool)
    g = tri_group[touched_tri].ravel()
    touched[g[g >= 0]] = True
    vn_of = pairs // n
    added: list[bytes] = []
    repoint = np.full(len(pairs), -1, dtype=np.int64)  # new 0-based vn index of a pair, -1: its own
    shared = np.bincount(vn_of, minlength=len(nat.vn_lines))[vn_of] > 1
    for p in np.flatnonzero(~shared & touched & valid).tolist():  # the usual case: a vn at one vertex
        out[nat.vn_lines[vn_of[p]]] = _normal_line(normals[p])
    many = np.flatnonzero(shared)
    many = many[np.argsort(vn_of[many], kind="stable")]
    starts = np.flatnonzero(np.r_[True, vn_of[many][1:] != vn_of[many][:-1]]) if many.size else []
    for members in (np.split(many, starts[1:]) if many.size else []):
        if not touched[members].any():
            continue
        k = int(vn_of[members[0]])
        moving = members[touched[members] & valid[members]]
        if moving.size == 0:
            continue
        if moving.size == members.size:  # all recomputed: the line takes the first one's
            line_normal = normals[moving[0]]
            out[nat.vn_lines[k]] = _normal_line(line_normal)
        else:  # corners elsewhere keep the line as it is
            line_normal = _parse_normal(out[nat.vn_lines[k]])
        keep = normals[moving] @ line_normal >= np.cos(_SAME_NORMAL)  # the line's own normal
        made: dict[tuple, int] = {}  # this vn's further normals (rounded far below the text's digits)
        for p, key in zip(moving[~keep].tolist(), map(tuple, np.round(normals[moving[~keep]], 9).tolist())):
            if key not in made:
                made[key] = len(nat.vn_lines) + len(added)
                added.append(_normal_line(normals[p]))
            repoint[p] = made[key]
    if not added:
        return
    corners = np.flatnonzero(has)[repoint[corner_pair] >= 0]
    new_index = repoint[group[corners]]
    face_of = np.repeat(np.arange(len(counts)), counts)[corners]  # corners are in face order
    position = corners - (np.cumsum(counts) - counts)[face_of]  # of the corner in its face
    cuts = np.flatnonzero(np.diff(face_of)) + 1
    for f, at, j in zip(face_of[np.r_[0, cuts]].tolist(), np.split(position, cuts), np.split(new_index, cuts)):
        li = int(nat.f_lines[f])
        line = out[li]
        lead = line[: len(line) - len(line.lstrip())]
        words = line.split()
        for c, k in zip(at.tolist(), j.tolist()):
            parts = words[1 + c].split(b"/")
            parts[2] = b"%d" % (k + 1)
            words[1 + c] = b"/".join(parts)
        out[li] = lead + b" ".join(words)
    at = len(out) if nat.vn_relative else int(nat.vn_lines[-1]) + 1
    out.insert(at, added)


def _parse_normal(line: bytes) -> np.ndarray:
    n = np.array([float(x) for x in line.split()[1:4]])
    length = np.linalg.norm(n)
    return n / length if length > 0 else n


def write_converted(doc: Document, target: Path) -> bytes:
    """A plain OBJ of a document read in another format (see :func:`_plain`); its material
    library is ``target``'s name with ``.mtl`` (:func:`~hybridedit.fileio.formats.obj_materials.converted_companions`)."""
    return _plain(doc, target.stem + ".mtl")


def _plain(doc: Document, mtl_name: str = "") -> bytes:
    """A plain OBJ of ``doc``: v (with colours) in their shortest exact form, vt and usemtl when it
    has texture coordinates and materials, vn per vertex if it had normals, polygons."""
    mesh = doc.mesh
    counts, flat = doc.polygon_lists()
    tex = doc.textures()
    has_uv = tex is not None and tex.uv is not None and tex.corner_uv is not None
    has_mtl = tex is not None and bool(tex.materials) and bool(mtl_name)
    parts = [f"# {mesh.n_vertices} vertices, {len(counts)} faces\n"]
    if has_mtl:
        parts.append(f"mtllib {mtl_name}\n")
    # progress: the rows' shares of the text (a vertex line is about as long as a face line)
    nv, nf = mesh.n_vertices, len(counts)
    rows_total = max(nv * (2 if doc.normals else 1) + nf, 1)
    v_end = nv / rows_total
    vn_end = v_end + (nv / rows_total if doc.normals else 0.0)
    with span(0.0, v_end):
        if doc.colors is not None:
            parts += _shortest_rows("v", mesh.vertices, tail=doc.colors[:, :3])
        else:
            parts += _shortest_rows("v", mesh.vertices)
    if has_uv:
        parts += _shortest_rows("vt", tex.uv)
    if doc.normals:
        with span(v_end, vn_end):
            parts.append(_format_rows("vn %.7g %.7g %.7g\n", vertex_normals(mesh.vertices, mesh.faces)))
    one = flat + 1
    columns = [one]
    if has_uv:
        columns.append(np.where(tex.corner_uv >= 0, tex.corner_uv + 1, 0))
    if doc.normals:
        columns.append(one)
    table = one[:, None] if len(columns) == 1 else np.stack(columns, axis=1)  # (corners, 1..3)
    material = tex.face_material if has_mtl and tex.face_material is not None else np.full(nf, -1)
    cuts = np.flatnonzero(np.diff(material)) + 1
    starts = np.append(np.cumsum(counts) - counts, len(table))
    text = [part.encode("utf-8") if isinstance(part, str) else part for part in parts]
    with span(vn_end, 1.0):
        for lo, hi in zip(np.r_[0, cuts].tolist(), np.r_[cuts, nf].tolist()):
            if hi > lo and material[lo] >= 0:
                text.append(f"usemtl {tex.materials[material[lo]].name}\n".encode("utf-8"))
            for a in range(lo, hi, _ROWS_PER_CHUNK):  # compiled, a chunk at a time (for the progress)
                b = min(a + _ROWS_PER_CHUNK, hi)
                text.append(face_lines(counts[a:b], table[starts[a]:starts[b]], doc.normals and not has_uv))
                report(b / nf)
    return b"".join(text)
