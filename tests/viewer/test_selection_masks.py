"""The selection of a session (no Qt): handle groups as roles, strokes as one undo step, and a
selection that needs of its owner only what :class:`SelectionOwner` declares (and holds it weakly)."""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest

from hybridedit.deform.roles import FIXED, FREE, handle
from hybridedit.viewer.model.selection_masks import HANDLE, NO_GROUP, ROI, Selection, SelectionOwner


def test_handle_groups_are_roles_and_an_empty_group_drops_out(session):
    s = session
    sel = s.selection
    P = s.cage_positions
    x = P[:, 0]
    sel.set_mask(ROI, x > 0.0)
    sel.set_mask(HANDLE, x > 1.4)
    assert sel.new_group() and sel.active == 1 and not sel.handle.any()
    sel.set_mask(HANDLE, x < -1.4)
    assert np.array_equal(sel.handle_group[x > 1.4], np.full(np.count_nonzero(x > 1.4), handle(0)))
    assert np.all(sel.handle_group[x < -1.4] == handle(1)) and np.all(sel.handle_group[np.abs(x) <= 1.4] == NO_GROUP)
    r = sel.cage_roles()
    assert np.all(r[x > 1.4] == handle(0)) and np.all(r[x < -1.4] == handle(1))
    assert np.all(r[(x > 0.0) & (x <= 1.4)] == FREE) and np.all(r[(x <= 0.0) & (x >= -1.4)] == FIXED)
    # a third group left empty: the engine numbers the groups it is given 0..G-1, all non-empty
    assert sel.new_group() and sel.n_groups == 3 and len(s.transforms) == 3
    assert sel.next_group() == 0
    s.begin_drag()
    assert sel.n_groups == 2 and s.editor.n_groups == 2 and len(s.transforms) == 2
    assert np.array_equal(sel.cage_roles()[x < -1.4], np.full(np.count_nonzero(x < -1.4), handle(1)))


def test_a_stroke_is_one_undo_step(session):
    s = session
    sel = s.selection
    x = s.cage_positions[:, 0]
    n = len(s.history)
    sel.begin_stroke(ROI)
    sel.stroke(x > 1.0, "replace")
    sel.stroke(x < -1.0, "add")
    assert len(s.history) == n
    assert sel.end_stroke() and len(s.history) == n + 1
    assert np.array_equal(sel.roi, (x > 1.0) | (x < -1.0))
    s.undo()
    assert not sel.roi.any()


class Owner:
    """Only what a :class:`SelectionOwner` declares (no session): it records what it is told."""

    def __init__(self, editor):
        self.editor = editor
        self.told: list[str] = []

    def finish_settle(self) -> None:
        self.told.append("finish_settle")

    def group_added(self, label: str) -> None:
        self.told.append(f"group_added {label}")

    def reset_transforms(self) -> None:
        self.told.append("reset_transforms")

    def selection_changed(self, label: str) -> None:
        self.told.append(f"changed {label}")


def test_a_selection_asks_its_owner_only_what_the_protocol_declares(session):
    owner = Owner(session.editor)
    assert isinstance(owner, SelectionOwner) and isinstance(session, SelectionOwner)
    sel = Selection(owner)
    x = session.editor.cage.vertices[:, 0]
    assert sel.set_mask(HANDLE, x > 1.4) and not sel.set_mask(HANDLE, x > 1.4)
    assert sel.new_group() and sel.next_group() == 0
    assert sel.clear_all() and not sel.clear_all()
    assert owner.told == ["changed select handle", "finish_settle", "group_added new handle group",
                          "finish_settle", "reset_transforms", "changed clear selection"]
    assert not sel.engine_has_masks() and sel.shape_roles().shape == (session.mesh.n_vertices,)


def test_a_session_dropped_is_freed_at_once(editor_parts):
    """The selection holds its session weakly: no reference cycle keeps a dropped session (and its engine's
    arrays) alive until the garbage collector runs."""
    from hybridedit.deform.editor import HybridEditor
    from hybridedit.viewer.model.session import Session

    mesh, cage, M = editor_parts
    s = Session(HybridEditor(mesh, 150, cage=cage, binding=M), cage_size=150)
    s.selection.set_mask(HANDLE, np.arange(s.n_cage) < 5)
    sel, gone = s.selection, weakref.ref(s)
    gc.disable()
    try:
        del s
        assert gone() is None
    finally:
        gc.enable()
    with pytest.raises(ReferenceError, match="gone"):
        sel.clear_all()
