import numpy as np
import pytest
import scipy.sparse as sp

from hybridedit.deform.arap import ARAPSolver, edge_weights, laplacian
from hybridedit.core.linsolve import SPDSolver, cholmod_available
from hybridedit.core.transforms import apply_transform, rigid_transform

from shapes import bumpy_blob, icosphere


def test_cholmod_is_installed():
    # the design factors the cage Laplacian with CHOLMOD; the scipy path is only a fallback
    assert cholmod_available()


@pytest.mark.parametrize("kind", ["uniform", "cotangent"])
def test_weights_and_laplacian(kind):
    m = bumpy_blob(2)
    e, w = edge_weights(m.vertices, m.faces, kind)
    assert len(e) == 3 * m.n_faces // 2  # closed mesh: every edge in two faces
    assert np.all(w > 0)
    if kind == "uniform":
        assert np.all(w == 1)
    L = laplacian(m.n_vertices, e, w)
    assert abs(L - L.T).max() < 1e-14
    assert np.allclose(L @ np.ones(m.n_vertices), 0)


def test_cotangent_weights_on_a_flat_square():
    # two right triangles: the diagonal's opposite angles are 90 deg -> cot 0 -> clamped tiny
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    e, w = edge_weights(v, f, "cotangent")
    d = {tuple(k): x for k, x in zip(e.tolist(), w)}
    assert np.isclose(d[(0, 1)], 0.5)  # one 45 degree angle opposite: cot = 1, halved
    assert 0 < d[(0, 2)] < 1e-2


def test_cotangent_weights_of_a_zero_area_face_are_finite_and_the_solve_too():
    # a pole kept as two copies of one point (as a UV sphere's OBJ has it): the face (0, 1, 2) has no
    # area; its corner at 2 sees the edge 0-1 under a zero angle. The weights stay finite and an ARAP
    # solve with the pole held stays finite too.
    v = np.array([[0, 0, 1], [0, 0, 1], [1, 0, 0], [0, 1, 0], [-1, 0, 0], [0, 0, -1]], float)
    f = np.array([[0, 1, 2], [0, 2, 3], [1, 3, 4], [2, 5, 3], [3, 5, 4], [4, 5, 2], [1, 4, 2]])
    e, w = edge_weights(v, f, "cotangent")
    assert np.all(np.isfinite(w)) and np.all(w > 0)
    s = ARAPSolver(v, f, weights="cotangent")
    s.set_constrained(np.array([0, 1, 5]), moving=np.zeros(0, dtype=np.int64))
    out = s.solve(v[[0, 1, 5]] + [0.0, 0.0, 0.1], iterations=3)
    assert np.all(np.isfinite(out))


def blob_solver(weights="uniform"):
    m = bumpy_blob(2)
    return m, ARAPSolver(m.vertices, m.faces, weights=weights)


def two_ends(m):
    x = m.vertices[:, 0]
    return np.flatnonzero(x < x.min() + 0.3), np.flatnonzero(x > x.max() - 0.3)


@pytest.mark.parametrize("weights", ["uniform", "cotangent"])
def test_rigid_motion_of_all_constraints_is_reproduced(weights):
    m, s = blob_solver(weights)
    a, b = two_ends(m)
    c = np.union1d(a, b)
    s.set_constrained(c)
    T = rigid_transform(translate=(0.3, -1.0, 2.0), axis=(1, 2, 3), degrees=70, center=(0.5, 0, 0))
    for _ in range(60):
        s.solve(apply_transform(T, m.vertices[c]), iterations=10)
    expect = apply_transform(T, m.vertices)
    assert np.abs(s.positions - expect).max() < 1e-8 * m.bbox_diagonal()
    assert s.energy() < 1e-14


def test_no_motion_stays_at_rest():
    m, s = blob_solver()
    a, _ = two_ends(m)
    s.set_constrained(a)
    p = s.solve(m.vertices[a], iterations=3)
    assert np.abs(p - m.vertices).max() < 1e-12


@pytest.mark.parametrize("weights", ["uniform", "cotangent"])
def test_energy_never_increases(weights):
    m, s = blob_solver(weights)
    a, b = two_ends(m)
    c = np.union1d(a, b)
    s.set_constrained(c)
    target = m.vertices[c].copy()
    target[np.isin(c, b)] += [0.0, 1.2, 0.4]
    energies = []
    for _ in range(15):
        s.solve(target, iterations=1)
        energies.append(s.energy())
    assert all(e2 <= e1 * (1 + 1e-9) + 1e-15 for e1, e2 in zip(energies, energies[1:]))
    assert energies[-1] < energies[0]
    # the constrained vertices are exactly where they were put
    assert np.array_equal(s.positions[c], target)


def test_unconstrained_part_is_held_where_it_is():
    a = icosphere(1)
    b = icosphere(1)
    v = np.vstack([a.vertices, b.vertices + 5])
    f = np.vstack([a.faces, b.faces + a.n_vertices])
    s = ARAPSolver(v, f)
    s.set_constrained([0, 1], moving=[0])
    assert s.held.tolist() == list(range(a.n_vertices, len(v)))
    target = v[[0, 1]] + [[0.3, 0.0, 0.0], [0.0, 0.0, 0.0]]
    p = s.solve(target, 5)
    assert np.array_equal(p[s.held], v[s.held])  # the loose part stays
    assert not np.allclose(p[: a.n_vertices], v[: a.n_vertices])  # the constrained part deforms
    s.set_constrained([0, a.n_vertices])  # one in each part: nothing held
    assert s.held.size == 0


def test_links_make_a_part_follow_its_host():
    a = icosphere(1)
    b = icosphere(0)
    v = np.vstack([a.vertices, 0.2 * b.vertices])  # a small ball inside a big one
    f = np.vstack([a.faces, b.faces + a.n_vertices])
    inner = np.arange(a.n_vertices, len(v))
    links = np.stack([inner, np.argmin(np.linalg.norm(a.vertices[None] - v[inner, None], axis=2), axis=1)], 1)
    s = ARAPSolver(v, f, links=links)
    everything_outer = np.arange(a.n_vertices)
    s.set_constrained(everything_outer)
    assert s.held.size == 0
    p = s.solve(v[everything_outer] + [1.0, 2.0, 3.0], 300)
    assert np.allclose(p[inner], v[inner] + [1.0, 2.0, 3.0], atol=1e-6)  # carried along rigidly
    s.set_constrained(everything_outer)
    s2 = ARAPSolver(v, f)  # without links the inner ball is held where it is
    s2.set_constrained(everything_outer)
    assert s2.held.tolist() == inner.tolist()


def test_cholmod_and_scipy_agree():
    m = bumpy_blob(2)
    e, w = edge_weights(m.vertices, m.faces, "cotangent")
    L = laplacian(m.n_vertices, e, w) + sp.eye(m.n_vertices) * 1e-3
    b = np.random.default_rng(0).normal(size=(m.n_vertices, 3))
    x1 = SPDSolver(L, "cholmod").solve(b)
    x2 = SPDSolver(L, "scipy").solve(b)
    assert np.allclose(L @ x1, b, atol=1e-9)
    assert np.allclose(x1, x2, atol=1e-9)


def test_edge_data_given_is_the_same_solver():
    import trimesh as _t

    s = _t.creation.icosphere(subdivisions=2)
    v, f = np.asarray(s.vertices), np.asarray(s.faces)
    made = ARAPSolver(v, f, weights="cotangent")
    given = ARAPSolver(v, f, weights="cotangent", edge_data=edge_weights(v, f, "cotangent"))
    assert np.array_equal(made.edges, given.edges) and np.array_equal(made.w, given.w)
    assert (made.L != given.L).nnz == 0


def test_an_editor_solves_with_its_rigs_cage_weights():
    import hybridedit as he
    from shapes import bumpy_blob

    rig = he.build_rig(bumpy_blob(3), cage_size=80)
    ed = he.HybridEditor(rig)
    e, w = rig.cage_weights
    assert np.array_equal(ed.arap.edges[: len(e)], e) and np.array_equal(ed.arap.w[: len(w)], w)
    assert rig.cage_weights is rig.cage_weights  # made once


def test_a_solve_turns_only_the_rotations_its_global_step_reads():
    # counting, not timing: the rotations inside the handle (all neighbours constrained) are never
    # read, so poisoning them changes nothing, and the solve leaves them as they were; the pose is
    # bit for bit the one of a solver that updates every rotation
    m, s = blob_solver()
    _, full = blob_solver()
    a, _ = two_ends(m)
    b = np.flatnonzero(m.vertices[:, 0] > np.median(m.vertices[:, 0]))  # a big handle
    c = np.union1d(a, b)
    s.set_constrained(c, moving=b)
    full.set_constrained(c, moving=b)
    full.active = np.arange(m.n_vertices)
    L = s.L.tocsr()
    next_to_free = np.zeros(m.n_vertices, dtype=bool)
    next_to_free[L[s.free].indices] = True
    inside = np.flatnonzero(~next_to_free)  # constrained, every neighbour constrained
    assert inside.size > 0.2 * m.n_vertices
    assert np.array_equal(s.active, np.flatnonzero(next_to_free))
    poisoned = s.rotations.copy()
    poisoned[inside] = np.nan
    s.set_rotations(poisoned)
    T = rigid_transform(translate=(0.2, 0.4, 0.0), axis=(0, 0, 1), degrees=40, center=m.vertices[b].mean(0))
    target = m.vertices[c].copy()
    target[np.isin(c, b)] = apply_transform(T, m.vertices[b])
    for _ in range(5):
        s.solve(target, iterations=2)
        full.solve(target, iterations=2)
    assert np.array_equal(s.positions, full.positions)
    assert np.all(np.isnan(s.rotations[inside]))
    assert np.array_equal(s.rotations[s.active], full.rotations[s.active])


def test_a_solve_given_slots_moves_only_those_and_equals_a_full_solve():
    m, s = blob_solver()
    _, full = blob_solver()
    a, b = two_ends(m)
    c = np.union1d(a, b)
    for solver in (s, full):
        solver.set_constrained(c, moving=b)
    slots = np.flatnonzero(np.isin(c, b))
    T = rigid_transform(translate=(0.1, 0.3, 0.0), axis=(1, 0, 0), degrees=20, center=m.vertices[b].mean(0))
    target = m.vertices[c].copy()
    target[slots] = apply_transform(T, m.vertices[b])
    for _ in range(3):
        s.solve(target[slots], iterations=2, slots=slots)
        full.solve(target, iterations=2)
    assert np.array_equal(s.positions, full.positions)
    with pytest.raises(ValueError, match="expected"):
        s.solve(target, slots=slots)
    with pytest.raises(ValueError, match="slots"):
        s.solve(target[:1], slots=[len(c)])


def test_the_local_step_is_each_covariances_closest_rotation_on_either_twin():
    # the rotations are turned in lanes (core.rotations.polar_lanes): bit for bit the closest
    # rotation of each vertex's covariance taken one at a time, on one thread or two, for rows in
    # any order and a last block that is not full
    from hybridedit.core.rotations import closest_rotation
    from hybridedit.deform.arap import _local_step_twins

    m, s = blob_solver("cotangent")
    rng = np.random.default_rng(5)
    cur = m.vertices @ rigid_transform(axis=(1, 1, 0), degrees=30)[:3, :3].T + 0.05 * rng.normal(size=m.vertices.shape)
    rows = rng.permutation(m.n_vertices)[: m.n_vertices - 7]
    ref = np.full((m.n_vertices, 3, 3), 7.0)
    L = sp.csr_matrix(s.L)
    for i in rows:
        a = np.zeros((3, 3))
        for j in L.indices[L.indptr[i]:L.indptr[i + 1]]:
            if j != i:
                a += -L[i, j] * np.outer(cur[i] - cur[j], m.vertices[i] - m.vertices[j])
        closest_rotation(a, ref[i])
    from numba import njit

    from hybridedit.deform.arap import _covariance_of

    @njit
    def one_at_a_time(rest, cur, indptr, indices, wts, rots, rows):
        for i in rows:
            _covariance_of(i, rest, cur, indptr, indices, wts, rots[i])
            closest_rotation(rots[i], rots[i])

    exact = np.full((m.n_vertices, 3, 3), 7.0)
    one_at_a_time(s.reference, cur, s._indptr, s._indices, s._wts, exact, rows)
    assert np.abs(exact - ref).max() < 1e-12
    for twin in _local_step_twins:
        out = np.full((m.n_vertices, 3, 3), 7.0)  # rows not asked for are not written
        twin(s.reference, cur, s._indptr, s._indices, s._wts, out, rows)
        assert np.array_equal(out, exact)
