"""The window's information dialogs: Help ▸ Shortcuts, How to Edit and About, and File ▸ Mesh Info."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from qtpy import QtCore, QtGui, QtWidgets

from ... import backend_description
from .help_texts import ABOUT, HOWTO, MOUSE_HELP

if TYPE_CHECKING:
    from ..model.session import Session
    from ..jobs.polish_worker import PolishOutcome


def mesh_info_text(session: "Session | None", last_polish: "PolishOutcome | None" = None) -> str:
    """File ▸ Mesh Info's text.

    Parameters
    ----------
    session : the shape being edited, or None.
    last_polish : the latest polish on release of this shape, or None.

    Returns
    -------
    The shape's name and its vertex, face, edge and cage counts, the repairs made to the input
    (or "none") and, after a polish, its iterations, times and edge errors.
    """
    s = session
    if s is None:
        return "No shape loaded."
    m, c = s.mesh, s.editor.cage
    lines = [
        f"Shape: {s.path if s.path is not None else (m.name or 'shape')}",
        f"Vertices: {m.n_vertices:,}",
        f"Faces: {m.n_faces:,}",
        f"Edges: {len(s.edges):,}",
        f"Cage: {c.n_vertices:,} vertices, {c.n_faces:,} faces",
        f"Solver: {backend_description()}",
    ]
    notes = [str(n) for n in (getattr(s.editor, "notes", None) or [])]
    lines.append("")
    if notes:
        lines.append("Repairs made to the input:")
        lines += [f"  • {n}" for n in notes]
    else:
        lines.append("Repairs made to the input: none")
    if last_polish is not None:
        p = last_polish
        lines += ["", f"Last polish: {p.result.iterations} iterations in {p.seconds:.2f} s "
                      f"(set-up {p.setup_seconds:.2f} s), "
                      f"edge error {p.error_before:.2f}% → {p.error_after:.2f}%"]
    return "\n".join(lines)


class ShortcutsDialog(QtWidgets.QDialog):
    """Help > Shortcuts: every action with a shortcut, and the mouse bindings."""

    def __init__(self, actions: list[QtGui.QAction], parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Keyboard and mouse shortcuts")
        rows = [(a.shortcut().toString(QtGui.QKeySequence.SequenceFormat.NativeText), a.text().replace("&", ""))
                for a in actions if not a.shortcut().isEmpty()]
        rows += MOUSE_HELP
        table = QtWidgets.QTableWidget(len(rows), 2, self)
        table.setHorizontalHeaderLabels(["Shortcut", "Action"])
        table.verticalHeader().hide()
        table.setEditTriggers(QtWidgets.QAbstractItemView.EditTrigger.NoEditTriggers)
        for r, (key, text) in enumerate(rows):
            table.setItem(r, 0, QtWidgets.QTableWidgetItem(key))
            table.setItem(r, 1, QtWidgets.QTableWidgetItem(text))
        table.resizeColumnsToContents()
        table.horizontalHeader().setStretchLastSection(True)
        self.table = table
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Close)
        buttons.rejected.connect(self.reject)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(table)
        layout.addWidget(buttons)
        self.resize(720, 560)


class HowToDialog(QtWidgets.QDialog):
    """Help ▸ How to Edit: :data:`~.help_texts.HOWTO` rendered from Markdown, wrapped to the dialog's
    width and scrolled, at a size that fits a 700 px high screen (:attr:`SIZE`, less on a smaller one)."""

    SIZE = (620, 600)  # logical pixels: with a title bar and a panel, still inside 700

    def __init__(self, parent: QtWidgets.QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("How to edit")
        self.text = QtWidgets.QTextBrowser(self)
        self.text.setMarkdown(HOWTO)
        self.text.setLineWrapMode(QtWidgets.QTextEdit.LineWrapMode.WidgetWidth)
        buttons = QtWidgets.QDialogButtonBox(QtWidgets.QDialogButtonBox.StandardButton.Close)
        buttons.rejected.connect(self.reject)
        layout = QtWidgets.QVBoxLayout(self)
        layout.addWidget(self.text)
        layout.addWidget(buttons)
        screen = (parent.screen() if parent is not None else None) or QtGui.QGuiApplication.primaryScreen()
        room = screen.availableGeometry() if screen is not None else QtCore.QRect(0, 0, *self.SIZE)
        self.resize(min(self.SIZE[0], room.width() - 40), min(self.SIZE[1], room.height() - 80))


@runtime_checkable
class PolishShown(Protocol):
    """The window's pose side as Mesh Info sees it: the latest polish on display."""

    @property
    def last_polish(self) -> PolishOutcome | None: ...


@runtime_checkable
class InfoSource(Protocol):
    """What :class:`InfoDialogs` reads of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def actions_(self) -> Mapping[str, QtGui.QAction]: ...  # the shortcuts listed
    @property
    def session(self) -> Session | None: ...
    @property
    def posing(self) -> PolishShown: ...


class InfoDialogs:
    """The information dialogs of a :class:`~.main_window.MainWindow`.

    Parameters
    ----------
    window : what the dialogs show (:class:`InfoSource`).
    parent : the widget the dialogs are parented to (the window).

    Attributes
    ----------
    shortcuts_dialog : the last Shortcuts dialog opened, or None.
    mesh_info_box : the last Mesh Info box opened, or None.
    howto_dialog : the last How to Edit dialog opened, or None.
    """

    def __init__(self, window: InfoSource, parent: QtWidgets.QWidget | None = None) -> None:
        self.w = window
        self.parent = parent
        self.shortcuts_dialog: ShortcutsDialog | None = None
        self.mesh_info_box: QtWidgets.QMessageBox | None = None
        self.howto_dialog: HowToDialog | None = None

    def shortcuts(self) -> ShortcutsDialog:
        """Help ▸ Shortcuts: every action with a key, and the mouse bindings (window-modal, not blocking)."""
        dlg = ShortcutsDialog(list(self.w.actions_.values()), self.parent)
        dlg.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        self.shortcuts_dialog = dlg
        dlg.open()
        return dlg

    def howto(self) -> HowToDialog:
        """Help ▸ How to Edit: the editing workflow in a few steps (non-modal: it can stay open beside the view)."""
        dlg = HowToDialog(self.parent)
        dlg.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        self.howto_dialog = dlg
        dlg.show()
        return dlg

    def mesh_info(self) -> QtWidgets.QMessageBox:
        """File ▸ Mesh Info: counts and repairs (:func:`mesh_info_text`), in a non-modal box."""
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Information, "Mesh info",
                                    mesh_info_text(self.w.session, self.w.posing.last_polish),
                                    QtWidgets.QMessageBox.StandardButton.Ok, self.parent)
        box.setAttribute(QtCore.Qt.WidgetAttribute.WA_DeleteOnClose)
        box.setModal(False)
        self.mesh_info_box = box
        box.show()
        return box

    def about(self) -> None:
        """Help ▸ About."""
        QtWidgets.QMessageBox.about(self.parent, "About hybridedit", ABOUT)
