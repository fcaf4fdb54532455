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
