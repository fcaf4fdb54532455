"""The selection of a session (no Qt): handle groups as roles, strokes as one undo step."""

from __future__ import annotations

import numpy as np

from hybridedit.deform.roles import FIXED, FREE, handle
from hybridedit.viewer.model.selection_masks import HANDLE, NO_GROUP, ROI


def test_handle_groups_are_roles_and_an_empty_group_drops_out(session):
    s = session
    P = s.cage_positions
    x = P[:, 0]
    s.set_mask(ROI, x > 0.0)
    s.set_mask(HANDLE, x > 1.4)
    assert s.new_group() and s.active == 1 and not s.handle.any()
    s.set_mask(HANDLE, x < -1.4)
    assert np.array_equal(s.handle_group[x > 1.4], np.full(np.count_nonzero(x > 1.4), handle(0)))
    assert np.all(s.handle_group[x < -1.4] == handle(1)) and np.all(s.handle_group[np.abs(x) <= 1.4] == NO_GROUP)
    r = s.cage_roles()
    assert np.all(r[x > 1.4] == handle(0)) and np.all(r[x < -1.4] == handle(1))
    assert np.all(r[(x > 0.0) & (x <= 1.4)] == FREE) and np.all(r[(x <= 0.0) & (x >= -1.4)] == FIXED)
    # a third group left empty: the engine numbers the groups it is given 0..G-1, all non-empty
    assert s.new_group() and s.n_groups == 3
    assert s.next_group() == 0
    s.begin_drag()
    assert s.n_groups == 2 and s.editor.n_groups == 2
    assert np.array_equal(s.cage_roles()[x < -1.4], np.full(np.count_nonzero(x < -1.4), handle(1)))


def test_a_stroke_is_one_undo_step(session):
    s = session
    x = s.cage_positions[:, 0]
    n = len(s.history)
    s.begin_stroke(ROI)
    s.stroke(x > 1.0, "replace")
    s.stroke(x < -1.0, "add")
    assert len(s.history) == n
    assert s.end_stroke() and len(s.history) == n + 1
    assert np.array_equal(s.roi, (x > 1.0) | (x < -1.0))
    s.undo()
    assert not s.roi.any()
