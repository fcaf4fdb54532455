import numpy as np
import pytest

from hybridedit.core import index_sets
from hybridedit.core.index_sets import difference_in_range, union_in_range, unique_in_range


@pytest.mark.parametrize("k", [0, 3, 500, 50_000])
def test_the_mask_and_the_sort_give_np_unique(k, monkeypatch):
    rng = np.random.default_rng(k)
    n = 20_000
    idx = rng.integers(0, n, k)
    other = rng.integers(0, n, k // 2 + 1)
    for share in (0.0, 1.0, index_sets.MASK_SHARE):  # always the mask, always the sort, the default
        monkeypatch.setattr(index_sets, "MASK_SHARE", share)
        u = unique_in_range(idx, n)
        assert u.dtype == np.int64 and np.array_equal(u, np.unique(idx))
        assert np.array_equal(union_in_range(idx, other, n), np.union1d(idx, other))
        d = difference_in_range(idx, other, n)
        assert d.dtype == np.int64 and np.array_equal(d, np.setdiff1d(idx, other))


@pytest.mark.parametrize("dtype", [np.int32, np.int64, np.uint8])
@pytest.mark.parametrize("k", [0, 1, 2, 7, 10_000])
def test_unique_sorted_gives_np_unique(dtype, k):
    rng = np.random.default_rng(k)
    values = rng.integers(0, 100 if dtype == np.uint8 else 10**9, (k, 2)).astype(dtype)
    u = index_sets.unique_sorted(values)
    expected = np.unique(values)
    assert u.dtype == expected.dtype and np.array_equal(u, expected)
    assert values.shape == (k, 2)  # (the input is left as it was)


def test_unique_sorted_keeps_negative_values_and_repeats_of_one():
    assert np.array_equal(index_sets.unique_sorted(np.array([-3, 5, -3, 0])), [-3, 0, 5])
    assert np.array_equal(index_sets.unique_sorted(np.full(9, 4)), [4])
