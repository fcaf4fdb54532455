"""The shape drawn as one plain-coloured actor per vertex role."""

from __future__ import annotations

import numpy as np
import trimesh
from vtkmodules.vtkRenderingCore import vtkRenderer

from hybridedit.viewer.render.palette import SHAPE_COLOR, shape_tint, stretch_lookup_table
from hybridedit.viewer.render.shape_parts import ShapeParts, face_roles


def _sphere():
    s = trimesh.creation.icosphere(subdivisions=3)
    return np.asarray(s.vertices, dtype=np.float32), np.asarray(s.faces, dtype=np.int64)


def _roles(V):
    r = np.zeros(len(V), dtype=np.int64)
    r[V[:, 0] < -0.2] = -1  # fixed
    r[V[:, 0] > 0.6] = 1  # handle group 0
    r[V[:, 1] > 0.8] = 2  # handle group 1
    return r


def _parts(V, F, roles):
    normals = V / np.linalg.norm(V, axis=1, keepdims=True)
    stretch = np.arange(len(V), dtype=np.float32)
    parts = ShapeParts(vtkRenderer(), F, len(V), shape_tint, stretch_lookup_table())
    parts.set_roles(roles, V, normals.astype(np.float32), stretch)
    return parts, normals.astype(np.float32), stretch


def test_face_roles_common_role_or_free():
    F = np.array([[0, 1, 2], [1, 2, 3], [3, 4, 5], [0, 3, 5]])
    roles = np.array([-1, -1, -1, 2, 2, 2])
    assert face_roles(F, roles).tolist() == [-1, 0, 2, 0]


def test_every_face_drawn_once_in_its_role_colour():
    V, F = _sphere()
    roles = _roles(V)
    parts, normals, _ = _parts(V, F, roles)
    assert sorted(p.role for p in parts.parts) == [-1, 0, 1, 2]
    assert np.all(parts.drawn_faces() == 1)
    fr = face_roles(F, roles)
    colours = parts.face_colours()
    for role in (-1, 0, 1, 2):
        want = shape_tint(np.array([role]))[0]
        assert np.all(colours[fr == role] == want)
    assert np.all(colours[fr == 0] == SHAPE_COLOR.astype(np.uint8))
    assert len({tuple(shape_tint(np.array([r]))[0]) for r in (-1, 0, 1, 2)}) == 4
    # each part's faces, in its local numbering, are the shape's faces
    for p in parts.parts:
        local = p.poly.faces.reshape(-1, 4)[:, 1:]
        assert np.array_equal(p.vertices[local], F[p.face_rows])
    assert np.array_equal(parts.drawn_points(), V)
    assert np.array_equal(parts.drawn_points(normals=True), normals)


def test_a_frame_copies_only_the_changed_rows():
    V, F = _sphere()
    parts, normals, _ = _parts(V, F, _roles(V))
    changed = np.flatnonzero(V[:, 0] > 0.0)
    assert parts.changed is None  # (all rows)
    parts.set_changed(changed)
    assert np.array_equal(parts.changed, changed)
    moved = V.copy()
    moved[changed] += np.float32(0.25)
    moved[~np.isin(np.arange(len(V)), changed)] += np.float32(9.0)  # not copied: must not show
    parts.copy_rows(moved, normals)
    drawn = parts.drawn_points()
    assert np.array_equal(drawn[changed], moved[changed])
    rest = np.setdiff1d(np.arange(len(V)), changed)
    assert np.array_equal(drawn[rest], V[rest])
    parts.copy_rows(moved, normals, everything=True)
    assert np.array_equal(parts.drawn_points(), moved)


def test_new_roles_keep_the_pose_and_stretch_colours_every_part():
    V, F = _sphere()
    parts, normals, stretch = _parts(V, F, np.zeros(len(V), dtype=np.int64))
    assert [p.role for p in parts.parts] == [0]
    parts.set_stretch_visible(True)
    parts.set_roles(_roles(V), V, normals, stretch)  # a new selection while the map is shown
    assert len(parts.parts) == 4
    assert all(p.mapper.GetScalarVisibility() for p in parts.parts)
    for p in parts.parts:
        assert np.array_equal(p.stretch, stretch[p.vertices])
    parts.copy_stretch(stretch[::-1].copy())
    for p in parts.parts:
        assert np.array_equal(p.stretch, stretch[::-1][p.vertices])
    parts.set_stretch_visible(False)
    assert not any(p.mapper.GetScalarVisibility() for p in parts.parts)
    assert np.array_equal(parts.drawn_points(), V)
