"""Build jobs: reading a mesh and building its cage and binding in the background, one at a time,
with the status bar's progress bar and Cancel button, and the message that says how it ended.

The work runs in a :class:`~.worker.BuildWorker` thread; this module starts it, follows its
signals on the UI thread and hands a finished build to the window, which puts it on display
(:meth:`~.window.MainWindow.install_build`). A cancelled or failed build leaves the shape and
the edit on display as they were.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from qtpy import QtCore, QtWidgets

from .worker import BuildRequest, BuildResult, BuildWorker, release

if TYPE_CHECKING:
    from ..mesh import Mesh
    from .session import Session


@runtime_checkable
class Cancels(Protocol):
    """Something under way that can be stopped (the view controller's gesture, the polish)."""

    def cancel(self) -> None: ...


@runtime_checkable
class KeepsWork(Protocol):
    """The file actions as a build sees them: the Save / Discard / Cancel question."""

    def keep_work(self, doing: str) -> bool: ...


@runtime_checkable
class BuildHost(Protocol):
    """What :class:`BuildJobs` asks of the window (:class:`~.window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def files(self) -> KeepsWork: ...
    @property
    def controller(self) -> Cancels: ...
    @property
    def polisher(self) -> Cancels: ...
    def cage_size(self) -> int | float: ...
    def finish_settle(self) -> None: ...
    def show_error(self, title: str, text: str) -> None: ...
    def message(self, text: str) -> None: ...
    def install_build(self, result: BuildResult) -> tuple[bool, str | None]: ...


def built_message(result: BuildResult, session: "Session", rebuilt: bool, note: str | None = None) -> str:
    """The status message for a build on display.

    Parameters
    ----------
    result : the finished build.
    session : the session that shows it.
    rebuilt : the build was a new cage for the shape being edited (not a new shape).
    note : what the rebuild said about carrying the edit over, or why Mirror is off for a new shape, or None.

    Returns
    -------
    One line: what was loaded or rebuilt, its cage size, whether it came from the cache (else how
    long the cage and the binding took), ``note``, and the repairs made to a new input.
    """
    req, ed = result.request, result.editor
    name = req.path.name if req.path is not None else (session.mesh.name or "shape")
    t = ed.timings
    how = "from the cache" if getattr(ed, "cache_hit", False) else (
        f"cage {t.get('cage_seconds', 0):.1f} s, binding {t.get('bind_seconds', 0):.1f} s")
    notes = [str(n) for n in (getattr(ed, "notes", None) or [])]
    msg = f"{'Rebuilt the cage of' if rebuilt else 'Loaded'} {name}: cage {session.n_cage:,} vertices ({how})"
    if note:
        msg += f"; {note}"
    if notes and not rebuilt:
        msg += f" · input repaired: {'; '.join(notes)} (File ▸ Mesh Info…)"
    return msg


class BuildJobs(QtCore.QObject):
    """The build jobs of a :class:`~.window.MainWindow`: open a file, build a loaded shape, rebuild the cage.

    One job runs at a time; while it runs, :attr:`progress` and :attr:`cancel_button` (placed in
    the window's status bar by :meth:`place_in`) show it, and a second job is refused in words.

    The window is used through what :class:`BuildHost` names; it follows :attr:`busy_changed` to
    enable its actions.

    Parameters
    ----------
    window : the window, as far as a build needs it (:class:`BuildHost`).
    parent : the Qt parent (the window).

    Attributes
    ----------
    worker : the build thread running now, or None.
    progress : the progress bar (stage and percentage).
    cancel_button : the Cancel button beside it.

    Signals
    -------
    busy_changed(busy: bool)   a job started, or ended (built, failed or cancelled)
    """

    busy_changed = QtCore.Signal(bool)

    def __init__(self, window: BuildHost, parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.w = window
        self.worker: BuildWorker | None = None
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 1000)
        self.progress.setFixedWidth(420)
        self.progress.setTextVisible(True)
        self.cancel_button = QtWidgets.QPushButton("Cancel")
        self.cancel_button.clicked.connect(self.cancel)

    @property
    def busy(self) -> bool:
        return self.worker is not None

    def place_in(self, statusbar: QtWidgets.QStatusBar) -> None:
        """Put the progress bar and the Cancel button at the right of ``statusbar``, hidden until a job runs."""
        statusbar.addPermanentWidget(self.progress)
        statusbar.addPermanentWidget(self.cancel_button)
        self.progress.hide()
        self.cancel_button.hide()

    # ------------------------------------------------------------------ starting
    def open_file(self, path: str | os.PathLike) -> bool:
        """Read a mesh file and build its cage and binding (asks first if the pose is unsaved).

        Returns True when the job started.
        """
        p = Path(path)
        if not self.w.files.keep_work(f"opening {p.name}"):
            return False
        return self.start(BuildRequest(cage_size=self.w.cage_size(), path=p), f"Opening {p.name}")

    def open_mesh(self, mesh: "Mesh", path: Path | None = None) -> bool:
        """Build an already loaded shape (asks first if the pose is unsaved); True when the job started."""
        if not self.w.files.keep_work("opening another shape"):
            return False
        return self.start(BuildRequest(cage_size=self.w.cage_size(), path=path, mesh=mesh), "Building")

    def rebuild(self) -> bool:
        """Build the session's cage and binding again at the toolbar's size; True when the job started.

        The window carries the selection, the pose and the undo history over to the new cage.
        """
        w = self.w
        # the settle only, not the polish: the settled pose is what the question below may save; a rebuild
        # refused there (Cancel) leaves a polish under way running, and one that goes ahead stops it in start()
        w.finish_settle()
        s = w.session
        if s is None:
            w.show_error("Rebuild cage", "Open a mesh first.")
            return False
        if not w.files.keep_work("rebuilding the cage (the pose is solved again on the new cage)"):
            return False
        return self.start(BuildRequest(cage_size=w.cage_size(), path=s.path, mesh=s.mesh, rebuild=True),
                          "Rebuilding the cage")

    def start(self, request: BuildRequest, label: str) -> bool:
        """Run ``request`` in a build thread, its progress shown as ``label…`` until the first report.

        Refused (an error, False) while another job runs. Gestures and polishes under way stop first.
        """
        w = self.w
        if self.worker is not None:
            w.show_error("Busy", "A cage is being built; wait for it or cancel it first.")
            return False
        # the polish only, not the settle: a settle under way may go on while the thread builds, and
        # install_build completes it before the build goes on display
        w.controller.cancel()
        w.polisher.cancel()
        job = BuildWorker(request, self)
        job.progress.connect(self._progress)
        job.succeeded.connect(self._succeeded)
        job.failed.connect(self._failed)
        job.cancelled.connect(self._cancelled)
        job.finished.connect(self._finished)
        self.worker = job
        self.progress.setValue(0)
        self.progress.setFormat(f"{label}…")
        self.progress.show()
        self.cancel_button.show()
        self.cancel_button.setEnabled(True)
        self.busy_changed.emit(True)
        job.start()
        return True

    # ------------------------------------------------------------------ stopping
    def cancel(self) -> None:
        """Stop the job under way at its next progress report; the shape on display stays."""
        if self.worker is not None:
            self.worker.cancel()
            self.cancel_button.setEnabled(False)
            self.progress.setFormat("Cancelling…")

    def wait(self, ms: int = 30000) -> None:
        """Cancel the job under way and wait for its thread to end (before closing)."""
        if self.worker is not None:
            self.worker.cancel()
            self.worker.wait(ms)

    # ------------------------------------------------------------------ the build thread's signals
    def _progress(self, stage: str, fraction: float) -> None:
        if self.worker is not None and self.worker.cancel_requested:
            return  # the bar says "Cancelling…" until the thread ends
        self.progress.setValue(int(round(1000 * min(max(fraction, 0.0), 1.0))))
        self.progress.setFormat(f"{stage} %p%")

    def _succeeded(self, result: BuildResult) -> None:
        w = self.w
        try:
            rebuilt, note = w.install_build(result)
            w.message(built_message(result, w.session, rebuilt, note))
        except Exception as e:  # noqa: BLE001
            w.show_error("Could not show the shape", f"{e.__class__.__name__}: {e}")

    def _failed(self, message: str) -> None:
        req = self.worker.request if self.worker is not None else None
        rebuilding = req is not None and req.rebuild
        self.w.show_error("Could not rebuild the cage" if rebuilding else "Could not open the mesh", message)

    def _cancelled(self) -> None:
        self.w.message("Cancelled; the current shape and edit are unchanged.")

    def _finished(self) -> None:
        job, self.worker = self.worker, None
        release(job)
        self.progress.hide()
        self.cancel_button.hide()
        self.busy_changed.emit(False)
