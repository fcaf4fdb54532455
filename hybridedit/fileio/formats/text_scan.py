"""Compiled scans of a text mesh file's bytes (an OBJ's): its lines' spans and kinds, the tokens
of some of them, a join of their texts and their face indices, each in one pass over the bytes
instead of a Python ``bytes`` object per line (an 11M-vertex OBJ has 33M lines).

Every function reads a (b,) uint8 array of the file (``np.frombuffer`` of its bytes) and gives
what the equivalent Python on ``bytes.splitlines()`` gives; where a line does not fit the
common form (:func:`face_corners`), it says so and the caller takes its slower Python path,
which can name the line that is wrong.

Examples
--------
>>> b = np.frombuffer(b"v 1 2 3\\r\\n  f 1 2 3\\nx", dtype=np.uint8)
>>> starts, ends, heads, kinds, endings, indented = line_spans(b)
>>> starts.tolist(), ends.tolist(), heads.tolist(), endings.tolist(), indented
([0, 9, 19], [7, 18, 20], [0, 11, 19], [1, 0, 1], True)
>>> [int(k) for k in kinds] == [V, F, OTHER]
True
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["line_spans", "token_counts", "gather", "face_corners"]

#: line ends counted by :func:`line_spans`: ``\\n``, ``\\r`` and ``\\r\\n``
LF, CR, CRLF = range(3)

#: kinds of line (:func:`line_spans`): ``v``, ``vn``, ``f``, comment, blank, any other statement,
#: ``vt`` (a line whose first word is ``vt``)
V, VN, F, COMMENT, BLANK, OTHER, VT = range(7)


@njit(cache=True)
def _is_space(c):  # pragma: no cover - compiled
    """Whitespace inside a line as ``bytes.split`` sees it (space, \\t, \\v, \\f; \\n and \\r too)."""
    return c == 32 or (c >= 9 and c <= 13)


@njit(cache=True)
def _kind(b, p, end):  # pragma: no cover - compiled
    """The kind of the line ``b[p:end]`` from its first three bytes (0 past its end)."""
    c0 = b[p] if p < end else 0
    c1 = b[p + 1] if p + 1 < end else 0
    c2 = b[p + 2] if p + 2 < end else 0
    ws1 = c1 == 32 or c1 == 9
    ws2 = c2 == 32 or c2 == 9
    if c0 == 0:
        return BLANK  # an empty line (a NUL byte is refused before)
    if c0 == 35:  # "#"
        return COMMENT
    if c0 == 102 and ws1:  # "f"
        return F
    if c0 == 118:  # "v"
        if ws1:
            return V
        if c1 == 110 and ws2:  # "vn"
            return VN
        if c1 == 116 and (ws2 or c2 == 0 or c2 == 11 or c2 == 12):  # "vt" and the word's end
            return VT
    return OTHER


@njit(cache=True)
def _spans(b, i, k, starts, ends, heads, kinds, state):  # pragma: no cover - compiled
    """Lines from byte ``i`` on into rows ``k`` on of the arrays, until they are full; returns
    (the next byte, the next row). ``state``: (3,) endings, then indented, then lines led by
    whitespace."""
    n = b.shape[0]
    room = starts.shape[0]
    while i < n and k < room:
        starts[k] = i
        j = i
        while j < n and (b[j] == 32 or b[j] == 9 or b[j] == 11 or b[j] == 12):
            j += 1
        heads[k] = j
        if j > i:
            state[4] += 1
            if b[i] == 32 or b[i] == 9:
                state[3] = 1
        while j < n and b[j] != 10 and b[j] != 13:
            j += 1
        ends[k] = j
        kinds[k] = _kind(b, heads[k], j)
        if j < n:
            if b[j] == 13 and j + 1 < n and b[j + 1] == 10:
                state[CRLF] += 1
                j += 1
            elif b[j] == 13:
                state[CR] += 1
            else:
                state[LF] += 1
            j += 1
        i = j
        k += 1
    return i, k


@njit(cache=True)
def _unstripped(starts, heads, kinds):  # pragma: no cover - compiled
    """In a file without indentation lines are read as they are: one led by \\v or \\f is
    another statement."""
    for t in range(starts.shape[0]):
        if heads[t] > starts[t]:
            heads[t] = starts[t]
            kinds[t] = OTHER


def _grown(a: np.ndarray, size: int) -> np.ndarray:
    out = np.empty(size, dtype=a.dtype)
    out[:len(a)] = a
    return out


def line_spans(b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """The lines of a text as ``bytes.splitlines`` cuts it (at ``\\n``, ``\\r`` and ``\\r\\n``),
    and their kinds, in one pass.

    Parameters
    ----------
    b : (b,) uint8 array
        The text.

    Returns
    -------
    starts, ends : (k,) int64 arrays
        Each line is ``b[starts[i]:ends[i]]`` (without its line end).
    heads : (k,) int64 arrays
        Where each line's statement starts: after its leading whitespace when some line is
        indented (then every line is read stripped, as ``bytes.lstrip`` strips it), else at
        ``starts``.
    kinds : (k,) int8 array
        :data:`V`, :data:`VN`, :data:`F`, :data:`COMMENT`, :data:`BLANK`, :data:`VT` or
        :data:`OTHER`, from the first three bytes from ``heads`` (0 past the line's end).
    endings : (3,) int64 array
        How many lines end in ``\\n``, ``\\r`` and ``\\r\\n`` (:data:`LF`, :data:`CR`, :data:`CRLF`).
    indented : bool
        Whether some line starts with a space or a tab.
    """
    sample = b[: 1 << 20].tobytes()  # lines in the first MiB, to size the arrays (they grow if needed)
    per_byte = (sample.count(b"\\n") + sample.count(b"\\r") - sample.count(b"\\r\\n") + 1) / max(len(sample), 1)
    room = int(b.shape[0] * per_byte * 1.05) + 1024
    arrays = [np.empty(room, dtype=np.int64), np.empty(room, dtype=np.int64), np.empty(room, dtype=np.int64),
              np.empty(room, dtype=np.int8)]
    state = np.zeros(5, dtype=np.int64)
    i, k = _spans(b, 0, 0, *arrays, state)
    while i < b.shape[0]:
        room = k + k // 2 + 1024
        arrays = [_grown(a, room) for a in arrays]
        i, k = _spans(b, i, k, *arrays, state)
    starts, ends, heads, kinds = (a[:k] for a in arrays)
    indented = bool(state[3])
    if state[4] and not indented:
        _unstripped(starts, heads, kinds)
    return starts, ends, heads, kinds, state[:3].copy(), indented


@njit(cache=True)
def _token_counts(b, lo, hi, out):  # pragma: no cover - compiled
    for i in range(lo.shape[0]):
        count = 0
        inside = False
        for p in range(lo[i], hi[i]):
            if _is_space(b[p]):
                inside = False
            elif not inside:
                inside = True
                count += 1
        out[i] = count


def token_counts(b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Whitespace-separated tokens of each line ``b[lo[i]:hi[i]]`` (``len(line.split())``), (k,) int64."""
    out = np.empty(lo.shape[0], dtype=np.int64)
    _token_counts(b, lo, hi, out)
    return out


@njit(cache=True)
def _gather(b, lo, hi, out):  # pragma: no cover - compiled
    q = 0
    for i in range(lo.shape[0]):
        if i:
            out[q] = 10
            q += 1
        m = hi[i] - lo[i]
        out[q:q + m] = b[lo[i]:hi[i]]
        q += m


def gather(b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """``b"\\n".join`` of the pieces ``b[lo[i]:hi[i]]`` ((k,) int64 each, ``lo <= hi``), (t,) uint8.

    Like a ``bytes`` object's, the text is followed in memory by a NUL byte (the last of the
    array it is a view of): a C parser given it (``np.fromstring``) stops there, not in the
    memory after it.
    """
    size = int((hi - lo).sum()) + max(lo.shape[0] - 1, 0)
    out = np.empty(size + 1, dtype=np.uint8)
    _gather(b, lo, hi, out)
    out[size] = 0
    return out[:size]


#: most digits of an index :func:`face_corners` reads (more could pass int64's range)
_MAX_DIGITS = 18


@njit(cache=True)
def _int_at(b, p, end):  # pragma: no cover - compiled
    """The integer ``[+-]?[0-9]{1,18}`` at ``b[p:]`` (before ``end``): (value, position after it),
    position -1 when there is none."""
    sign = 1
    if p < end and (b[p] == 43 or b[p] == 45):
        if b[p] == 45:
            sign = -1
        p += 1
    value = 0
    digits = 0
    while p < end and b[p] >= 48 and b[p] <= 57:
        value = value * 10 + (b[p] - 48)
        digits += 1
        p += 1
    if digits == 0 or digits > _MAX_DIGITS:
        return 0, -1
    return sign * value, p


@njit(cache=True)
def _face_corners(b, lo, hi, first, c, counts, idx, normals, want_normals):  # pragma: no cover - compiled
    """Corners of lines ``first`` on, from corner ``c`` on, until a line has no room left in
    ``idx``; returns (the next line, the next corner, the first line not in the common form or
    -1)."""
    room = idx.shape[0]
    for i in range(first, lo.shape[0]):
        end = hi[i]
        p = lo[i]
        line_start = c
        while p < end:
            if _is_space(b[p]):
                p += 1
                continue
            v, p = _int_at(b, p, end)
            if p < 0:
                return i, c, i
            vn = 0
            if p < end and b[p] == 47:  # "/": a texture and maybe a normal index follow
                p += 1
                while p < end and b[p] != 47 and not _is_space(b[p]):
                    p += 1  # the texture index (read on demand, elsewhere)
                if p < end and b[p] == 47:
                    p += 1
                    if want_normals:
                        if p < end and not _is_space(b[p]):
                            vn, p = _int_at(b, p, end)
                            if p < 0:
                                return i, c, i
                    else:
                        while p < end and not _is_space(b[p]):
                            p += 1
            if p < end and not _is_space(b[p]):
                return i, c, i
            if c == room:
                return i, line_start, -1  # (this line again, with more room)
            idx[c] = v
            if want_normals:
                normals[c] = vn
            c += 1
        counts[i] = c - line_start
    return lo.shape[0], c, -1


def face_corners(b: np.ndarray, lo: np.ndarray, hi: np.ndarray,
                 want_normals: bool) -> tuple[np.ndarray, np.ndarray, np.ndarray | None] | int:
    """The corners of face lines whose statement (``f``) ends at ``lo`` and that end at ``hi``.

    Every corner must be ``v``, ``v/t``, ``v//n`` or ``v/t/n`` with ``v`` (and ``n``, when
    ``want_normals``) an integer of at most 18 digits with an optional sign; ``t`` (and ``n``
    otherwise) is skipped to the next whitespace.

    Parameters
    ----------
    b : (b,) uint8 array
    lo, hi : (p,) int64 arrays
    want_normals : bool
        Also read each corner's normal index.

    Returns
    -------
    counts : (p,) int64 array
        Corners of each line.
    idx : (sum(counts),) int64 array
        Vertex index of each corner, as written (1-based or negative).
    normals : (sum(counts),) int64 array or None
        Normal index of each corner as written, 0 for none (None unless ``want_normals``).

    or, for a line not in that form, its position in ``lo`` (an int).
    """
    counts = np.empty(lo.shape[0], dtype=np.int64)
    room = 3 * lo.shape[0] + 16  # triangles; it grows for polygons
    idx = np.empty(room, dtype=np.int64)
    normals = np.empty(room if want_normals else 0, dtype=np.int64)
    i, c, bad = _face_corners(b, lo, hi, 0, 0, counts, idx, normals, want_normals)
    while bad < 0 and i < lo.shape[0]:
        room = c + c // 2 + 1024
        idx = _grown(idx, room)
        normals = _grown(normals, room) if want_normals else normals
        i, c, bad = _face_corners(b, lo, hi, i, c, counts, idx, normals, want_normals)
    if bad >= 0:
        return int(bad)
    idx = idx[:c] if c == 3 * lo.shape[0] else idx[:c].copy()  # (polygons: not the room it grew by)
    return counts, idx, (normals[:c].copy() if want_normals else None)
