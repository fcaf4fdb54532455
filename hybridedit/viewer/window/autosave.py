"""Nothing lost: the unsaved pose kept in a recovery file while the window runs, and offered back after
an unclean exit (a crash, a kill, a power cut), as Blender's File ▸ Recover and ZBrush's QuickSave do.

The file (:mod:`..model.recovery`) is written after every change of the undo history (a release, a
polish, a selection, undo and redo) or of the kept poses, while the pose or the kept poses are not
saved, once the drag or settle under way is done; it is removed when both are saved (or the pose undone
back to the saved one) and when the window quits cleanly. A recovery whose window died is offered when its shape is opened again, or, for the last
session, on the first shape opened after a start; the offer is a question that does not block the
window (a damaged recovery file is said in one line and ignored).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

from qtpy import QtCore, QtWidgets

from ..model.recovery import Recovery, RecoveryError, RecoveryFile, orphans, recover, recovery_folder
from .interfaces import Busy, RedrawsAll

if TYPE_CHECKING:
    from ..model.session import Session

#: how often the history is looked at for a change to write (a release is written within this)
POLL_MS = 400


@runtime_checkable
class Modified(Protocol):
    """The unsaved-pose mark as the autosave sees it."""

    @property
    def modified(self) -> bool: ...
    def set_modified(self, modified: bool) -> None: ...


@runtime_checkable
class Says(Protocol):
    """The status bar as the autosave sees it."""

    def message(self, text: str) -> None: ...


@runtime_checkable
class Reloads(Protocol):
    """The loading as the autosave sees it: the shape (or a new cage) a recovery needs."""

    def open_path(self, path) -> bool: ...
    def rebuild(self) -> bool: ...


@runtime_checkable
class SizeBox(Protocol):
    """The cage size box as the autosave sees it: the size a recovery's cage was built at."""

    def set_value(self, size: int | float, *, of_shape: bool = False) -> None: ...


@runtime_checkable
class Settles(Protocol):
    """The pose side as the autosave sees it (:class:`~.posing.Posing`)."""

    def settle_and_stop_polish(self) -> None: ...


@runtime_checkable
class Refreshes(Protocol):
    """The actions as the autosave sees them."""

    def refresh(self) -> None: ...


@runtime_checkable
class Focus(Protocol):
    """The 3D view as the autosave sees it: the keyboard back after the question."""

    def setFocus(self, reason: QtCore.Qt.FocusReason) -> None: ...  # noqa: N802 (Qt's name)


@runtime_checkable
class AutosaveHost(Protocol):
    """What :class:`Autosave` asks of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def unsaved(self) -> Modified: ...
    @property
    def controller(self) -> Busy: ...
    @property
    def jobs(self) -> Busy: ...
    @property
    def status(self) -> Says: ...
    @property
    def loading(self) -> Reloads: ...
    @property
    def cage_control(self) -> SizeBox: ...
    @property
    def posing(self) -> Settles: ...
    @property
    def sync(self) -> RedrawsAll: ...
    @property
    def actions_(self) -> Refreshes: ...
    @property
    def view(self) -> Focus: ...


class Autosave:
    """The window's recovery file, and the recovery of the ones whose window died.

    Parameters
    ----------
    window : the window, as far as the autosave needs it (:class:`AutosaveHost`).
    parent : the widget the question is shown over (the window); its view gets the keyboard back.
    folder : where recovery files are (default: ``recovery/`` in the user cache folder, read now).

    Attributes
    ----------
    keeper : this window's recovery file (:class:`~..model.recovery.RecoveryFile`).
    box : the recovery question on screen, or None.
    offered : the recovery the question is about (or was, until answered).
    declined : recoveries answered Not Now: kept until the window quits cleanly.
    pending : a recovery waiting for its shape or cage to be built.
    """

    def __init__(self, window: AutosaveHost, parent: QtWidgets.QWidget, *, folder=None) -> None:
        self.w = window
        self.parent = parent
        self.folder = recovery_folder(folder)
        self.keeper = RecoveryFile(folder=self.folder)
        self.box: QtWidgets.QMessageBox | None = None
        self.offered: Recovery | None = None
        self.declined: list[Recovery] = []
        self.pending: Recovery | None = None
        self._written: tuple | None = None  # the history state last written
        self._failed = False  # the last write failed (said once)
        self._started = False  # the last session was looked for (on the first shape shown)
        self._damaged: list = []  # the damaged recovery files said (removed on a clean quit)
        self.timer = QtCore.QTimer(parent)
        self.timer.setInterval(POLL_MS)
        self.timer.timeout.connect(self.tick)
        self.timer.start()

    # ------------------------------------------------------------------ keeping the file
    def _state(self, s: Session) -> tuple:
        h = s.history
        return id(s), s.generation, id(h.current), len(h), s.poses.revision

    def tick(self) -> bool:
        """Write the recovery file if the history changed since (nothing under way), remove it when the pose
        is saved; True when a file was written."""
        w, s = self.w, self.w.session
        if s is None or w.controller.busy or w.jobs.busy or s.settling:
            return False
        if not w.unsaved.modified:
            self.keeper.remove()
            self._written = None
            return False
        state = self._state(s)
        if state == self._written:
            return False
        try:
            self.keeper.write(s)
        except Exception as e:  # noqa: BLE001 -- never in the way of editing: said once, tried again
            if not self._failed:
                w.status.message(f"Autosave failed ({e.__class__.__name__}: {e}); it is tried again after the "
                                 "next change.")
            self._failed = True
            return False
        self._failed = False
        self._written = state
        return True

    def up_to_date(self) -> bool:
        """The recovery file holds the session as it is now (or there is nothing unsaved to hold)."""
        s = self.w.session
        if s is None or not self.w.unsaved.modified:
            return self.keeper.path is None
        return self._written == self._state(s) and self.keeper.path is not None and self.keeper.path.is_file()

    def quit_cleanly(self) -> None:
        """The window quits with nothing unsaved left (saved, or discarded by the user): this window's file
        goes, and so do the recoveries answered Not Now and the damaged files said."""
        self.timer.stop()
        self.keeper.remove()
        for rec in self.declined:
            rec.discard()
        for p in self._damaged:
            try:
                p.unlink(missing_ok=True)
            except OSError:
                pass
        self.declined.clear()

    # ------------------------------------------------------------------ recovering
    def shape_installed(self, rebuilt: bool) -> None:
        """A build is on display: replay the recovery waiting for it, else offer one for this shape (and, on
        the first shape since the start, the last session's), after the build's own message."""
        QtCore.QTimer.singleShot(0, lambda: self._after_install(rebuilt))

    def _after_install(self, rebuilt: bool) -> None:
        s = self.w.session
        if s is None:
            return
        if self.pending is not None:
            rec, self.pending = self.pending, None
            self._apply(rec)
            return
        if rebuilt or self.box is not None:
            return
        first, self._started = not self._started, True
        found, problems = orphans(folder=self.folder)
        for path, line in problems:
            if path not in self._damaged:
                self._damaged.append(path)
                self.w.status.message(f"Ignored a damaged recovery file: {line}")
        topology = self.keeper.fingerprint(s.mesh)["topology"]
        here = [r for r in found if r.fingerprint.get("topology") == topology and r.fits(s.mesh)]
        others = [r for r in found if r not in here and r.mesh_path is not None and r.mesh_path.is_file()]
        pick = here[0] if here else (others[0] if first and others else None)
        if pick is not None and all(pick.file != d.file for d in self.declined):
            self.offer(pick)

    def offer(self, rec: Recovery) -> None:
        """Ask, without blocking the window, whether to recover ``rec``."""
        self.offered = rec
        Btn = QtWidgets.QMessageBox.ButtonRole
        here = self.w.session is not None and rec.fits(self.w.session.mesh)
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Question, "Recover unsaved pose",
                                    f"Recover the unsaved pose of {rec.summary()}?", parent=self.parent)
        box.setInformativeText(
            "The window editing it did not quit cleanly (a crash, a kill or a power cut). Recover replays "
            "that pose exactly"
            + ("" if here else f" on {rec.mesh_path}, opened for it") + ". Not Now keeps it until hybridedit "
            "next quits cleanly.")
        self.recover_button = box.addButton("&Recover", Btn.AcceptRole)
        self.later_button = box.addButton("&Not Now", Btn.RejectRole)
        box.setDefaultButton(self.recover_button)
        box.setEscapeButton(self.later_button)
        box.setWindowModality(QtCore.Qt.WindowModality.NonModal)
        box.buttonClicked.connect(self._answered)
        self.box = box
        box.show()

    def _answered(self, button) -> None:
        box, rec, self.box = self.box, self.offered, None
        if box is not None:
            box.deleteLater()
        if self.parent is not None:
            self.parent.activateWindow()
        self.w.view.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)
        if rec is None:
            return
        if button is self.recover_button:
            self.accept(rec)
        else:
            self.declined.append(rec)
            self.w.status.message(f"Not recovered: the pose of {rec.summary()} is kept until hybridedit quits "
                                  "cleanly.")

    def accept(self, rec: Recovery) -> None:
        """Recover ``rec``: at once on the shape on display, or after opening its shape or building its cage."""
        w, s = self.w, self.w.session
        if s is not None and rec.fits(s.mesh) and rec.cage_vertices == s.editor.cage.n_vertices:
            self._apply(rec)
            return
        self.pending = rec
        w.cage_control.set_value(rec.cage_size)
        started = w.loading.rebuild() if s is not None and rec.fits(s.mesh) else (
            rec.mesh_path is not None and w.loading.open_path(rec.mesh_path))
        if not started:
            self.pending = None
            w.status.message(f"Not recovered: {rec.summary()} needs "
                             + (f"{rec.mesh_path}, which could not be opened." if rec.mesh_path else
                                "its shape, which was not read from a file."))

    def _apply(self, rec: Recovery) -> None:
        w, s = self.w, self.w.session
        w.posing.settle_and_stop_polish()
        try:
            recover(s, rec)
        except RecoveryError as e:
            w.status.message(f"Not recovered: {e}")
            return
        w.unsaved.set_modified(True)
        w.sync.refresh_all()
        w.actions_.refresh()
        self.tick()  # this window's file holds the pose now, before the old one goes
        rec.discard()
        self.declined = [d for d in self.declined if d.file != rec.file]
        w.status.message(f"Recovered the unsaved pose of {rec.summary()}: it is replayed exactly; Ctrl+Z "
                         "goes back to the pose it was recovered on.")
