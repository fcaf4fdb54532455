"""The history's long sums: the products numpy gives, to rounding, in one order every call."""

import numpy as np
import pytest

from hybridedit.core.row_sums import combine, gram


@pytest.mark.parametrize("rows, cols, n", [(21, 3, 66_157), (7, 2, 1023), (1, 1, 5), (5, 3, 2049)])
def test_gram_is_the_matrix_product(rows, cols, n):
    rng = np.random.default_rng(rows + n)
    A, V = rng.standard_normal((rows, n)), rng.standard_normal((cols, n))
    out = gram(A, V, np.full((rows, cols), np.nan))
    exact = A @ V.T
    assert np.abs(out - exact).max() <= 1e-13 * np.sqrt(n) * np.abs(A).max() * np.abs(V).max()


@pytest.mark.parametrize("rows, n", [(21, 66_157), (4, 1024), (3, 1025), (1, 7)])
def test_combine_is_the_weighted_sum_of_rows(rows, n):
    rng = np.random.default_rng(rows * n)
    A, g = rng.standard_normal((rows, n)), rng.standard_normal(rows)
    out = combine(g, A, np.full(n, np.nan))
    assert np.abs(out - g @ A).max() <= 1e-14 * rows * np.abs(g).max() * np.abs(A).max()


def test_the_same_rows_give_the_same_sums_bit_for_bit():
    rng = np.random.default_rng(3)
    A, V, g = rng.standard_normal((21, 50_001)), rng.standard_normal((3, 50_001)), rng.standard_normal(21)
    first = gram(A, V, np.zeros((21, 3))), combine(g, A, np.zeros(50_001))
    for _ in range(3):
        assert np.array_equal(gram(A, V, np.zeros((21, 3))), first[0])
        assert np.array_equal(combine(g, A, np.zeros(50_001)), first[1])


def test_zero_rows_add_nothing():
    """(the history's empty slots are rows of zeros: they must leave the sums as they are)"""
    rng = np.random.default_rng(4)
    A = rng.standard_normal((6, 3000))
    padded = np.vstack([A, np.zeros((4, 3000))])
    g = rng.standard_normal(6)
    assert np.array_equal(combine(np.concatenate([g, np.ones(4)]), padded, np.zeros(3000)),
                          combine(np.concatenate([g, np.zeros(4)]), padded, np.zeros(3000)))
    V = rng.standard_normal((2, 3000))
    assert not gram(padded, V, np.ones((10, 2)))[6:].any()
