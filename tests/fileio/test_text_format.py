"""The compiled row text (text_format) is byte for byte what Python's %-formatting wrote before."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.fileio.formats.text_format import face_lines


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
