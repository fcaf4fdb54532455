"""The window's file actions: open, save, save as, edit files (with the kept poses), screenshots, dropped
files, and the Save / Discard / Cancel question before anything would lose an unsaved pose or kept poses."""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Protocol, runtime_checkable

from qtpy import QtCore, QtWidgets

from ...fileio.atomic import WriteError
from ...fileio.editfile import EditFileError, load_edit_with_poses, save_edit
from ...deform.selection import SelectionError
from ...fileio.meshfiles import SUPPORTED_EXTENSIONS, MeshFileError, write_mesh
from ...core.mesh import MeshError
from ..model.pose_library import replay_poses
from .interfaces import Busy, RedrawsAll

if TYPE_CHECKING:
    from ..model.session import Session

MESH_FILTER = ("Meshes (*.obj *.ply *.stl *.off *.glb);;OBJ (*.obj);;PLY (*.ply);;STL (*.stl);;OFF (*.off);;"
               "glTF binary (*.glb);;All files (*)")
EDIT_FILTER = "Edit files (*.json);;All files (*)"

SAVE, DISCARD, CANCEL = "save", "discard", "cancel"

#: a save that takes longer than this shows its progress in a dialog
PROGRESS_AFTER_MS = 1000


class SaveProgress:
    """Progress of a save that runs on the UI thread (a big OBJ takes seconds): a dialog that
    appears once it has run :data:`PROGRESS_AFTER_MS`, repainted from the writer's reports
    without taking user input meanwhile. Call it as ``progress(step, fraction)``."""

    def __init__(self, parent: QtWidgets.QWidget | None) -> None:
        self._timer = QtCore.QElapsedTimer()
        self._timer.start()
        self.dialog = QtWidgets.QProgressDialog("", "", 0, 100, parent)
        self.dialog.setWindowTitle("Saving")
        self.dialog.setCancelButton(None)  # half a file is never written: nothing to cancel
        self.dialog.setMinimumDuration(0)
        self.dialog.setAutoClose(False)
        self.dialog.setAutoReset(False)
        self.dialog.reset()  # (stops the dialog's own show timer: it is shown from __call__ only)
        self.dialog.hide()

    def __call__(self, step: str, fraction: float) -> None:
        if self._timer.elapsed() < PROGRESS_AFTER_MS:
            return
        self.dialog.setLabelText(step[:1].upper() + step[1:] + "…")
        self.dialog.setValue(int(round(100 * min(max(fraction, 0.0), 1.0))))
        if not self.dialog.isVisible():
            self.dialog.show()
        # paint, but take no clicks or keys: the save is still running on this thread
        QtWidgets.QApplication.processEvents(QtCore.QEventLoop.ProcessEventsFlag.ExcludeUserInputEvents)

    def close(self) -> None:
        self.dialog.reset()
        self.dialog.hide()
        self.dialog.deleteLater()


def same_file(a: Path, b: Path) -> bool:
    try:
        return a.resolve() == b.resolve() or (a.exists() and b.exists() and os.path.samefile(a, b))
    except OSError:
        return False


def dropped_path(mime: QtCore.QMimeData) -> Path | None:
    """The one local mesh or edit file being dropped, else None."""
    urls = mime.urls() if mime.hasUrls() else []
    if len(urls) != 1 or not urls[0].isLocalFile():
        return None
    p = Path(urls[0].toLocalFile())
    if p.suffix.lower() in SUPPORTED_EXTENSIONS + (".json",):
        return p
    return None


@runtime_checkable
class Screenshots(Protocol):
    """The 3D view as the file actions see it: its screenshots, and the keyboard back after a dialog."""

    def screenshot(self, filename: str) -> object: ...
    def setFocus(self, reason: QtCore.Qt.FocusReason) -> None: ...  # noqa: N802 (Qt's name)


@runtime_checkable
class Says(Protocol):
    """The status bar as the file actions see it: errors, questions and messages."""

    def show_error(self, title: str, text: str) -> None: ...
    def confirm(self, title: str, text: str) -> bool: ...
    def message(self, text: str) -> None: ...


@runtime_checkable
class Unsaved(Protocol):
    """The unsaved-work mark as the file actions see it: the pose on display, and the kept poses."""

    @property
    def modified(self) -> bool: ...
    @property
    def pose_modified(self) -> bool: ...
    def poses_unsaved(self) -> bool: ...
    def set_modified(self, modified: bool) -> None: ...
    def poses_changed(self) -> None: ...
    def update_title(self) -> None: ...


@runtime_checkable
class Opens(Protocol):
    """The window's loading as the file actions see it: File ▸ Open."""

    def open_path(self, path: str | os.PathLike) -> bool: ...


@runtime_checkable
class Guard(Protocol):
    """The window's pose side as the file actions see it (:class:`~.posing.Posing`)."""

    def finish_settle(self) -> None: ...
    def settle_and_stop_polish(self) -> None: ...


@runtime_checkable
class FileHost(Protocol):
    """What :class:`FileActions` asks of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def controller(self) -> Busy: ...
    @property
    def view(self) -> Screenshots: ...
    @property
    def loading(self) -> Opens: ...
    @property
    def posing(self) -> Guard: ...
    @property
    def sync(self) -> RedrawsAll: ...
    @property
    def status(self) -> Says: ...
    @property
    def unsaved(self) -> Unsaved: ...


def edit_summary(edit) -> str:
    """'3 steps (2 selections, 1 polish)': what an edit file holds, in words."""
    steps = edit.steps
    n_sel = sum(not st.continues for st in steps)
    n_pol = sum(st.polish is not None for st in steps)
    parts = [f"{n_sel} selection{'s' if n_sel != 1 else ''}"] + ([f"{n_pol} polish{'es' if n_pol != 1 else ''}"]
                                                               if n_pol else [])
    return f"{len(steps)} step{'s' if len(steps) != 1 else ''} ({', '.join(parts)})"


def cage_note(edit, cage_vertices: int) -> str:
    """' Note: ...' when an edit's steps ran on another cage than the one it is replayed on ('' else)."""
    other = sorted({st.cage["vertices"] for st in edit.steps if st.cage is not None} - {cage_vertices})
    if not other:
        return ""
    made = " and ".join(f"{c:,}" for c in other)
    return (f" Note: it was made on a cage of {made} vertices and replayed on this one of {cage_vertices:,}, so the "
            "pose differs from the one it was saved from by what the cages differ; rebuild at that size "
            "(Cage box, Ctrl+B) and load it again for that pose.")


class FileActions:
    """File menu actions of a :class:`~.main_window.MainWindow`.

    Parameters
    ----------
    window : the window, as far as the file actions need it (:class:`FileHost`).
    parent : the widget the dialogs are parented to (the window).

    Attributes
    ----------
    save_path : where Save writes without asking (set by the first Save As), or None.
    edit_path : the last edit file saved or loaded, or None (where Load Edit starts).
    saved_edit_path : the last edit file saved, or None (where Save Edit starts; else in the mesh's folder).
    """

    def __init__(self, window: FileHost, parent: QtWidgets.QWidget | None = None) -> None:
        self.w = window
        self.parent = parent
        self.save_path: Path | None = None
        self.edit_path: Path | None = None
        self.saved_edit_path: Path | None = None
        self.unsaved_box: QtWidgets.QMessageBox | None = None

    @property
    def session(self):
        return self.w.session

    @property
    def document_name(self) -> str | None:
        """The name the shape goes by: the file it was last saved to (Save As), else the file it was
        opened from, else its mesh's name; None without a shape."""
        s = self.session
        if s is None:
            return None
        if self.save_path is not None:
            return self.save_path.name
        return s.path.name if s.path is not None else (s.mesh.name or "shape")

    def forget_paths(self) -> None:
        """A new shape: nothing saved yet."""
        self.save_path = None
        self.edit_path = None
        self.saved_edit_path = None

    def suggested_path(self, suffix: str, ext: str) -> str:
        """A new file beside the opened mesh, named after it (``suffix``, ``ext``), as an absolute path (a
        file dialog reads a relative one from where the process started); else in the working folder."""
        s = self.session
        if s is not None and s.path is not None:
            return str(s.path.absolute().with_name(f"{s.path.stem}{suffix}{ext}"))
        return str(Path.cwd() / f"shape{suffix}{ext}")

    def file_dialog(self, ask: Callable, *args, **kwargs) -> tuple[str, str]:
        """``QFileDialog.ask(parent, *args, **kwargs)``, then the keyboard back to the 3D view: without a
        window manager nothing reactivates the window after a dialog, and the single-key shortcuts would
        do nothing until a click."""
        try:
            return ask(self.parent, *args, **kwargs)
        finally:
            if self.parent is not None:
                self.parent.activateWindow()
            self.w.view.setFocus(QtCore.Qt.FocusReason.OtherFocusReason)

    # ------------------------------------------------------------------ unsaved work
    def keep_work(self, doing: str) -> bool:
        """Before ``doing`` something that would drop an unsaved pose or kept poses: ask Save / Discard /
        Cancel. Save writes the mesh (the pose) and the edit file (the kept poses), whichever is unsaved.

        Returns True when it may go ahead (saved, discarded, or nothing unsaved).
        """
        w = self.w
        if not w.unsaved.modified or self.session is None:
            return True
        Btn = QtWidgets.QMessageBox.StandardButton
        name = self.document_name if self.save_path is not None or self.session.path is not None else "the shape"
        pose, kept = w.unsaved.pose_modified, w.unsaved.poses_unsaved()
        n = len(self.session.poses)
        poses = f"{n} kept pose{'s' if n != 1 else ''}" if n else "kept poses (some were removed)"
        if pose and kept:
            title, text = "Unsaved work", (f"The pose of {name} and its {poses} are not saved (Save Edit keeps "
                                           f"the kept poses).\n\nSave them before {doing}?")
        elif kept:
            them, are = ("it", "is") if n == 1 else ("them", "are")
            title, text = "Unsaved poses", (f"The {'kept pose' if n == 1 else poses} of {name} {are} not saved "
                                            f"(Save Edit keeps {them}).\n\nSave {them} before {doing}?")
        else:
            title, text = "Unsaved pose", f"The pose of {name} is not saved.\n\nSave it before {doing}?"
        box = QtWidgets.QMessageBox(QtWidgets.QMessageBox.Icon.Question, title, text,
                                    Btn.Save | Btn.Discard | Btn.Cancel, self.parent)
        box.setDefaultButton(Btn.Save)
        box.setEscapeButton(Btn.Cancel)
        self.unsaved_box = box
        try:
            choice = box.exec()
        finally:
            self.unsaved_box = None
        if choice == Btn.Save:
            return (not pose or bool(self.save())) and (not kept or bool(self.save_edit_dialog()))
        return choice == Btn.Discard

    # ------------------------------------------------------------------ meshes
    def open_dialog(self) -> None:
        s = self.session
        start = str(s.path.parent) if s and s.path else os.getcwd()
        path, _ = self.file_dialog(QtWidgets.QFileDialog.getOpenFileName, "Open mesh", start, MESH_FILTER)
        if path:
            self.w.loading.open_path(path)

    def save(self) -> bool:
        if self.session is None:
            return False
        if self.save_path is None:
            return bool(self.save_as_dialog())
        return self.save_to(self.save_path, asked=False)

    def save_as_dialog(self) -> bool:
        s = self.session
        if s is None:
            return False
        ext = s.path.suffix.lower() if s.path else ".ply"
        start = str(self.save_path) if self.save_path else self.suggested_path("-edited", ext)
        path, selected = self.file_dialog(
            QtWidgets.QFileDialog.getSaveFileName, "Save deformed mesh", start, MESH_FILTER,
            options=QtWidgets.QFileDialog.Option.DontConfirmOverwrite)
        if not path:
            return False
        p = Path(path)
        if not p.suffix:
            for e in SUPPORTED_EXTENSIONS:
                if f"*{e}" in selected:
                    p = p.with_suffix(e)
                    break
            else:
                p = p.with_suffix(".ply")
        return self.save_to(p, asked=False)

    def save_to(self, path: str | os.PathLike, asked: bool = False) -> bool:
        """Write the shape on display; asks before replacing the opened file or any existing file."""
        w = self.w
        # the settle only, not the polish: saving reads the pose and changes nothing (a polish under way
        # goes on, and shows its result when it ends)
        w.posing.finish_settle()
        s = self.session
        if s is None:
            return False
        p = Path(path)
        if p.suffix.lower() not in SUPPORTED_EXTENSIONS:
            w.status.show_error("Cannot save", f"{p.name}: unsupported format; use " + ", ".join(SUPPORTED_EXTENSIONS))
            return False
        if not asked:
            if s.path is not None and same_file(p, s.path):
                if not w.status.confirm("Overwrite the input file?",
                                 f"{p} is the file this shape was opened from.\n\n"
                                 "Replace it with the deformed shape? The original will be lost."):
                    w.status.message("Not saved")
                    return False
            elif p.exists() and p != self.save_path:
                if not w.status.confirm("Replace file?", f"{p} already exists. Replace it?"):
                    w.status.message("Not saved")
                    return False
        progress = SaveProgress(self.parent)
        try:
            # what is shown (the polished pose when there is one), in the opened file's structure
            notes = write_mesh(p, s.mesh.copy(vertices=s.shown_positions.copy()), like=s.path,
                               progress=progress)
        except (MeshError, MeshFileError, WriteError, OSError) as e:
            w.status.show_error("Could not save the mesh", str(e))
            return False
        finally:
            progress.close()
        self.save_path = p
        w.unsaved.update_title()  # (Save As: the title names the new file)
        w.unsaved.set_modified(False)
        # what a conversion could not carry, references not copied: said, as the CLI says them
        w.status.message(" ".join([f"Saved {p}."] + [f"Note: {n}." for n in notes]))
        return True

    # ------------------------------------------------------------------ edit files
    def save_edit_dialog(self) -> bool:
        if self.session is None:
            return False
        # beside the mesh (not where an edit was loaded from), or where the last one was saved
        start = str(self.saved_edit_path) if self.saved_edit_path else self.suggested_path("-edit", ".json")
        path, _ = self.file_dialog(QtWidgets.QFileDialog.getSaveFileName, "Save edit", start, EDIT_FILTER)
        if not path:
            return False
        p = Path(path)
        if not p.suffix:
            p = p.with_suffix(".json")
        return self.save_edit_to(p)

    def save_edit_to(self, path: str | os.PathLike) -> bool:
        """Write how the pose on screen was made (every step since the rest pose) as a JSON edit file, and
        the kept poses beside it (each its name and steps)."""
        w = self.w
        w.posing.finish_settle()  # the settle only, not the polish: as save_to, this reads and changes nothing
        s = self.session
        if s is None:
            return False
        try:
            edit = s.to_edit()
            save_edit(path, edit, poses=s.poses.entries())
        except (SelectionError, ValueError, WriteError, OSError) as e:
            w.status.show_error("Could not save the edit", str(e))
            return False
        self.edit_path = self.saved_edit_path = Path(path).absolute()
        s.poses.mark_saved()
        w.unsaved.poses_changed()
        n = len(s.poses)
        kept = f" and {n} kept pose{'s' if n != 1 else ''}" if n else ""
        w.status.message(f"Saved the edit{kept} to {path}: {edit_summary(edit)} from the rest pose, in shape vertices. "
                  + ("'hybridedit deform --edit' replays them to the pose on screen."
                     if s.replayable else
                     "Note: the last drag was not settled (Edit ▸ Settle on Release is off), so its pose depends on "
                     "the mouse's path; 'hybridedit deform' replays it settled."))
        return True

    def load_edit_dialog(self) -> bool:
        if self.session is None:
            self.w.status.show_error("Load edit", "Open a mesh first.")
            return False
        start = str(self.edit_path) if self.edit_path else self.suggested_path("-edit", ".json")
        path, _ = self.file_dialog(QtWidgets.QFileDialog.getOpenFileName, "Load edit", start, EDIT_FILTER)
        if not path:
            return False
        return self.load_edit_from(path)

    def load_edit_from(self, path: str | os.PathLike) -> bool:
        """Apply a JSON edit file as 'hybridedit deform' does (from the rest pose); the poses kept in it
        are replayed and go to the pose library (in place of its own when those are saved, else after
        them: :meth:`~..model.pose_library.PoseLibrary.take`)."""
        w = self.w
        s = self.session
        if s is None:
            w.status.show_error("Load edit", "Open a mesh first.")
            return False
        if w.controller.busy:
            return False
        w.posing.settle_and_stop_polish()
        try:
            edit, entries = load_edit_with_poses(path)
            kept = replay_poses(s, entries, path=str(path))  # (first: a pose that does not fit changes nothing)
            s.load_edit(edit, path=str(path))
        except (EditFileError, SelectionError, ValueError) as e:
            w.status.show_error("Could not load the edit", str(e))
            return False
        self.edit_path = Path(path)
        said = ""
        if kept:
            replaced = s.poses.take(kept, saved=True)
            said = (f" Its {len(kept)} kept pose{'s are' if len(kept) != 1 else ' is'} in the Poses panel"
                    + ("." if replaced else ", after the unsaved ones kept here."))
        w.unsaved.set_modified(True)
        w.sync.refresh_all()
        w.status.message(f"Applied {Path(path).name}: {edit_summary(edit)}.{cage_note(edit, s.editor.cage.n_vertices)}"
                         + said)
        return True

    # ------------------------------------------------------------------ screenshots
    def screenshot_dialog(self) -> bool:
        w = self.w
        path, _ = self.file_dialog(QtWidgets.QFileDialog.getSaveFileName, "Save screenshot",
                                   self.suggested_path("", ".png"), "PNG images (*.png)")
        if not path:
            return False
        try:
            w.view.screenshot(path)
        except Exception as e:  # noqa: BLE001
            w.status.show_error("Could not save the screenshot", f"{path}: {e}")
            return False
        w.status.message(f"Saved {path}")
        return True
