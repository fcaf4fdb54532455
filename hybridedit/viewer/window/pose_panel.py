"""The pose library in the window: Pose ▸ Keep Pose, and the dockable Poses panel that lists the kept
poses (as Blender's shape keys, ZBrush's layers), to continue from, rename, remove, reorder and export.

The library itself is the session's (:class:`~..model.pose_library.PoseLibrary`, Qt-free); the panel
shows it and turns clicks and keys into its operations. Export Poses writes the kept poses into one
file with :func:`hybridedit.save_poses`: glTF morph targets (.glb) or USD blend shapes (.usda, .usdc).
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Protocol, runtime_checkable

import numpy as np
from qtpy import QtCore, QtGui, QtWidgets

from ...core.mesh import MeshError
from ...deform.selection import SelectionError
from ...fileio.atomic import WriteError
from ...fileio.document import Document
from ...fileio.editfile import EditFileError
from ...fileio.meshfiles import MeshFileError, read_document
from ...fileio.poses import save_poses
from ..model.pose_library import PoseLibraryError
from .file_actions import cage_note
from .interfaces import ActionChecks, Busy, RedrawsAll

if TYPE_CHECKING:
    from ..model.pose_library import PoseLibrary
    from ..model.session import Session

POSE_FILTER = "glTF binary, morph targets (*.glb);;USD text, blend shapes (*.usda);;USD binary, blend shapes (*.usdc)"
"""Export Poses' file types (:data:`hybridedit.fileio.poses.POSE_EXTENSIONS` holds .gltf and .usd too)."""
EXPORT_EXTENSIONS = (".glb", ".gltf", ".usda", ".usdc", ".usd")


@runtime_checkable
class Guard(Protocol):
    """The pose side as the panel sees it (:class:`~.posing.Posing`): the settle done before the pose
    is read; the settle done and the polish stopped before it is replaced."""

    def finish_settle(self) -> None: ...
    def settle_and_stop_polish(self) -> None: ...


@runtime_checkable
class Marks(Protocol):
    """The unsaved-work mark as the panel sees it."""

    def set_modified(self, modified: bool) -> None: ...
    def pose_saved(self) -> bool: ...
    def poses_changed(self) -> None: ...


@runtime_checkable
class Says(Protocol):
    """The status bar as the panel sees it: one line for each result and each refusal."""

    def message(self, text: str) -> None: ...


@runtime_checkable
class Dialogs(Protocol):
    """The file actions as the panel sees them (:class:`~.file_actions.FileActions`): a file dialog that
    gives the keyboard back to the view, and where a new file is suggested."""

    def file_dialog(self, ask: Callable, *args, **kwargs) -> tuple[str, str]: ...
    def suggested_path(self, suffix: str, ext: str) -> str: ...


@runtime_checkable
class Focus(Protocol):
    """The 3D view as the panel sees it: the keyboard back to it after continuing from a pose."""

    def setFocus(self, reason: QtCore.Qt.FocusReason) -> None: ...  # noqa: N802 (Qt's name)


@runtime_checkable
class PanelHost(Protocol):
    """What :class:`PosePanel` asks of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def controller(self) -> Busy: ...
    @property
    def posing(self) -> Guard: ...
    @property
    def unsaved(self) -> Marks: ...
    @property
    def sync(self) -> RedrawsAll: ...
    @property
    def status(self) -> Says: ...
    @property
    def files(self) -> Dialogs: ...
    @property
    def view(self) -> Focus: ...
    @property
    def actions_(self) -> ActionChecks: ...


def plural(n: int, word: str) -> str:
    return f"{n} {word}{'s' if n != 1 else ''}"


class PosePanel:
    """Pose ▸ Keep Pose and the Poses panel of a :class:`~.main_window.MainWindow`.

    The panel (a dock, on the right, shown when the first pose is kept) lists the kept poses by name:
    a double-click (or Continue) loads one into the session, so that editing goes on from it (one
    undo step); a click on the selected name (or F2, or Rename) renames it in place; Delete removes it;
    the arrows move it; Export Poses… writes them all to one file.

    Parameters
    ----------
    window : the window, as far as the panel needs it (:class:`PanelHost`).
    parent : the main window the dock belongs to.

    Attributes
    ----------
    dock : the dock widget ("Poses"); list : its list of names (a ``QListWidget``).
    buttons : the panel's buttons by name (keep, continue, rename, delete, up, down, export).
    """

    def __init__(self, window: PanelHost, parent: QtWidgets.QMainWindow) -> None:
        self.w = window
        self.parent = parent
        self._shown: tuple | None = None  # (the library on display, its revision)
        self._last: tuple[int, int] = (0, 0)  # (the last library listed, how many it had): see refresh
        self._filling = False  # the list is being filled: its item changes are not renames
        self.list = QtWidgets.QListWidget()
        self.list.setObjectName("pose_list")
        self.list.setSelectionMode(QtWidgets.QAbstractItemView.SelectionMode.SingleSelection)
        Trigger = QtWidgets.QAbstractItemView.EditTrigger
        self.list.setEditTriggers(Trigger.EditKeyPressed | Trigger.SelectedClicked)
        self.list.itemDoubleClicked.connect(lambda item: self.continue_from(self.list.row(item)))
        self.list.itemChanged.connect(self._renamed)
        self.list.currentRowChanged.connect(lambda _row: self._enable())
        # Delete on the list removes the selected pose (while a name is edited, the editor takes the key)
        remove = QtGui.QAction("Delete Pose", self.list)
        remove.setShortcut(QtGui.QKeySequence(QtGui.QKeySequence.StandardKey.Delete))
        remove.setShortcutContext(QtCore.Qt.ShortcutContext.WidgetShortcut)
        remove.triggered.connect(lambda *_: self.remove())
        self.list.addAction(remove)
        self.buttons: dict[str, QtWidgets.QToolButton] = {}
        top, bottom = QtWidgets.QHBoxLayout(), QtWidgets.QHBoxLayout()
        for row, name, text, tip, slot in (
                (top, "keep", "Keep", "Keep the pose on display (Pose ▸ Keep Pose, K)", self.keep),
                (top, "continue", "Continue", "Load the selected pose, to go on editing from it (double-click)",
                 self.continue_from),
                (top, "rename", "Rename", "Rename the selected pose (F2, or click its name)", self.rename),
                (top, "delete", "Delete", "Remove the selected pose (Delete)", self.remove),
                (bottom, "up", "▲", "Move the selected pose up", lambda: self.move(-1)),
                (bottom, "down", "▼", "Move the selected pose down", lambda: self.move(1)),
                (bottom, "export", "Export Poses…", "Write the kept poses to one file: glTF morph targets "
                                                    "(.glb) or USD blend shapes (.usda, .usdc)", self.export_dialog)):
            b = QtWidgets.QToolButton()
            b.setText(text)
            b.setToolTip(tip)
            b.setFocusPolicy(QtCore.Qt.FocusPolicy.NoFocus)  # (the keyboard stays where it is)
            b.clicked.connect(lambda *_, f=slot: f())
            row.addWidget(b)
            self.buttons[name] = b
        bottom.addStretch(1)
        body = QtWidgets.QWidget()
        layout = QtWidgets.QVBoxLayout(body)
        layout.setContentsMargins(4, 4, 4, 4)
        layout.addWidget(self.list, 1)
        layout.addLayout(top)
        layout.addLayout(bottom)
        self.dock = QtWidgets.QDockWidget("Poses", parent)
        self.dock.setObjectName("poses")
        self.dock.setWidget(body)
        parent.addDockWidget(QtCore.Qt.DockWidgetArea.RightDockWidgetArea, self.dock)
        self.dock.hide()
        self.dock.visibilityChanged.connect(lambda v: self.w.actions_["show_poses"].setChecked(v))
        self._enable()

    # ------------------------------------------------------------------ what is shown
    @property
    def library(self) -> PoseLibrary | None:
        s = self.w.session
        return None if s is None else s.poses

    def refresh(self) -> None:
        """List the session's kept poses again when they changed (another shape, a file read, a recovery);
        the panel shows itself when poses arrive in a library it showed none of."""
        lib = self.library
        key = None if lib is None else (id(lib), lib.revision)
        if key == self._shown:
            self._enable()
            return
        # poses arriving where none were listed (a file read, a recovery) show the panel; the same poses
        # back after a shape put aside (an open cancelled) do not, should the panel have been closed
        arrived = lib is not None and (self._last[0] != id(lib) or self._last[1] == 0)
        row = self.list.currentRow()
        self._filling = True
        try:
            self.list.clear()
            for p in lib or []:
                item = QtWidgets.QListWidgetItem(p.name)
                item.setFlags(item.flags() | QtCore.Qt.ItemFlag.ItemIsEditable)
                item.setToolTip(f"{p.name}: {plural(len(p.edit.steps), 'step')} from the rest pose; "
                                "double-click to continue from it")
                self.list.addItem(item)
        finally:
            self._filling = False
        self._shown = key
        if lib is not None:
            self._last = (id(lib), len(lib))
        if self.list.count():
            self.list.setCurrentRow(min(max(row, 0), self.list.count() - 1))
            if arrived:
                self.dock.show()
        self._enable()

    def _enable(self) -> None:
        lib, row = self.library, self.list.currentRow()
        chosen = lib is not None and 0 <= row < len(lib)
        self.buttons["keep"].setEnabled(lib is not None)
        for name in ("continue", "rename", "delete"):
            self.buttons[name].setEnabled(chosen)
        self.buttons["up"].setEnabled(chosen and row > 0)
        self.buttons["down"].setEnabled(chosen and lib is not None and row < len(lib) - 1)
        self.buttons["export"].setEnabled(bool(lib))

    def _changed(self, row: int | None = None) -> None:
        """The library changed here: listed again (``row`` the one chosen), the title's mark and the
        actions as it is now."""
        self.refresh()
        if row is not None and 0 <= row < self.list.count():
            self.list.setCurrentRow(row)
        self.w.unsaved.poses_changed()
        self.w.actions_.refresh()

    def toggle_panel(self) -> None:
        """Pose ▸ Poses Panel: show or hide the dock."""
        self.dock.setVisible(not self.dock.isVisible())

    def _chosen(self) -> int | None:
        row = self.list.currentRow()
        lib = self.library
        return row if lib is not None and 0 <= row < len(lib) else None

    # ------------------------------------------------------------------ the operations
    def keep(self) -> bool:
        """Pose ▸ Keep Pose: the pose on display goes to the end of the library (as "Pose N")."""
        w = self.w
        s = w.session
        if s is None or w.controller.busy:
            return False
        w.posing.finish_settle()  # the settle only: keeping reads the pose (a polish under way goes on)
        try:
            pose = s.poses.keep(s)
        except PoseLibraryError as e:
            w.status.message(str(e))
            return False
        self._changed(len(s.poses) - 1)
        self.dock.show()
        note = ("" if s.replayable else " Note: the last drag was not settled (Edit ▸ Settle on Release is off): "
                "continuing from it gives it settled.")
        w.status.message(f"Kept the pose as '{pose.name}' ({plural(len(s.poses), 'kept pose')}): double-click it "
                         f"in the Poses panel to go on from it; File ▸ Save Edit keeps them.{note}")
        return True

    def continue_from(self, row: int | None = None) -> bool:
        """Load a kept pose (``row``, default the selected one) into the session: its shape exactly, and the
        next drag goes on from it; one undo step."""
        w = self.w
        s = w.session
        row = self._chosen() if row is None else row
        if s is None or row is None or w.controller.busy:
            return False
        w.posing.settle_and_stop_polish()
        try:
            pose = s.poses.continue_from(s, row)
        except (EditFileError, SelectionError, ValueError) as e:
            w.status.message(f"Could not continue from '{s.poses[row].name}': {e}")
            return False
        w.unsaved.set_modified(not w.unsaved.pose_saved())
        w.sync.refresh_all()
        w.view.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)  # (the next keys are the editing's)
        w.status.message(f"Continued from '{pose.name}': the shape is that pose, and the next drag goes on from "
                         f"it (Ctrl+Z goes back).{cage_note(pose.edit, s.editor.cage.n_vertices)}")
        return True

    def rename(self) -> None:
        """Rename the selected pose in place (its name opens for typing; Enter ends, Esc keeps it)."""
        row = self._chosen()
        if row is not None:
            self.list.editItem(self.list.item(row))

    def _renamed(self, item: QtWidgets.QListWidgetItem) -> None:
        """A name was edited in place: the library renames the pose, or refuses in one line (and the old
        name is back)."""
        lib = self.library
        if self._filling or lib is None:
            return
        row = self.list.row(item)
        old = lib[row].name
        try:
            pose = lib.rename(row, item.text())
        except PoseLibraryError as e:
            self.w.status.message(f"Not renamed: {e}")
            self._shown = None  # (listed again: the old name back)
            self._changed(row)
            return
        self._changed(row)
        if pose.name != old:
            self.w.status.message(f"Renamed '{old}' to '{pose.name}'.")

    def remove(self) -> bool:
        """Remove the selected pose (Delete)."""
        row = self._chosen()
        if row is None:
            return False
        pose = self.library.remove(row)
        self._changed(min(row, len(self.library) - 1))
        self.w.status.message(f"Removed the pose '{pose.name}' ({plural(len(self.library), 'kept pose')} left).")
        return True

    def move(self, by: int) -> None:
        """Move the selected pose up (``by`` -1) or down (1)."""
        row = self._chosen()
        if row is not None:
            self._changed(self.library.move(row, by))

    # ------------------------------------------------------------------ export
    def export_dialog(self) -> bool:
        """Export Poses…: ask where (Qt's own file dialog), then :meth:`export_to`."""
        w = self.w
        if not self.library:
            w.status.message("No kept poses to export: Pose ▸ Keep Pose (K) keeps the pose on display.")
            return False
        path, chosen = w.files.file_dialog(
            QtWidgets.QFileDialog.getSaveFileName, "Export poses", w.files.suggested_path("-poses", ".glb"),
            POSE_FILTER, options=QtWidgets.QFileDialog.Option.DontUseNativeDialog)
        if not path:
            return False
        p = Path(path)
        if not p.suffix:
            p = p.with_suffix(next((e for e in EXPORT_EXTENSIONS if f"*{e}" in chosen), ".glb"))
        return self.export_to(p)

    def export_to(self, path: str | os.PathLike) -> bool:
        """Write every kept pose, by name, into one file with :func:`hybridedit.save_poses` (the format by
        the extension), on the shape as its file has it (textures, materials, colours); a failure is one
        line in the status bar."""
        w = self.w
        s, lib = w.session, self.library
        if s is None or not lib:
            return False
        p = Path(path)
        try:
            notes = save_poses(p, self._rest(s), [k.positions for k in lib], names=lib.names)
        except (MeshFileError, MeshError, WriteError, OSError, ValueError) as e:
            w.status.message(f"Could not export the poses: {e}")
            return False
        kind = "morph targets" if p.suffix.lower() in (".glb", ".gltf") else "blend shapes"
        w.status.message(" ".join([f"Exported {plural(len(lib), 'pose')} to {p} as {kind}."]
                                  + [f"Note: {n}." for n in notes]))
        return True

    @staticmethod
    def _rest(s: Session) -> Document:
        """The rest shape to export on: its file read again when it is still the shape (its textures,
        materials, colours go along), else the bare mesh."""
        mesh = s.mesh
        if s.path is not None:
            try:
                doc = read_document(s.path)
            except (MeshError, MeshFileError, OSError, ValueError):
                doc = None
            if doc is not None and np.array_equal(doc.mesh.vertices, mesh.vertices) and \
                    np.array_equal(doc.mesh.faces, mesh.faces):
                return doc
        return Document.from_mesh(mesh)
