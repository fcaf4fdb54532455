"""SelectionRows: a selection's rows propagated from their own copy give what the whole binding gives."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.spatial.transform import Rotation

from hybridedit.deform.propagate import propagate
from hybridedit.deform.residual import SelectionRows, propagate_with_residual, residual_setup


def _binding(n: int, c: int, seed: int):
    rng = np.random.default_rng(seed)
    cols = np.stack([rng.choice(c, 5, replace=False) for _ in range(n)])
    vals = rng.random((n, 5)) + 0.1
    M = sp.csr_matrix((vals.ravel() / np.repeat(vals.sum(1), 5), (np.repeat(np.arange(n), 5), cols.ravel())),
                      shape=(n, c))
    cage = rng.normal(size=(c, 3))
    points = M @ cage + 0.05 * rng.normal(size=(n, 3))
    y = cage + 0.2 * rng.normal(size=(c, 3))
    rots = Rotation.random(c, random_state=seed).as_matrix()
    return M, points, cage, y, rots


@pytest.mark.parametrize("residual", [True, False])
@pytest.mark.parametrize("fraction", [0.1, 0.9])  # copied out, and propagated in place
def test_selection_rows_equal_the_whole_propagation(residual, fraction):
    M, points, cage, y, rots = _binding(400, 40, seed=int(fraction * 10) + residual)
    res = residual_setup(M, points, cage) if residual else None
    rows = np.sort(np.random.default_rng(1).choice(400, int(fraction * 400), replace=False))
    sel = SelectionRows(M, rows, res)
    assert (sel._part is not None) == (fraction <= 0.5)
    if sel._part is not None:  # the binding's index type: no second compiled version of the kernels
        assert sel._part[0].indptr.dtype == M.indptr.dtype and sel._part[0].indices.dtype == M.indices.dtype
    out = np.full((400, 3), 7.0)
    sel.run(y, rots, out)
    want = propagate_with_residual(M, y, rots, *res) if residual else propagate(M, y)
    assert np.allclose(out[rows], want[rows], rtol=0, atol=1e-12)
    others = np.setdiff1d(np.arange(400), rows)
    assert np.all(out[others] == 7.0)  # only the selection's rows are written
