"""The browser editor's key actions on its session, in-process (no browser): handle groups (Ctrl+G, G),
Select Through (Alt+Z), Mirror X (Shift+X) and what the status line says of each."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("trame")

import hybridedit as he  # noqa: E402
from hybridedit.viewer.model.selection_masks import HANDLE, ROI  # noqa: E402
from hybridedit.viewer.model.session import Session  # noqa: E402
from hybridedit.web.editor_app import WebEditor  # noqa: E402
from shapes import icosphere  # noqa: E402


@pytest.fixture
def web():
    mesh = icosphere(3)
    w = WebEditor(Session(he.HybridEditor(mesh, 80), cage_size=80), "token")
    yield w
    w.polisher.close()
    w.plotter.close()


def test_groups_select_through_and_mirror_from_the_keys(web):
    s, st = web.session, web.state
    web.on_hotkey("g", True)  # Ctrl+G with an empty handle
    assert "still empty" in st.status and s.selection.n_groups == 1
    P = s.cage_positions
    s.selection.select(ROI, P[:, 1] > -0.5, "replace")
    s.selection.select(HANDLE, P[:, 1] > 0.8, "replace")
    web.on_hotkey("g", True)
    assert s.selection.n_groups == 2 and web.gestures.target == HANDLE
    assert "handle group 2 of 2 (magenta)" in st.status, st.status
    web.on_hotkey("g")
    assert s.selection.active == 0 and "Now handle group 1 of 2 (orange)" in st.status, st.status
    web.on_hotkey("z", False, False, True)  # Alt+Z
    assert web.gestures.select_through and "; select through" in st.status
    web.on_hotkey("z", False, False, True)
    assert not web.gestures.select_through and "select through" not in st.status.split(" -- ")[0]
    web.on_hotkey("X", False, True)  # Shift+X: a ball is symmetric across X
    assert s.selection.symmetry == "x" and "; mirror X" in st.status and st.mirror
    assert s.undo() and s.selection.symmetry is None  # one undo step
    assert np.array_equal(s.shape_positions, s.mesh.vertices)
