import numpy as np
from scipy.spatial.transform import Rotation

from hybridedit.core.rotations import closest_rotation, closest_rotations


def svd_rotation(a):
    u, s, vt = np.linalg.svd(a)
    r = u @ vt
    if np.linalg.det(r) < 0:
        u[:, 2] *= -1
        r = u @ vt
    return r


def test_matches_svd_on_general_matrices():
    rng = np.random.default_rng(1)
    a = rng.normal(size=(500, 3, 3))  # about half are reflections (det < 0)
    out = np.empty_like(a)
    closest_rotations(a, out)
    ref = np.array([svd_rotation(m) for m in a])
    assert np.abs(out - ref).max() < 1e-10
    assert np.allclose(np.linalg.det(out), 1.0)


def test_near_rotations_and_scaled_rotations():
    rng = np.random.default_rng(2)
    R = Rotation.random(300, random_state=3).as_matrix()
    a = R @ (np.eye(3) + 0.05 * rng.normal(size=(300, 3, 3))) * 1e-4  # tiny scale must not matter
    out = np.empty_like(a)
    closest_rotations(a, out)
    ref = np.array([svd_rotation(m) for m in a])
    assert np.abs(out - ref).max() < 1e-12
    # an exact rotation is its own closest rotation
    closest_rotations(R.copy(), out)
    assert np.abs(out - R).max() < 1e-14


def test_degenerate_inputs():
    out = np.empty((3, 3))
    closest_rotation(np.zeros((3, 3)), out)
    assert np.allclose(out, np.eye(3))
    rank1 = np.outer([1.0, 2.0, 3.0], [0.5, -1.0, 2.0])
    closest_rotation(rank1, out)
    assert np.allclose(out @ out.T, np.eye(3), atol=1e-12)
    assert np.isclose(np.linalg.det(out), 1.0)
    # it still maximizes trace(R^T a) as well as the SVD answer does
    assert np.trace(out.T @ rank1) >= np.trace(svd_rotation(rank1).T @ rank1) - 1e-12


def near_planar(k, seed):
    """ARAP covariances of near-planar vertex rings, as a QEM cage has them: singular values
    (1, ~0.7, ~1e-3..1e-9), turned, half of them reflections (det < 0)."""
    rng = np.random.default_rng(seed)
    U = Rotation.random(k, random_state=seed).as_matrix()
    V = Rotation.random(k, random_state=seed + 1).as_matrix()
    s = np.stack([np.ones(k), 0.4 + 0.5 * rng.random(k), 10.0 ** rng.uniform(-9, -3, k)], axis=1)
    s[: k // 2, 2] *= -1.0
    return np.einsum("kij,kj,klj->kil", U, s, V) * 10.0 ** rng.uniform(-8, 2, (k, 1, 1))


def test_near_planar_rings_and_reflections_match_svd():
    a = near_planar(2000, 4)
    out = np.empty_like(a)
    closest_rotations(a, out)
    ref = np.array([svd_rotation(m) for m in a])
    assert np.abs(out - ref).max() < 1e-9
    assert np.abs(np.einsum("kji,kjl->kil", out, out) - np.eye(3)).max() < 1e-14
    assert np.all(np.abs(np.linalg.det(out) - 1.0) < 1e-14)


def test_the_jacobi_decomposition_alone_matches_svd_on_general_matrices():
    from numba import njit

    from hybridedit.core.rotations import _rotation_jacobi

    @njit
    def jacobi_all(a, out):
        for k in range(a.shape[0]):
            _rotation_jacobi(a[k], out[k])

    rng = np.random.default_rng(5)
    a = np.concatenate([rng.normal(size=(1000, 3, 3)), near_planar(1000, 6)])
    out = np.empty_like(a)
    jacobi_all(a, out)
    ref = np.array([svd_rotation(m) for m in a])
    assert np.abs(out - ref).max() < 1e-9
    # in place, as the local step calls it
    b = a.copy()
    jacobi_all(b, b)
    assert np.array_equal(b, out)


def _one_at_a_time(a):
    from numba import njit

    @njit
    def each(a, out):
        for k in range(a.shape[0]):
            closest_rotation(a[k], out[k])

    out = np.empty_like(a)
    each(a, out)
    return out


def test_rotations_in_lanes_are_bitwise_the_ones_taken_one_at_a_time():
    from hybridedit.core.rotations import LANES

    rng = np.random.default_rng(7)
    general = rng.normal(size=(3 * LANES + 5, 3, 3))  # a last block of 5 lanes; reflections among them
    general[::7] = 0.0  # zero matrices (the identity) in the middle of blocks
    slow = rng.normal(size=(LANES, 3, 3))
    slow[:, 0] *= 1e-4  # ill-conditioned lanes needing more steps than their block's others
    a = np.concatenate([general, near_planar(2 * LANES + 1, 9), slow, Rotation.random(3, random_state=2).as_matrix()])
    ref = _one_at_a_time(a)
    out = np.empty_like(a)
    closest_rotations(a, out)
    assert np.array_equal(out, ref)
    inplace = a.copy()
    closest_rotations(inplace, inplace)
    assert np.array_equal(inplace, ref)


def test_polar_lanes_solves_only_the_lanes_not_done():
    from hybridedit.core.rotations import LANES, polar_lanes

    rng = np.random.default_rng(3)
    m = rng.normal(size=(LANES, 3, 3))
    m[np.linalg.det(m) < 0, 0] *= -1.0  # polar factors are the closest rotations
    x = np.ascontiguousarray(m.reshape(LANES, 9).T)
    done = np.zeros(LANES)
    done[1] = 1.0  # left as it is
    polar_lanes(x, done, 4)  # and lanes 4.. are not in use
    assert np.all(done[:4] == 1.0)
    ref = _one_at_a_time(m[:4])
    for lane in (0, 2, 3):
        assert np.array_equal(x[:, lane].reshape(3, 3), ref[lane])
    assert np.array_equal(x[:, 1], m[1].ravel())
    assert np.array_equal(x[:, 4:], m[4:].reshape(-1, 9).T)
