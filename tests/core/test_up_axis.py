"""Which way is up (hybridedit.core.up_axis): guessed from the format and the geometry."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh

from hybridedit.core.mesh import Mesh
from hybridedit.core.up_axis import AXES, axis_vector, guess_up_axis

from shapes import bumpy_blob


def as_mesh(t) -> Mesh:
    return Mesh(np.asarray(t.vertices, dtype=np.float64), np.asarray(t.faces))


def turned(mesh: Mesh, up: str) -> Mesh:
    """``mesh`` (made +Z up) turned so that +Z goes to ``up``."""
    z = np.array([0.0, 0, 1])
    u = axis_vector(up)
    if np.allclose(u, z):
        R = np.eye(3)
    elif np.allclose(u, -z):
        R = np.diag([1.0, -1.0, -1.0])
    else:
        from scipy.spatial.transform import Rotation

        R = Rotation.align_vectors([u], [z])[0].as_matrix()
    return Mesh(mesh.vertices @ R.T, mesh.faces)


def statue_on_a_base() -> Mesh:
    """A ball standing on a flat box base, +Z up, closed."""
    base = trimesh.creation.box(extents=[1.0, 1.0, 0.2])
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.6)
    ball.apply_translation([0, 0, 0.7])
    return as_mesh(trimesh.util.concatenate([base, ball]))


def scanned_on_its_base() -> Mesh:
    """A bumpy dome scanned from above: open at the bottom (no faces under it), +Z up."""
    s = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
    keep = s.vertices[s.faces].mean(axis=1)[:, 2] > -0.3
    t = trimesh.Trimesh(s.vertices, s.faces[keep], process=False)
    t.remove_unreferenced_vertices()
    v = np.asarray(t.vertices) * [1.0, 0.8, 1.6]
    return Mesh(v, np.asarray(t.faces))


@pytest.mark.parametrize("up", AXES)
def test_a_flat_base_or_an_open_bottom_says_which_way_is_up(up):
    assert guess_up_axis(turned(statue_on_a_base(), up)) == up
    assert guess_up_axis(turned(scanned_on_its_base(), up)) == up


def test_nothing_telling_is_y_up_and_gltf_is_y_up_by_its_specification():
    blob = bumpy_blob(3)  # closed, round: no base
    assert guess_up_axis(blob) == "+Y"
    z_up_statue = turned(statue_on_a_base(), "+Z")
    assert guess_up_axis(z_up_statue, path="statue.glb") == "+Y"  # the format says so
    assert guess_up_axis(z_up_statue, path="statue.ply") == "+Z"


def quadruped() -> Mesh:
    """A horse-like shape, +Z up: a round body on four thin legs, a head forward; mirrored left to right."""
    body = trimesh.creation.capsule(height=1.2, radius=0.4, count=[16, 16])
    body.apply_transform(trimesh.transformations.rotation_matrix(np.pi / 2, [0, 1, 0]))
    body.apply_translation([0, 0, 1.4])
    parts = [body]
    for x in (-0.7, 0.7):
        for y in (-0.25, 0.25):
            leg = trimesh.creation.cylinder(radius=0.08, height=1.1, sections=12)
            leg.apply_translation([x, y, 0.55])
            parts.append(leg)
    head = trimesh.creation.icosphere(subdivisions=2, radius=0.25)
    head.apply_scale([1.4, 1, 1])
    head.apply_translation([1.2, 0, 2.0])
    parts.append(head)
    return as_mesh(trimesh.util.concatenate(parts))


def boat() -> Mesh:
    """A closed boat, +Z up: a round hull, a flat stern, a flat deck with a cabin on it; mirrored port to
    starboard."""
    s = trimesh.creation.icosphere(subdivisions=4)
    v = np.asarray(s.vertices) * [2.0, 0.6, 0.6]
    v[:, 0] = np.maximum(v[:, 0], -1.4)
    v[:, 2] = np.minimum(v[:, 2], 0.15)
    cabin = trimesh.creation.box(extents=[0.8, 0.5, 0.3])
    cabin.apply_translation([-0.3, 0, 0.3])
    return as_mesh(trimesh.util.concatenate([trimesh.Trimesh(v, s.faces), cabin]))


def y_up_to_z_up(mesh: Mesh) -> Mesh:
    v = mesh.vertices
    return Mesh(np.c_[v[:, 0], -v[:, 2], v[:, 1]], mesh.faces)


def shared_shape(name: str) -> Mesh:
    from hybridedit.fileio.meshfiles import read_mesh

    from shapes import SHARED_MESHES

    path = SHARED_MESHES / name
    if not path.exists():
        pytest.skip(f"{path} is not there")
    return y_up_to_z_up(read_mesh(path))  # (all of them are +Y up)


@pytest.mark.parametrize("shape", ["quadruped", "boat", "armadillo43k.obj", "spot/spot_triangulated.obj", "cat/cat.obj",
                                   "creature"])
def test_shapes_lying_on_their_side_in_each_axis_come_out_upright(shape):
    from shapes import REPO
    from hybridedit.fileio.meshfiles import read_mesh

    if shape in ("quadruped", "boat"):
        mesh = quadruped() if shape == "quadruped" else boat()
    elif shape == "creature":
        mesh = y_up_to_z_up(read_mesh(REPO / "data" / "creature.ply"))
    else:
        mesh = shared_shape(shape)
    got = {up: guess_up_axis(turned(mesh, up)) for up in AXES}
    assert got == {up: up for up in AXES}


def biped() -> Mesh:
    """A figure +Z up, wider (X) than deep (Y), its head and arms reaching out towards -Y."""
    body = trimesh.creation.box(extents=[1.0, 0.5, 1.6])
    body.apply_translation([0, 0, 0.8])
    head = trimesh.creation.icosphere(subdivisions=2, radius=0.25)
    head.apply_translation([0, -0.1, 1.85])
    arms = trimesh.creation.box(extents=[0.9, 0.5, 0.2])
    arms.apply_translation([0, -0.4, 1.3])
    return as_mesh(trimesh.util.concatenate([body, head, arms]))


@pytest.mark.parametrize("up", AXES)
def test_the_front_is_the_broad_side_the_shape_leans_to(up):
    from hybridedit.core.facing import conventional_front, front_direction

    R = turned(Mesh(np.eye(3), np.zeros((0, 3), dtype=np.int64)), up).vertices.T  # (+Z goes to up)
    # a figure faces where its arms reach (-Y, Z up), whichever way it is turned ...
    assert np.allclose(front_direction(turned(biped(), up).vertices, up), R @ [0, -1, 0])
    # ... and the horse is seen from its side: the camera looks across its length (X, Z up)
    got = front_direction(turned(quadruped(), up).vertices, up)
    assert abs(got @ (R @ [1.0, 0, 0])) < 1e-9 and abs(got @ axis_vector(up)) < 1e-9
    # a shape with nothing to tell faces the convention's front
    assert np.allclose(front_direction(turned(as_mesh(trimesh.creation.icosphere(2)), up).vertices, up),
                       conventional_front(up))


def test_the_creature_and_the_armadillo_face_the_first_camera_and_the_cow_shows_its_side():
    from shapes import REPO
    from hybridedit.core.facing import front_direction
    from hybridedit.fileio.meshfiles import read_mesh

    from shapes import SHARED_MESHES

    # (all three +Y up; the creature and the armadillo face +Z, the cow -Z: it is seen from its side)
    for path, front in ((REPO / "data" / "creature.ply", [0, 0, 1]), (SHARED_MESHES / "armadillo43k.obj", [0, 0, 1]),
                        (SHARED_MESHES / "spot" / "spot_triangulated.obj", [1, 0, 0])):
        if not path.exists():
            pytest.skip(f"{path} is not there")
        mesh = read_mesh(path)
        assert np.allclose(front_direction(mesh.vertices, guess_up_axis(mesh)), front), path.name
