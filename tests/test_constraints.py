import numpy as np
import scipy.sparse as sp

from hybridedit.arap import edge_weights, laplacian
from hybridedit.constraints import SeamSpread

from shapes import icosphere


def path_laplacian(n):
    e = np.stack([np.arange(n - 1), np.arange(1, n)], 1)
    return laplacian(n, e, np.ones(n - 1))


def test_the_correction_is_harmonic_between_its_boundaries():
    # a path 0..10: vertex 0 is the seam (correction 1), vertex 10 does not move
    s = SeamSpread(path_laplacian(11), np.arange(1, 10), np.array([0]))
    c = s.correction(np.array([[1.0, 2.0, -1.0]]))
    assert np.allclose(c[:, 0], 1 - np.arange(1, 10) / 10)  # linear: harmonic on a path
    assert np.allclose(c[:, 1], 2 * c[:, 0]) and np.allclose(c[:, 2], -c[:, 0])


def test_the_correction_is_smooth_on_a_surface_and_bounded_by_the_seam():
    m = icosphere(3)
    e, w = edge_weights(m.vertices, m.faces, "cotangent")
    L = laplacian(m.n_vertices, e, w)
    z = m.vertices[:, 2]
    seam = np.flatnonzero(np.abs(z) < 0.05)
    free = np.flatnonzero((z > 0.05) & (z < 0.8))  # above the seam, below a still cap
    mismatch = np.c_[m.vertices[seam, 0], np.zeros((seam.size, 2))] * 0.1
    c = SeamSpread(L, free, seam).correction(mismatch)
    assert np.abs(c).max() <= np.abs(mismatch).max() + 1e-12  # maximum principle
    near = z[free] < 0.2
    far = z[free] > 0.7
    assert np.abs(c[near]).mean() > 3 * np.abs(c[far]).mean()  # fades away from the seam


def test_a_free_part_with_no_boundary_gets_no_correction():
    L = sp.block_diag([path_laplacian(4), path_laplacian(3)]).tocsr()
    s = SeamSpread(L, np.array([1, 2, 4, 5, 6]), np.array([0]))
    c = s.correction(np.array([[1.0, 0, 0]]))
    assert np.allclose(c[2:], 0.0, atol=1e-6) and c[0, 0] > 0.5


def test_empty_seam():
    s = SeamSpread(path_laplacian(3), np.arange(3), np.zeros(0, dtype=np.int64))
    assert s.correction(np.zeros((0, 3))).shape == (3, 3)


def test_a_large_region_is_solved_in_a_band_around_the_seam(monkeypatch):
    import hybridedit.constraints as C
    from hybridedit import HybridEditor
    from hybridedit.transforms import apply_transform, rigid_transform

    from shapes import bumpy_blob

    blob = bumpy_blob(4)
    x = blob.vertices
    ed = HybridEditor(blob, cage_size=300)
    handle, fixed = np.flatnonzero(x[:, 0] > 1.6), np.flatnonzero(x[:, 0] < -1.0)
    monkeypatch.setattr(C, "REGION_WHOLE_MAX", 100)
    ed.set_selection(handle, fixed=fixed)
    sel = ed._sel
    solved = sel.spread.free
    assert 0 < solved.size < sel.rows.size  # a band, not the whole region
    d = np.linalg.norm(x[solved][:, None] - x[sel.seam][None], axis=2).min(axis=1)
    assert d.max() <= C.BAND_CAGE_EDGES * ed._cage_edge + 1e-12
    T = rigid_transform(translate=(0, 0.4, 0.1), axis=(0, 0, 1), degrees=20, center=x[handle].mean(0))
    for _ in range(5):
        V = ed.drag(transform=T)
    assert np.abs(V[fixed] - x[fixed]).max() < 1e-12
    assert np.allclose(V[handle], apply_transform(T, x[handle]), atol=1e-12)
    # the inside of the region follows the cage: exactly the propagation there
    inside = np.setdiff1d(sel.rows, solved)
    d, idx, w = ed._residual
    from hybridedit.residual import propagate_with_residual

    full = propagate_with_residual(ed.M, ed.arap.positions, ed._rots, d, idx, w)
    assert np.abs(V[inside] - full[inside]).max() < 1e-12
