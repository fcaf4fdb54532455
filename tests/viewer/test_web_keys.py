"""The browser editor's keys (hybridedit.web.keys) are the window's shortcuts for the same actions."""

from __future__ import annotations

from qtpy import QtGui

from hybridedit.web.keys import ALT_KEYS, CTRL_KEYS, PLAIN_KEYS, SHIFT_KEYS, action_of


def _shortcuts(w, action: str) -> set[str]:
    return {s.toString() for s in w.actions_[action].shortcuts()}


def test_each_browser_key_is_the_windows_shortcut_for_its_action(win):
    for key, action in PLAIN_KEYS.items():
        assert QtGui.QKeySequence(key.upper()).toString() in _shortcuts(win, action), (key, action)
        assert action_of(key, False, False) == action
    for key, action in SHIFT_KEYS.items():
        assert QtGui.QKeySequence("Shift+" + key.upper()).toString() in _shortcuts(win, action), (key, action)
        assert action_of(key.upper(), False, True) == action
    for mods, keys in (("Ctrl+", CTRL_KEYS), ("Alt+", ALT_KEYS)):
        for key, action in keys.items():
            if (mods, key) == ("Ctrl+", "y"):
                continue  # (the browser's own Ctrl+Y for Redo, beside the window's Ctrl+Shift+Z)
            assert QtGui.QKeySequence(mods + key.upper()).toString() in _shortcuts(win, action), (mods, key, action)
            assert action_of(key, mods == "Ctrl+", False, mods == "Alt+") == action
    assert "Ctrl+Z" in _shortcuts(win, "undo") and action_of("z", True, False) == "undo"
    assert "Ctrl+Shift+Z" in _shortcuts(win, "redo") and action_of("z", True, True) == "redo"
    assert action_of("y", True, False) == "redo"  # (the browser's own Ctrl+Y too)
    assert action_of("s", True, False) is None  # Ctrl+S stays the browser's
    assert action_of("q", False, False) is None
