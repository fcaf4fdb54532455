"""The frame steps: cage targets and solve, rotations, propagation, exact placement, region, mirror."""

import numpy as np
import pytest

from hybridedit import build_rig
from hybridedit.deform.arap import ARAPSolver, edge_weights, laplacian
from hybridedit.deform.base_pose import current_base, propagated_residual, rest_base
from hybridedit.binding.bind import dominant_cage_vertex
from hybridedit.deform.constraints import RegionStep, SeamSpread
from hybridedit.deform.roles import FIXED
from hybridedit.deform.frame_steps import (MAX_REACH, AverageMirror, Frame, RegionSolver, RegionStepSolver, SeamSpreadSolver,
                                    build_frame_steps, cage_targets, solve_cage)
from hybridedit.deform.residual import residual_setup
from hybridedit.deform.selection import CageMap, build_selection, choose_roles, user_roles
from hybridedit.deform.symmetry import Mirror
from hybridedit.core.transforms import apply_transform, rigid_transform

from shapes import bumpy_blob


@pytest.fixture(scope="module")
def rig():
    from scipy.spatial import cKDTree

    r = build_rig(bumpy_blob(3), cage_size=150)
    maps = CageMap(nearest=cKDTree(r.mesh.vertices).query(r.cage.vertices)[1].astype(np.int64),
                   dominant=dominant_cage_vertex(r.M))
    d, idx, w = residual_setup(r.M, r.mesh.vertices, r.cage.vertices)
    e, wt = edge_weights(r.mesh.vertices, r.mesh.faces, "cotangent")
    return r, maps, d, (idx, w), laplacian(r.mesh.n_vertices, e, wt)


def session(rig, propagation, *, base=None, symmetry=None, roi=None):
    """(arap, selection, steps, base) for an edit of the blob's right end, the left end fixed
    (or, with ``roi``, everything outside those shape vertices)."""
    r, maps, d, blend, L = rig
    x = r.mesh.vertices
    base = base or rest_base(binding=r.M, cage=r.cage.vertices, residual=d, blend=blend, propagation=propagation,
                     shape=r.mesh.vertices)
    a, b = np.flatnonzero(x[:, 0] < -1.0), np.flatnonzero(x[:, 0] > 1.4)
    mirror = Mirror(x, symmetry) if symmetry else None
    roles = choose_roles(user_roles(b, fixed=None if roi is not None else a, roi=roi, maps=maps), mirror=mirror,
                         maps=maps)
    arap = ARAPSolver(r.cage.vertices, r.cage.faces, links=r.links)
    arap.set_reference(base.cage)
    arap.set_constrained(roles.constrained, moving=roles.moving)
    sel = build_selection(roles, free_cage=arap.free, held=arap.held, binding=r.M,
                          blend_idx=blend[0] if propagation == "residual" else None)
    steps = build_frame_steps(sel, base, binding=r.M, residual=propagated_residual(base, blend, propagation=propagation),
                              propagation=propagation, laplacian=L, rest=x, blend=blend, cage_edge=0.2)
    return arap, sel, steps, base


def frame(arap, sel, steps, base, T, *, out=None, propagation="residual"):
    """Run one frame with user transform T; returns (out, rotations)."""
    internal = sel.group_transforms([T])
    solve_cage(arap, *cage_targets(base.cage, sel, internal, scale=5.0), iterations=2)
    out = base.shape.copy() if out is None else out
    rots = np.tile(np.eye(3), (len(base.cage), 1, 1))
    prop = rots if propagation == "residual" else np.tile(np.eye(3), (len(base.cage), 1, 1))
    steps.run(Frame(base_shape=base.shape, transforms=internal, cage=arap.positions, cage_rotations=arap.rotations,
                    rotations=rots, propagation_rotations=prop, out=out))
    return out, rots


def test_cage_targets_move_each_group_and_the_solve_holds_fixed_vertices(rig):
    arap, sel, steps, base = session(rig, "residual")
    T = rigid_transform(translate=(0, 0.3, 0), axis=(0, 0, 1), degrees=25)
    slots, target = cage_targets(base.cage, sel, [T], scale=5.0)
    assert np.array_equal(slots, sel.slots[0]) and np.array_equal(sel.constrained[slots], sel.cage_groups[0])
    assert np.allclose(target, apply_transform(T, base.cage[sel.cage_groups[0]]), atol=1e-14)
    fixed = sel.constrained[sel.cage_roles[sel.constrained] == FIXED]
    assert fixed.size
    for _ in range(3):  # the fixed vertices are not written: they stay where the base has them
        solve_cage(arap, slots, target, iterations=2)
    assert np.array_equal(arap.positions[fixed], base.cage[fixed])
    assert np.array_equal(arap.positions[sel.cage_groups[0]], target)


def test_cage_targets_refuse_far_and_non_finite_moves(rig):
    arap, sel, steps, base = session(rig, "residual")
    with pytest.raises(ValueError, match="non-finite"):
        cage_targets(base.cage, sel, [rigid_transform(translate=(np.nan, 0, 0))], scale=5.0)
    with pytest.raises(ValueError, match="times the shape.s size"):
        cage_targets(base.cage, sel, [rigid_transform(translate=(0, 0, 10 * MAX_REACH))], scale=5.0)


def test_a_failed_cage_solve_leaves_the_solver_as_it_was(rig):
    arap, sel, steps, base = session(rig, "residual")
    T = rigid_transform(translate=(0, 0.3, 0), axis=(0, 0, 1), degrees=25)
    solve_cage(arap, *cage_targets(base.cage, sel, [T], scale=5.0), iterations=2)
    before = (arap.positions.copy(), arap.rotations.copy())
    slots, target = cage_targets(base.cage, sel, [rigid_transform(translate=(0, 0.5, 0))], scale=5.0)
    target[:] = 1e300  # finite, but the solve overflows
    with pytest.raises(ValueError, match="non-finite cage positions"):
        solve_cage(arap, slots, target, iterations=2)
    assert np.array_equal(arap.positions, before[0]) and np.array_equal(arap.rotations, before[1])
    solve_cage(arap, *cage_targets(base.cage, sel, [T], scale=5.0), iterations=2)  # and it goes on
    assert np.all(np.isfinite(arap.positions))


@pytest.mark.parametrize("threshold", [10**9, 0])  # the serial kernel, then the parallel one
def test_turn_rotations_gives_free_vertices_arap_s_and_each_group_its_transform_s(monkeypatch, threshold):
    from hybridedit.core.parallel import THRESHOLDS
    from hybridedit.deform.frame_steps import TurnRotations

    monkeypatch.setitem(THRESHOLDS, "place", threshold)
    rng = np.random.default_rng(3)
    c = 40
    cage_rots = rng.normal(size=(c, 3, 3))
    free, g0, g1 = np.array([1, 5, 7]), np.array([0, 2, 30]), np.array([11, 12])
    Ts = [rigid_transform(axis=(0, 0, 1), degrees=30), rigid_transform(axis=(1, 0, 0), degrees=-70)]
    out = np.full((c, 3, 3), 7.0)
    TurnRotations(free, (g0, g1)).run(Frame(base_shape=None, transforms=Ts, cage=None, cage_rotations=cage_rots,
                                            rotations=out, propagation_rotations=out, out=None))
    assert np.array_equal(out[free], cage_rots[free])
    assert np.array_equal(out[g0], np.broadcast_to(Ts[0][:3, :3], (3, 3, 3)))
    assert np.array_equal(out[g1], np.broadcast_to(Ts[1][:3, :3], (2, 3, 3)))
    rest = np.setdiff1d(np.arange(c), np.concatenate([free, g0, g1]))
    assert np.all(out[rest] == 7.0)  # the others are not written


@pytest.mark.parametrize("propagation", ["residual", "linear"])
def test_the_frame_steps_place_constrained_vertices_exactly(rig, propagation):
    arap, sel, steps, base = session(rig, propagation)
    T = rigid_transform(translate=(0.1, 0.4, 0.2), axis=(0, 0, 1), degrees=30,
                        center=base.shape[sel.shape_groups[0]].mean(axis=0))
    for _ in range(3):
        out, rots = frame(arap, sel, steps, base, T, propagation=propagation)
    fixed = sel.roles == FIXED
    assert np.array_equal(out[fixed], base.shape[fixed])  # never written, or set back
    handle = sel.shape_groups[0]
    assert np.abs(out[handle] - apply_transform(T, base.shape[handle])).max() < 1e-12
    moved = np.abs(out - base.shape).max(axis=1) > 0
    assert np.all(np.isin(np.flatnonzero(moved), sel.moving_vertices))  # nothing else moves
    assert np.allclose(rots[sel.cage_groups[0]], T[:3, :3])  # a handle's cage vertices turn with it
    assert np.array_equal(rots[sel.free_cage], arap.rotations[sel.free_cage])


@pytest.mark.parametrize("propagation", ["residual", "linear"])
def test_an_identity_frame_from_a_base_leaves_the_base_unchanged(rig, propagation):
    # a posed base: some drags from rest, then their pose taken as the next edit's base
    arap, sel, steps, rest = session(rig, propagation)
    T = rigid_transform(translate=(0, 0.5, 0.1), axis=(0, 1, 0), degrees=20)
    for _ in range(4):
        out, _ = frame(arap, sel, steps, rest, T, propagation=propagation)
    base = current_base(rest, moved=True, cage=arap.positions, shape=out, binding=rig[0].M)
    arap, sel, steps, base = session(rig, propagation, base=base)
    out, _ = frame(arap, sel, steps, base, np.eye(4), propagation=propagation)
    assert np.abs(out - base.shape).max() < 1e-12
    # the same selection measured from the base after being built from rest gives the same frame
    _, sel2, from_rest, _ = session(rig, propagation)
    again = from_rest.measured_from(base, propagated_residual(base, rig[3], propagation=propagation))
    arap.set_reference(base.cage)
    out2, _ = frame(arap, sel2, again, base, np.eye(4), propagation=propagation)
    assert np.abs(out2 - base.shape).max() < 1e-12


def test_both_region_solvers_have_one_face(rig):
    _, _, residual_steps, _ = session(rig, "residual")
    _, _, linear_steps, _ = session(rig, "linear")
    assert isinstance(residual_steps.region, RegionStepSolver) and isinstance(residual_steps.region.solver, RegionStep)
    assert isinstance(linear_steps.region, SeamSpreadSolver) and isinstance(linear_steps.region.solver, SeamSpread)
    for region in (residual_steps.region, linear_steps.region, RegionSolver()):
        assert isinstance(region, RegionSolver)
        assert callable(region.before) and callable(region.after) and callable(region.measured_from)
    # the region step places its rows itself: they are not propagated
    solved = residual_steps.region.solved
    assert solved.size and not np.any(np.isin(solved, residual_steps.propagate.rows.rows))
    assert linear_steps.region.solved.size == 0


def test_the_mirror_average_makes_the_displacement_symmetric():
    from shapes import icosphere

    x = icosphere(3).vertices
    mirror = Mirror(x, "x")
    assert np.array_equal(mirror.map[mirror.map], np.arange(len(x)))  # an involution on this sphere
    rng = np.random.default_rng(0)
    out = x + 0.05 * rng.standard_normal(x.shape)
    rows = np.arange(len(x))
    AverageMirror(rows, mirror).run(Frame(base_shape=x, transforms=[], cage=None, cage_rotations=None,
                                          rotations=None, propagation_rotations=None, out=out))
    D = out - x
    S = mirror.S[:3, :3]
    assert np.abs(D - D[mirror.map] @ S.T).max() < 1e-15


@pytest.mark.parametrize("propagation", ["residual", "linear"])
def test_a_frame_reads_and_writes_only_the_moving_rows_and_their_ring(rig, propagation):
    """Counting, not timing: every row of the shape outside the rows a drag can move, the seam
    and their one-ring is NaN in the frame's output array; frames leave each of them untouched
    (nothing wrote there) and every moving row finite (nothing read there)."""
    r, maps, d, blend, L = rig
    arap, sel, steps, base = session(rig, propagation, roi=np.flatnonzero(r.mesh.vertices[:, 0] > 1.0))
    moving = np.union1d(sel.moving_vertices, sel.seam)
    near = np.zeros(r.mesh.n_vertices, dtype=bool)
    near[moving] = True
    near[L[moving].indices] = True  # their neighbours: the region step's boundary
    outside = np.flatnonzero(~near)
    assert 0.3 * r.mesh.n_vertices < outside.size  # (a local edit: most of the shape is outside)
    out = base.shape.copy()
    out[outside] = np.nan
    T = rigid_transform(translate=(0.1, 0.4, 0.2), axis=(0, 0, 1), degrees=30,
                        center=base.shape[sel.shape_groups[0]].mean(axis=0))
    for _ in range(3):
        frame(arap, sel, steps, base, T, out=out, propagation=propagation)
    assert np.isnan(out[outside]).all()
    assert np.isfinite(out[near]).all()
    assert np.abs(out[sel.moving_vertices] - base.shape[sel.moving_vertices]).max() > 0.05
