"""The information dialogs (hybridedit.viewer.dialogs): Mesh Info's text and the Help and File menu dialogs."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np

import hybridedit as he
from qtpy import QtCore, QtWidgets

from hybridedit.viewer.window.dialogs import mesh_info_text
from hybridedit.viewer.window.help_texts import ABOUT


def fake_session(path=None, notes=()):
    mesh = SimpleNamespace(name="blob", n_vertices=12345, n_faces=24686)
    editor = SimpleNamespace(cage=SimpleNamespace(n_vertices=617, n_faces=1230), notes=list(notes))
    return SimpleNamespace(mesh=mesh, editor=editor, edges=np.zeros((37029, 2)), path=path)


def test_mesh_info_text_counts_repairs_and_last_polish():
    assert mesh_info_text(None) == "No shape loaded."
    assert mesh_info_text(fake_session()) == (
        "Shape: blob\nVertices: 12,345\nFaces: 24,686\nEdges: 37,029\nCage: 617 vertices, 1,230 faces\n"
        f"Solver: {he.backend_description()}\n\n"
        "Repairs made to the input: none")
    assert he.backend_description().split()[0] in ("cholmod", "cholespy", "superlu")  # which backend runs
    polish = SimpleNamespace(result=SimpleNamespace(iterations=42), seconds=1.004, setup_seconds=0.25,
                             error_before=3.456, error_after=1.2)
    text = mesh_info_text(fake_session(Path("/data/creature.ply"), notes=["merged 3 duplicate vertices"]), polish)
    assert text.splitlines()[0] == f"Shape: {Path('/data/creature.ply')}"
    assert text.endswith("Repairs made to the input:\n  • merged 3 duplicate vertices\n\n"
                         "Last polish: 42 iterations in 1.00 s (set-up 0.25 s), edge error 3.46% → 1.20%")


def close_modal_box(seen: list) -> None:
    """Record and close the modal message box once it is up (retrying until it is)."""
    box = QtWidgets.QApplication.activeModalWidget()
    if isinstance(box, QtWidgets.QMessageBox):
        seen.append((box.windowTitle(), box.text()))
        box.done(0)
    else:
        QtCore.QTimer.singleShot(20, lambda: close_modal_box(seen))


def test_the_menus_open_the_dialogs(qtbot, win):
    w = win
    # File > Mesh Info: the text above, in a box that leaves the window usable
    w.actions_["mesh_info"].trigger()
    box = w.dialogs.mesh_info_box
    qtbot.waitExposed(box)
    assert not box.isModal() and box.windowTitle() == "Mesh info"
    assert box.text() == mesh_info_text(w.session, w.posing.last_polish)
    assert "Vertices: 2,562" in box.text() and f"Cage: {w.session.n_cage:,} vertices" in box.text()
    box.close()
    # Help > Shortcuts lists Cancel with its key
    w.actions_["shortcuts"].trigger()
    dlg = w.dialogs.shortcuts_dialog
    qtbot.waitExposed(dlg)
    rows = {dlg.table.item(r, 1).text(): dlg.table.item(r, 0).text() for r in range(dlg.table.rowCount())}
    assert rows["Cancel"] == "Esc" and rows["Rebuild Cage"] == "Ctrl+B"
    dlg.close()
    # Help > About: its text, closed again (How to Edit: test_first_minute.py)
    seen = []
    QtCore.QTimer.singleShot(20, lambda: close_modal_box(seen))
    w.actions_["about"].trigger()
    assert seen == [("About hybridedit", ABOUT)]
