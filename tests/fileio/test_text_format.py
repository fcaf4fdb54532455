"""The compiled row text (text_format) is byte for byte what Python's %-formatting wrote before."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.fileio.formats.text_format import counted_lines, face_lines, float_rows


def old_face_lines(counts: np.ndarray, table: np.ndarray, normals_only: bool) -> bytes:
    """The face text as obj._plain made it with %-formatting (the reference)."""
    m = table.shape[1]
    corner_fmt = "%d//%d" if normals_only else {1: "%d", 2: "%d/%d", 3: "%d/%d/%d"}[m]
    has_uv = m >= 2 and not normals_only
    out, at = [], 0
    for c in counts.tolist():
        words = [corner_fmt % tuple(r) for r in table[at: at + c].tolist()]
        at += c
        line = "f " + " ".join(words) + "\n"
        if has_uv:
            line = line.replace("/0/", "//").replace("/0 ", " ").replace("/0\n", "\n")
        out.append(line)
    return "".join(out).encode()


def random_faces(rng: np.random.Generator, m: int, mixed: bool, top: int) -> tuple[np.ndarray, np.ndarray]:
    n = int(rng.integers(0, 300))
    counts = rng.integers(3, 9, n) if mixed else np.full(n, int(rng.integers(3, 5)))
    table = rng.integers(1, top, (int(counts.sum()), m))
    if m >= 2:  # texture coordinates missing at some corners (0), or none at all
        table[rng.random(len(table)) < rng.choice([0.0, 0.3, 1.0]), 1] = 0
    return counts, table


@pytest.mark.parametrize("m,normals_only", [(1, False), (2, False), (2, True), (3, False)])
@pytest.mark.parametrize("mixed", [False, True])
def test_face_lines_match_percent_formatting(m: int, normals_only: bool, mixed: bool) -> None:
    rng = np.random.default_rng(m * 10 + normals_only * 5 + mixed)
    for trial in range(40):
        top = [10, 1000, 10 ** 9, 2 ** 62][trial % 4]  # every digit count up to huge indices
        counts, table = random_faces(rng, m, mixed, top)
        if normals_only:
            table[:, 1] = np.maximum(table[:, 1], 1)
        got = face_lines(counts, table, normals_only)
        assert got.dtype == np.uint8
        assert got.tobytes() == old_face_lines(counts, table, normals_only)


def test_face_lines_at_digit_boundaries() -> None:
    values = np.array(sorted({v for k in range(19) for v in (10 ** k - 1, 10 ** k, 10 ** k + 1)} - {-1, 0})
                      + [2 ** 63 - 1], dtype=np.int64)
    counts = np.full(len(values) // 3, 3)
    table = np.stack([values[: 3 * len(counts)]] * 3, axis=1)
    table[::2, 1] = 0
    for m in (1, 2, 3):
        assert face_lines(counts, table[:, :m]).tobytes() == old_face_lines(counts, table[:, :m], False)


def test_face_lines_of_one_corner_and_of_nothing() -> None:
    assert face_lines(np.array([1]), np.array([[7, 0, 9]])).tobytes() == b"f 7//9\n"
    assert face_lines(np.array([1]), np.array([[7, 0]])).tobytes() == b"f 7\n"
    assert face_lines(np.array([1]), np.array([[7, 8]]), normals_only=True).tobytes() == b"f 7//8\n"
    assert face_lines(np.zeros(0, np.int64), np.zeros((0, 3), np.int64)).size == 0


def test_face_lines_refuse_a_table_that_does_not_fit() -> None:
    with pytest.raises(ValueError):
        face_lines(np.array([3]), np.ones((4, 1), np.int64))
    with pytest.raises(ValueError):
        face_lines(np.array([1]), np.ones((1, 3), np.int64), normals_only=True)


# --------------------------------------------------------------------------- float_rows


def reprs(values: np.ndarray) -> list[bytes]:
    return [repr(x).encode() for x in values.ravel().tolist()]


def float_texts(values: np.ndarray) -> list[bytes]:
    return float_rows(b"", np.asarray(values, dtype=np.float64).reshape(-1, 1)).tobytes().split(b"\n")[:-1]


def special_floats() -> np.ndarray:
    """Values where a shortest-form writer goes wrong: extremes, subnormals, powers of 2 and 10 (and
    their neighbours), integers about 2**53, the layout's boundaries (1e-4, 1e16), halves."""
    v = [0.0, -0.0, 5e-324, 1e-323, 2.225073858507201e-308, 2.2250738585072014e-308, 1.7976931348623157e308,
         0.1, 0.2, 0.3, 1 / 3, 2 / 3, 9007199254740993.0, 1.2345e17, 299792458.0, 9999999999999998.0]
    v += [10.0 ** k for k in range(-323, 309)] + [2.0 ** k for k in range(-1074, 1024)]
    v += [float(i) for i in range(-1000, 1000)] + [float(2 ** 53 + d) for d in range(-64, 64, 2)]
    near = [np.nextafter(x, d) for x in [10.0 ** k for k in range(-30, 30)] + [2.0 ** k for k in range(-1074, 1024, 7)]
            for d in (0.0, np.inf)]
    v += near + [k * 10.0 ** e for k in range(1, 100) for e in (-6, -5, -4, -3, 14, 15, 16, 17)]
    v += [k + 0.5 for k in range(-20, 20)] + [k / 8 for k in range(1, 200)]
    v = np.array(v)
    return np.concatenate([v, -v])


def test_float_text_is_repr_at_special_values() -> None:
    v = special_floats()
    assert float_texts(v) == reprs(v)


def test_float_text_is_repr_of_non_finite_values() -> None:
    v = np.array([np.inf, -np.inf, np.nan, -np.nan])
    assert float_texts(v) == [b"inf", b"-inf", b"nan", b"nan"]


def test_float_text_is_repr_at_random_values() -> None:
    """Random bit patterns (every exponent) and mesh-like values, float32 ones widened among them."""
    rng = np.random.default_rng(7)
    bits = rng.integers(0, 2 ** 64, size=60_000, dtype=np.uint64).view(np.float64)
    bits = bits[np.isfinite(bits)]
    mesh = rng.normal(size=60_000) * 10.0 ** rng.integers(-3, 4, size=60_000)
    widened = rng.normal(size=40_000).astype(np.float32).astype(np.float64)
    dyadic = rng.integers(-2 ** 60, 2 ** 60, size=40_000) / 2.0 ** rng.integers(0, 70, size=40_000)
    for v in (bits, mesh, widened, dyadic):
        assert float_texts(v) == reprs(v)


def test_float_texts_read_back_to_the_values() -> None:
    v = np.random.default_rng(3).integers(0, 2 ** 64, size=20_000, dtype=np.uint64).view(np.float64)
    v = v[np.isfinite(v)]
    assert np.array_equal(np.array(float_texts(v), dtype=np.float64), v)


@pytest.mark.parametrize("head", [b"v", b"vt", b""])
def test_float_rows_lay_out_rows_as_percent_r(head: bytes) -> None:
    rng = np.random.default_rng(len(head))
    for c in (1, 2, 3):
        values = rng.normal(size=(50, c)) * 10.0 ** rng.integers(-6, 18, size=(50, c))
        fmt = (head.decode() + " %r" * c if head else " ".join(["%r"] * c)) + "\n"
        assert float_rows(head, values).tobytes() == ((fmt * len(values)) % tuple(values.ravel().tolist())).encode()
    assert float_rows(head, np.zeros((0, 3))).size == 0


# --------------------------------------------------------------------------- counted_lines


def test_counted_lines_match_the_off_text() -> None:
    rng = np.random.default_rng(5)
    for trial in range(30):
        p = int(rng.integers(0, 200))
        counts = rng.integers(1, 12, p) if trial % 2 else np.full(p, 3)
        flat = rng.integers(0, [10, 10 ** 6, 2 ** 62][trial % 3], int(counts.sum()))
        starts = np.cumsum(counts) - counts
        want = "".join(" ".join(map(str, [c, *flat[s: s + c].tolist()])) + "\n"
                       for s, c in zip(starts.tolist(), counts.tolist()))
        assert counted_lines(counts, flat).tobytes() == want.encode()
    assert counted_lines(np.array([3]), np.array([0, 9, 10])).tobytes() == b"3 0 9 10\n"
    with pytest.raises(ValueError):
        counted_lines(np.array([3]), np.array([0, 1]))
