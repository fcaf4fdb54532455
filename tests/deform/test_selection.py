"""The selection model (hybridedit.deform.selection): a user's selection read as masks or indices, user
roles, mirror images, cage roles, the rows a drag can move."""

import numpy as np
import pytest

from hybridedit import build_rig
from hybridedit.deform.arap import ARAPSolver
from hybridedit.binding.bind import dominant_cage_vertex
from hybridedit.deform.roles import FIXED, FREE
from hybridedit.deform.residual import residual_setup
from hybridedit.deform.selection import SelectionError, as_groups, as_indices
from hybridedit.deform.selection import (CageMap, build_selection, choose_roles, mirrored_roles, rows_that_can_move,
                                        user_roles)
from hybridedit.deform.symmetry import Mirror
from hybridedit.core.transforms import rigid_transform

from shapes import icosphere


@pytest.fixture(scope="module")
def rig():
    """A sphere (symmetric across x = 0), its cage and binding, and the selection maps."""
    from scipy.spatial import cKDTree

    r = build_rig(icosphere(3), cage_size=120)
    maps = CageMap(nearest=cKDTree(r.mesh.vertices).query(r.cage.vertices)[1].astype(np.int64),
                   dominant=dominant_cage_vertex(r.M))
    return r, maps


def selected(rig, handle, *, fixed=None, roi=None, symmetry=None, space="shape", propagation="residual"):
    """(roles, selection) of a selection, ARAP factored for it as the editor does."""
    r, maps = rig
    mirror = Mirror(r.mesh.vertices, symmetry) if symmetry is not None else None
    roles = choose_roles(user_roles(handle, fixed, roi, space=space, maps=maps), mirror=mirror, maps=maps)
    arap = ARAPSolver(r.cage.vertices, r.cage.faces, links=r.links)
    arap.set_constrained(roles.constrained, moving=roles.moving)
    blend = residual_setup(r.M, r.mesh.vertices, r.cage.vertices)[1]
    sel = build_selection(roles, free_cage=arap.free, held=arap.held, binding=r.M,
                          blend_idx=blend if propagation == "residual" else None)
    return roles, sel


def test_user_roles_encode_groups_fixed_and_roi(rig):
    _, maps = rig
    n = maps.n_shape
    u = user_roles([[0, 1], [5]], fixed=[9, 10], maps=maps)
    assert u.n_groups == 2 and not u.roi_mode
    assert u.roles[[0, 1, 5, 9, 10]].tolist() == [1, 1, 2, FIXED, FIXED]
    assert np.count_nonzero(u.roles) == 5
    u = user_roles([3], roi=np.arange(100), maps=maps)
    assert u.roi_mode and u.roles[3] == 1
    assert np.all(u.roles[100:] == FIXED) and np.all(np.delete(u.roles[:100], 3) == FREE)
    assert u.roles.shape == (n,)


@pytest.mark.parametrize("args, message", [
    (dict(handle=[1], fixed=[2], roi=[3]), "either fixed or roi"),
    (dict(handle=[1], fixed=[1, 2]), "handle and fixed share 1"),
    (dict(handle=[1], space="world"), "space must be one of"),
    (dict(handle=[]), "empty"),
])
def test_user_roles_refuse_malformed_selections(rig, args, message):
    with pytest.raises(SelectionError, match=message):
        user_roles(args.pop("handle"), maps=rig[1], **args)


def test_a_mirrored_selection_covers_both_sides(rig):
    r, _ = rig
    x = r.mesh.vertices
    mirror = Mirror(x, "x")
    one_side = np.flatnonzero((x[:, 0] > 0.6) & (x[:, 1] > 0.3))
    straddles = np.flatnonzero(x[:, 1] < -0.85)
    fixed = np.flatnonzero((x[:, 2] < -0.7) & (x[:, 0] > 0.2))  # on one side only
    user = np.zeros(len(x), dtype=np.int32)
    user[fixed] = FIXED
    user[one_side] = 1
    user[straddles] = 2
    roles, source, kind = mirrored_roles(user, n_groups=2, mirror=mirror)
    assert kind == ["same", "self", "mirror"] and source == [0, 1, 0]
    image = mirror.map
    # every vertex whose mirror image is in a group is in that group or in its mirror image
    for k in (1, 2):
        held = np.flatnonzero(user[image] == k)
        assert np.all(np.isin(roles[held], [k] + [i + 1 for i, s in enumerate(source) if s == k - 1]))
    assert np.all(roles[np.flatnonzero(user[image] == FIXED)] == FIXED)  # the fixed set is mirrored
    assert np.all(roles[one_side] == 1) and np.all(roles[straddles] == 2)  # the user's own roles stay
    mirrored = np.flatnonzero(roles == 3)
    assert mirrored.size and np.all(x[mirrored, 0] < 0)  # the image is on the other side


def test_a_mirrored_roi_stays_fixed_only_where_both_sides_are(rig):
    r, _ = rig
    x = r.mesh.vertices
    mirror = Mirror(x, "x")
    user = np.full(len(x), FIXED, dtype=np.int32)
    user[x[:, 0] > 0.3] = FREE  # a region of interest on one side
    user[x[:, 0] > 0.8] = 1
    roles, _, _ = mirrored_roles(user, n_groups=1, mirror=mirror, roi_mode=True)
    assert np.array_equal(roles == FIXED, (user == FIXED) & (user[mirror.map] == FIXED))


def test_cage_vertices_take_their_nearest_shape_vertex_role(rig):
    r, maps = rig
    x = r.mesh.vertices
    a, b = np.flatnonzero(x[:, 0] < -0.6), np.flatnonzero(x[:, 0] > 0.7)
    roles = choose_roles(user_roles(b, fixed=a, maps=maps), mirror=None, maps=maps)
    near = roles.roles[maps.nearest]
    assert np.array_equal(roles.cage_roles[near != FREE], near[near != FREE])
    assert np.array_equal(roles.constrained, np.flatnonzero(roles.cage_roles != FREE))
    assert np.array_equal(roles.moving, np.flatnonzero(roles.cage_roles > 0))
    assert roles.moving.size > 0


def test_a_small_handle_gets_the_cage_vertices_it_depends_on_most(rig):
    r, maps = rig
    free_shape = np.setdiff1d(np.arange(maps.n_shape), maps.nearest)  # no cage vertex is nearest to it
    v = int(free_shape[0])
    roles = choose_roles(user_roles([v], maps=maps), mirror=None, maps=maps)
    assert roles.cage_roles[maps.dominant[v]] == 1
    assert np.count_nonzero(roles.cage_roles) == 1


def test_a_cage_selection_keeps_the_users_picks(rig):
    r, maps = rig
    c = r.cage.vertices
    pick, hold = np.flatnonzero(c[:, 0] > 0.6), np.flatnonzero(c[:, 0] < -0.6)
    user = user_roles(pick, fixed=hold, space="cage", maps=maps)
    assert np.array_equal(user.roles, user.given[maps.dominant])  # shape vertices: their dominant cage vertex
    roles = choose_roles(user, mirror=None, maps=maps)
    assert np.all(roles.cage_roles[pick] == 1) and np.all(roles.cage_roles[hold] == FIXED)
    # and the same selection given in shape vertices selects the same cage vertices
    again = choose_roles(user_roles(*_split(maps.shape_roles(roles.cage_roles)), maps=maps), mirror=None, maps=maps)
    assert np.array_equal(again.cage_roles, roles.cage_roles)


def _split(shape_roles):
    return np.flatnonzero(shape_roles == 1), np.flatnonzero(shape_roles == FIXED)


def test_to_cage_maps_shape_picks_to_cage_vertices(rig):
    _, maps = rig
    picked = maps.nearest[:5]
    assert set(maps.to_cage(picked).tolist()) >= set(range(5))
    lone = np.setdiff1d(np.arange(maps.n_shape), maps.nearest)[:1]
    assert maps.to_cage(lone).tolist() == [maps.dominant[lone[0]]]
    assert maps.to_cage([3, 1], space="cage").tolist() == [1, 3]


@pytest.mark.parametrize("propagation", ["residual", "linear"])
def test_the_rows_a_drag_can_move_are_those_bound_to_moving_cage_vertices(rig, propagation):
    r, maps = rig
    x = r.mesh.vertices
    a, b = np.flatnonzero(x[:, 0] < -0.2), np.flatnonzero(x[:, 0] > 0.7)
    roles, sel = selected(rig, b, fixed=a, propagation=propagation)
    changing = roles.cage_roles > 0
    changing[sel.free_cage] = True
    bound = np.asarray(r.M.tocsr()[:, np.flatnonzero(changing)].getnnz(axis=1)).ravel() > 0
    if propagation == "residual":  # a row turning with a moving cage vertex moves too
        bound |= changing[residual_setup(r.M, x, r.cage.vertices)[1]].any(axis=1)
    assert np.array_equal(np.union1d(sel.rows, sel.seam), np.flatnonzero(bound))
    assert 0 < sel.rows.size and np.count_nonzero(bound) < len(x)
    assert np.all(sel.roles[sel.rows] == FREE) and np.all(sel.roles[sel.seam] != FREE)
    assert np.array_equal(sel.seam_role, sel.roles[sel.seam])
    for k in range(len(sel.source)):  # each group's cage vertices, found at its slots among the constrained
        assert np.array_equal(sel.constrained[sel.slots[k]], sel.cage_groups[k])
        assert np.array_equal(sel.shape_groups[k], np.flatnonzero(sel.roles == k + 1))
    assert np.array_equal(sel.moving_vertices, np.union1d(sel.rows, np.flatnonzero(sel.roles > 0)))


@pytest.mark.parametrize("threshold", [10**9, 0])  # the serial kernel, then the parallel one
def test_rows_that_can_move_follow_the_binding_and_the_rotation_blend(monkeypatch, threshold):
    import scipy.sparse as sp

    from hybridedit.core.parallel import THRESHOLDS

    monkeypatch.setitem(THRESHOLDS, "propagate", threshold)
    M = sp.csr_matrix(np.array([[1.0, 0, 0], [0.5, 0.5, 0], [0, 0, 1.0]]))
    changing = np.array([False, True, False])
    assert rows_that_can_move(M, changing).tolist() == [1]
    blend = np.array([[0, 0], [0, 1], [2, 1]])  # row 2 turns with cage vertex 1
    assert rows_that_can_move(M, changing, blend_idx=blend).tolist() == [1, 2]
    # a bigger one against the definition
    rng = np.random.default_rng(0)
    M = sp.random(3000, 200, density=0.02, format="csr", random_state=1)
    changing = rng.random(200) < 0.05
    blend = rng.integers(0, 200, (3000, 4))
    want = (M[:, changing].getnnz(axis=1) > 0) | changing[blend].any(axis=1)
    assert np.array_equal(rows_that_can_move(M, changing, blend_idx=blend), np.flatnonzero(want))


def test_a_mirrored_selections_mirror_groups_follow_the_mirrored_transform(rig):
    r, _ = rig
    x = r.mesh.vertices
    hand = np.flatnonzero((x[:, 0] > 0.6) & (x[:, 1] > 0.3))
    foot = np.flatnonzero(x[:, 1] < -0.85)
    roles, sel = selected(rig, [hand, foot], roi=np.flatnonzero(x[:, 2] > -0.5), symmetry="x")
    assert sel.kind == ("same", "self", "mirror")
    T0, T1 = rigid_transform(translate=(0.2, 0.1, 0)), rigid_transform(translate=(0.1, -0.1, 0.05))
    internal = sel.group_transforms([T0, T1])
    assert np.array_equal(internal[0], T0)
    assert np.allclose(internal[1], sel.mirror.symmetric_part(T1))
    assert np.allclose(internal[2], sel.mirror.mirrored(T0))
    assert internal[2][0, 3] == pytest.approx(-0.2)
    # the public roles count a mirror image in its group
    public = sel.public(sel.roles)
    assert np.all(public[sel.roles == 3] == 1)
    assert sel.sym_rows.size and np.all(sel.roles[sel.mirror.map[sel.sym_rows]] == FREE)
    # the default rotation centres are each user group's centroid in the given pose
    centers = sel.centers(shape=x + 1.0, cage=r.cage.vertices)
    assert np.allclose(centers[0], x[hand].mean(axis=0) + 1.0)


# ---------------------------------------------------------------------------- reading a selection


def test_masks_and_indices_name_the_same_vertices():
    mask = np.zeros(6, dtype=bool)
    mask[[1, 4]] = True
    want = [1, 4]
    assert as_indices(mask, 6).tolist() == want
    assert as_indices(mask.tolist(), 6).tolist() == want
    assert as_indices([4, 1, 4], 6).tolist() == want
    assert as_indices((1, 4), 6).tolist() == want
    assert as_indices(np.array([4, 1], dtype=np.int32), 6).tolist() == want
    assert as_indices(np.array([4, 1], dtype=np.uint16), 6).tolist() == want
    assert as_indices(range(1, 5, 3), 6).tolist() == want
    # a boolean mask of length 2 is a mask, not the indices 0 and 1
    assert as_indices(np.array([False, True]), 2).tolist() == [1]


@pytest.mark.parametrize(
    "sel, words",
    [
        (None, "got NoneType"),
        ("0,1", "got str"),
        (np.array([True, False]), "boolean mask of length 2"),
        ([True, False, True], "boolean list of length 3"),
        ([[0, 1], [2]], "nested list"),
        ([0, 1.5], "list holding float"),
        (np.array([0.0, 1.0]), "array of float64"),
        (np.zeros((2, 2), dtype=int), "2-dimensional array"),
        ({0, 1}, "got set"),
        ([0, 2 ** 70], "out of range"),
        ([-1], "out of range"),
        ([6], "out of range [0, 5], e.g. 6"),
    ],
)
def test_anything_else_is_one_line_selection_error(sel, words):
    with pytest.raises(SelectionError) as e:
        as_indices(sel, 6, role="fixed")
    msg = str(e.value)
    assert words in msg and "\n" not in msg and msg.startswith("fixed")


def test_groups():
    assert [g.tolist() for g in as_groups([0, 2], 5)] == [[0, 2]]  # one list of ints: one group
    assert [g.tolist() for g in as_groups([[0], np.array([2, 3])], 5)] == [[0], [2, 3]]
    mask = np.array([True, False, False, False, True])
    assert [g.tolist() for g in as_groups([mask, [2]], 5)] == [[0, 4], [2]]
    with pytest.raises(SelectionError, match="share 1 vertices"):
        as_groups([[0, 1], [1, 2]], 5)
    with pytest.raises(SelectionError, match="handle group 1 is empty"):
        as_groups([[0], []], 5)
    with pytest.raises(SelectionError, match="the handle is empty"):
        as_groups([], 5)
