"""A shape's limbs found from its geometry (hybridedit.deform.limbs) and posed at their joints
(HybridEditor.limbs / pose_limb, hybridedit.deform.limb_posing)."""

from __future__ import annotations


import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

import hybridedit as he
from hybridedit.core.face_geometry import centre_of_mass
from hybridedit.core.mesh import Mesh, edge_error_stats
from hybridedit.core.transforms import apply_transform, rigid_transform
from hybridedit.deform.limbs import MAX_SHARE, cross_sections, find_limbs, limb_at, swing_axis
from shapes import (ARM_TIPS, FEET, HIPS, SHARED_MESHES, SHOULDERS, capsule_distance, figure, smooth_union,
                    surface_nets)

CAGE = 0.1  # (a fraction of the figure's vertices: 571 cage vertices)


def bottle() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A bottle's vertices, edges and triangles: a body of radius 1 for z in [0, 2], a neck of radius 0.25
    from z = 2.6 to 5, one part."""
    z = [0, 0, 0.5, 1, 1.5, 2, 2.3, 2.6, 3, 3.5, 4, 4.5, 5, 5.2]
    r = [0, 1, 1, 1, 1, 1, 0.6, 0.25, 0.25, 0.25, 0.25, 0.25, 0.25, 0]
    m = trimesh.creation.revolve(np.c_[r, z], sections=16)
    return np.asarray(m.vertices), np.asarray(m.edges_unique), np.asarray(m.faces)


#: the beast's head (a ball), its neck (a capsule from inside the body to the head's centre) and horn
HEAD, HEAD_RADIUS = np.array([0.0, 0.6, -1.05]), 0.5
NECK, NECK_RADIUS = (np.array([0.0, 0.25, -0.5]), HEAD), 0.35
BODY, BODY_RADIUS = (np.array([0.0, 0.0, -0.4]), np.array([0.0, 0.0, 0.6])), 0.5
HORN_TIP = np.array([0.3, 1.3, -0.95])


def beast(h: float = 0.05) -> Mesh:
    """Spot's build: a body (a capsule of radius 0.5 along z, as wide as the head) on four legs (radius
    0.15), its head a ball of radius 0.5 in front, up on a neck of radius 0.35, and a horn (0.07) on
    the head; one closed surface sampled every ``h`` (6,270 vertices)."""
    lo = np.array([-0.9, -1.2, -1.7]) + [0.0131, 0.0077, 0.0113]  # (off the grid: no sample on the surface)
    axes = [np.arange(lo[i], hi + h / 2, h) for i, hi in enumerate((0.9, 1.5, 1.0))]
    p = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)
    d = capsule_distance(p, *BODY, BODY_RADIUS)
    d = smooth_union(d, capsule_distance(p, *NECK, NECK_RADIUS), 0.1)
    d = smooth_union(d, np.linalg.norm(p - HEAD, axis=-1) - HEAD_RADIUS, 0.1)
    d = smooth_union(d, capsule_distance(p, (0.15, 1.0, -1.0), HORN_TIP, 0.07), 0.05)
    for x in (-0.25, 0.25):
        for z in (-0.25, 0.45):
            d = smooth_union(d, capsule_distance(p, (x, -0.3, z), (x, -1.0, z), 0.15), 0.1)
    v, f = surface_nets(d, lo, h)
    return Mesh(v, f, name="beast")


def neck_base() -> np.ndarray:
    """Where the neck's axis leaves the body."""
    s = np.linspace(0.0, 1.0, 1001)
    axis = NECK[0] + s[:, None] * (NECK[1] - NECK[0])
    return axis[np.argmax(capsule_distance(axis, *BODY, BODY_RADIUS) >= 0)]


@pytest.fixture(scope="module")
def editor():
    return he.HybridEditor(figure(), CAGE)


@pytest.fixture(scope="module")
def beast_editor():
    return he.HybridEditor(beast(), CAGE)


def nearest(points: np.ndarray, p: np.ndarray) -> float:
    return float(np.linalg.norm(points - p, axis=1).min())


# ----------------------------------------------------------------------------------------------- finding
def test_the_figures_limbs_are_its_arms_and_legs_joined_where_they_meet_the_body(editor):
    limbs = editor.limbs()
    tips = np.array([limb.tip for limb in limbs])
    assert len(limbs) == 4
    for p in ARM_TIPS:  # (a tip is on the end's hemisphere: within its radius of the pole)
        assert nearest(tips, p) < 0.14
    for p in FEET:
        assert nearest(tips, p) < 0.18
    for limb in limbs:
        arm = abs(limb.tip[0]) > 1
        body = SHOULDERS if arm else HIPS
        assert nearest(body, limb.joint) < 0.2  # the joint is where it leaves the body
        assert limb.radius == pytest.approx(0.14 if arm else 0.18, rel=0.35)
        # the length runs from the tip to the joint: the limb's outer part
        assert limb.length == pytest.approx(np.linalg.norm(limb.tip - limb.joint), rel=0.15)
    assert [limb.index for limb in limbs] == list(range(4))
    assert editor.limbs() is not editor.limbs() and editor.limbs()[0] is editor.limbs()[0]  # (found once)


def test_a_rigid_motion_moves_the_limbs_with_it(editor):
    v, e, f, links = editor.cage.vertices, editor.cage.edges(), editor.cage.faces, editor.rig.links
    centre = centre_of_mass(editor.mesh.vertices, editor.mesh.faces)
    before = find_limbs(v, e, centre_point=centre, cage_faces=f, links=links)
    assert [b.extremity for b in before] == [limb.extremity for limb in editor.limbs()]
    R = Rotation.from_euler("xyz", [30, -50, 110], degrees=True).as_matrix()
    t = np.array([3.0, -1.0, 7.5])
    after = find_limbs(v @ R.T + t, e, centre_point=R @ centre + t, cage_faces=f, links=links)
    assert [a.extremity for a in after] == [b.extremity for b in before]
    for a, b in zip(after, before):
        assert a.length == pytest.approx(b.length, rel=1e-9)
        assert a.radius == pytest.approx(b.radius, rel=1e-9)
        assert np.allclose(a.joint, R @ b.joint + t, atol=1e-9)
        pa, pb = a.parts(at=0.7), b.parts(at=0.7)
        assert np.array_equal(pa.cage_roi, pb.cage_roi) and np.array_equal(pa.cage_handle, pb.cage_handle)
        assert np.allclose(pa.axis, R @ pb.axis, atol=1e-9)


def test_the_bottles_neck_is_its_one_limb_and_its_body_is_none():
    v, e, f = bottle()
    limbs = find_limbs(v, e, centre_point=np.array([0.0, 0, 1.0]), cage_faces=f)
    assert len(limbs) == 1
    [neck] = limbs
    assert neck.tip[2] > 4.9 and 2.3 <= neck.joint[2] <= 2.9 and np.hypot(*neck.joint[:2]) < 0.1
    region = neck.cage_region
    assert region[v[:, 2] > 3].all() and not region[v[:, 2] < 2].any()


def test_a_head_on_a_neck_about_as_wide_as_it_is_a_limb_joined_where_the_neck_meets_the_body(beast_editor):
    ed = beast_editor
    v, f = ed.cage.vertices, ed.cage.faces
    limbs = ed.limbs()
    heads = [limb for limb in limbs if np.linalg.norm(limb.tip - HEAD) < HEAD_RADIUS + 0.1]
    assert len(heads) == 1
    [head] = heads
    assert np.linalg.norm(head.joint - neck_base()) < NECK_RADIUS  # (the base at (0, 0.39, -0.72))
    assert np.linalg.norm(head.joint - HEAD) > HEAD_RADIUS  # (not in the head)
    region = head.cage_region
    assert region[np.linalg.norm(v - HEAD, axis=1) < HEAD_RADIUS + 0.05].all() and not region[v[:, 2] > 0].any()
    area = np.bincount(f.ravel(), np.repeat(trimesh.triangles.area(v[f]), 3), len(v))
    assert area[region].sum() / area.sum() > MAX_SHARE  # (more than a limb's share: the neck's rule)
    # the legs are limbs as ever, and the horn, a part of the head's
    assert sum(limb.tip[1] < -1.0 for limb in limbs) == 4
    assert min(np.linalg.norm(limb.tip - HORN_TIP) for limb in limbs) < 0.1
    # posed as any limb
    rest = ed.mesh.vertices
    ed.reset()
    V = ed.pose_limb(head, degrees=30)
    assert edge_error_stats(rest, V, ed.mesh.edges())[0] < 5.0
    tip = int(np.argmin(np.linalg.norm(rest - head.tip, axis=1)))
    assert ed.vertex_roles[tip] == 1 and ed.limb_at(tip) is head


def test_a_rigid_motion_moves_the_head_with_it(beast_editor):
    ed = beast_editor
    v, e, f = ed.cage.vertices, ed.cage.edges(), ed.cage.faces
    centre = centre_of_mass(ed.mesh.vertices, ed.mesh.faces)
    R = Rotation.from_euler("xyz", [-70, 20, 155], degrees=True).as_matrix()
    t = np.array([-2.0, 0.5, 4.0])
    after = find_limbs(v @ R.T + t, e, centre_point=R @ centre + t, cage_faces=f)
    assert [a.extremity for a in after] == [b.extremity for b in ed.limbs()]
    assert all(np.allclose(a.joint, R @ b.joint + t, atol=1e-9) for a, b in zip(after, ed.limbs()))


@pytest.mark.slow
@pytest.mark.skipif(not (SHARED_MESHES / "spot" / "spot_triangulated.obj").is_file(), reason="no ../shared/meshes")
def test_spot_s_head_is_a_limb_as_on_disk_and_loop_subdivided():
    source = SHARED_MESHES / "spot" / "spot_triangulated.obj"
    t = trimesh.load(source, process=False, force="mesh")
    v, f = trimesh.remesh.subdivide_loop(np.asarray(t.vertices), np.asarray(t.faces), iterations=1)
    found = {}
    for name, ed in (("file", he.open(source, cache=False)), ("loop", he.HybridEditor(Mesh(v, f, name="spot"), 0.05))):
        limbs = ed.limbs()
        legs = [limb for limb in limbs if limb.tip[1] < -0.6]
        heads = [limb for limb in limbs if limb.length > 0.8 and limb.tip[2] < -0.3]
        assert len(legs) == 4 and len(heads) == 1, name
        head = heads[0]
        # the neck between the withers and the brisket, behind the head (its back at z = -0.15)
        assert 0.1 < head.joint[1] < 0.3 and -0.15 < head.joint[2] < 0.05 and abs(head.joint[0]) < 0.05, name
        found[name] = head
        if name == "file":  # (the Pose tool's target: the head bent 30 degrees)
            rest = ed.mesh.vertices
            assert edge_error_stats(rest, ed.pose_limb(head, degrees=30), ed.mesh.edges())[0] < 5.0
    assert np.linalg.norm(found["file"].joint - found["loop"].joint) < 0.05
    assert np.linalg.norm(found["file"].tip - found["loop"].tip) < 0.1


def test_the_parts_at_every_joint_place_the_window_offers():
    v, e, f = bottle()
    [neck] = find_limbs(v, e, centre_point=np.array([0.0, 0, 1.0]), cage_faces=f)
    tip = neck.extremity
    for at in np.round(np.arange(0.2, 1.51, 0.1), 1):
        p = neck.parts(at=at)
        free = p.cage_roi & ~p.cage_handle
        assert p.cage_handle[tip] and free.any() and (~p.cage_roi).any()  # never empty, never everything
        assert not (p.cage_handle & ~p.cage_roi).any()
        d = neck.cage_distance
        assert d[free].min() > p.distance - p.half_width and d[p.cage_handle].max() <= p.distance - p.half_width
        assert 0 < p.half_width <= 0.5 * p.distance
        assert np.isclose(np.linalg.norm(p.axis), 1) and np.dot(p.axis, neck.tip - p.joint) > 0
        assert np.isclose(p.joint_weights.sum(), 1) and np.allclose(p.joint_weights @ v[p.joint_vertices], p.joint)
        assert p.cage_roles[tip] == 1 and (p.cage_roles[~p.cage_roi] == -1).all()
    # the band about the joint is about the neck's radius each side (an elbow)
    assert neck.parts(at=1.0).half_width == pytest.approx(neck.radius)
    with pytest.raises(ValueError):
        neck.parts(at=0)


def test_a_tube_s_cross_sections_have_its_radius():
    t = trimesh.creation.cylinder(radius=0.5, height=4, sections=24)
    v, e = np.asarray(t.vertices), np.asarray(t.edges_unique)
    z = v[:, 2] + 2.0  # the distance from the bottom
    cs = cross_sections(z, v, e, step=0.5)
    inside = (cs.t > 0) & (cs.t < 4)
    assert np.allclose(cs.radius[inside], 0.5, rtol=0.02) and np.allclose(cs.centre[inside, :2], 0, atol=1e-9)
    assert np.allclose(cs.centre[inside, 2], cs.t[inside] - 2.0)


def test_a_vertex_is_on_the_limb_it_is_nearest_the_tip_of():
    v, e, f = bottle()
    limbs = find_limbs(v, e, centre_point=np.array([0.0, 0, 1.0]), cage_faces=f)
    top, bottom = int(np.argmax(v[:, 2])), int(np.argmin(v[:, 2]))
    assert limb_at(limbs, top) is limbs[0] and limb_at(limbs, bottom) is None
    d = limbs[0].cage_distance
    just_past = int(np.argmin(np.where(d > limbs[0].length, d, np.inf)))  # past the joint, within the margin
    assert limb_at(limbs, just_past) is (limbs[0] if d[just_past] <= 1.15 * limbs[0].length else None)


def test_the_swing_axis_is_perpendicular_to_the_limb_and_turns_both_arms_up():
    for a in ([1.0, 0, 0], [-1.0, 0, 0], [0.3, -1, 0.2], [0, 0, 1.0]):
        s = swing_axis(np.array(a))
        assert np.isclose(np.linalg.norm(s), 1) and abs(np.dot(s, a)) < 1e-12
    for a in ([1.0, 0, 0], [-1.0, 0, 0]):  # 30 degrees about the swing axis raises the hand
        T = rigid_transform(axis=swing_axis(np.array(a)), degrees=30)
        assert apply_transform(T, np.array([a]))[0, 1] > 0.4
    leg = rigid_transform(axis=swing_axis(np.array([0.0, -1, 0])), degrees=30)
    assert apply_transform(leg, np.array([[0.0, -1, 0]]))[0, 2] > 0.4  # a leg swings forward (+Z)


# ----------------------------------------------------------------------------------------------- posing
def posed(editor, limb, **kw):
    editor.reset()
    V = editor.pose_limb(limb, **kw)
    return V, editor.vertex_roles.copy()


@pytest.mark.parametrize("which", [0, 2])
def test_pose_limb_holds_the_body_and_turns_the_limb_about_its_joint(editor, which):
    limb = editor.limbs()[which]
    rest = editor.mesh.vertices
    V, roles = posed(editor, limb, degrees=40)
    parts = limb.parts()
    assert (roles == -1).any() and (roles == 1).any() and (roles == 0).any()
    assert np.abs(V[roles == -1] - rest[roles == -1]).max() <= 1e-12
    axis = swing_axis(parts.axis)
    T = rigid_transform(axis=axis, degrees=40, center=parts.joint)
    hand = roles == 1
    assert np.abs(V[hand] - apply_transform(T, rest[hand])).max() <= 1e-9
    tip = int(np.argmin(np.linalg.norm(rest - limb.tip, axis=1)))
    assert hand[tip]  # the tip turned with the limb
    rrms, _ = edge_error_stats(rest, V, editor.mesh.edges())
    assert rrms < 5.0
    # the selection is the limb's parts, in shape vertices: by their distance from the tip
    assert np.array_equal(roles, editor.limb_roles(limb))
    d = editor.limb_distance(limb)
    assert d[hand].max() <= parts.inner < d[roles == 0].min()
    assert d[roles == 0].max() <= parts.outer < d[roles == -1].min()


def test_pose_limb_takes_an_axis_a_joint_place_and_a_translation(editor):
    limb = editor.limbs()[1]
    rest = editor.mesh.vertices
    V, roles = posed(editor, limb, degrees=-25, axis=(0, 0, 2), at=0.6, translate=(0, 0.1, 0))
    parts = limb.parts(at=0.6)
    T = rigid_transform(axis=(0, 0, 1), degrees=-25, center=parts.joint, translate=(0, 0.1, 0))
    assert np.abs(V[roles == 1] - apply_transform(T, rest[roles == 1])).max() <= 1e-9
    assert np.array_equal(roles, editor.limb_roles(limb, at=0.6))
    with pytest.raises(ValueError):
        editor.pose_limb(limb, degrees=float("nan"))
    other = he.HybridEditor(figure(), 0.2)
    with pytest.raises(ValueError, match="this editor's limbs"):
        other.pose_limb(limb, degrees=10)


def test_a_second_pose_of_the_limb_turns_it_on_from_where_it_is(editor):
    limb = editor.limbs()[0]
    rest = editor.mesh.vertices
    editor.reset()
    editor.pose_limb(limb, degrees=20)
    parts = editor.limb_parts(limb)  # the joint and axis where the pose put them
    before = editor.deformed_vertices.copy()
    V = editor.pose_limb(limb, degrees=20)
    hand = editor.vertex_roles == 1
    T = rigid_transform(axis=swing_axis(parts.axis), degrees=20, center=parts.joint)
    assert np.abs(V[hand] - apply_transform(T, before[hand])).max() <= 1e-9
    total = rigid_transform(axis=swing_axis(limb.parts().axis), degrees=40, center=limb.joint)
    assert np.abs(V[hand] - apply_transform(total, rest[hand])).max() < 0.05  # about one 40 degree turn


def test_the_limb_under_a_shape_vertex(editor):
    rest = editor.mesh.vertices
    for limb in editor.limbs():
        tip = int(np.argmin(np.linalg.norm(rest - limb.tip, axis=1)))
        assert editor.limb_at(tip) is limb
        assert editor.limb_at(limb.extremity, space="cage") is limb
    navel = int(np.argmin(np.linalg.norm(rest - [0, 0, 0.45], axis=1)))
    assert editor.limb_at(navel) is None
    with pytest.raises(he.SelectionError):
        editor.limb_at(len(rest))


def test_an_edit_saved_after_pose_limb_replays_with_hybridedit_deform(editor, tmp_path):
    from hybridedit.cli import main
    from hybridedit.fileio.meshfiles import read_mesh, write_mesh

    mesh_file = tmp_path / "figure.ply"
    write_mesh(mesh_file, editor.mesh)
    limb = editor.limbs()[3]
    V, _ = posed(editor, limb, degrees=35)
    assert editor.replayable
    he.save_edit(tmp_path / "pose.json", editor.edit)
    out = tmp_path / "posed.ply"
    assert main(["deform", str(mesh_file), "-o", str(out), "--edit", str(tmp_path / "pose.json"),
                 "--cage", str(CAGE), "-q"]) == 0
    assert np.abs(read_mesh(out).vertices - V).max() <= 1e-9
