"""The window's editing state (no Qt): epochs, settling, undo, edit files."""

from __future__ import annotations

import numpy as np
import pytest

from hybridedit.fileio.editfile import Edit
from hybridedit.deform.editor import HybridEditor, SelectionError
from hybridedit.core.transforms import rigid_transform
from hybridedit.viewer.model.selection_masks import HANDLE, ROI
from hybridedit.viewer.model.session import Session


def _select(s: Session, roi_x: float = 0.0, handle_x: float = 1.4) -> None:
    P = s.cage_positions
    s.selection.set_mask(ROI, P[:, 0] > roi_x)
    s.selection.set_mask(HANDLE, P[:, 0] > handle_x)


def test_settle_in_slices_equals_the_batch_replay(session, editor_parts):
    s = session
    _select(s)
    T0 = s.begin_drag()
    for k in range(1, 6):
        s.drag_to(rigid_transform(translate=(0, 0.1 * k, 0)) @ T0)
    assert s.end_drag() and s.settling
    steps = 0
    while not s.settle_step(3):
        steps += 1
    assert steps >= 5 and not s.settling
    V = s.shape_positions.copy()
    # what `hybridedit deform` does: a fresh editor, 30 frames of 2 iterations at the final transform
    mesh, cage, M = editor_parts
    ed = HybridEditor(mesh, 150, cage=cage, binding=M)
    ed.set_selection(np.flatnonzero(s.selection.handle), roi=np.flatnonzero(s.selection.roi), space="cage")
    for _ in range(30):
        W = ed.drag(transform=s.transform)
    assert np.array_equal(V, W)
    assert s.history.current.label == "drag"


def test_reading_the_pose_completes_a_settle(session):
    s = session
    _select(s)
    s.begin_drag()
    s.drag_to(rigid_transform(translate=(0, 0.3, 0)))
    s.end_drag()
    assert s.settling
    P = s.cage_positions  # completes it
    h = s.selection.handle
    assert not s.settling and np.allclose(P[h] - s.editor.cage.vertices[h], [0, 0.3, 0])


def test_second_drag_continues_the_same_selection(session):
    s = session
    _select(s)
    T = s.begin_drag()
    s.drag_to(rigid_transform(translate=(0, 0.2, 0)) @ T)
    s.end_drag()
    T = s.begin_drag()
    s.drag_to(rigid_transform(translate=(0.1, 0, 0)) @ T)
    s.end_drag()
    edit = s.to_edit()
    assert np.allclose(edit.translate, [0.1, 0.2, 0]) and edit.rotate is None
    assert s.replayable and len(edit.steps) == 1 and edit.iterations == s.settle_frames * s.settle_iterations
    # undo one drag: the transform goes back too
    s.undo()
    assert np.allclose(s.transform[:3, 3], [0, 0.2, 0])
    assert np.allclose(s.to_edit().translate, [0, 0.2, 0])
    # a new selection on the deformed pose starts a new epoch
    s.selection.set_mask(HANDLE, s.selection.handle & (s.cage_positions[:, 0] > 1.6))
    assert not s.applied
    s.begin_drag()
    assert np.allclose(s.transform, np.eye(4))
    edit = s.to_edit()  # the first selection's settled drag, then the new selection (not dragged yet)
    assert s.replayable and len(edit.steps) == 2 and edit.iterations == 0
    assert np.allclose(edit.before[0].translate, [0, 0.2, 0])


def test_undo_into_an_earlier_selection_restores_its_engine_selection(session):
    s = session
    _select(s)
    T = s.begin_drag()
    s.drag_to(rigid_transform(translate=(0, 0.2, 0)) @ T)
    s.end_drag()
    after_first = s.cage_positions
    s.selection.set_mask(HANDLE, s.cage_positions[:, 1] < -0.6)  # another handle, another epoch
    T = s.begin_drag()
    s.drag_to(rigid_transform(translate=(0, -0.2, 0)) @ T)
    s.end_drag()
    s.undo()  # the drag of the second handle
    s.undo()  # the second handle selection
    assert np.array_equal(s.cage_positions, after_first)
    # dragging again continues the first epoch
    T = s.begin_drag()
    assert np.allclose(T[:3, 3], [0, 0.2, 0])
    s.drag_to(rigid_transform(translate=(0, 0.1, 0)) @ T)
    s.end_drag()
    assert np.allclose(s.to_edit().translate, [0, 0.3, 0])


def test_selection_errors(session):
    s = session
    with pytest.raises(SelectionError, match="handle is empty"):
        s.begin_drag()
    with pytest.raises(SelectionError, match="handle is empty"):
        s.to_edit()
    with pytest.raises(ValueError):
        s.selection.set_mask(ROI, np.ones(3, dtype=bool))


def test_load_edit_replays_and_failures_keep_the_state(session):
    s = session
    _select(s)
    T = s.begin_drag()
    s.drag_to(rigid_transform(translate=(0, 0.2, 0)) @ T)
    s.end_drag()
    before = s.cage_positions
    n = len(s.history)
    bad = Edit(handle=np.array([10_000]), space="cage")
    with pytest.raises(SelectionError):
        s.load_edit(bad)
    assert np.array_equal(s.cage_positions, before) and len(s.history) == n
    # an edit in shape space, with fixed instead of roi
    V = s.mesh.vertices
    edit = Edit(handle=np.flatnonzero(V[:, 0] > 1.7), fixed=np.flatnonzero(V[:, 0] < -0.5), space="shape",
                translate=np.array([0.0, 0.0, 0.25]))
    s.load_edit(edit)
    assert s.history.current.label == "load edit"
    assert s.replayable and np.allclose(s.transform[:3, 3], [0, 0, 0.25])
    mesh = s.mesh
    ed = HybridEditor(mesh, 150, cage=s.editor.cage, binding=s.editor.M)
    ed.set_selection(edit.handle, fixed=edit.fixed, space="shape")
    for _ in range(30):
        W = ed.drag(translate=(0, 0, 0.25))
    assert np.array_equal(s.shape_positions, W)


def test_load_edit_converges_a_last_step_that_converged(session, editor_parts):
    """An edit whose last step converged (HybridEditor.converge, e.g. from the API or Blender's
    settle) loads to the pose ``hybridedit deform`` replays, exactly, not to a settle's frames."""
    s = session
    mesh, cage, M = editor_parts
    V = mesh.vertices
    ed = HybridEditor(mesh, 150, cage=cage, binding=M)
    ed.set_selection(np.flatnonzero(V[:, 0] > 1.7), roi=np.flatnonzero(V[:, 0] > 0.0), space="shape")
    T = rigid_transform(translate=(0, 0.1, 0.35))
    ed.drag(transform=T)
    r = ed.converge(transform=T, tolerance=1e-8)
    assert r.converged
    edit = ed.edit
    assert edit.converge is not None and edit.converge["tolerance"] == 1e-8
    s.load_edit(edit)
    fresh = HybridEditor(mesh, 150, cage=cage, binding=M)
    fresh.apply_edit(edit)  # (what `hybridedit deform` runs)
    assert np.array_equal(s.shape_positions, fresh.deformed_vertices)
    assert np.abs(s.shape_positions - r.vertices).max() <= 1e-7 * mesh.bbox_diagonal()
