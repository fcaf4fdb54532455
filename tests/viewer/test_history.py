"""The undo history's memory budget (hybridedit.viewer.model.history): real snapshots of a real session,
the oldest steps dropped and reported, undo and redo exact after drops, the default sized to the shape,
and the window saying once that the history is full."""

from __future__ import annotations

import numpy as np
import pytest
from qtpy import QtCore

from hybridedit.core.transforms import rigid_transform
from hybridedit.deform.editor import HybridEditor
from hybridedit.viewer.model.history import FLOOR, SHAPE_COPIES, History, default_budget, snapshot_buffers
from hybridedit.viewer.model.selection_masks import HANDLE, ROI
from hybridedit.viewer.model.session import Session
from support.window_driving import key, rubber_band

Qt = QtCore.Qt


def _cycle(s: Session, k: int) -> None:
    """A new selection (ROI and handle round a cage point that moves with ``k``), a drag and its settle:
    three undo steps, two of them new poses."""
    P = s.cage_positions
    c = P[(37 * k) % len(P)]
    d = np.linalg.norm(P - c, axis=1)
    s.selection.set_mask(ROI, d < 0.9)
    s.selection.set_mask(HANDLE, d < 0.25)
    T0 = s.begin_drag()
    for j in range(1, 4):
        s.drag_to(rigid_transform(translate=(0.0, 0.03 * j, 0.02 * (k % 3))) @ T0)
    s.end_drag()
    s.finish_settle()


def _union_bytes(h: History) -> int:
    """The distinct buffers the kept snapshots hold, counted afresh."""
    found: dict[int, int] = {}
    for snap in h._items:
        found.update(snapshot_buffers(snap))
    return sum(found.values())


@pytest.fixture
def small_budget_session(editor_parts):
    """A session whose history keeps about four select-and-drag cycles of the test shape."""
    mesh, cage, M = editor_parts
    probe = Session(HybridEditor(mesh, 150, cage=cage, binding=M), cage_size=150)
    _cycle(probe, 0)
    _cycle(probe, 1)
    per_cycle = (probe.history.nbytes - sum(snapshot_buffers(probe.history._items[0]).values())) / 2
    return Session(HybridEditor(mesh, 150, cage=cage, binding=M), cage_size=150,
                   history_budget=int(4 * per_cycle))


def test_the_budget_is_kept_and_counts_shared_arrays_once(small_budget_session):
    s = small_budget_session
    h = s.history
    for k in range(12):
        _cycle(s, k)
        assert h.nbytes == _union_bytes(h)  # the running count is the union of what the snapshots hold
        assert h.nbytes <= h.budget
    assert h.dropped > 0 and len(h) < 3 * 12
    # snapshots share arrays: a selection step keeps the pose of the step before it
    assert h.nbytes < sum(sum(snapshot_buffers(snap).values()) for snap in h._items)


def test_the_oldest_steps_are_dropped_and_reported(small_budget_session):
    s = small_budget_session
    h = s.history
    dropped = []
    real_push = h.push
    h.push = lambda snap: dropped.append(real_push(snap)) or dropped[-1]
    for k in range(12):
        _cycle(s, k)
    assert sum(dropped) == h.dropped > 0 and dropped[0] == 0
    # the oldest kept step is the base state now: undo goes back to it and no further
    undone = 0
    while s.undo():
        undone += 1
    assert undone == len(h) - 1 and not h.can_undo()


def test_undo_and_redo_are_exact_after_drops(small_budget_session):
    s = small_budget_session
    h = s.history
    poses = []  # the pose after each step, by the step's snapshot
    real_push = h.push

    def push(snap):
        poses.append((snap, s.editor.deformed_vertices.copy(), s.cage_positions))
        return real_push(snap)

    h.push = push
    for k in range(12):
        _cycle(s, k)
    assert h.dropped > 0
    kept = {id(snap): (V, P) for snap, V, P in poses}
    steps = []
    while True:  # back to the base state, every step its exact pose
        V, P = kept[id(h.current)]
        assert np.array_equal(s.shape_positions, V) and np.array_equal(s.cage_positions, P)
        steps.append(id(h.current))
        if not s.undo():
            break
    while s.redo():
        V, P = kept[id(h.current)]
        assert np.array_equal(s.shape_positions, V) and np.array_equal(s.cage_positions, P)
    assert len(steps) == len(h)
    _cycle(s, 99)  # and editing goes on from a redone pose
    assert np.isfinite(s.shape_positions).all()


def test_the_default_budget_is_sized_to_the_shape(editor_parts):
    big = 1 << 40
    assert default_budget(2_000_000, memory=big) == 2 * default_budget(1_000_000, memory=big) \
        == 2 * SHAPE_COPIES * 1_000_000 * 24
    assert default_budget(100, memory=big) == FLOOR  # a small shape: the count limits it
    assert default_budget(10**9, memory=16 * 2**30) == 4 * 2**30  # at most a quarter of the memory
    mesh, cage, M = editor_parts
    s = Session(HybridEditor(mesh, 150, cage=cage, binding=M), cage_size=150)
    assert s.history.budget == default_budget(mesh.n_vertices)


def test_the_window_says_once_that_the_history_is_full(qtbot, win):
    w = win
    h = w.session.history
    h.limit = 4  # (the count limit: the rectangles below each make one step)
    key(qtbot, w, Qt.Key.Key_S)  # Select mode (the rectangle tool, target ROI)
    assert w.controller.mode == "select"
    for k in range(6):
        rubber_band(qtbot, w, x_from=0.3 - 0.25 * k)
    assert h.dropped >= 2
    log = w.status.log.toPlainText()
    assert log.count("Undo history full") == 1, log
    assert "the oldest 1 was dropped" in log


def test_the_heap_is_trimmed_once_half_the_budget_is_let_go(small_budget_session, monkeypatch):
    import hybridedit.viewer.model.history as history

    trims = []
    monkeypatch.setattr(history, "trim_heap", lambda: trims.append(h.dropped) or True)
    s = small_budget_session
    h = s.history
    for k in range(12):
        _cycle(s, k)
    # each trim after at least half a budget's snapshots went: a few over the run, not one a step
    assert 2 <= len(trims) < h.dropped / 2
