import numpy as np
import pytest

from hybridedit.core.row_copy import put_rows, take_rows


def test_take_and_put_rows_are_fancy_indexing():
    rng = np.random.default_rng(0)
    src = rng.normal(size=(500, 3))
    rows = rng.choice(500, 120, replace=False)
    got = take_rows(src, rows)
    assert got.flags.c_contiguous and np.array_equal(got, src[rows])
    out = src.copy()
    new = rng.normal(size=(120, 3))
    put_rows(new, rows, out)
    want = src.copy()
    want[rows] = new
    assert np.array_equal(out, want)
    put_rows(np.asfortranarray(new * 2), rows, out)  # any memory order in
    want[rows] = new * 2
    assert np.array_equal(out, want)
    assert take_rows(src, np.zeros(0, dtype=np.int64)).shape == (0, 3)


def test_copy_rows_is_a_gather_into_other_rows():
    from hybridedit.core.row_copy import copy_rows

    rng = np.random.default_rng(1)
    src = rng.random((50, 3)).astype(np.float32)
    dst = np.zeros((20, 3), np.float32)
    rows, at = rng.choice(50, 8, replace=False), rng.choice(20, 8, replace=False)
    copy_rows(src, rows, dst, at)
    want = np.zeros((20, 3), np.float32)
    want[at] = src[rows]
    assert np.array_equal(dst, want)


@pytest.mark.parametrize("threshold", [0, 10**9])  # the parallel twin, the serial one
def test_rows_into_copies_and_casts_like_numpy(monkeypatch, threshold):
    from hybridedit.core import parallel
    from hybridedit.core.row_copy import copied, rows_into

    monkeypatch.setitem(parallel.THRESHOLDS, "copy", threshold)
    rng = np.random.default_rng(3)
    a = rng.standard_normal((1001, 3))
    b = copied(a)
    assert b.flags.c_contiguous and not np.shares_memory(a, b) and np.array_equal(a, b)
    for code in ("<i4", ">i4", "<u4", "<u2"):  # PLY face records: a count byte, then three indices
        rec = np.zeros(1001, dtype=[("n", "u1"), ("v", code, (3,))])
        rec["v"] = rng.integers(0, 60000, (1001, 3))
        out = np.full((1001, 3), -1, dtype=np.int64)
        rows_into(rec["v"], out)
        assert np.array_equal(out, rec["v"].astype(np.int64)), code
    f = np.asfortranarray(a)  # another layout: the same values
    out = np.empty((1001, 3))
    rows_into(f, out)
    assert np.array_equal(out, a)
