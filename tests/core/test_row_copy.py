import numpy as np

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
