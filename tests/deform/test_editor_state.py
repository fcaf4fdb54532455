"""Snapshots of an editor's selection and pose, and going back to them (hybridedit.deform.editor_state)."""

import numpy as np
import pytest

from hybridedit import HybridEditor


@pytest.fixture(scope="module")
def ed(blob):
    return HybridEditor(blob, cage_size=300, propagation="linear")


def ends(mesh, frac=0.2):
    x = mesh.vertices[:, 0]
    span = x.max() - x.min()
    return np.flatnonzero(x < x.min() + frac * span), np.flatnonzero(x > x.max() - frac * span)


def test_save_and_restore_state_bring_back_selection_and_pose(ed):
    a, b = ends(ed.mesh)
    ed.set_selection(b, fixed=a)
    x = ed.deformed_vertices.copy()  # the pose the constraints refer to
    ed.drag(translate=(0, 0.5, 0))
    state = ed.save_state()
    shape = ed.deformed_vertices.copy()
    ed.set_selection(a, roi=np.arange(ed.mesh.n_vertices // 2))
    ed.drag(translate=(0.3, 0, 0))
    ed.restore_state(state)
    assert np.array_equal(ed.deformed_vertices, shape)
    assert np.allclose(ed.transform[:3, 3], [0, 0.5, 0])
    ed.drag(translate=(0, 0.6, 0))  # continues from the restored selection: constraints exact
    assert np.abs(ed.deformed_vertices[a] - x[a]).max() == 0.0
    assert np.allclose(ed.deformed_vertices[b], x[b] + [0, 0.6, 0], atol=1e-12)


def test_snapshots_of_one_pose_share_its_arrays_and_each_restores_exactly(blob):
    """A selection changes no pose: its snapshot shares the previous snapshot's shape (an 11M shape
    is 265 MB a copy); a new pose gets its own, and every snapshot brings back its pose bit for bit."""
    ed = HybridEditor(blob, cage_size=300, propagation="linear")
    a, b = ends(ed.mesh)
    ed.set_selection(b, fixed=a)
    first = ed.save_state()
    ed.set_selection(a, fixed=b)
    second = ed.save_state()
    assert second.shape is first.shape and second.rotations is first.rotations
    ed.drag(translate=(0, 0.4, 0))
    posed, posed_shape = ed.save_state(), ed.deformed_vertices.copy()
    assert posed.shape is not first.shape and not np.array_equal(posed.shape, first.shape)
    x = ed._out[1, 0]
    ed._out[1, 0] = 0.0
    plus = ed.save_state()
    ed._out[1, 0] = -0.0  # (equal to 0.0 for array_equal, not the same bits)
    minus = ed.save_state()
    assert minus.shape is not plus.shape and np.signbit(minus.shape[1, 0]) and not np.signbit(plus.shape[1, 0])
    ed._out[1, 0] = x
    ed.restore_state(first)
    assert np.array_equal(ed.deformed_vertices.view(np.uint8), first.shape.view(np.uint8))
    ed.restore_state(posed)
    assert np.array_equal(ed.deformed_vertices, posed_shape)


def test_a_snapshot_measures_what_it_holds_beyond_the_editor(blob):
    """state_buffers counts a snapshot's pose, base, selection and frame steps, each buffer once, and none
    of what the editor holds for its whole life (the shape, binding, Laplacian)."""
    from hybridedit.core.held_bytes import held_buffers, owner

    ed = HybridEditor(blob, cage_size=300)
    a, b = ends(ed.mesh)
    ed.set_selection(b, fixed=a)
    ed.drag(translate=(0, 0.5, 0))
    s1 = ed.save_state()
    ed.set_selection(a, fixed=b)  # a new selection from that pose: a new base, no new pose
    s2 = ed.save_state()
    one, two = ed.state_buffers(s1), ed.state_buffers(s2)
    n3 = ed.mesh.n_vertices * 3 * 8
    assert id(owner(s1.shape)) in one and s2.shape is s1.shape  # the pose, shared by the two snapshots
    both = ed.state_buffers(s2, out=dict(one))
    assert sum(both.values()) < sum(one.values()) + sum(two.values()) - n3 + 1
    own = held_buffers(ed.mesh, ed.M, ed.rig)
    assert not set(own) & (set(one) | set(two))
    assert sum(two.values()) - sum(one.values()) > 1.5 * n3  # s2's base pose: its shape and residual
