"""Tests of the hierarchical kernel (hybridedit.binding.mvc_tree) through bind(method="fast")."""

from __future__ import annotations


import numpy as np
import pytest
import trimesh

from hybridedit.binding import mvc_layout

from hybridedit.binding import mvc_tree, tree_cage
from hybridedit.binding.bind import bind
from hybridedit.core.mesh import Mesh
from hybridedit.binding.mvc import mean_value_coordinates

from shapes import SHARED_MESHES

T = 0.03
ARMADILLO = SHARED_MESHES / "armadillo43k.obj"


def sphere(subdiv, radius=1.0, center=(0.0, 0.0, 0.0)):
    s = trimesh.creation.icosphere(subdivisions=subdiv, radius=radius)
    return np.asarray(s.vertices) + np.asarray(center), np.asarray(s.faces)


def bumpy(v, amp=0.15):
    r = 1.0 + amp * np.sin(4 * v[:, 0]) * np.sin(3 * v[:, 1] + 1.0) * np.cos(2 * v[:, 2])
    return v * r[:, None]


def hat_weights(verts, faces, star_vertices, x, levels=3):
    """sum_j W_j(x) over the given vertices by a fine centroid rule (numpy reference)."""
    # barycentric centroids of a regular 4^levels subdivision of the triangle
    n = 2**levels
    pts = []
    for i in range(n):
        for j in range(n - i):
            pts.append(((i + 1 / 3) / n, (j + 1 / 3) / n))
            if i + j < n - 1:
                pts.append(((i + 2 / 3) / n, (j + 2 / 3) / n))
    b = np.array(pts)
    bary = np.column_stack([1 - b.sum(axis=1), b])  # (q, 3)
    want = np.zeros(len(verts), bool)
    want[star_vertices] = True
    total = 0.0
    for f in faces[want[faces].any(axis=1)]:
        p = bary @ verts[f]
        nrm = np.cross(verts[f[1]] - verts[f[0]], verts[f[2]] - verts[f[0]])
        area = 0.5 * np.linalg.norm(nrm)
        nrm /= 2 * area
        d = p - x
        k = (d @ nrm) / np.einsum("ij,ij->i", d, d) ** 2
        phi = bary[:, want[f]].sum(axis=1)
        total += area * np.mean(phi * k)
    return total


def test_node_expansion_error_falls_like_the_cube_of_distance():
    v, f = sphere(3)
    v = bumpy(v, 0.1)
    fast = mvc_layout.prepare_fast_cage(v, f)
    tree = tree_cage.prepare_tree_cage(fast)
    verts = fast.verts_t.T
    faces = fast.far_idx[:, :3].astype(np.int64)
    # a node of a few dozen vertices
    sizes = tree.hi - tree.lo
    k = int(np.flatnonzero((sizes >= 20) & (sizes <= 40))[0])
    c, r = tree.geo[k, :3], tree.geo[k, 3]
    members = tree.order[tree.lo[k]:tree.hi[k]]
    direction = tree.geo[k, 4:7] + np.array([0.3, -0.2, 0.1])
    direction /= np.linalg.norm(direction)
    errs = []
    for ratio in (0.4, 0.2, 0.1):
        x = c + r / ratio * direction
        want = hat_weights(verts, faces, members, x)
        got = mvc_tree._node_total(tree.mom, k, *(c - x))
        errs.append(abs(got - want) / abs(want))
    assert errs[0] < 0.05, errs
    assert errs[1] < errs[0] / 4 and errs[2] < errs[1] / 4, errs


def shapes():
    """(name, points, cage) cases: closed, open, several parts, on/near the cage, far away.

    The shapes lie close to their cages (about an edge length away), as a
    scan does to its 5% cage: there rows keep a handful of entries and the
    far field is what the truncation drops.
    """
    cv, cf = sphere(4, radius=1.06)
    sv, _ = sphere(5)
    closed = bumpy(sv, 0.02)
    open_patch = closed[closed[:, 2] > 0.2]  # an open surface's vertices
    cage = Mesh(cv, cf)
    # two parts: two cages, points in both
    a_v, a_f = sphere(3, radius=1.06, center=(-1.5, 0, 0))
    b_v, b_f = sphere(3, radius=1.06, center=(1.5, 0, 0))
    two = Mesh(np.vstack([a_v, b_v]), np.vstack([a_f, b_f + len(a_v)]))
    s2, _ = sphere(4)
    two_pts = np.vstack([bumpy(s2, 0.02) + (-1.5, 0, 0), bumpy(s2, 0.02) + (1.5, 0, 0)])
    # on and near the cage (faces, edges, vertices), and far outside
    rng = np.random.default_rng(5)
    sel = rng.choice(len(cf), 40, replace=False)
    bc = rng.dirichlet([2, 2, 2], size=40)
    on = np.einsum("ij,ijk->ik", bc, cv[cf[sel]])
    nrm = np.cross(cv[cf[sel, 1]] - cv[cf[sel, 0]], cv[cf[sel, 2]] - cv[cf[sel, 0]])
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    near = np.vstack([on + 1e-9 * nrm, on - 1e-6 * nrm, on - 1e-3 * nrm, cv[:20] * (1 - 1e-7)])
    far = rng.standard_normal((30, 3))
    far *= rng.uniform(2.0, 20.0, (30, 1)) / np.linalg.norm(far, axis=1)[:, None]
    return [
        ("closed", closed[::3], cage),
        ("open", open_patch[::2], cage),
        ("two parts", two_pts[::2], two),
        ("on and near the cage", np.vstack([on, near, closed[::20]]), cage),
        ("far away", np.vstack([far, closed[::20]]), cage),
    ]


def kept_sets(M):
    return [tuple(M.indices[M.indptr[i]:M.indptr[i + 1]]) for i in range(M.shape[0])]


@pytest.mark.slow
@pytest.mark.parametrize("case", shapes(), ids=lambda c: c[0])
def test_hierarchical_rows_against_exact(case):
    _, pts, cage = case
    M = bind(pts, cage, truncation=T, method="fast", max_row=None)
    Mf = bind(pts, cage, truncation=T, method="flat", max_row=None)
    Me = bind(pts, cage, truncation=T, method="exact", max_row=None)
    E = mean_value_coordinates(pts, cage.vertices, cage.faces)
    n = len(pts)
    assert M.shape == Me.shape and M.has_sorted_indices
    np.testing.assert_allclose(np.asarray(M.sum(axis=1)).ravel(), 1.0, rtol=0, atol=1e-12)
    mag = np.abs(E).sum(axis=1)
    for i in range(n):
        cols = M.indices[M.indptr[i]:M.indptr[i + 1]]
        # at least 97% of the row's magnitude is kept (to the exact rows' 1e-5)
        assert np.abs(E[i, cols]).sum() >= (1 - T - 1e-5) * mag[i], i
        # what is dropped is no larger than what is kept
        dropped = np.setdiff1d(np.arange(cage.n_vertices), cols)
        if len(dropped) and len(cols):
            assert np.abs(E[i, dropped]).max() <= np.abs(E[i, cols]).min() + 1e-5 * mag[i], i
    ks, kf, ke = kept_sets(M), kept_sets(Mf), kept_sets(Me)
    same_f = np.array([a == b for a, b in zip(ks, kf)])
    same_e = np.array([a == b for a, b in zip(ks, ke)])
    # Mostly the same entries as the exact truncation (these round shapes
    # keep hundreds of entries a row, many at the threshold, where the flat
    # kernel's own quadrature flips entries too)...
    jac = np.mean([len(set(a) & set(b)) / len(set(a) | set(b)) for a, b in zip(ks, ke)])
    assert jac >= 0.97, jac
    assert same_e.mean() >= 0.7 and same_f.mean() >= 0.7, (same_e.mean(), same_f.mean())
    # ...and then the same values, to the flat kernel's accuracy. (The worst rows keep hundreds of
    # entries, points deep inside these round cages: their values carry the error of the far field's
    # aggregated total, which depends on the batch a point falls in, 0.8e-4 to 1.1e-4 here.)
    for same, other in ((same_f, Mf), (same_e, Me)):
        rows = np.flatnonzero(same)
        d = abs(M[rows] - other[rows]).max(axis=1).toarray().ravel()
        assert d.max() <= 1.5e-4, d.max()
    # the reconstruction error is the truncation's
    err = np.linalg.norm(M @ cage.vertices - pts, axis=1)
    err_e = np.linalg.norm(Me @ cage.vertices - pts, axis=1)
    assert np.sqrt(np.mean(err**2)) <= 1.1 * np.sqrt(np.mean(err_e**2)) + 1e-12


@pytest.mark.skipif(not ARMADILLO.exists(), reason=f"{ARMADILLO} not available")
def test_most_rows_of_a_scan_are_decided_by_the_hierarchy():
    """The kernel itself (no fallback) on the armadillo with a 2,000-vertex
    cage: nearly every row is decided with the far field in aggregate, and
    a much smaller opening ratio (far more vertices opened, a more accurate
    far field) mostly keeps the same entries (the rest differ at the
    threshold, where the aggregated mass decides)."""
    import fast_simplification

    m = trimesh.load(ARMADILLO, process=False)
    v = np.asarray(m.vertices, dtype=float)
    f = np.asarray(m.faces, dtype=np.int64)
    cv, cf = fast_simplification.simplify(v, f, target_reduction=1.0 - 2000.0 / len(v))
    pts = np.ascontiguousarray(v[::10])
    fast = mvc_layout.prepare_fast_cage(cv, cf)
    tree = tree_cage.prepare_tree_cage(fast)
    plan = mvc_layout.plan_fast(pts, fast)
    n = len(pts)
    out = []
    for theta in (mvc_tree.THETA, 0.1):
        counts = np.empty(n, np.int64)
        cols = np.empty((n, 256), np.int32)
        mvc_tree.compute_tree_truncated(plan, tree, 0, n, T, 0.5, counts, cols, np.empty((n, 256)),
                                        3.0, mvc_tree.tree_scratch(tree, 2), theta=theta)
        out.append((counts, cols))
    counts = out[0][0]
    assert np.mean(counts > 0) >= 0.7, np.mean(counts > 0)
    both = np.flatnonzero((counts > 0) & (out[1][0] > 0))
    same = [np.array_equal(out[0][1][i, :counts[i]], out[1][1][i, :out[1][0][i]]) for i in both]
    assert np.mean(same) >= 0.75, np.mean(same)


def test_points_at_cage_vertices_and_next_to_face_planes_stay_off_the_flat_kernel(monkeypatch):
    """A point at a cage vertex (a simplification keeps some of the shape's vertices) gets the
    unit row of that vertex, and a point next to a near face's plane takes the flat kernel's rules
    for that face inside the hierarchical kernel: neither costs a pass over every cage face."""
    import hybridedit.binding.bind as B

    cv, cf = sphere(3, radius=1.06)
    cage = Mesh(bumpy(cv, 0.05), cf)
    rng = np.random.default_rng(3)
    sel = rng.choice(len(cf), 60, replace=False)
    v = cage.vertices
    nrm = np.cross(v[cf[sel, 1]] - v[cf[sel, 0]], v[cf[sel, 2]] - v[cf[sel, 0]])
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    inside = np.einsum("ij,ijk->ik", rng.dirichlet([2, 2, 2], size=60), v[cf[sel]]) - 1e-10 * nrm
    # in a face's plane (to 1e-13), beyond one of its edges, inside the cage
    edge_mid = 0.5 * (v[cf[sel, 0]] + v[cf[sel, 1]])
    beyond = edge_mid + 0.05 * (edge_mid - v[cf[sel, 2]])
    beyond -= ((beyond - v[cf[sel, 0]]) * nrm).sum(axis=1)[:, None] * nrm + 1e-13 * nrm
    interior = bumpy(np.asarray(trimesh.creation.icosphere(subdivisions=3).vertices), 0.02)
    pts = np.vstack([v, inside, beyond, interior])
    flat_rows = []
    real = B._fast_truncated_chunk

    def counting(plan, fast, ratio, scratch, t, start, stop, *bufs):
        flat_rows.append(stop - start)
        return real(plan, fast, ratio, scratch, t, start, stop, *bufs)

    monkeypatch.setattr(B, "_fast_truncated_chunk", counting)
    M = bind(pts, cage, truncation=T, method="fast", max_row=None)
    monkeypatch.undo()
    at_vertex = M[: len(v)]
    assert np.array_equal(at_vertex.indices, np.arange(len(v))) and np.all(at_vertex.data == 1.0)
    Mf = bind(pts, cage, truncation=T, method="flat", max_row=None)
    ks, kf = kept_sets(M), kept_sets(Mf)
    same = np.flatnonzero([a == b for a, b in zip(ks, kf)])
    assert same.size >= 0.9 * len(pts)
    assert abs(M[same] - Mf[same]).max() <= 1e-4
    assert sum(flat_rows) <= 0.02 * len(pts), sum(flat_rows)


def test_plan_groups_batches_only_near_points_and_finds_each_points_row():
    from hybridedit.binding.mvc_layout import LANES, plan_groups, prepare_fast_cage

    cv, cf = sphere(2, radius=1.0)
    fast = prepare_fast_cage(cv, cf)
    rng = np.random.default_rng(4)
    clusters = rng.uniform(-0.5, 0.5, (5, 3))
    pts = np.vstack([c + 0.01 * rng.normal(size=(int(n), 3)) for c, n in zip(clusters, (3, 40, 1, 70, 9))])
    pts = pts[rng.permutation(len(pts))]
    radius = 0.1 / fast.unit  # (the plan's unit box)
    plan, position = plan_groups(pts, fast, radius)
    nb = plan.bx.shape[0]
    assert plan.order.shape == (nb * LANES,) and plan.bsph.shape == (nb, 4)
    # each point's position holds it, and every lane of a batch holds a point of its own cluster
    lanes = plan.bx.transpose(0, 2, 1).reshape(-1, 3)
    assert np.allclose(lanes[position] * fast.unit + fast.origin, pts)
    assert np.array_equal(plan.order[position], np.arange(len(pts)))
    label = np.argmin(np.linalg.norm(pts[:, None] - clusters[None], axis=2), axis=1)
    assert all(len(set(label[plan.order[b * LANES:(b + 1) * LANES]])) == 1 for b in range(nb))
    assert nb == sum(-(-n // LANES) for n in (3, 40, 1, 70, 9))  # 1 + 2 + 1 + 3 + 1
    # spheres hold their lanes and are at least the radius given
    d = np.linalg.norm(plan.bx - plan.bsph[:, :3, None], axis=1).max(axis=1)
    assert np.all(d <= plan.bsph[:, 3] + 1e-12) and np.all(plan.bsph[:, 3] >= radius)


@pytest.mark.parametrize("h", [1e-6, 0.3, 40.0])
def test_batch_quadratic_reproduces_any_quadratic(h):
    """The far nodes' ten-point fit is exact for a quadratic: its values at the stencil scaled by
    ``h`` about a centre give back the quadratic at every point of the sphere (and a cubic's
    remainder shrinks like h^3)."""
    rng = np.random.default_rng(7)
    c = rng.normal(size=3) * 5.0
    a0, g, H = rng.normal(), rng.normal(size=3), rng.normal(size=(3, 3))
    H = H + H.T

    def quad(p):
        y = p - c
        return a0 + y @ g + 0.5 * np.einsum("...i,ij,...j->...", y, H, y)

    stencil = c + h * mvc_tree._STENCIL.T
    S = quad(stencil)
    dirs = rng.normal(size=(32, 3))
    X = c + h * rng.uniform(0, 1, size=(32, 1)) * dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    acc = np.full(32, 2.5)
    mvc_tree._add_quadratic(S, h, np.ascontiguousarray(X.T), c[0], c[1], c[2], acc)
    scale = abs(a0) + np.abs(g).sum() * h + np.abs(H).sum() * h * h
    assert np.abs(acc - 2.5 - quad(X)).max() <= 1e-12 * scale


def test_batch_quadratic_of_a_far_field_is_close():
    """Fitted to 1 / |p - C|^3 (a far node's decay) at a batch of radius LOCAL_RATIO |C - c|, the
    quadratic is within 20 (R / d)^3 of it at the batch's points, and the error falls like the
    cube of the radius."""
    C = np.array([10.0, -3.0, 4.0])
    c = np.zeros(3)
    d = np.linalg.norm(C - c)

    def field(p):
        return 1.0 / np.linalg.norm(p - C, axis=-1) ** 3

    rng = np.random.default_rng(3)
    dirs = rng.normal(size=(32, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    errs = []
    for ratio in (mvc_tree.LOCAL_RATIO, 0.1 * mvc_tree.LOCAL_RATIO):
        h = ratio * d
        X = c + h * dirs
        acc = np.zeros(32)
        mvc_tree._add_quadratic(field(c + h * mvc_tree._STENCIL.T), h, np.ascontiguousarray(X.T), 0.0, 0.0, 0.0, acc)
        errs.append(np.abs(acc / field(X) - 1.0).max())
    assert errs[0] <= 20 * mvc_tree.LOCAL_RATIO ** 3
    assert errs[1] <= errs[0] * 2e-3
