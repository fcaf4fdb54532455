"""Property tests: mean value coordinates and ARAP on randomly generated closed meshes."""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from scipy.spatial import ConvexHull
import trimesh

from hybridedit.deform.arap import ARAPSolver
from hybridedit.binding.bind import bind
from hybridedit.core.mesh import Mesh
from hybridedit.binding.mvc import mean_value_coordinates
from hybridedit.core.transforms import rigid_transform

SETTINGS = settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
_ICO = trimesh.creation.icosphere(subdivisions=1)


def convex_hull_mesh(rng: np.random.Generator, n: int) -> Mesh:
    """The convex hull of n random points, faces oriented outward."""
    while True:
        p = rng.normal(size=(n, 3)) * rng.uniform(0.3, 3.0, size=3)
        try:
            hull = ConvexHull(p)
        except Exception:  # noqa: BLE001 -- degenerate draw: draw again
            continue
        if hull.volume > 1e-3 * np.prod(np.ptp(p, axis=0)):
            break
    used = np.unique(hull.simplices)
    remap = np.full(n, -1)
    remap[used] = np.arange(len(used))
    f = remap[hull.simplices]
    v = p[used]
    a, b, c = (v[f[:, k]] for k in range(3))
    normal = np.cross(b - a, c - a)
    outward = np.einsum("ij,ij->i", normal, hull.equations[:, :3]) > 0
    f[~outward] = f[~outward][:, [0, 2, 1]]
    return Mesh(v, f)


def star_mesh(rng: np.random.Generator) -> Mesh:
    """A non-convex closed mesh: an icosphere with random radii (star-shaped, outward)."""
    r = rng.uniform(0.6, 1.4, size=len(_ICO.vertices))
    return Mesh(np.asarray(_ICO.vertices) * r[:, None], np.asarray(_ICO.faces))


def interior_points(rng: np.random.Generator, mesh: Mesh, k: int, star: bool) -> np.ndarray:
    if star:  # inside the ball of the smallest radius
        d = rng.normal(size=(k, 3))
        d /= np.linalg.norm(d, axis=1)[:, None]
        rmin = np.linalg.norm(mesh.vertices, axis=1).min()
        return d * rng.uniform(0.0, 0.9 * rmin, size=(k, 1))
    w = rng.dirichlet(np.ones(mesh.n_vertices), size=k)  # convex combinations: inside the hull
    return w @ mesh.vertices


meshes = st.tuples(st.integers(0, 2**32 - 1), st.booleans(), st.integers(6, 40))


def draw(seed: int, star: bool, n: int) -> tuple[np.random.Generator, Mesh]:
    rng = np.random.default_rng(seed)
    return rng, (star_mesh(rng) if star else convex_hull_mesh(rng, n))


@SETTINGS
@given(meshes)
def test_coordinates_partition_of_unity_and_linear_precision(args):
    rng, cage = draw(*args)
    pts = interior_points(rng, cage, 25, args[1])
    scale = cage.bbox_diagonal()
    W = mean_value_coordinates(pts, cage.vertices, cage.faces)
    assert W.shape == (len(pts), cage.n_vertices)
    assert np.all(np.isfinite(W))
    assert np.allclose(W.sum(axis=1), 1.0, atol=1e-10)
    assert np.allclose(W @ cage.vertices, pts, atol=1e-9 * scale)
    # inside a convex cage the coordinates are positive
    if not args[1]:
        assert W.min() > -1e-12
    # the untruncated binding is the same thing, sparse
    M = bind(pts, cage, truncation=0.0)
    assert np.allclose(np.asarray(M.sum(axis=1)).ravel(), 1.0, atol=1e-10)
    assert np.allclose(M @ cage.vertices, pts, atol=1e-9 * scale)
    # truncation renormalizes: still a partition of unity
    Mt = bind(pts, cage, truncation=0.03)
    assert np.allclose(np.asarray(Mt.sum(axis=1)).ravel(), 1.0, atol=1e-10)


@SETTINGS
@given(meshes)
def test_coordinates_interpolate_at_cage_vertices(args):
    _, cage = draw(*args)
    W = mean_value_coordinates(cage.vertices, cage.vertices, cage.faces)
    assert np.allclose(W, np.eye(cage.n_vertices), atol=1e-9)


@SETTINGS
@given(meshes, st.integers(0, 2**32 - 1))
def test_arap_reproduces_rigid_motions(args, seed2):
    rng, mesh = draw(*args)
    rng2 = np.random.default_rng(seed2)
    T = rigid_transform(translate=rng2.normal(size=3), axis=rng2.normal(size=3) + 1e-3,
                        degrees=float(rng2.uniform(-180, 180)), center=rng2.normal(size=3))
    moved = mesh.vertices @ T[:3, :3].T + T[:3, 3]
    solver = ARAPSolver(mesh.vertices, mesh.faces)
    assert solver.energy(moved) < 1e-20 * mesh.bbox_diagonal() ** 2 * mesh.n_vertices + 1e-24
    k = int(rng2.integers(1, max(2, mesh.n_vertices // 3)))
    c = np.sort(rng2.choice(mesh.n_vertices, size=k, replace=False))
    solver.set_constrained(c)
    solver.positions[:] = moved  # a rigid pose is a fixed point of the iterations
    solver.solve(moved[c], iterations=3)
    assert np.allclose(solver.positions, moved, atol=1e-9 * mesh.bbox_diagonal())


@SETTINGS
@given(meshes, st.integers(0, 2**32 - 1))
def test_arap_energy_does_not_increase(args, seed2):
    rng, mesh = draw(*args)
    rng2 = np.random.default_rng(seed2)
    solver = ARAPSolver(mesh.vertices, mesh.faces)
    x = mesh.vertices[:, 0]
    handle = np.flatnonzero(x >= np.quantile(x, 0.8))
    fixed = np.flatnonzero(x <= np.quantile(x, 0.2))
    fixed = np.setdiff1d(fixed, handle)
    c = np.union1d(handle, fixed)
    solver.set_constrained(c, moving=handle)
    target = mesh.vertices[c].copy()
    target[np.isin(c, handle)] += rng2.normal(size=3) * 0.3 * mesh.bbox_diagonal()
    energies = []
    for _ in range(12):
        solver.solve(target, iterations=1)
        energies.append(solver.energy())
    e = np.asarray(energies)
    assert np.all(np.isfinite(e))
    assert np.all(np.diff(e) <= 1e-9 * max(e[0], 1e-300))
