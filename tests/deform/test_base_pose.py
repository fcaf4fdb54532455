"""The pose the next edit starts from: the rest base, the current pose as a base, propagation from a base."""

import numpy as np
import pytest

from hybridedit import HybridEditor, build_rig
from hybridedit.deform.base_pose import BasePose, current_base, fit_cage, propagate_from, propagated_residual, rest_base
from hybridedit.deform.residual import residual_setup
from hybridedit.core.transforms import rigid_transform

from shapes import bumpy_blob


@pytest.fixture(scope="module")
def rig():
    r = build_rig(bumpy_blob(3), cage_size=150)
    d, idx, w = residual_setup(r.M, r.mesh.vertices, r.cage.vertices)
    return r, d, (idx, w)


def test_the_rest_base_is_the_input_with_the_residual_propagation(rig):
    r, d, blend = rig
    base = rest_base(binding=r.M, cage=r.cage.vertices, residual=d, blend=blend, propagation="residual",
                     shape=r.mesh.vertices)
    assert base.at_rest and base.cage is r.cage.vertices
    assert np.array_equal(base.shape, r.mesh.vertices)  # the input itself: exact
    assert np.abs(r.M @ r.cage.vertices + d - r.mesh.vertices).max() < 1e-12  # what the propagation gives there
    assert propagated_residual(base, blend, propagation="residual")[0] is d


def test_the_rest_base_is_m_times_the_cage_with_the_linear_propagation(rig):
    r, d, blend = rig
    base = rest_base(binding=r.M, cage=r.cage.vertices, residual=d, blend=blend, propagation="linear",
                     shape=r.mesh.vertices)
    assert np.abs(base.shape - r.M @ r.cage.vertices).max() < 1e-14
    assert not np.any(base.residual)
    assert propagated_residual(base, blend, propagation="linear") is None  # the paper's plain x' = M y'


def test_the_current_pose_becomes_a_base_of_its_own(rig):
    r, d, blend = rig
    rest = rest_base(binding=r.M, cage=r.cage.vertices, residual=d, blend=blend, propagation="residual",
                     shape=r.mesh.vertices)
    cage = r.cage.vertices + 0.1
    shape = r.mesh.vertices * 1.05
    assert current_base(rest, moved=False, cage=cage, shape=shape, binding=r.M) is rest
    base = current_base(rest, moved=True, cage=cage, shape=shape, binding=r.M)
    assert not base.at_rest
    assert np.array_equal(base.residual, shape - r.M @ cage)
    cage[:] = 0.0  # the base keeps copies
    shape[:] = 0.0
    assert np.any(base.cage) and np.any(base.shape)


@pytest.mark.parametrize("propagation", ["residual", "linear"])
def test_propagating_a_base_unmoved_gives_the_base(rig, propagation):
    r, d, blend = rig
    rest = rest_base(binding=r.M, cage=r.cage.vertices, residual=d, blend=blend, propagation=propagation,
                     shape=r.mesh.vertices)
    rng = np.random.default_rng(1)
    base = current_base(rest, moved=True, cage=r.cage.vertices + 0.02 * rng.standard_normal(r.cage.vertices.shape),
                        shape=r.mesh.vertices + 0.02 * rng.standard_normal(r.mesh.vertices.shape), binding=r.M)
    out = np.empty_like(base.shape)
    eye = np.tile(np.eye(3), (len(base.cage), 1, 1))
    propagate_from(base, binding=r.M, cage=base.cage, rotations=eye, blend=blend, propagation=propagation, out=out)
    assert np.abs(out - base.shape).max() < 1e-12  # the linear propagation adds a moved base's residual too


def test_the_residual_turns_with_the_cage(rig):
    r, d, blend = rig
    rest = rest_base(binding=r.M, cage=r.cage.vertices, residual=d, blend=blend, propagation="residual",
                     shape=r.mesh.vertices)
    T = rigid_transform(axis=(0, 0, 1), degrees=40, translate=(0.3, 0, 0))
    R = T[:3, :3]
    out = np.empty_like(rest.shape)
    propagate_from(rest, binding=r.M, cage=r.cage.vertices @ R.T + T[:3, 3], rotations=np.tile(R, (len(rest.cage), 1, 1)),
                   blend=blend, propagation="residual", out=out)
    assert np.abs(out - (rest.shape @ R.T + T[:3, 3])).max() < 1e-12  # a rigid motion moves everything rigidly


def test_fit_cage_moves_the_cage_as_the_nearest_shape_vertices(rig):
    r, _, _ = rig
    x, c = r.mesh.vertices, r.cage.vertices
    nearest = np.arange(len(c)) % len(x)
    assert np.array_equal(fit_cage(x, rest_shape=x, rest_cage=c, nearest=nearest), c)
    assert np.allclose(fit_cage(x + [0.5, 0, -1], rest_shape=x, rest_cage=c, nearest=nearest), c + [0.5, 0, -1],
                       atol=1e-14)


@pytest.mark.parametrize("propagation", ["residual", "linear"])
def test_successive_edits_compose_through_the_front_door(rig, propagation):
    r, _, _ = rig
    x = r.mesh.vertices
    ed = HybridEditor(r, propagation=propagation)
    a, b = np.flatnonzero(x[:, 0] < -1.0), np.flatnonzero(x[:, 0] > 1.4)
    ed.set_selection(b, fixed=a)
    for _ in range(3):
        ed.drag(translate=(0, 0.4, 0))
    posed = ed.deformed_vertices.copy()
    ed.set_selection(a, fixed=b)  # the next edit starts from the current pose
    assert isinstance(ed._base, BasePose) and not ed.starts_at_rest
    assert np.abs(ed.drag(transform=np.eye(4)) - posed).max() < 1e-12
    ed.reset()
    assert ed.starts_at_rest and ed._base is ed._rest_base
