"""The Qt binding keeps None's reference count: before Python 3.12 None is counted like any object, and
a binding whose calls that return nothing each drop a reference to it (PySide6 6.12.0) makes the
window abort with "none_dealloc" once the count runs out, a few hundred edits into a session
(benchmarks/soak.py found it; pyproject.toml leaves that version out)."""

from __future__ import annotations

import sys

import pytest
from qtpy import QtWidgets


@pytest.mark.skipif(sys.version_info >= (3, 12), reason="None is immortal from Python 3.12: no count to run out")
def test_calls_that_return_nothing_keep_nones_count(qtbot):
    label = QtWidgets.QLabel()
    qtbot.addWidget(label)
    label.setText("warm")
    before = sys.getrefcount(None)
    for k in range(2000):
        label.setText("a" if k % 2 else "b")  # (what the status bar does a few times a second)
        label.setEnabled(True)
    assert sys.getrefcount(None) - before > -100, "the Qt binding drops a reference to None on each call"
