"""The window's structure: its helpers take the narrow protocols they declare, and MainWindow
satisfies them; "finish the settle, cancel the polish" is one guard (settle_and_stop_polish),
checked in the source and through real Qt events."""

from __future__ import annotations

import ast
import inspect
from pathlib import Path

import numpy as np
from qtpy import QtCore

from hybridedit.viewer.input import drags as dragging
from hybridedit.viewer.jobs import build_jobs as building
from hybridedit.viewer.window import dialogs
from hybridedit.viewer.window import file_actions as files
from hybridedit.viewer.jobs.build_jobs import BuildHost, Cancels, KeepsWork
from hybridedit.viewer.window.dialogs import InfoSource
from hybridedit.viewer.input.drags import DragHost, GestureHolder
from hybridedit.viewer.window.file_actions import Busy, FileHost, Screenshots
from hybridedit.viewer.window.main_window import MainWindow
from test_window import key, mouse_drag, settled, win  # noqa: F401 (fixture)
from test_window_polish import handle_point, select_tip

Qt = QtCore.Qt

# each helper module, the protocol its class takes the window as
HOSTS = {building: BuildHost, dialogs: InfoSource, dragging: DragHost, files: FileHost}


def members(protocol: type) -> set[str]:
    """The names a protocol declares (methods, properties and annotated attributes)."""
    names = set()
    for klass in protocol.__mro__:
        if klass is object or klass.__name__ in ("Protocol", "Generic"):
            continue
        names |= {n for n in vars(klass) if not n.startswith("_") or n == "actions_"}
        names |= set(getattr(klass, "__annotations__", {}))
    return names - {"_is_protocol", "_is_runtime_protocol"}


def window_uses(module) -> dict[str, set[str]]:
    """What a helper module reaches through the window: ``self.w.X`` or ``w.X`` (``w = self.w``),
    each with the names used on it in turn (``w.X.Y``)."""
    tree = ast.parse(Path(module.__file__).read_text())

    def is_window(node: ast.AST) -> bool:
        return (isinstance(node, ast.Name) and node.id == "w") or (
            isinstance(node, ast.Attribute) and node.attr == "w"
            and isinstance(node.value, ast.Name) and node.value.id == "self")

    used: dict[str, set[str]] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and is_window(node.value):
            used.setdefault(node.attr, set())
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute) and is_window(node.value.value):
            used[node.value.attr].add(node.attr)
    return used


def test_main_window_satisfies_the_helpers_protocols(qtbot):
    w = MainWindow()
    try:
        for protocol in HOSTS.values():
            assert isinstance(w, protocol), protocol.__name__
        # the objects the protocols name, as the helpers use them
        assert isinstance(w.files, KeepsWork)
        for controller_protocol in (Cancels, Busy, GestureHolder):
            assert isinstance(w.controller, controller_protocol)
        assert isinstance(w.polisher, Cancels)
        assert isinstance(w.view, Screenshots)
        # the helpers were given the window, and the drag its scene and view
        assert w.files.w is w and w.jobs.w is w and w.dialogs.w is w and w.dragging.w is w
        assert w.dragging.scene is w.scene and w.dragging.view is w.view
        # (the check means something: a plain object satisfies none)
        for protocol in HOSTS.values():
            assert not isinstance(object(), protocol)
    finally:
        w.close()
        w.deleteLater()


def test_the_helpers_use_only_what_their_protocols_name():
    """Static: every ``w.X`` in a helper module is a member of its protocol, and every ``w.X.Y`` a member of
    the protocol X is typed with there (when that is a protocol of the module); every member is used."""
    checked = []
    for module, protocol in HOSTS.items():
        names = members(protocol)
        used = window_uses(module)
        assert set(used) <= names, (module.__name__, set(used) - names)
        assert names <= set(used), (module.__name__, "declared but unused", names - set(used))
        for name, inner in used.items():
            member = inspect.getattr_static(protocol, name)
            if not (isinstance(member, property) and inner):
                continue
            typed = getattr(module, str(member.fget.__annotations__.get("return")), None)
            if getattr(typed, "_is_protocol", False):  # (not a class of its own, such as the Session)
                checked.append(f"{module.__name__}: {name}")
                assert inner <= members(typed), (module.__name__, name, inner - members(typed))
    # building: files, controller, polisher, status; dragging: controller, status, unsaved; files: controller,
    # view, status, unsaved
    assert len(checked) == 11, checked


def test_a_selection_press_stops_a_running_polish(qtbot, win):
    w = win
    select_tip(qtbot, w)
    # a polish that would run for a minute: never converges, no iteration cap
    w.polisher.iterations, w.polisher.tolerance = 10 ** 9, 0.0
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -60))
    settled(qtbot, w)
    qtbot.waitUntil(lambda: w.polisher.worker is not None and w.polisher.holder.shape_arap is not None, timeout=10000)
    qtbot.wait(150)  # iterating now
    running = w.polisher.worker
    assert running.isRunning() and not running.cancel_requested
    # Select mode, press on empty space (a corner of the view): the selection gesture begins with the guard
    key(qtbot, w, Qt.Key.Key_S)
    corner = QtCore.QPoint(6, 6)
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, corner)
    assert w.controller.busy  # (the gesture did begin)
    assert running.cancel_requested
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, corner)
    qtbot.waitUntil(lambda: w.polisher.worker is None, timeout=5000)
    qtbot.wait(50)
    assert w.polished is None and w.last_polish is None  # its result was dropped


def test_a_selection_press_completes_a_settle_and_drops_its_polish(qtbot, win):
    w = win
    s = w.session
    select_tip(qtbot, w)
    s.settle_frames = 3000  # a settle of many timer ticks: still under way when the press comes
    started = []
    w.polisher.started.connect(lambda: started.append(w.polisher.worker))
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -60))
    assert s.settling and w.settle_timer.isActive()
    assert not started
    key(qtbot, w, Qt.Key.Key_S)
    assert s.settling, "the settle ended before the press: make it longer"
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, QtCore.QPoint(6, 6))
    # the settle was completed at the press, and the final pose is on display ...
    assert not s.settling and not w.settle_timer.isActive()
    assert np.allclose(w.scene.parts.drawn_points(), s.shape_positions, atol=1e-5)
    # ... and the polish it started (after_drag) was cancelled at once
    assert len(started) == 1 and started[0].cancel_requested
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, QtCore.QPoint(6, 6))
    qtbot.waitUntil(lambda: w.polisher.worker is None, timeout=20000)
    qtbot.wait(50)
    assert w.polished is None and w.last_polish is None
