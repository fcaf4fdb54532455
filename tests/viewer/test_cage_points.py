"""The pose stays visible: the cage points hide on a key and a View menu entry and while dragging, and a
dense ROI's points are thinned out on screen without changing the selection (real Qt events)."""

from __future__ import annotations

import numpy as np
import pytest
from qtpy import QtCore, QtWidgets

from hybridedit.viewer.render.point_thinning import CELL_WIDTHS, THIN_FROM, one_per_cell
from support.window_driving import handle_point, key, opened_window, projected, select_tip, select_tip_to_drag, settled

Qt = QtCore.Qt


def drawn(qtbot, w) -> None:
    """Wait for the next frame the view draws."""
    with qtbot.waitSignal(w.view.rendered, timeout=5000):
        w.view.request_render()


def view_menu_entry(w, text: str) -> QtWidgets.QAction:
    """The View menu's entry named ``text`` (as the menu bar holds it)."""
    menu = next(a.menu() for a in w.menuBar().actions() if a.text() == "&View")
    return next(a for a in menu.actions() if a.text().replace("&", "") == text)


def test_p_and_the_view_menu_hide_and_show_the_cage_points(qtbot, win):
    w = win
    select_tip(w)
    drawn(qtbot, w)
    assert w.scene.points_drawn and len(w.scene.drawn_points) > 0
    key(qtbot, w, Qt.Key.Key_V)
    drawn(qtbot, w)
    assert not w.scene.points_drawn and not w.actions_["show_points"].isChecked()
    view_menu_entry(w, "Show Cage Points").trigger()  # back from the menu
    drawn(qtbot, w)
    assert w.scene.points_drawn and w.actions_["show_points"].isChecked()
    # the selection stays as it was through both
    assert len(w.scene.shown_points) == np.count_nonzero(w.session.selection.cage_roles() >= 0)


@pytest.mark.parametrize("hide", [True, False])
def test_while_dragging_the_points_are_hidden_by_default(qtbot, win, hide):
    w = win
    w.polisher.enabled = False
    assert w.actions_["hide_points_dragging"].isChecked()  # the default
    if not hide:
        view_menu_entry(w, "Hide Points While Dragging").trigger()
    select_tip_to_drag(qtbot, w)
    a = handle_point(w)
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a)
    for k in range(1, 5):
        qtbot.mouseMove(w.view, a + QtCore.QPoint(0, -15 * k))
        qtbot.wait(10)
    assert w.scene.dragging
    drawn(qtbot, w)
    assert w.scene.points_drawn is not hide  # hidden while the drag is under way, unless asked otherwise
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, a + QtCore.QPoint(0, -60))
    settled(qtbot, w)
    drawn(qtbot, w)
    assert not w.scene.dragging and w.scene.points_drawn  # back on release


@pytest.fixture
def dense_win(qtbot, blob_file):
    """The window with the test shape at a cage of 1,000 vertices: its ROI draws many points."""
    with opened_window(qtbot, cage_size=1000, path=blob_file) as w:
        yield w


def test_a_dense_roi_is_thinned_on_screen_and_the_selection_is_not(qtbot, dense_win):
    w = dense_win
    s = w.session
    P = s.cage_positions
    s.selection.set_mask("roi", np.ones(len(P), dtype=bool))
    s.selection.set_mask("handle", P[:, 0] > P[:, 0].max() - 0.1)
    w.sync.refresh_selection()
    roi_before = s.selection.cage_roles().copy()
    drawn(qtbot, w)
    sc = w.scene
    shown, points = sc.shown_points, sc.drawn_points
    assert len(shown) == len(P) > THIN_FROM
    assert 0 < len(points) < len(shown) and set(points.tolist()) <= set(shown.tolist())
    assert sc.points_poly.n_verts == len(points)  # what VTK draws
    # every handle point is drawn; of the ROI's, at most one per cell on screen
    handle = np.flatnonzero(roi_before > 0)
    assert set(handle.tolist()) <= set(points.tolist())
    roi_drawn = np.setdiff1d(points, handle)
    d, _ = projected(w, P[roi_drawn])
    assert one_per_cell(d[:, :2], CELL_WIDTHS * sc.point_pixels()).all()
    # the selection itself is unchanged
    assert np.array_equal(s.selection.cage_roles(), roi_before)
    assert np.count_nonzero(s.selection.cage_roles() >= 0) == len(P)
    # closer up the points spread out on screen: more of them are drawn
    w.view.plotter.camera.zoom(3.0)
    drawn(qtbot, w)
    assert len(sc.drawn_points) > len(points)


def test_one_per_cell_keeps_the_first_point_of_each_cell():
    xy = np.array([[0.2, 0.2], [2.9, 2.9], [3.1, 0.0], [0.0, 3.1], [3.5, 3.5], [3.2, 3.2]])
    assert one_per_cell(xy, 3.0).tolist() == [True, False, True, True, True, False]
    assert not one_per_cell(np.zeros((0, 2)), 3.0).any()
