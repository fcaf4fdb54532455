import numpy as np
import pytest
import scipy.sparse as sp

from hybridedit.core.csr_checks import FAULTS, csr_check
from hybridedit.core.parallel import THRESHOLDS


@pytest.fixture(params=[10**9, 0], ids=["serial", "parallel"])
def twin(request, monkeypatch):
    monkeypatch.setitem(THRESHOLDS, "propagate", request.param)


def binding(n=500, c=40, seed=0):
    every_row = sp.csr_matrix((np.ones(n), (np.arange(n), np.arange(n) % c)), shape=(n, c))
    M = sp.random(n, c, density=0.1, format="csr", random_state=seed) + every_row
    M = sp.csr_matrix(sp.diags(1.0 / np.asarray(M.sum(axis=1)).ravel()) @ M)
    M.sort_indices()
    return M


def check(M, **kw):
    return csr_check(M.indptr, M.indices, M.data, n_columns=M.shape[1], **kw)


def test_a_sound_binding_passes(twin):
    assert check(binding(), row_sum=1.0) == ("", True)
    assert check(binding()) == ("", True)


def test_each_fault_is_named(twin):
    M = binding()
    bad = M.copy()
    bad.indices[7] = 40
    assert check(bad)[0] == FAULTS[2]
    bad = M.copy()
    bad.indices[7] = -1
    assert check(bad)[0] == FAULTS[2]
    bad = M.copy()
    bad.data[3] = np.nan
    assert check(bad)[0] == FAULTS[3]
    bad = M.copy()
    bad.data[3] += 1e-6
    assert check(bad, row_sum=1.0)[0] == "a row does not sum to 1"
    assert check(bad)[0] == ""  # (no sum asked)
    for ptr in ([0, 5, 3] + [len(M.indices)] * 498, np.r_[M.indptr[:-1], len(M.indices) + 1]):
        p = np.asarray(ptr, dtype=M.indptr.dtype)
        assert csr_check(p, M.indices, M.data, n_columns=40)[0] == FAULTS[1]  # never read out of bounds
    # a pointer far past the end in the middle, the last one right
    p = M.indptr.copy()
    p[10] = 10**9
    assert csr_check(p, M.indices, M.data, n_columns=40)[0] == FAULTS[1]


def test_unsorted_columns_are_reported_not_refused(twin):
    M = binding()
    a, b = M.indptr[4], M.indptr[5]
    assert b - a >= 2
    M.indices[a:b] = M.indices[a:b][::-1].copy()
    M.data[a:b] = M.data[a:b][::-1].copy()
    assert check(M, row_sum=1.0) == ("", False)
    M.data[0] = np.inf  # a fault is still found beside an unsorted row
    assert check(M, row_sum=1.0) == (FAULTS[3], False)
