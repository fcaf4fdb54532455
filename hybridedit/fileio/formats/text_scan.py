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
>>> starts, ends, lead, endings, indented = line_spans(b)
>>> starts.tolist(), ends.tolist(), lead.tolist(), endings.tolist(), indented
([0, 9, 19], [7, 18, 20], [0, 2, 0], [1, 0, 1], True)
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["line_spans", "line_heads", "token_counts", "gather", "face_corners"]

#: line ends counted by :func:`line_spans`: ``\\n``, ``\\r`` and ``\\r\\n``
LF, CR, CRLF = range(3)


@njit(cache=True)
def _is_space(c):  # pragma: no cover - compiled
    """Whitespace inside a line as ``bytes.split`` sees it (space, \\t, \\v, \\f; \\n and \\r too)."""
    return c == 32 or (c >= 9 and c <= 13)


@njit(cache=True)
def _count_lines(b):  # pragma: no cover - compiled
    n = b.shape[0]
    k = 0
    i = 0
    while i < n:
        c = b[i]
        if c == 10:
            k += 1
        elif c == 13:
            k += 1
            if i + 1 < n and b[i + 1] == 10:
                i += 1
        i += 1
    if n and b[n - 1] != 10 and b[n - 1] != 13:
        k += 1  # a last line without a line end
    return k


@njit(cache=True)
def _fill_spans(b, starts, ends, lead, endings):  # pragma: no cover - compiled
    n = b.shape[0]
    indented = False
    k = 0
    i = 0
    while i < n:
        starts[k] = i
        j = i
        while j < n and (b[j] == 32 or b[j] == 9 or b[j] == 11 or b[j] == 12):
            j += 1
        lead[k] = j - i
        if j > i and (b[i] == 32 or b[i] == 9):
            indented = True
        while j < n and b[j] != 10 and b[j] != 13:
            j += 1
        ends[k] = j
        if j < n:
            if b[j] == 13 and j + 1 < n and b[j + 1] == 10:
                endings[CRLF] += 1
                j += 1
            elif b[j] == 13:
                endings[CR] += 1
            else:
                endings[LF] += 1
            j += 1
        i = j
        k += 1
    return indented


def line_spans(b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, bool]:
    """The lines of a text as ``bytes.splitlines`` cuts it (at ``\\n``, ``\\r`` and ``\\r\\n``).

    Parameters
    ----------
    b : (b,) uint8 array
        The text.

    Returns
    -------
    starts, ends : (k,) int64 arrays
        Each line is ``b[starts[i]:ends[i]]`` (without its line end).
    lead : (k,) int64 array
        Bytes of leading whitespace of each line (what ``bytes.lstrip`` removes).
    endings : (3,) int64 array
        How many lines end in ``\\n``, ``\\r`` and ``\\r\\n`` (:data:`LF`, :data:`CR`, :data:`CRLF`).
    indented : bool
        Whether some line starts with a space or a tab.
    """
    k = _count_lines(b)
    starts = np.empty(k, dtype=np.int64)
    ends = np.empty(k, dtype=np.int64)
    lead = np.empty(k, dtype=np.int64)
    endings = np.zeros(3, dtype=np.int64)
    indented = bool(_fill_spans(b, starts, ends, lead, endings))
    return starts, ends, lead, endings, indented


@njit(cache=True)
def _heads(b, lo, hi, out):  # pragma: no cover - compiled
    for i in range(lo.shape[0]):
        for j in range(3):
            p = lo[i] + j
            out[i, j] = b[p] if p < hi[i] else 0


def line_heads(b: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """The first three bytes of each line ``b[lo[i]:hi[i]]``, 0 past its end, (k, 3) uint8 (as
    ``np.array([line[:3] ...], dtype="S3")`` has them)."""
    out = np.empty((lo.shape[0], 3), dtype=np.uint8)
    _heads(b, lo, hi, out)
    return out


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
        for p in range(lo[i], hi[i]):
            out[q] = b[p]
            q += 1


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
def _face_corners(b, lo, hi, counts, idx, normals, want_normals):  # pragma: no cover - compiled
    """Fill ``counts`` (tokens of each line) and, when ``idx`` is given room, the indices; the
    first line not in the common form, or -1."""
    c = 0
    for i in range(lo.shape[0]):
        end = hi[i]
        p = lo[i]
        count = 0
        while p < end:
            if _is_space(b[p]):
                p += 1
                continue
            count += 1
            if idx.shape[0] == 0:  # counting only
                while p < end and not _is_space(b[p]):
                    p += 1
                continue
            v, p = _int_at(b, p, end)
            if p < 0:
                return i
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
                                return i
                    else:
                        while p < end and not _is_space(b[p]):
                            p += 1
            if p < end and not _is_space(b[p]):
                return i
            idx[c] = v
            if want_normals:
                normals[c] = vn
            c += 1
        counts[i] = count
    return -1


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
    nothing = np.empty(0, dtype=np.int64)
    _face_corners(b, lo, hi, counts, nothing, nothing, False)
    total = int(counts.sum())
    idx = np.empty(total, dtype=np.int64)
    normals = np.empty(total if want_normals else 0, dtype=np.int64)
    bad = _face_corners(b, lo, hi, counts, idx, normals, want_normals)
    if bad >= 0:
        return int(bad)
    return counts, idx, (normals if want_normals else None)
