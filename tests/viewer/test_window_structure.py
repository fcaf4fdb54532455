"""The window's structure: a QMainWindow and collaborators, each taking the window as the narrow
protocol its module declares (no mixins), and the window satisfies them all; no viewer class built on
a mixin; the Qt-free model; the sub-packages importing one way; and "finish the settle, cancel the
polish" as one guard (settle_and_stop_polish), checked in the source and through real Qt events."""

from __future__ import annotations

import ast
import dataclasses
import inspect
import pkgutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
from qtpy import QtCore, QtWidgets

import hybridedit.viewer as viewer
from hybridedit.viewer.input import drags
from hybridedit.viewer.input.mouse_gestures import DragHandler, PoseHandler, SelectionHandler
from hybridedit.viewer.jobs import build_jobs
from hybridedit.viewer.window import (
    actions, dialogs, file_actions, file_drops, first_steps, limb_posing, pose_panel, posing, scene_sync, selecting,
    shape_loading, status_bar, undo_commands, unsaved_mark, view_options,
)
from hybridedit.viewer.window.main_window import MainWindow
from support.window_driving import handle_point, key, mouse_drag, select_tip_to_drag, settled

Qt = QtCore.Qt

# each collaborator's module, the protocol its class takes the window as, and the window's attribute
# that holds it
HOSTS = {
    actions: (actions.ActionsHost, "actions_"), dialogs: (dialogs.InfoSource, "dialogs"),
    drags: (drags.DragHost, "dragging"), build_jobs: (build_jobs.BuildHost, "jobs"),
    file_actions: (file_actions.FileHost, "files"), file_drops: (file_drops.DropsHost, "drops"),
    first_steps: (first_steps.HintHost, "first_steps"), limb_posing: (limb_posing.PoseHost, "limb_posing"),
    pose_panel: (pose_panel.PanelHost, "pose_panel"),
    posing: (posing.PosingHost, "posing"), scene_sync: (scene_sync.SyncHost, "sync"),
    selecting: (selecting.SelectHost, "selecting"), shape_loading: (shape_loading.LoadingHost, "loading"),
    status_bar: (status_bar.StatusHost, "status"), undo_commands: (undo_commands.UndoHost, "undo_commands"),
    unsaved_mark: (unsaved_mark.MarkHost, "unsaved"), view_options: (view_options.OptionsHost, "options"),
}


def members(protocol: type) -> set[str]:
    """The names a protocol declares (methods, properties and annotated attributes)."""
    names = set()
    for klass in protocol.__mro__:
        if klass is object or klass.__name__ in ("Protocol", "Generic"):
            continue
        names |= {n for n in vars(klass) if not n.startswith("_") or n in ("actions_", "__getitem__")}
        names |= set(getattr(klass, "__annotations__", {}))
    return names - {"_is_protocol", "_is_runtime_protocol"}


def nested(module, protocol: type, name: str) -> type | None:
    """The protocol of the module that member ``name`` of ``protocol`` is typed with, or None (a class of
    its own, such as the Session)."""
    member = inspect.getattr_static(protocol, name, None)
    if isinstance(member, property):
        annotation = member.fget.__annotations__.get("return")
    else:
        annotation = protocol.__annotations__.get(name)
    typed = getattr(module, str(annotation), None)
    return typed if getattr(typed, "_is_protocol", False) else None


def window_uses(module) -> dict[str, set[str]]:
    """What a collaborator's module reaches through the window: ``self.w.X`` or ``w.X`` (``w = self.w``),
    each with the names used on it in turn (``w.X.Y``, ``w.X[...]``); a ``@guarded`` method uses the
    status bar (:func:`hybridedit.viewer.window.slot_errors.guarded`)."""
    tree = ast.parse(Path(module.__file__).read_text())

    def is_window(node: ast.AST) -> bool:
        return (isinstance(node, ast.Name) and node.id == "w") or (
            isinstance(node, ast.Attribute) and node.attr == "w"
            and isinstance(node.value, ast.Name) and node.value.id == "self")

    used: dict[str, set[str]] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and is_window(node.value):
            used.setdefault(node.attr, set())
        if isinstance(node, ast.FunctionDef) and any(isinstance(d, ast.Name) and d.id == "guarded"
                                                     for d in node.decorator_list):
            used.setdefault("status", set()).add("show_error")
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Attribute) and is_window(node.value.value):
            used[node.value.attr].add(node.attr)
        if isinstance(node, ast.Subscript) and isinstance(node.value, ast.Attribute) and is_window(node.value.value):
            used[node.value.attr].add("__getitem__")
    return used


def test_the_window_is_a_qmainwindow_and_its_collaborators_not_mixins():
    assert MainWindow.__bases__ == (QtWidgets.QMainWindow,)
    mixins = []
    for info in pkgutil.walk_packages(viewer.__path__, "hybridedit.viewer."):
        tree = ast.parse(Path(__import__(info.name, fromlist=["_"]).__file__).read_text())
        mixins += [f"{info.name}.{n.name}" for n in ast.walk(tree) if isinstance(n, ast.ClassDef)
                   and n.name.endswith("Mixin")]
    assert mixins == []


def viewer_classes() -> list[type]:
    """Every class defined in a module of the viewer."""
    found = []
    for info in pkgutil.walk_packages(viewer.__path__, "hybridedit.viewer."):
        module = __import__(info.name, fromlist=["_"])
        found += [k for k in vars(module).values() if inspect.isclass(k) and k.__module__ == info.name]
    return found


def is_viewer_class(k: type) -> bool:
    return k.__module__.startswith("hybridedit.viewer.")


def may_be_built_on(base: type) -> bool:
    """The kinds of viewer class another viewer class may inherit from: a protocol, an exception, a record
    (NamedTuple, dataclass), or a Qt class (a widget or thread specialised)."""
    return (getattr(base, "_is_protocol", False) or issubclass(base, BaseException)
            or dataclasses.is_dataclass(base) or (issubclass(base, tuple) and hasattr(base, "_fields"))
            or any(k.__module__.split(".")[0] in ("PySide6", "PyQt6") for k in base.__mro__))


def undefined_uses(klass: type) -> set[str]:
    """The ``self.X`` a class's methods use that neither it nor a class it inherits from defines (a class
    member, or ``self.X = ...`` in a method): what a mixin takes from the class it is mixed into."""
    defined = set()
    for k in klass.__mro__:
        if not is_viewer_class(k) and k is not klass:
            continue
        tree = ast.parse(textwrap.dedent(inspect.getsource(k)))
        defined |= {n.target.id for n in tree.body[0].body if isinstance(n, ast.AnnAssign)
                    and isinstance(n.target, ast.Name)}  # (a record's fields)
        for node in ast.walk(tree):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target] if isinstance(
                node, ast.AnnAssign) else []
            for t in targets:
                for e in ast.walk(t):
                    if isinstance(e, ast.Attribute) and isinstance(e.value, ast.Name) and e.value.id == "self":
                        defined.add(e.attr)
    tree = ast.parse(textwrap.dedent(inspect.getsource(klass)))
    used = {n.attr for n in ast.walk(tree)
            if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name) and n.value.id == "self"}
    return {name for name in used - defined if not hasattr(klass, name)}


class _Mixin:
    def go(self):
        return self.engine.run(self.steps)


class _Full:
    steps = 3

    def __init__(self):
        self.engine = None

    def go(self):
        return self.engine.run(self.steps)


def test_no_viewer_class_builds_on_a_mixin():
    """A viewer class inherits from another viewer class only when that one is a protocol, an exception, a
    record or a Qt class; and none of those uses on ``self`` what it does not define (a mixin does)."""
    assert undefined_uses(_Mixin) == {"engine", "steps"} and undefined_uses(_Full) == set()
    classes = viewer_classes()
    assert len(classes) > 60, len(classes)
    built_on = {b for k in classes for b in k.__bases__ if is_viewer_class(b)}
    assert {b.__name__ for b in built_on} >= {"OutlineOverlay", "BuildWorker"}  # (the check sees them)
    assert [(k.__name__, b.__name__) for k in classes for b in k.__bases__
            if is_viewer_class(b) and not may_be_built_on(b)] == []
    assert {b.__name__: undefined_uses(b) for b in built_on if undefined_uses(b)} == {}


def test_main_window_satisfies_its_collaborators_protocols(qtbot):
    w = MainWindow()
    try:
        nested_checked = 0
        for module, (protocol, attr) in HOSTS.items():
            assert isinstance(w, protocol), protocol.__name__
            assert getattr(w, attr).w is w, attr  # each collaborator was given the window
            for name in members(protocol):
                inner = nested(module, protocol, name)
                if inner is not None:  # the object the protocol names, as the collaborator uses it
                    assert isinstance(getattr(w, name), inner), (module.__name__, name, inner.__name__)
                    nested_checked += 1
            assert not isinstance(object(), protocol)  # (the check means something: a plain object fails)
        assert nested_checked > 60, nested_checked
        # the mouse's gestures go to the selection and to the drags, and the drag draws in the scene and view
        assert isinstance(w.selecting, SelectionHandler) and isinstance(w.dragging, DragHandler)
        assert isinstance(w.limb_posing, PoseHandler) and w.controller.poses is w.limb_posing
        assert w.controller.selection is w.selecting and w.controller.drags is w.dragging
        assert w.dragging.scene is w.scene and w.dragging.view is w.view
    finally:
        w.close()
        w.deleteLater()


def test_the_collaborators_use_only_what_their_protocols_name():
    """Static: every ``w.X`` in a collaborator's module is a member of its protocol, and every ``w.X.Y`` a
    member of the protocol X is typed with there (when that is a protocol of the module); every member
    is used."""
    checked = 0
    for module, (protocol, _attr) in HOSTS.items():
        names = members(protocol)
        used = window_uses(module)
        assert set(used) <= names, (module.__name__, set(used) - names)
        assert names <= set(used), (module.__name__, "declared but unused", names - set(used))
        for name, inner in used.items():
            typed = nested(module, protocol, name)
            if typed is not None and inner:
                checked += 1
                assert inner <= members(typed), (module.__name__, name, inner - members(typed))
    assert checked > 60, checked


SUBPACKAGES = ("model", "render", "input", "jobs", "window")
"""The viewer's sub-packages, each importing only those before it."""


def viewer_imports(path: Path) -> set[str]:
    """The viewer modules a module imports (absolute names), at its top or inside functions."""
    package = "hybridedit.viewer." + ".".join(path.relative_to(Path(viewer.__file__).parent).with_suffix("").parts)
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            base = package.rsplit(".", node.level)[0] if node.level else ""
            name = ".".join(p for p in (base, node.module or "") if p)
            found |= {name} | {f"{name}.{a.name}" for a in node.names}
        elif isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
    return {n for n in found if n.startswith("hybridedit.viewer.")}


def test_the_sub_packages_import_one_way():
    root = Path(viewer.__file__).parent
    for rank, sub in enumerate(SUBPACKAGES):
        for path in sorted((root / sub).glob("*.py")):
            for name in viewer_imports(path):
                other = name.split(".")[2]
                assert other not in SUBPACKAGES[rank + 1:], f"{sub}/{path.name} imports {name}"
                assert other in SUBPACKAGES, f"{sub}/{path.name} imports {name}"


def test_the_model_and_shutdown_load_no_qt_and_no_vtk():
    """The model is what another front end would drive: importing it (and the shutdown helper the CLI
    uses) loads neither Qt nor VTK."""
    models = [f"hybridedit.viewer.model.{m.name}" for m in pkgutil.iter_modules(
        [str(Path(viewer.__file__).parent / "model")])]
    code = ("import sys\n" + "".join(f"import {m}\n" for m in models + ["hybridedit.viewer.shutdown"])
            + "print(sorted(m for m in sys.modules\n"
            "             if m.split('.')[0] in ('PySide6', 'qtpy', 'vtkmodules', 'pyvista')))")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "[]", r.stdout
    assert len(models) >= 6


def test_a_selection_press_stops_a_running_polish(qtbot, win):
    w = win
    select_tip_to_drag(qtbot, w)
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
    assert w.posing.polished is None and w.posing.last_polish is None  # its result was dropped


def test_a_selection_press_completes_a_settle_and_drops_its_polish(qtbot, win):
    w = win
    s = w.session
    select_tip_to_drag(qtbot, w)
    s.settle_frames = 3000  # a settle of many timer ticks: still under way when the press comes
    started = []
    w.polisher.started.connect(lambda: started.append(w.polisher.worker))
    a = handle_point(w)
    mouse_drag(qtbot, w.view, a, a + QtCore.QPoint(0, -60))
    assert s.settling and w.dragging.settle_timer.isActive()
    assert not started
    key(qtbot, w, Qt.Key.Key_S)
    assert s.settling, "the settle ended before the press: make it longer"
    qtbot.mousePress(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, QtCore.QPoint(6, 6))
    # the settle was completed at the press, and the final pose is on display ...
    assert not s.settling and not w.dragging.settle_timer.isActive()
    assert np.allclose(w.scene.parts.drawn_points(), s.shape_positions, atol=1e-5)
    # ... and the polish it started (after_drag) was cancelled at once
    assert len(started) == 1 and started[0].cancel_requested
    qtbot.mouseRelease(w.view, Qt.MouseButton.LeftButton, Qt.KeyboardModifier.NoModifier, QtCore.QPoint(6, 6))
    qtbot.waitUntil(lambda: w.polisher.worker is None, timeout=20000)
    qtbot.wait(50)
    assert w.posing.polished is None and w.posing.last_polish is None
