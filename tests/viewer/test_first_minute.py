"""The first minute in the window: the first-steps hint on the view (shown until the first selection,
never again once dismissed) and Help ▸ How to Edit (fits a 700 px high screen, wraps to its width, and
is the same text as docs/window.md's). Real Qt events; each test has a user cache folder of its own."""

from __future__ import annotations

import re

import pytest
from qtpy import QtCore, QtWidgets

from hybridedit.fileio import user_flags
from hybridedit.fileio.user_flags import flag_set
from hybridedit.viewer.window.first_steps import DISMISSED
from hybridedit.viewer.window.help_texts import HOWTO
from shapes import REPO
from support.window_driving import CAGE, key, rubber_band

Qt = QtCore.Qt


@pytest.fixture
def new_user(monkeypatch, tmp_path):
    """A user who has never dismissed the hint: the flags in an empty folder of this test's own (before
    ``win``; the binding cache and the compiled kernels' stamp stay in the tests' shared cache folder)."""
    folder = tmp_path / "cache"
    monkeypatch.setattr(user_flags, "default_cache_dir", lambda: folder)
    return folder


def another_window(qtbot):
    """A second window (no shape), shown; closed by the caller."""
    from hybridedit.viewer.window.main_window import MainWindow

    w = MainWindow(cage_size=CAGE)
    w.show()
    qtbot.waitExposed(w)
    return w


def test_the_hint_is_on_the_view_at_first_launch_and_gone_after_a_selection(new_user, qtbot, win):
    panel = win.first_steps.panel
    assert panel.isVisible() and panel.parent() is win.view
    assert win.view.rect().contains(panel.geometry())  # inside the view, in its corner
    assert panel.geometry().topLeft() == QtCore.QPoint(panel.MARGIN, panel.MARGIN)
    text = panel.text.text()
    for k in ("<b>S</b>", "<b>R</b>", "<b>H</b>", "<b>D</b>", "<b>P</b>"):  # what to press first (P: the Pose tool)
        assert k in text
    key(qtbot, win, Qt.Key.Key_S)  # Select mode, target ROI: a rectangle over the right half
    assert rubber_band(qtbot, win, 0.0).any() and win.session.selection.roi.any()
    assert not panel.isVisible() and not win.first_steps.shown
    assert not flag_set(DISMISSED)  # gone for this window only: a selection is not a dismissal
    other = another_window(qtbot)
    try:
        assert other.first_steps.panel.isVisible()
    finally:
        other.close()


def test_the_hint_dismissed_with_its_close_button_is_never_shown_again(new_user, qtbot, win):
    panel = win.first_steps.panel
    assert panel.isVisible()
    qtbot.mouseClick(panel.close_button, Qt.MouseButton.LeftButton)
    assert not panel.isVisible()
    assert flag_set(DISMISSED) and (new_user / "user-flags.json").is_file()
    other = another_window(qtbot)
    try:
        assert not other.first_steps.panel.isVisible() and not other.first_steps.shown
    finally:
        other.close()


def test_esc_dismisses_the_hint(new_user, qtbot, win):
    assert win.first_steps.panel.isVisible()
    key(qtbot, win, Qt.Key.Key_Escape)
    assert not win.first_steps.panel.isVisible() and flag_set(DISMISSED)


def test_how_to_edit_fits_a_700_px_screen_and_wraps_to_its_width(qtbot, win):
    win.actions_["howto"].trigger()
    dlg = win.dialogs.howto_dialog
    qtbot.waitExposed(dlg)
    try:
        assert dlg.frameGeometry().height() <= 700
        browser = dlg.text
        shown = browser.document().toPlainText()
        assert "Save Edit" in shown and "**" not in shown  # Markdown, rendered
        bar = browser.horizontalScrollBar()
        assert bar.maximum() == 0 and not bar.isVisible()  # no line wider than the dialog
        tall = browser.document().size().height()
        dlg.resize(380, dlg.height())  # narrower: the text wraps again, still no horizontal scroll
        qtbot.waitUntil(lambda: browser.document().size().height() > tall * 1.3)
        assert browser.horizontalScrollBar().maximum() == 0
        assert browser.verticalScrollBar().maximum() > 0  # the rest is reached by scrolling
    finally:
        dlg.close()


def test_how_to_edit_says_one_thing_about_edit_files_and_is_docs_window_md():
    doc = (REPO / "docs" / "window.md").read_text(encoding="utf-8")
    (block,) = re.findall(r"<!-- how-to-edit: begin -->\n(.*?)<!-- how-to-edit: end -->", doc, re.S)
    assert block == HOWTO
    assert "every step since the rest pose" in HOWTO and "last selection" not in HOWTO
