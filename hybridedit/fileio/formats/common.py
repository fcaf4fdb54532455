"""What every format module shares: the file error, numeric parsing helpers,
fan triangulation, welding and the checks every engine mesh passes."""

from __future__ import annotations

import warnings

import numpy as np

from ...core.index_sets import unique_sorted
from ...core.mesh import Mesh, MeshError
from .reporting import report
from .text_format import float_rows


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


def fan_triangles(counts: np.ndarray, flat: np.ndarray) -> np.ndarray:
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


def _check_indices(faces: np.ndarray, n: int) -> None:
    """_Bad naming the first face index out of ``[0, n)``: two reductions over the faces, and the
    mask (a temporary of every index) only when one is out of range."""
    if faces.size and (faces.min() < 0 or faces.max() >= n):
        bad = (faces < 0) | (faces >= n)
        value = int(faces.ravel()[int(np.argmax(bad.ravel()))])
        raise _Bad(f"face index {value} out of range (file has {_words(n, 'vertex')})")


def _mesh(vertices: np.ndarray, faces: np.ndarray) -> Mesh:
    """The engine mesh of a file's positions and triangles (every reader makes its mesh here);
    _Bad naming the first face index out of range."""
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    try:
        return Mesh(vertices, faces)  # (it checks the index range: not done twice)
    except MeshError:
        _check_indices(faces, len(vertices))
        raise


def _validate(vertices: np.ndarray, faces: np.ndarray) -> None:
    """Check finiteness and that there is a face (the indices were checked making the mesh,
    :func:`_mesh`); raise _Bad if not."""
    n = len(vertices)
    finite = np.isfinite(vertices).all(axis=1)
    if not finite.all():
        k = int((~finite).sum())
        first = int(np.argmin(finite))
        raise _Bad(f"{k} {'vertex has' if k == 1 else 'vertices have'} NaN or infinite "
                   f"coordinates (first is vertex {first}, counting from 0)")
    if len(faces) == 0:
        raise _Bad("file has no faces" if n else "file has no vertices and no faces")


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


def _token_rows(rows: list[list[bytes]], dtype: type, lines: list[bytes], line_at, what: str) -> np.ndarray:
    """Every token of ``rows`` (words of ``lines``, at 0-based line numbers ``line_at``) as one flat
    ``dtype`` array, read by numpy: the text formats' slow path, after :func:`_numbers` refused a
    block. Raises _Bad naming the first line with a token that is not a number ("line 7: cannot
    read {what} '...'")."""
    flat = [t for row in rows for t in row]
    try:
        return (np.array(flat) if flat else np.zeros(0, "S1")).astype(dtype)
    except ValueError:
        for k, row in enumerate(rows):
            try:
                (np.array(row) if row else np.zeros(0, "S1")).astype(dtype)
            except ValueError:
                raise _Bad(f"line {line_at[k] + 1}: cannot read {what} '{_snippet(lines[k])}'") from None
        raise


def _is_space(b: np.ndarray) -> np.ndarray:
    """Which bytes are ASCII whitespace (space, \\t \\n \\v \\f \\r: 32 and 9-13), as bytes.split sees it."""
    return (b == 32) | ((b >= 9) & (b <= 13))


def _token_count(text: bytes) -> int:
    """Number of whitespace-separated tokens, like ``len(text.split())`` but without the list."""
    if not text:
        return 0
    space = _is_space(np.frombuffer(text, dtype=np.uint8))
    return int(np.count_nonzero(space[:-1] & ~space[1:])) + int(not space[0])


def _widths(lines: list[bytes]) -> np.ndarray:
    """Number of whitespace-separated tokens of each line, (k,) int64."""
    return np.fromiter(map(len, map(bytes.split, lines)), dtype=np.int64, count=len(lines))


#: rows (lines, faces) a writer turns into text between two progress reports
_ROWS_PER_CHUNK = 1 << 16


def _in_chunks(values: np.ndarray, text) -> list:
    """``text(chunk)`` of each chunk of :data:`_ROWS_PER_CHUNK` rows of ``values``, in order, each
    reported to :func:`hybridedit.fileio.formats.reporting.report`."""
    out = []
    for start in range(0, len(values), _ROWS_PER_CHUNK):
        chunk = values[start: start + _ROWS_PER_CHUNK]
        out.append(text(chunk))
        report((start + len(chunk)) / len(values))
    return out


def _format_rows(fmt: str, values: np.ndarray) -> str:
    """Apply a %-format for one row to every row of a 2-d array, in chunks (:func:`_in_chunks`)."""
    return "".join(_in_chunks(values, lambda chunk: (fmt * len(chunk)) % tuple(chunk.ravel().tolist())))


# --------------------------------------------------------------------------- text precision

#: Fewer significant digits than this in a file's coordinates is a coarse grid (integers, a
#: CAD file's 2 decimals): moved values are then written in the shortest exact form instead
#: of being snapped to that grid.
_MIN_FILE_DIGITS = 6


def _shortest(x: float, dtype: np.dtype) -> bytes:
    """The shortest text that reads back to ``x`` in its number type (float64 or float32)."""
    if np.dtype(dtype) == np.float32:
        return str(np.float32(x)).encode()
    return repr(float(x)).encode()


class TextPrecision:
    """How a text file writes its coordinates, measured from a sample of its own numbers,
    so that a moved coordinate is written with the file's precision and no more.

    Exporters write either a fixed number of decimals (``%.6f``: every number has
    the same count) or a number of significant digits (``%g``, whose default is 6:
    spot's ``0.348799 -0.0832331``), or the shortest exact form (``repr``, ``%.17g``).
    The first two are recognised when every sampled number reads back as that
    format writes it; a moved value is then rounded the same way (to 0.5e-d, or
    half a unit of its s-th significant digit), unless the shortest exact form of
    the value in its number type is no longer (``0.5`` rather than ``0.500000``).
    Anything else, and a file with fewer than 6 significant digits (a coarse grid
    an edit must not snap to), gets the shortest exact form.
    """

    def __init__(self, kind: str, digits: int = 0):
        self.kind, self.digits = kind, digits  # "fixed" (decimals), "general" (significant), "shortest"

    def __repr__(self) -> str:
        return f"TextPrecision({self.kind!r}, {self.digits})"

    @classmethod
    def of(cls, tokens: list[bytes]) -> "TextPrecision":
        """The precision of ``tokens`` (a sample of a file's numbers, as written)."""
        tokens = [t for t in tokens if t]
        if not tokens:
            return cls("shortest")
        decimals, significant, plain = set(), 0, True
        for t in tokens:
            mantissa, e, _ = t.lower().partition(b"e")
            plain = plain and not e
            whole, dot, frac = mantissa.lstrip(b"+-").partition(b".")
            decimals.add(len(frac) if dot else 0)
            significant = max(significant, len((whole + frac).lstrip(b"0")) or 1)
        if significant < _MIN_FILE_DIGITS or significant >= 17:
            return cls("shortest")
        try:
            values = [float(t) for t in tokens]
        except ValueError:
            return cls("shortest")
        if plain and len(decimals) == 1 and (d := decimals.pop()) > 0:
            if all(b"%.*f" % (d, v) == t.lstrip(b"+") for v, t in zip(values, tokens)):
                return cls("fixed", d)
        if all(b"%.*g" % (significant, v) == t.lstrip(b"+") for v, t in zip(values, tokens)):
            return cls("general", significant)
        return cls("shortest")

    def text(self, x: float, dtype: np.dtype = np.float64) -> bytes:
        """``x`` as the file would write it (see the class docstring)."""
        exact = _shortest(x, dtype)
        if self.kind == "fixed":
            rounded = b"%.*f" % (self.digits, x)
        elif self.kind == "general":
            rounded = b"%.*g" % (self.digits, x)
        else:
            return exact
        if rounded in (b"-0", b"-0." + b"0" * self.digits):
            rounded = rounded[1:]
        return exact if len(exact) <= len(rounded) else rounded

    def bound(self, x: np.ndarray) -> np.ndarray:
        """The largest difference between ``x`` and its text's value: half a unit of the last
        digit written ((k,) float64; 0 where the text is exact)."""
        x = np.abs(np.asarray(x, dtype=np.float64))
        if self.kind == "fixed":
            return np.full(x.shape, 0.5 * 10.0 ** -self.digits)
        if self.kind == "general":
            exponent = np.floor(np.log10(np.where(x > 0, x, 1.0)))
            return 0.5 * 10.0 ** (exponent - self.digits + 1)
        return np.zeros(x.shape)


def _sample_rows(n: int, limit: int = 2000) -> np.ndarray:
    """Up to ``limit`` row indices spread evenly over ``n`` rows."""
    return unique_sorted(np.linspace(0, n - 1, min(n, limit)).astype(np.int64)) if n else np.zeros(0, np.int64)


def _float32_texts(values: np.ndarray) -> np.ndarray:
    """The shortest text reading back to each float32 value (values exactly float32), (k,) str."""
    flat = values.ravel()
    out = np.empty(flat.shape, dtype=object)
    todo = np.arange(len(flat))
    for digits in range(6, 10):  # 9 significant digits always round-trip a float32
        texts = np.array(["%.*g" % (digits, x) for x in flat[todo].tolist()], dtype=object)
        ok = np.array(texts, dtype=np.float64).astype(np.float32) == flat[todo].astype(np.float32) \
            if digits < 9 else np.ones(len(todo), dtype=bool)
        out[todo[ok]] = texts[ok]
        todo = todo[~ok]
        if not todo.size:
            break
    return out.reshape(values.shape)


def _shortest_rows(head: str, values: np.ndarray, tail: np.ndarray | None = None) -> list:
    """``head`` and each row of ``values`` ((k, c) float64) in its shortest exact text, one line a
    row (``tail`` columns after it with %.6g), as pieces of text to join (``bytes`` or uint8
    arrays): float32 text when every value is a float32 (read from a float32 PLY, STL or glTF),
    else float64's (repr: compiled, :func:`~hybridedit.fileio.formats.text_format.float_rows`,
    when there is no ``tail``). Progress is reported per chunk."""
    if len(values) and np.array_equal(values.astype(np.float32).astype(np.float64), values):
        texts = _float32_texts(values)
        table = texts if tail is None else np.concatenate([texts, tail.astype(object)], axis=1)
        fmt = head + " %s" * values.shape[1] + (" %.6g" * tail.shape[1] if tail is not None else "") + "\n"
        return [_format_rows(fmt, table).encode()]
    if tail is None:
        return _float_chunks(head.encode(), values)
    fmt = head + " %r" * values.shape[1] + " %.6g" * tail.shape[1] + "\n"
    return [_format_rows(fmt, np.column_stack([values, tail])).encode()]


def _float_chunks(head: bytes, values: np.ndarray) -> list[np.ndarray]:
    """:func:`~hybridedit.fileio.formats.text_format.float_rows` of ``values`` ((k, c) float64),
    a chunk of rows at a time (:func:`_in_chunks`): the texts (uint8 arrays), in order."""
    return _in_chunks(values, lambda chunk: float_rows(head, chunk))
