"""Tests of the truncation rule (hybridedit.binding.truncation)."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.binding.truncation import MIN_KEPT_SUM, UNDECIDED, check_truncation, keep_row


def reference_kept(row, t):
    """The rule with a full sort (no safeguard): kept positions, sorted."""
    a = np.abs(row)
    order = np.argsort(a, kind="stable")
    cum = np.cumsum(a[order])
    n_drop = int(np.searchsorted(cum, t * a.sum(), side="right"))
    return np.sort(order[n_drop:])


def scratch(c):
    return np.empty(c, dtype=np.int64), np.empty(c), np.empty(c, dtype=np.int64)


@pytest.mark.parametrize("seed", range(4))
def test_keep_row_with_aggregated_entries_is_the_rule_on_the_whole_row(seed):
    """Entries given only as a mass (all smaller than every kept one) change nothing."""
    rng = np.random.default_rng(seed)
    c = 400
    d = rng.uniform(0.3, 8.0, c)
    row = 1.0 / d**4 * np.where(rng.random(c) < 0.1, -0.2, 1.0)
    row /= row.sum()
    t = 0.03
    kept = reference_kept(row, t)
    small = np.abs(row) < 0.5 * np.abs(row[kept]).min()
    assert small.sum() > 100  # a real aggregate
    part = row[~small]
    surv, vals, idx = scratch(c)
    n, scale = keep_row(part, t, MIN_KEPT_SUM, float(np.abs(row[small]).sum()), surv, vals, idx)
    got = np.sort(np.flatnonzero(~small)[idx[:n]])
    np.testing.assert_array_equal(got, kept)
    np.testing.assert_allclose(scale, 1.0 / row[kept].sum(), rtol=1e-12)


def test_keep_row_reports_undecided_rows():
    row = np.array([0.5, 0.3, 0.2])
    surv, vals, idx = scratch(3)
    # the aggregated mass alone is over the budget
    assert keep_row(row, 0.03, MIN_KEPT_SUM, 0.1, surv, vals, idx)[0] == UNDECIDED
    # the safeguard would keep the aggregated entries too
    neg = np.array([2.0, -1.6, 0.4, 0.2])  # kept 2.0 and -1.6 would sum to 0.4
    surv, vals, idx = scratch(4)
    assert keep_row(neg, 0.3, MIN_KEPT_SUM, 0.01, surv, vals, idx)[0] == UNDECIDED
    n, scale = keep_row(neg, 0.3, MIN_KEPT_SUM, 0.0, surv, vals, idx)
    assert n == 4 and scale == 1.0  # whole row: the safeguard keeps it


def test_long_rows_with_even_magnitudes_match_the_reference():
    """Rows where most entries survive the first stages (the histogram stage)."""
    rng = np.random.default_rng(9)
    for _ in range(50):
        row = rng.uniform(0.5, 1.0, 1000)
        row /= row.sum()
        surv, vals, idx = scratch(len(row))
        for t in (0.03, 0.3):
            n, _ = keep_row(row, t, MIN_KEPT_SUM, 0.0, surv, vals, idx)
            np.testing.assert_array_equal(np.sort(idx[:n]), reference_kept(row, t))


def test_check_truncation():
    assert check_truncation(0.03) == 0.03
    for bad in (-0.1, 1.0, "x", None):
        with pytest.raises(ValueError):
            check_truncation(bad)


def test_cap_rows_keeps_the_largest_entries_of_a_wide_row_refitted():
    import scipy.sparse as sp

    from hybridedit.binding.truncation import cap_rows

    cage = np.array([[1.0, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]])
    rows = [np.array([0.5, 0.2, -0.05, 0.15, 0.12, 0.08]),  # wide: its 4 largest (0.5, 0.2, 0.15, 0.12) kept
            np.array([0.7, 0.3, 0, 0, 0, 0]),               # narrow: as it is
            np.array([-3.0, 2.5, 0.4, 0.4, 0.3, 0.4])]      # its 4 largest sum to 0.3, all at z = 0
    M = sp.csr_matrix(np.array(rows))
    M.sort_indices()
    x = M @ cage
    C = cap_rows(M, x, cage, 4)
    dense = C.toarray()
    assert np.allclose(dense.sum(axis=1), 1.0, rtol=0, atol=1e-14) and np.all(np.diff(C.indptr) <= 4)
    assert np.array_equal(np.flatnonzero(dense[0]), [0, 1, 3, 4])
    assert np.array_equal(dense[1], rows[1])
    assert np.allclose(C[:2] @ cage, x[:2], rtol=0, atol=1e-14)  # the points reproduced (kept vertices span 3D)
    assert np.array_equal(np.flatnonzero(dense[2]), [0, 1, 2, 3])  # (the first of the equal ones)
    assert np.allclose((C @ cage)[2, :2], x[2, :2], rtol=0, atol=1e-14)  # in their plane
    assert cap_rows(M, x, cage, 6) is M  # nothing wider than the cap: the matrix itself
    with pytest.raises(ValueError):
        cap_rows(M, x, cage, 0)
    with pytest.raises(ValueError):
        cap_rows(M, x[:2], cage, 4)


def test_bind_bounds_every_row_and_keeps_a_partition_of_unity():
    from hybridedit.binding.bind import bind
    from hybridedit.binding.truncation import MAX_ROW

    from shapes import bumpy_blob, icosphere

    cage = icosphere(3)
    pts = bumpy_blob(3).vertices * 1.8  # many points far outside the cage: wide, signed rows
    whole = bind(pts, cage, truncation=0.03, max_row=None)
    assert np.diff(whole.indptr).max() > MAX_ROW  # (the plain rule keeps them wide)
    M = bind(pts, cage, truncation=0.03)
    assert np.diff(M.indptr).max() <= MAX_ROW
    assert np.allclose(np.asarray(M.sum(axis=1)).ravel(), 1.0)
    narrow = np.diff(whole.indptr) <= MAX_ROW  # the rows within the bound are the rule's own
    assert (abs(M[narrow] - whole[narrow]) > 0).nnz == 0
    # (the cut rows cannot reproduce these points: 12 cage vertices near a point far outside the cage
    # reach it only with coordinates in the hundreds; tests/binding/test_row_bound.py checks points in it)
