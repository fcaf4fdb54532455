"""Selecting in the window as in Blender and MeshLab, through real Qt mouse and key events: the cage points
in sight and the part they lie in, through its thickness (Select Through, Alt+Z, for what is behind
another part), a click on empty space keeps the selection,
Ctrl+Shift+A clears everything as one undo step and Alt+A the current target."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from qtpy import QtCore

from hybridedit.core.mesh import Mesh
from hybridedit.viewer.window.main_window import MainWindow
from support.window_driving import around, key, look_down_minus_z, mouse_drag, opened_window, projected, to_widget

Qt = QtCore.Qt
CTRL, SHIFT, ALT = (Qt.KeyboardModifier.ControlModifier, Qt.KeyboardModifier.ShiftModifier,
                    Qt.KeyboardModifier.AltModifier)
FRONT_Z, BACK_Z = 0.9, -0.9


def two_limbs() -> Mesh:
    """Two limbs side by side as seen from the side: upright bumpy capsules, one in front of the other
    along the front view's line of sight (a front leg hiding the hind leg)."""
    parts, faces, n = [], [], 0
    for z in (FRONT_Z, BACK_Z):
        s = trimesh.creation.icosphere(subdivisions=4, radius=1.0)
        v = np.asarray(s.vertices).copy()
        v *= (1.0 + 0.04 * np.sin(7 * v[:, 1]) * np.cos(5 * v[:, 0]))[:, None]
        v *= [0.45, 1.6, 0.45]
        v[:, 2] += z
        parts.append(v)
        faces.append(np.asarray(s.faces) + n)
        n += len(v)
    return Mesh(np.vstack(parts), np.vstack(faces), name="limbs")


@pytest.fixture
def limbs(qtbot) -> MainWindow:
    """The window with the two limbs loaded (cage of 160 points), seen from +Z (looking down -Z), Select mode."""
    with opened_window(qtbot, cage_size=160, mesh=two_limbs()) as w:
        look_down_minus_z(w.scene)
        w.view.request_render()
        qtbot.wait(30)
        key(qtbot, w, Qt.Key.Key_S)
        assert w.controller.mode == "select"
        yield w


def click(qtbot, w: MainWindow, at: QtCore.QPoint, modifier=Qt.KeyboardModifier.NoModifier) -> None:
    """Press and release with a pixel of jitter (a hand's click)."""
    mouse_drag(qtbot, w.view, at, at + QtCore.QPoint(1, 1), steps=1, modifier=modifier)


def test_the_rectangle_takes_the_limb_in_sight_whole_not_the_one_behind(qtbot, limbs, tmp_path):
    w = limbs
    s = w.session
    P = s.cage_positions
    front = P[:, 2] > 0
    facing = front & (P[:, 2] - FRONT_Z > 0.15)  # the front limb's side facing the camera
    behind = ~front
    assert behind.sum() > 40 and facing.sum() > 20
    a, b = around(w, np.ones(len(P), dtype=bool))  # over both limbs
    mouse_drag(qtbot, w.view, a, b)
    assert not s.selection.roi[behind].any()  # the hind limb is not taken
    assert np.all(s.selection.roi[front])  # the front one whole: its far side too, through its thickness
    w.view.screenshot(tmp_path / "limbs.png")
    # Alt+Z: Select Through (Blender's X-ray) takes both
    key(qtbot, w, Qt.Key.Key_Z, ALT)
    assert w.actions_["select_through"].isChecked() and w.controller.select_through
    assert "hidden behind the shape" in w.status.current_message()
    mouse_drag(qtbot, w.view, a, b)
    assert s.selection.roi.all()
    # and off again: the brush takes only what is in sight too
    key(qtbot, w, Qt.Key.Key_Z, ALT)
    assert not w.controller.select_through
    key(qtbot, w, Qt.Key.Key_B)
    w.options.brush_spin.setValue(60)
    d, _ = projected(w, P)
    c = to_widget(w, d[behind].mean(axis=0))  # the middle of both limbs on screen
    mouse_drag(qtbot, w.view, c, c + QtCore.QPoint(0, 30), steps=3)
    assert s.selection.roi.any() and not s.selection.roi[behind].any()


def test_a_click_on_empty_space_keeps_the_selection(qtbot, limbs):
    w = limbs
    s = w.session
    P = s.cage_positions
    key(qtbot, w, Qt.Key.Key_Z, ALT)  # (through: the whole limbs)
    key(qtbot, w, Qt.Key.Key_R)
    mouse_drag(qtbot, w.view, *around(w, np.ones(len(P), dtype=bool)))
    key(qtbot, w, Qt.Key.Key_H)
    mouse_drag(qtbot, w.view, *around(w, P[:, 1] < -1.0))  # the feet
    roi, handle = s.selection.roi.copy(), s.selection.handle.copy()
    assert roi.all() and 10 < handle.sum() < len(P) // 3
    n_hist, label = len(s.history), w.status.sel_label.text()
    # a click on empty space, in Handle target, replace mode: nothing changes
    d, _ = projected(w, P)
    empty = to_widget(w, (d[:, 0].max() + 120, d[:, 1].mean()))
    click(qtbot, w, empty)
    assert np.array_equal(s.selection.roi, roi) and np.array_equal(s.selection.handle, handle)
    assert len(s.history) == n_hist and w.status.sel_label.text() == label
    assert w.status.current_message() == "No cage point there: the selection is kept"
    # Shift or Ctrl + click on empty space: nothing either
    click(qtbot, w, empty, CTRL)
    assert np.array_equal(s.selection.handle, handle) and len(s.history) == n_hist
    # a click on a cage point takes that point alone (one undo step)
    i = int(np.argmax(P[:, 2]))
    click(qtbot, w, to_widget(w, d[i]))
    assert np.flatnonzero(s.selection.handle).tolist() == [i] and len(s.history) == n_hist + 1
    key(qtbot, w, Qt.Key.Key_Z, CTRL)
    assert np.array_equal(s.selection.handle, handle)


def test_a_rectangle_over_empty_space_clears_with_a_way_back(qtbot, limbs):
    w = limbs
    s = w.session
    P = s.cage_positions
    key(qtbot, w, Qt.Key.Key_H)
    mouse_drag(qtbot, w.view, *around(w, P[:, 1] > 1.0))
    handle = s.selection.handle.copy()
    assert handle.any()
    d, _ = projected(w, P)
    x = d[:, 0].max() + 60
    mouse_drag(qtbot, w.view, to_widget(w, (x, d[:, 1].max())), to_widget(w, (x + 100, d[:, 1].min())))
    assert not s.selection.handle.any()  # as Blender: a drawn box that takes nothing replaces with nothing...
    assert w.status.current_message() == "Handle cleared (Ctrl+Z restores it)"  # ... and says how to get it back
    key(qtbot, w, Qt.Key.Key_Z, CTRL)
    assert np.array_equal(s.selection.handle, handle)


def test_ctrl_shift_a_clears_everything_in_one_step_and_alt_a_the_target(qtbot, limbs):
    w = limbs
    s = w.session
    P = s.cage_positions
    s.selection.set_mask("roi", P[:, 1] < 0.5)
    s.selection.set_mask("handle", (P[:, 1] < -1.0) & (P[:, 2] > 0))
    key(qtbot, w, Qt.Key.Key_G, CTRL)  # a second handle group: the hind foot
    s.selection.set_mask("handle", (P[:, 1] < -1.0) & (P[:, 2] < 0))
    w.sync.refresh_selection()
    roi, groups = s.selection.roi.copy(), s.selection.handle_group.copy()
    assert s.selection.n_groups == 2 and set(np.unique(groups)) == {0, 1, 2}
    n_hist = len(s.history)
    # Ctrl+Shift+A: the ROI and every handle group, one undo step
    key(qtbot, w, Qt.Key.Key_A, CTRL | SHIFT)
    assert not s.selection.roi.any() and not s.selection.all_handles.any() and s.selection.n_groups == 1
    assert len(s.history) == n_hist + 1
    assert "Ctrl+Z" in w.status.current_message()
    assert w.status.sel_label.text().startswith("ROI 0 · handle 0")
    key(qtbot, w, Qt.Key.Key_Z, CTRL)
    sel = s.selection
    assert np.array_equal(sel.roi, roi) and np.array_equal(sel.handle_group, groups) and sel.n_groups == 2
    # Alt+A in Handle target: the active group only
    key(qtbot, w, Qt.Key.Key_H)
    active = s.selection.active + 1
    key(qtbot, w, Qt.Key.Key_A, ALT)
    assert not np.any(s.selection.handle_group == active) and np.array_equal(s.selection.roi, roi)
    assert np.array_equal(s.selection.handle_group[groups != active], groups[groups != active])
    assert w.status.current_message() == f"Handle group {active} cleared (Ctrl+Z restores it)"
    key(qtbot, w, Qt.Key.Key_Z, CTRL)
    assert np.array_equal(s.selection.handle_group, groups)
    # Alt+A in ROI target: the ROI only
    key(qtbot, w, Qt.Key.Key_R)
    key(qtbot, w, Qt.Key.Key_A, ALT)
    assert not s.selection.roi.any() and np.array_equal(s.selection.handle_group, groups)
    assert w.status.current_message() == "ROI cleared (Ctrl+Z restores it)"
    n_hist = len(s.history)
    key(qtbot, w, Qt.Key.Key_A, ALT)
    assert w.status.current_message() == "Nothing to clear" and len(s.history) == n_hist


def test_the_select_menu_toolbar_and_shortcuts_list(qtbot, limbs):
    w = limbs
    menus = {m.title(): m for m in (a.menu() for a in w.menuBar().actions()) if m is not None}
    names = [a.text() for a in menus["&Select"].actions() if not a.isSeparator()]
    assert names == ["Select &All", "&Invert Selection", "&Clear All", "Clear &Target", "Select &Through",
                     "&Free Around Handle"]
    assert w.actions_["select_through"] in w.findChild(QtCore.QObject, "tools").actions()
    w.actions_["shortcuts"].trigger()
    dlg = w.dialogs.shortcuts_dialog
    qtbot.waitExposed(dlg)
    rows = {dlg.table.item(r, 1).text(): dlg.table.item(r, 0).text() for r in range(dlg.table.rowCount())}
    dlg.close()
    assert rows["Clear All"] == "Ctrl+Shift+A" and rows["Clear Target"] == "Alt+A"
    assert rows["Select Through"] == "Alt+Z"
    assert any(key == "Left click" and "empty space changes nothing" in text for text, key in rows.items())


def test_the_default_rectangle_takes_an_end_as_select_through_does(qtbot, win):
    """The capsule's right end, drawn over from the front: the same cage points with Select Through off (the
    default) as on, so the same drag gives the same pose; a handle clicked in the held part is warned of."""
    w = win
    s = w.session
    P = s.cage_positions
    end = P[:, 0] > 1.3
    key(qtbot, w, Qt.Key.Key_S)
    taken = {}
    for through in (False, True):
        if w.controller.select_through != through:
            key(qtbot, w, Qt.Key.Key_Z, ALT)
        key(qtbot, w, Qt.Key.Key_R)
        mouse_drag(qtbot, w.view, *around(w, P[:, 0] > 0.3))
        key(qtbot, w, Qt.Key.Key_H)
        mouse_drag(qtbot, w.view, *around(w, end, margin=3.0))
        taken[through] = (s.selection.roi.copy(), s.selection.handle.copy())
        assert "would tear" not in w.status.current_message()
    assert np.array_equal(taken[False][0], taken[True][0]) and np.array_equal(taken[False][1], taken[True][1])
    assert np.all(s.selection.handle[end & (P[:, 2] < -0.2)])  # the back of the end, hidden from the front
    # a handle of one point in the held part (a click, in sight): said before any drag
    key(qtbot, w, Qt.Key.Key_Z, ALT)
    d, _ = projected(w, P)
    i = int(np.argmax(np.where(P[:, 0] < -1.0, P[:, 2], -np.inf)))  # the left end's point facing the camera
    click(qtbot, w, to_widget(w, d[i]))
    assert np.flatnonzero(s.selection.handle).tolist() == [i] and not s.selection.roi[i]
    assert "touches 1 held cage point" in w.status.current_message()
    assert s.selection.tearing() == {0: 1}
    # the message is whole on screen, and offers its fix beside it: one key (or click) frees the points around
    assert not w.status.message_label.is_cut()
    assert w.status.offered_fix() is w.actions_["free_around_handle"]
    roi_before = s.selection.roi.copy()
    key(qtbot, w, Qt.Key.Key_F, Qt.KeyboardModifier.ShiftModifier)
    assert s.selection.tearing() == {} and w.status.offered_fix() is None
    freed = s.selection.roi & ~roi_before
    edges = s.editor.cage_edges
    ring = np.unique(edges[(edges == i).any(axis=1)])
    assert freed[ring[ring != i]].all() and not freed[i]  # every held neighbour of the handle, at least
    assert "Freed" in w.status.current_message()
    key(qtbot, w, Qt.Key.Key_Z, Qt.KeyboardModifier.ControlModifier)
    assert np.array_equal(s.selection.roi, roi_before) and s.selection.tearing() == {0: 1}
