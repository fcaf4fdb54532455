"""Tests of the 3D mean value coordinates (hybridedit.binding.mvc)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import trimesh

from hybridedit.binding import mvc
from hybridedit.binding.mvc import mean_value_coordinates
from hybridedit.core.topology import check_closed


# ---------------------------------------------------------------------------
# Cages
# ---------------------------------------------------------------------------


def cube_cage():
    """Axis-aligned cube [-0.5, 0.5]^3, 8 vertices, 12 outward triangles."""
    box = trimesh.creation.box(extents=(1.0, 1.0, 1.0))
    return np.asarray(box.vertices, dtype=float), np.asarray(box.faces, dtype=np.int64)


def sphere_cage(subdivisions=2):
    s = trimesh.creation.icosphere(subdivisions=subdivisions, radius=1.0)
    return np.asarray(s.vertices, dtype=float), np.asarray(s.faces, dtype=np.int64)


def star_cage():
    """A star-shaped, strongly nonconvex closed mesh: an icosphere with bumps."""
    v, f = sphere_cage(2)
    r = 1.0 + 0.45 * np.sin(3 * v[:, 0]) * np.cos(4 * v[:, 1]) + 0.25 * np.sin(5 * v[:, 2])
    return v * r[:, None], f


def voxel_cage(cells):
    """Closed surface of a union of unit cubes (integer corners), outward faces.

    Every exposed unit square becomes two triangles; squares of neighbouring
    cubes share their corners, so the surface is closed and T-junction free.
    """
    cells = {tuple(c) for c in cells}
    index: dict[tuple[int, int, int], int] = {}
    verts: list[tuple[int, int, int]] = []
    faces: list[tuple[int, int, int]] = []

    def vid(p):
        if p not in index:
            index[p] = len(verts)
            verts.append(p)
        return index[p]

    for c in cells:
        for axis in range(3):
            for side in (0, 1):
                nb = list(c)
                nb[axis] += 1 if side else -1
                if tuple(nb) in cells:
                    continue
                u, w = [a for a in range(3) if a != axis]
                corners = []
                for du, dw in ((0, 0), (1, 0), (1, 1), (0, 1)):
                    p = list(c)
                    p[axis] += side
                    p[u] += du
                    p[w] += dw
                    corners.append(tuple(p))
                q = [vid(p) for p in corners]
                tri = [(q[0], q[1], q[2]), (q[0], q[2], q[3])]
                # Orient outward: the normal must point along +-axis.
                a, b, cc = (np.array(verts[i], float) for i in tri[0])
                nrm = np.cross(b - a, cc - a)
                outward = (1 if side else -1) * nrm[axis] > 0
                for t in tri:
                    faces.append(t if outward else (t[0], t[2], t[1]))
    return np.array(verts, dtype=float), np.array(faces, dtype=np.int64)


def l_cage():
    """An L-shaped prism made of three unit cubes (nonconvex, concave edge)."""
    return voxel_cage([(0, 0, 0), (1, 0, 0), (0, 1, 0)])


def bbox_diag(v):
    return float(np.linalg.norm(v.max(axis=0) - v.min(axis=0)))


def signed_volume(v, f):
    p0, p1, p2 = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    return float(np.einsum("ij,ij->i", p0, np.cross(p1, p2)).sum() / 6.0)


def winding_number(p, v, f):
    """Generalized winding number of each point (1 inside, 0 outside).

    Sum of the signed solid angles of the faces (Van Oosterom and Strackee's
    formula) over 4 pi.
    """
    a = v[f[:, 0]][None] - p[:, None]
    b = v[f[:, 1]][None] - p[:, None]
    c = v[f[:, 2]][None] - p[:, None]
    la, lb, lc = (np.linalg.norm(x, axis=2) for x in (a, b, c))
    det = np.einsum("pfi,pfi->pf", a, np.cross(b, c))
    den = (la * lb * lc + np.einsum("pfi,pfi->pf", a, b) * lc
           + np.einsum("pfi,pfi->pf", b, c) * la + np.einsum("pfi,pfi->pf", c, a) * lb)
    return (2.0 * np.arctan2(det, den)).sum(axis=1) / (4.0 * np.pi)


def inside_points(v, f, n, rng):
    """Random points inside a closed, outward oriented mesh."""
    lo, hi = v.min(axis=0), v.max(axis=0)
    out = []
    while sum(len(o) for o in out) < n:
        cand = rng.uniform(lo, hi, size=(4 * n, 3))
        out.append(cand[winding_number(cand, v, f) > 0.5])
    return np.concatenate(out)[:n]


def reference_mvc(x, v, f):
    """Straightforward per-face mean value coordinates (Ju et al. 2005).

    Unit vectors, per-face angles with math.atan2 and the weights
    w_i = (n_i . m) / (n_i . u_i); an independent formulation of the kernel's
    arithmetic, for points away from the cage surface.
    """
    a = v - x
    d = np.linalg.norm(a, axis=1)
    u = a / d[:, None]
    lam = np.zeros(len(v))
    for tri in f:
        uu = u[tri]
        normals = []
        thetas = []
        for k in range(3):
            ua, ub = uu[k], uu[(k + 1) % 3]
            c = np.cross(ua, ub)
            s = np.linalg.norm(c)
            thetas.append(math.atan2(s, float(ua @ ub)))
            normals.append(c / s)
        m = 0.5 * sum(t * n for t, n in zip(thetas, normals))
        for k in range(3):
            n_opp = normals[(k + 1) % 3]  # edge (k+1 -> k+2), opposite vertex k
            w = (n_opp @ m) / (n_opp @ uu[k])
            lam[tri[k]] += w / d[tri[k]]
    return lam / lam.sum()


def check_linear(lam, v, p, tol_rel=1e-8):
    diag = bbox_diag(v)
    np.testing.assert_allclose(lam.sum(axis=1), 1.0, rtol=0, atol=1e-12)
    err = np.abs(lam @ v - p).max()
    assert err <= tol_rel * diag, f"linear precision error {err:.3e} (diag {diag:.3g})"


# ---------------------------------------------------------------------------
# The helpers themselves
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("make", [cube_cage, sphere_cage, star_cage, l_cage])
def test_test_cages_are_closed_and_outward(make):
    v, f = make()
    check_closed(f)
    assert signed_volume(v, f) > 0


# ---------------------------------------------------------------------------
# Arctangent
# ---------------------------------------------------------------------------


def test_atan2_matches_numpy_within_few_ulp():
    rng = np.random.default_rng(7)
    n = 200_000
    y = np.abs(rng.standard_normal(n)) * 10.0 ** rng.uniform(-6, 6, n)
    x = rng.standard_normal(n) * 10.0 ** rng.uniform(-6, 6, n)
    th = rng.uniform(0, np.pi, n)
    y = np.concatenate([y, np.sin(th), [0.0, 0.0, 1.0, 1e-300, 5.0]])
    x = np.concatenate([x, np.cos(th), [1.0, -1.0, 0.0, -1.0, 5.0]])
    got = mvc.atan2_pos_array(y, x)
    ref = np.arctan2(y, x)
    assert np.all((got >= 0) & (got <= np.pi))
    ulp = np.abs(got - ref) / np.spacing(np.maximum(np.abs(ref), 1e-300))
    assert ulp.max() <= 4.0, ulp.max()


# ---------------------------------------------------------------------------
# Partition of unity, linear precision, agreement with the reference
# ---------------------------------------------------------------------------


def test_cube_interior_points():
    v, f = cube_cage()
    rng = np.random.default_rng(0)
    p = rng.uniform(-0.49, 0.49, size=(300, 3))
    lam = mean_value_coordinates(p, v, f)
    assert lam.shape == (300, 8) and lam.dtype == np.float64
    check_linear(lam, v, p)
    # Positivity inside a convex cage.
    assert lam.min() > 0


@pytest.mark.parametrize("make", [cube_cage, lambda: sphere_cage(1), l_cage, star_cage])
def test_agrees_with_reference_formula(make):
    v, f = make()
    rng = np.random.default_rng(3)
    lo, hi = v.min(axis=0), v.max(axis=0)
    p = np.concatenate([
        inside_points(v, f, 12, rng),
        rng.uniform(lo - 1.0, hi + 1.0, size=(8, 3)),  # mostly outside
    ])
    lam = mean_value_coordinates(p, v, f)
    ref = np.array([reference_mvc(x, v, f) for x in p])
    # Outside the cage the coordinates come from cancelling front and back
    # faces and both evaluations lose a few more digits there.
    scale = np.abs(ref).max(axis=1)
    inside = winding_number(p, v, f) > 0.5
    err = np.abs(lam - ref).max(axis=1) / scale
    assert err[inside].max() < 1e-12, err
    assert err[~inside].max() < 1e-9, err


def test_sphere_cage_inside_and_outside():
    v, f = sphere_cage(3)
    rng = np.random.default_rng(1)
    dirs = rng.standard_normal((400, 3))
    dirs /= np.linalg.norm(dirs, axis=1)[:, None]
    r_in = rng.uniform(0.0, 0.95, 200)
    r_out = rng.uniform(1.05, 4.0, 200)
    p_in = dirs[:200] * r_in[:, None]
    p_out = dirs[200:] * r_out[:, None]
    lam_in = mean_value_coordinates(p_in, v, f)
    check_linear(lam_in, v, p_in)
    assert lam_in.min() > 0  # convex cage
    lam_out = mean_value_coordinates(p_out, v, f)
    check_linear(lam_out, v, p_out)
    assert lam_out.min() < 0  # outside, some coordinates must be negative


@pytest.mark.parametrize("make", [star_cage, l_cage])
def test_nonconvex_cages(make):
    v, f = make()
    rng = np.random.default_rng(2)
    p_in = inside_points(v, f, 300, rng)
    lam = mean_value_coordinates(p_in, v, f)
    check_linear(lam, v, p_in)
    lo, hi = v.min(axis=0), v.max(axis=0)
    p_out = rng.uniform(lo - 2.0, hi + 2.0, size=(200, 3))
    check_linear(mean_value_coordinates(p_out, v, f), v, p_out)


def test_l_cage_points_on_and_near_extended_face_planes():
    """Inside the L, the planes x=1 and y=1 of the concave faces cut the interior."""
    v, f = l_cage()
    rng = np.random.default_rng(4)
    n = 60
    yz = rng.uniform(0.05, 0.95, size=(n, 2))
    offsets = [0.0, 1e-14, -1e-14, 1e-11, -1e-10, 1e-9, -1e-7, 1e-5]
    pts = []
    for off in offsets:
        pts.append(np.column_stack([np.full(n, 1.0 + off), yz[:, 0], yz[:, 1]]))  # plane x = 1
        pts.append(np.column_stack([yz[:, 0], np.full(n, 1.0 + off), yz[:, 1]]))  # plane y = 1
    p = np.concatenate(pts)
    lam = mean_value_coordinates(p, v, f)
    assert np.all(np.isfinite(lam))
    check_linear(lam, v, p)
    # Continuity across those planes: the coordinates on either side agree.
    a = mean_value_coordinates(p[:n] + [1e-7, 0, 0], v, f)
    b = mean_value_coordinates(p[:n] - [1e-7, 0, 0], v, f)
    assert np.abs(a - b).max() < 1e-5


# ---------------------------------------------------------------------------
# Points on the cage
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("make", [cube_cage, sphere_cage, l_cage])
def test_points_on_vertices_give_unit_rows(make):
    v, f = make()
    lam = mean_value_coordinates(v, v, f)
    np.testing.assert_array_equal(lam, np.eye(len(v)))
    # A hair away (1e-14 of the size) still snaps to the vertex.
    lam2 = mean_value_coordinates(v + 1e-14 * bbox_diag(v) * np.array([0.3, -0.2, 0.1]), v, f)
    np.testing.assert_array_equal(lam2, np.eye(len(v)))


@pytest.mark.parametrize("make", [cube_cage, sphere_cage, star_cage, l_cage])
def test_points_on_faces_give_barycentric_rows(make):
    v, f = make()
    rng = np.random.default_rng(5)
    sel = rng.choice(len(f), size=min(40, len(f)), replace=False)
    b = rng.dirichlet([2.0, 2.0, 2.0], size=len(sel))
    p = np.einsum("ij,ijk->ik", b, v[f[sel]])
    lam = mean_value_coordinates(p, v, f)
    for row, tri, bb in zip(lam, f[sel], b):
        expect = np.zeros(len(v))
        expect[tri] = bb
        np.testing.assert_allclose(row, expect, rtol=0, atol=1e-12)
        assert np.count_nonzero(row) == 3
    check_linear(lam, v, p, tol_rel=1e-12)


@pytest.mark.parametrize("make", [cube_cage, sphere_cage, star_cage, l_cage])
def test_points_on_edges_give_linear_interpolation(make):
    v, f = make()
    edges = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
    rng = np.random.default_rng(6)
    sel = edges[rng.choice(len(edges), size=min(40, len(edges)), replace=False)]
    t = rng.uniform(0.05, 0.95, size=len(sel))
    p = (1 - t)[:, None] * v[sel[:, 0]] + t[:, None] * v[sel[:, 1]]
    lam = mean_value_coordinates(p, v, f)
    for row, (a, b), tt in zip(lam, sel, t):
        assert set(np.flatnonzero(row)) == {a, b}
        np.testing.assert_allclose([row[a], row[b]], [1 - tt, tt], rtol=0, atol=1e-12)
    check_linear(lam, v, p, tol_rel=1e-12)


@pytest.mark.parametrize("make", [cube_cage, sphere_cage, star_cage])
@pytest.mark.parametrize("side", [-1.0, 1.0])
def test_points_very_close_to_faces(make, side):
    """1e-9 off a face (either side): smooth, near-barycentric, linear precision."""
    v, f = make()
    rng = np.random.default_rng(8)
    sel = rng.choice(len(f), size=min(30, len(f)), replace=False)
    b = rng.dirichlet([3.0, 3.0, 3.0], size=len(sel))
    tri = v[f[sel]]
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    on = np.einsum("ij,ijk->ik", b, tri)
    p = on + side * 1e-9 * bbox_diag(v) * nrm
    lam = mean_value_coordinates(p, v, f)
    check_linear(lam, v, p)
    bary = np.zeros_like(lam)
    for k, t in enumerate(f[sel]):
        bary[k, t] = b[k]
    # The coordinates tend to the barycentric ones as the distance goes to 0.
    assert np.abs(lam - bary).max() < 1e-6


def test_points_near_edges_and_vertices():
    v, f = star_cage()
    diag = bbox_diag(v)
    rng = np.random.default_rng(9)
    edges = np.unique(np.sort(f[:, [0, 1]], axis=1), axis=0)[:30]
    mid = 0.5 * (v[edges[:, 0]] + v[edges[:, 1]])
    pts = []
    for delta in (1e-6, 1e-9, 1e-11):
        d = rng.standard_normal(mid.shape)
        d /= np.linalg.norm(d, axis=1)[:, None]
        pts.append(mid + delta * diag * d)
        pts.append(v[:30] + delta * diag * d)
    p = np.concatenate(pts)
    lam = mean_value_coordinates(p, v, f)
    assert np.all(np.isfinite(lam))
    check_linear(lam, v, p)


# ---------------------------------------------------------------------------
# Invariances
# ---------------------------------------------------------------------------


@pytest.mark.parametrize("make", [cube_cage, star_cage, l_cage])
def test_global_orientation_flip_is_invisible(make):
    v, f = make()
    rng = np.random.default_rng(10)
    lo, hi = v.min(axis=0), v.max(axis=0)
    p = np.concatenate([inside_points(v, f, 50, rng), rng.uniform(lo - 1, hi + 1, (50, 3))])
    a = mean_value_coordinates(p, v, f)
    b = mean_value_coordinates(p, v, f[:, ::-1])
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-13 * np.abs(a).max())


def test_similarity_transform_invariance():
    v, f = star_cage()
    rng = np.random.default_rng(11)
    p = np.concatenate([inside_points(v, f, 80, rng), rng.uniform(-3, 3, (40, 3))])
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    if np.linalg.det(q) < 0:
        q[:, 0] *= -1
    s, t = 37.5, np.array([100.0, -20.0, 3.0])
    a = mean_value_coordinates(p, v, f)
    b = mean_value_coordinates(s * p @ q.T + t, s * v @ q.T + t, f)
    # Rounding the transformed inputs perturbs them by ~1e-16 relative;
    # outside points seeing some face at a grazing angle amplify that more.
    err = np.abs(a - b).max(axis=1) / np.abs(a).max(axis=1)
    assert err[:80].max() < 1e-11, err[:80].max()
    assert err[80:].max() < 1e-8, err[80:].max()


def test_relabelling_cage_vertices_and_faces_permutes_columns():
    v, f = l_cage()
    rng = np.random.default_rng(12)
    p = np.concatenate([inside_points(v, f, 40, rng), rng.uniform(-1, 3, (20, 3))])
    perm = rng.permutation(len(v))  # new vertex k is old vertex perm[k]
    inv = np.argsort(perm)
    v2 = v[perm]
    f2 = inv[f][rng.permutation(len(f))]
    f2 = np.roll(f2, 1, axis=1)  # rotate each face's vertex order too
    a = mean_value_coordinates(p, v, f)
    b = mean_value_coordinates(p, v2, f2)
    np.testing.assert_allclose(b, a[:, perm], rtol=0, atol=1e-13 * np.abs(a).max())


# ---------------------------------------------------------------------------
# Input validation
# ---------------------------------------------------------------------------


def test_rejects_open_or_inconsistent_cages():
    # (the one closedness check, hybridedit.core.topology.check_closed, says why)
    v, f = cube_cage()
    with pytest.raises(ValueError, match="closed, consistently oriented surface: 3 edge.s. are unbalanced"):
        mean_value_coordinates(np.zeros((1, 3)), v, f[1:])
    g = f.copy()
    g[0] = g[0, ::-1]  # one face flipped
    for method in ("exact", "fast"):
        with pytest.raises(ValueError, match="closed, consistently oriented surface"):
            mean_value_coordinates(np.zeros((1, 3)), v, g, method=method)
        with pytest.raises(ValueError, match="repeated vertex index"):
            mean_value_coordinates(np.zeros((1, 3)), v, np.vstack([f, [[0, 0, 1]]]), method=method)


def test_rejects_bad_inputs():
    v, f = cube_cage()
    with pytest.raises(ValueError):
        mean_value_coordinates(np.zeros((2, 2)), v, f)
    with pytest.raises(ValueError):
        mean_value_coordinates(np.array([[0.0, np.nan, 0.0]]), v, f)
    with pytest.raises(ValueError):
        mean_value_coordinates(np.zeros((1, 3)), v, np.zeros((0, 3), dtype=int))
    with pytest.raises(ValueError):
        mean_value_coordinates(np.zeros((1, 3)), v, f + 100)
    with pytest.raises(ValueError):
        mean_value_coordinates(np.zeros((1, 3)), v, f.astype(float))
    assert mean_value_coordinates(np.zeros((0, 3)), v, f).shape == (0, 8)


# ---------------------------------------------------------------------------
# The fast method (exact near field, quadrature far field)
# ---------------------------------------------------------------------------


def sample_points(v, f, rng, n_in=150, n_out=50):
    lo, hi = v.min(axis=0), v.max(axis=0)
    return np.concatenate([inside_points(v, f, n_in, rng), rng.uniform(lo - 1.0, hi + 1.0, (n_out, 3))])


def row_errors(fast, exact):
    """max_j |fast_ij - exact_ij| / sum_j |exact_ij| per row."""
    return np.abs(fast - exact).max(axis=1) / np.abs(exact).sum(axis=1)


@pytest.mark.parametrize("make", [lambda: sphere_cage(3), star_cage, l_cage,
                                  lambda: voxel_cage([(i, j, k) for i in range(4) for j in range(3)
                                                      for k in range(2)])])
def test_fast_agrees_with_exact(make):
    v, f = make()
    rng = np.random.default_rng(20)
    p = sample_points(v, f, rng)
    exact = mean_value_coordinates(p, v, f)
    for ratio, bar in ((mvc.FAR_RATIO, 1e-4), (1.5, 1e-3)):
        fast = mean_value_coordinates(p, v, f, method="fast", far_ratio=ratio)
        assert fast.shape == exact.shape and np.all(np.isfinite(fast))
        # partition of unity and linear precision hold as for the exact ones
        check_linear(fast, v, p)
        err = row_errors(fast, exact)
        assert err.max() <= bar, (ratio, err.max())


def test_fast_far_field_error_falls_with_the_cube_of_distance():
    """All faces far: the rows are the quadrature's, and its error shrinks
    like (face size / distance)^3 (a wrong sign or factor would not)."""
    v, f = sphere_cage(2)
    rng = np.random.default_rng(21)
    d = rng.standard_normal((20, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    errs = []
    for r in (0.5, 0.25, 0.125):  # points at distance r from the centre
        p = r * d
        exact = mean_value_coordinates(p, v, f)
        fast = mean_value_coordinates(p, v, f, method="fast", far_ratio=1.0)
        errs.append(row_errors(fast, exact).max())
    # The distance to the faces goes from 0.5 to 0.875 of the radius: at
    # third order the error falls by (0.875 / 0.5)^3 ~ 5.4 overall, and more
    # since the faces' views shrink too.
    assert errs[0] > errs[1] > errs[2], errs
    assert errs[0] / errs[2] > 4.0, errs
    assert errs[0] < 1e-3, errs


def test_fast_with_infinite_ratio_is_exact():
    v, f = star_cage()
    rng = np.random.default_rng(22)
    p = sample_points(v, f, rng, 60, 30)
    exact = mean_value_coordinates(p, v, f)
    fast = mean_value_coordinates(p, v, f, method="fast", far_ratio=np.inf)
    # The fast method works in coordinates scaled to the cage's diagonal:
    # rounding differs, nothing else (outside, both lose a few more digits).
    err = row_errors(fast, exact)
    assert err[:60].max() < 1e-12 and err[60:].max() < 1e-9, err.max()


@pytest.mark.parametrize("make", [cube_cage, sphere_cage, star_cage, l_cage])
def test_fast_points_on_the_cage(make):
    v, f = make()
    rng = np.random.default_rng(23)
    np.testing.assert_array_equal(mean_value_coordinates(v, v, f, method="fast"), np.eye(len(v)))
    sel = rng.choice(len(f), size=min(40, len(f)), replace=False)
    b = rng.dirichlet([2.0, 2.0, 2.0], size=len(sel))
    tri = v[f[sel]]
    on = np.einsum("ij,ijk->ik", b, tri)
    # with points far from the cage in the same call (other batches' decisions)
    far = v.mean(axis=0) + 3 * bbox_diag(v) * rng.standard_normal((40, 3))
    lam = mean_value_coordinates(np.concatenate([on, far]), v, f, method="fast")
    for row, t, bb in zip(lam[: len(sel)], f[sel], b):
        expect = np.zeros(len(v))
        expect[t] = bb
        np.testing.assert_allclose(row, expect, rtol=0, atol=1e-12)
    check_linear(lam[len(sel):], v, far)
    # a hair off the faces: close to barycentric, smooth
    nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    nrm /= np.linalg.norm(nrm, axis=1)[:, None]
    off = on + 1e-9 * bbox_diag(v) * nrm
    lam = mean_value_coordinates(off, v, f, method="fast")
    check_linear(lam, v, off)
    bary = np.zeros_like(lam)
    for k, t in enumerate(f[sel]):
        bary[k, t] = b[k]
    assert np.abs(lam - bary).max() < 1e-6


def test_fast_points_on_edges():
    v, f = star_cage()
    edges = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
    rng = np.random.default_rng(24)
    sel = edges[rng.choice(len(edges), size=40, replace=False)]
    t = rng.uniform(0.05, 0.95, size=len(sel))
    p = (1 - t)[:, None] * v[sel[:, 0]] + t[:, None] * v[sel[:, 1]]
    lam = mean_value_coordinates(p, v, f, method="fast")
    for row, (a, b), tt in zip(lam, sel, t):
        assert set(np.flatnonzero(row)) == {a, b}
        np.testing.assert_allclose([row[a], row[b]], [1 - tt, tt], rtol=0, atol=1e-12)


def test_fast_invariances():
    v, f = l_cage()
    rng = np.random.default_rng(25)
    p = sample_points(v, f, rng, 40, 20)
    a = mean_value_coordinates(p, v, f, method="fast", far_ratio=1.5)
    # relabelled cage: permuted columns (same faces, so the same decisions)
    perm = rng.permutation(len(v))
    inv = np.argsort(perm)
    b = mean_value_coordinates(p, v[perm], inv[f], method="fast", far_ratio=1.5)
    np.testing.assert_allclose(b, a[:, perm], rtol=0, atol=1e-12 * np.abs(a).max())
    # the orientation of the cage does not matter
    c = mean_value_coordinates(p, v, f[:, ::-1], method="fast", far_ratio=1.5)
    np.testing.assert_allclose(c, a, rtol=0, atol=1e-12 * np.abs(a).max())
    # a similarity transform of everything changes nothing but rounding
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    s, t = 37.5, np.array([100.0, -20.0, 3.0])
    d = mean_value_coordinates(s * p @ q.T + t, s * v @ q.T + t, f, method="fast", far_ratio=1.5)
    assert row_errors(d, a).max() < 1e-9


def test_fast_rejects_bad_arguments():
    v, f = cube_cage()
    with pytest.raises(ValueError, match="method"):
        mean_value_coordinates(np.zeros((1, 3)), v, f, method="quick")
    for bad in (0.99, -2.0, float("nan"), "near"):
        with pytest.raises(ValueError, match="far_ratio"):
            mean_value_coordinates(np.zeros((1, 3)), v, f, method="fast", far_ratio=bad)
    with pytest.raises(ValueError, match="closed"):
        mean_value_coordinates(np.zeros((1, 3)), v, f[1:], method="fast")
    assert mean_value_coordinates(np.zeros((0, 3)), v, f, method="fast").shape == (0, 8)


@pytest.mark.parametrize("make", [cube_cage, sphere_cage, star_cage, l_cage])
def test_rows_on_the_cage_without_the_pass_over_every_face_are_the_flat_kernels(make):
    """``on_cage_truncated`` gives a point on a face, an edge or a vertex the flat kernel's truncated
    row bitwise, and leaves the rows of points off the cage alone."""
    from hybridedit.binding.mvc_flat import compute_fast_truncated, on_cage_truncated
    from hybridedit.binding.truncation import UNDECIDED

    v, f = make()
    rng = np.random.default_rng(25)
    sel = rng.choice(len(f), size=min(30, len(f)), replace=False)
    tri = v[f[sel]]
    on_face = np.einsum("ij,ijk->ik", rng.dirichlet([2.0, 2.0, 2.0], size=len(sel)), tri)
    on_edge = 0.3 * tri[:, 0] + 0.7 * tri[:, 1]
    near_vertex = v + 1e-14 * bbox_diag(v)
    off = v.mean(axis=0) + 0.1 * bbox_diag(v) * rng.standard_normal((10, 3))
    off = np.concatenate([off, on_face[:5] + 1e-3 * bbox_diag(v)])  # (a hair off is off)
    pts = np.concatenate([on_face, on_edge, near_vertex, off])
    fast = mvc.prepare_fast_cage(v, f)
    for t in (0.03, 0.4):
        k, w = len(pts), min(len(v), 16)
        got = (np.full(k, UNDECIDED, dtype=np.int64), np.zeros((k, w), dtype=np.int32), np.zeros((k, w)))
        for i in range(k):  # (one at a time: on these small cages every face is near every point)
            on_cage_truncated(pts[i:i + 1], fast, t, 0.5, got[0][i:i + 1], got[1][i:i + 1], got[2][i:i + 1])
        plan = mvc.plan_fast(np.ascontiguousarray(pts), fast)
        flat = (np.empty(k, dtype=np.int64), np.zeros((k, w), dtype=np.int32), np.zeros((k, w)))
        compute_fast_truncated(plan, fast, 0, k, t, 0.5, *flat)
        row = np.empty(k, dtype=np.int64)
        row[plan.order] = np.arange(k)  # the flat kernel's row of each point
        n_on = len(pts) - len(off)
        assert np.all(got[0][:n_on] >= 1) and np.all(got[0][:n_on] <= 3)
        assert np.all(got[0][n_on:] == UNDECIDED)
        for i in range(n_on):
            n = got[0][i]
            assert n == flat[0][row[i]]
            assert np.array_equal(got[1][i, :n], flat[1][row[i], :n])
            assert np.array_equal(got[2][i, :n], flat[2][row[i], :n])


def test_rows_on_the_cage_are_left_to_the_flat_kernel_when_every_face_is_near():
    """A cage with a face as large as itself: every face is a candidate for every point, more work
    than the flat kernel's pass; nothing is done (the rows stay undecided)."""
    from hybridedit.binding.mvc_flat import on_cage_truncated
    from hybridedit.binding.truncation import UNDECIDED

    v, f = cube_cage()  # 12 faces, each as large as a side of the cube
    fast = mvc.prepare_fast_cage(v, f)
    rng = np.random.default_rng(26)
    pts = np.einsum("ij,ijk->ik", rng.dirichlet([2.0, 2.0, 2.0], size=40), v[f[rng.integers(0, 12, 40)]])
    got = (np.full(40, UNDECIDED, dtype=np.int64), np.zeros((40, 8), dtype=np.int32), np.zeros((40, 8)))
    on_cage_truncated(pts, fast, 0.03, 0.5, *got)  # 40 points x 12 faces > 12 faces x 2 batches
    assert np.all(got[0] == UNDECIDED)
    on_cage_truncated(pts[:1], fast, 0.03, 0.5, *got)  # 12 <= 12 x 1: made
    assert got[0][0] >= 1
