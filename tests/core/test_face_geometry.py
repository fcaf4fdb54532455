"""Face normals, areas, the enclosed volume and the centre of mass: one rule each
(hybridedit.core.face_geometry)."""

from __future__ import annotations

import numpy as np
from numba import njit

from hybridedit.core.face_geometry import (centre_of_mass, face_areas, face_normals, face_vector, face_vectors,
                                           signed_volume, surface_area)

from shapes import bumpy_blob


@njit(cache=False)
def _each_face(v, f):
    out = np.empty((f.shape[0], 3))
    for t in range(f.shape[0]):
        out[t, 0], out[t, 1], out[t, 2] = face_vector(v, f, t)
    return out


def test_the_kernels_twin_gives_the_same_bits():
    blob = bumpy_blob(3)
    v = blob.vertices * 1e3 + 1e5  # far from the origin: any other order of operations rounds otherwise
    assert np.array_equal(_each_face(v, blob.faces), face_vectors(v, blob.faces))


def test_normals_areas_and_volume_of_a_unit_cube_corner():
    v = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])  # outward
    assert np.allclose(face_normals(v, f)[:3], [[0, 0, -1], [0, -1, 0], [-1, 0, 0]])
    assert np.allclose(face_areas(v, f), [0.5, 0.5, 0.5, np.sqrt(3) / 2])
    assert np.isclose(surface_area(v, f), 1.5 + np.sqrt(3) / 2)
    assert np.isclose(signed_volume(v, f), 1 / 6) and np.isclose(signed_volume(v, f[:, ::-1]), -1 / 6)
    assert np.isclose(signed_volume(v + 1e8, f), 1 / 6, rtol=1e-6)  # about the mean: no loss far away
    flat = np.array([[0, 0, 1]])  # two corners on one point: no area, a zero normal
    assert face_normals(v, flat).tolist() == [[0.0, 0.0, 0.0]] and face_areas(v, flat).tolist() == [0.0]


def test_centre_of_mass_weighs_by_area():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [5, 5, 0], [5.001, 5, 0], [5, 5.001, 0]], float)
    f = np.array([[0, 1, 2], [3, 4, 5]])
    assert np.linalg.norm(centre_of_mass(v, f) - [1 / 3, 1 / 3, 0]) < 1e-4
    assert np.allclose(centre_of_mass(v, np.array([[0, 0, 1]])), v.mean(axis=0))  # no area: the vertex mean
