"""Build jobs: reading a mesh and building its cage and binding in the background, one at a time,
with the status bar's progress bar and Cancel button, and the message that says how it ended.

The work runs in a :class:`~.build_worker.BuildWorker` thread; this module starts it, follows its
signals on the UI thread and hands a finished build to the window, which puts it on display
(:meth:`~..window.shape_loading.ShapeLoading.install_build`). A cancelled or failed build leaves the shape and
the edit on display as they were.

The cage size of a build (:func:`build_size`): a vertex count is checked against the shape before
its cage is built (:func:`~..model.cage_size.fit_cage_size`: above half the shape's vertices, 5 % is used,
shown in the box and said in the status bar); a file opened at a vertex count is read first for that
(:class:`FileBuildAtCount`). A new shape never starts from the vertex count of the shape on display:
it starts from 5 % (a percentage carries over, and so does a count set in the box since).
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from qtpy import QtCore, QtWidgets

from ...fileio.meshfiles import read_document
from ..model.cage_size import DEFAULT_SIZE, fit_cage_size, is_count
from ..model.crash_reports import is_crash
from ..model.look import shown_look
from .build_worker import BuildRequest, BuildResult, BuildWorker, Cancelled
from .threads import release

if TYPE_CHECKING:
    from ...core.mesh import Mesh
    from ..model.session import Session


@runtime_checkable
class Row(Protocol):
    """The status bar's row of fields, where the progress bar and the Cancel button go
    (:class:`~..window.status_widgets.StatusRow`)."""

    def add(self, widget: QtWidgets.QWidget, priority: int, *, preferred: int | None = None,
            minimum: int | None = None, wanted: bool = True) -> None: ...
    def set_wanted(self, widget: QtWidgets.QWidget, wanted: bool) -> None: ...


@runtime_checkable
class Cancels(Protocol):
    """Something under way that can be stopped (the view controller's gesture, the polish)."""

    def cancel(self) -> None: ...


@runtime_checkable
class KeepsWork(Protocol):
    """The file actions as a build sees them: the Save / Discard / Cancel question."""

    def keep_work(self, doing: str) -> bool: ...


@runtime_checkable
class Says(Protocol):
    """The status bar as a build sees it: errors (an unexpected one reported) and messages."""

    def show_error(self, title: str, text: str) -> None: ...
    def message(self, text: str) -> None: ...
    def report_crash(self, error: BaseException, *, what: str, context: str, kept: str | None = None,
                     details: dict | None = None) -> Path | None: ...


@runtime_checkable
class CageBox(Protocol):
    """The toolbar's cage size box as a build sees it (:class:`~..window.cage_size_box.CageSizeControl`)."""

    @property
    def of_shape(self) -> bool: ...  # it shows the cage size of the shape on display, not a size chosen since
    def value(self) -> int | float: ...
    def set_value(self, size: int | float, *, of_shape: bool = False) -> None: ...


@runtime_checkable
class Settles(Protocol):
    """The window's pose side as a build sees it: a settle under way completed first."""

    def finish_settle(self) -> None: ...


@runtime_checkable
class Shows(Protocol):
    """The window's loading as a build sees it (:class:`~..window.shape_loading.ShapeLoading`): a new
    shape shown while it is built, a finished build installed, or the shape before put back."""

    def install_build(self, result: BuildResult) -> tuple[bool, str | None]: ...
    def preview_shape(self, mesh: "Mesh", look, up: tuple[str, bool, str]) -> None: ...
    def end_preview(self) -> None: ...


@runtime_checkable
class BuildHost(Protocol):
    """What :class:`BuildJobs` asks of the window (:class:`~..window.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def files(self) -> KeepsWork: ...
    @property
    def controller(self) -> Cancels: ...
    @property
    def polisher(self) -> Cancels: ...
    @property
    def cage_control(self) -> CageBox: ...
    @property
    def posing(self) -> Settles: ...
    @property
    def loading(self) -> Shows: ...
    @property
    def status(self) -> Says: ...


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


def build_size(asked: int | float, of_shape: bool, new_shape: bool,
               n_vertices: int | None) -> tuple[int | float, str | None]:
    """The cage size a build uses, and a sentence when it is not the one ``asked``.

    Parameters
    ----------
    asked : the size in the toolbar's box.
    of_shape : ``asked`` is the cage size of the shape on display (not a size set since).
    new_shape : the build is of another shape (opening), not a new cage for the one on display.
    n_vertices : the vertex count of the shape to build, when known (None: a file not read yet).

    Returns
    -------
    size : the size to build at; a vertex count only once checked against ``n_vertices``.
    note : why ``size`` is not ``asked`` (said in the status bar before the build), or None.

    Examples
    --------
    >>> build_size(64_000, True, new_shape=True, n_vertices=None)  # the count of the shape on display
    (0.05, None)
    >>> build_size(0.1, True, new_shape=True, n_vertices=None)  # a percentage carries over
    (0.1, None)
    >>> build_size(9_999_999, False, new_shape=False, n_vertices=32_000)[0]
    0.05
    """
    if new_shape and of_shape and is_count(asked):
        return DEFAULT_SIZE, None
    return fit_cage_size(asked, n_vertices)


class FileBuildAtCount(BuildWorker):
    """A file opened at a vertex count: the file is read first, the count checked against the shape
    (:func:`~..model.cage_size.fit_cage_size`) and, when it is too many, :attr:`size_fitted` says so before
    the cage is built; then the build goes on as any other.

    A file that cannot be read is left to :class:`~.build_worker.BuildWorker` as it is (it reads it again and
    says why, in its words).

    Signals
    -------
    size_fitted(size, note)   the size used instead of the request's, and why (from the build thread)

    Attributes
    ----------
    look : the file's textures and colours once read (the build's result gets them: the build itself
        starts from the shape read here).
    """

    size_fitted = QtCore.Signal(object, str)

    def __init__(self, request: BuildRequest, parent: QtCore.QObject | None = None) -> None:
        super().__init__(request, parent)
        self.look = None

    def run(self) -> None:  # runs in the worker thread
        req = self.request
        try:
            document = read_document(req.path, progress=self._report)
        except Cancelled:
            self.cancelled.emit()
            return
        except Exception:  # noqa: BLE001 -- read again, and said, by BuildWorker.run
            super().run()
            return
        self.look = shown_look(document)
        self.announce(document.mesh, self.look)
        size, note = fit_cage_size(req.cage_size, document.mesh.n_vertices)
        if note:
            self.size_fitted.emit(size, note)
        self.request = dataclasses.replace(req, mesh=document.mesh, cage_size=size)
        super().run()


class BuildJobs(QtCore.QObject):
    """The build jobs of a :class:`~..window.main_window.MainWindow`: open a file, build a loaded shape,
    rebuild the cage.

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
    size_note : why the job under way builds at another size than the box had, or None.

    Signals
    -------
    busy_changed(busy: bool)   a job started, or ended (built, failed or cancelled)
    """

    busy_changed = QtCore.Signal(bool)

    def __init__(self, window: BuildHost, parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.w = window
        self.worker: BuildWorker | None = None
        self.size_note: str | None = None
        # (the box's size and whether it was the shape's, and what the job set there)
        self._box_before: tuple[int | float, bool, int | float] | None = None
        self.progress = QtWidgets.QProgressBar()
        self.progress.setRange(0, 1000)
        self.progress.setTextVisible(True)
        self.cancel_button = QtWidgets.QPushButton("Cancel")
        self.cancel_button.clicked.connect(self.cancel)
        self._row: Row | None = None

    @property
    def busy(self) -> bool:
        return self.worker is not None

    PROGRESS_WIDTH = 420
    """The progress bar's width when there is room; it shrinks to :attr:`PROGRESS_MIN` in a narrow window."""
    PROGRESS_MIN = 120

    def place_in(self, row: Row) -> None:
        """Put the progress bar and the Cancel button at the right of the status bar's ``row``, first in
        priority (the fields give way to them), hidden until a job runs."""
        self._row = row
        row.add(self.progress, 0, preferred=self.PROGRESS_WIDTH, minimum=self.PROGRESS_MIN, wanted=False)
        row.add(self.cancel_button, 0, wanted=False)

    def _show_bar(self, on: bool) -> None:
        if self._row is not None:
            self._row.set_wanted(self.progress, on)
            self._row.set_wanted(self.cancel_button, on)
        else:
            self.progress.setVisible(on)
            self.cancel_button.setVisible(on)

    # ------------------------------------------------------------------ the cage size
    def _size(self, new_shape: bool, n_vertices: int | None) -> int | float:
        """The size for the build about to start: shown in the box, and said when it is not the box's."""
        w = self.w
        asked = w.cage_control.value()
        size, note = build_size(asked, w.session is not None and w.cage_control.of_shape, new_shape, n_vertices)
        self.size_note = note
        self._show_size(asked, size, note)
        return size

    def _show_size(self, asked: int | float, size: int | float, note: str | None) -> None:
        w = self.w
        if size != asked or type(size) is not type(asked):
            before = self._box_before or (asked, w.cage_control.of_shape, size)
            self._box_before = (before[0], before[1], size)
            w.cage_control.set_value(size)
        if note:
            w.status.message(f"Cage size: {note}.")

    def _size_fitted(self, size: int | float, note: str) -> None:
        """The build thread read the file: its vertex count was too many for the shape."""
        self.size_note = note
        self._show_size(self.w.cage_control.value(), size, note)

    # ------------------------------------------------------------------ starting
    def open_file(self, path: str | os.PathLike) -> bool:
        """Read a mesh file and build its cage and binding (asks first if the pose is unsaved).

        Returns True when the job started.
        """
        p = Path(path)
        if not self.w.files.keep_work(f"opening {p.name}"):
            return False
        if self._refused():
            return False
        return self.start(BuildRequest(cage_size=self._size(True, None), path=p), f"Opening {p.name}")

    def open_mesh(self, mesh: "Mesh", path: Path | None = None) -> bool:
        """Build an already loaded shape (asks first if the pose is unsaved); True when the job started."""
        if not self.w.files.keep_work("opening another shape"):
            return False
        if self._refused():
            return False
        return self.start(BuildRequest(cage_size=self._size(True, mesh.n_vertices), path=path, mesh=mesh),
                          "Building")

    def rebuild(self) -> bool:
        """Build the session's cage and binding again at the toolbar's size; True when the job started.

        The window carries the selection, the pose and the undo history over to the new cage.
        """
        w = self.w
        # the settle only, not the polish: the settled pose is what the question below may save; a rebuild
        # refused there (Cancel) leaves a polish under way running, and one that goes ahead stops it in start()
        w.posing.finish_settle()
        s = w.session
        if s is None:
            w.status.show_error("Rebuild cage", "Open a mesh first.")
            return False
        if not w.files.keep_work("rebuilding the cage (the pose is solved again on the new cage)"):
            return False
        if self._refused():
            return False
        size = self._size(False, s.mesh.n_vertices)
        return self.start(BuildRequest(cage_size=size, path=s.path, mesh=s.mesh, rebuild=True),
                          "Rebuilding the cage")

    def _refused(self) -> bool:
        """A job runs: say so (an error) and return True."""
        if self.worker is None:
            return False
        self.w.status.show_error("Busy", "A cage is being built; wait for it or cancel it first.")
        return True

    def start(self, request: BuildRequest, label: str) -> bool:
        """Run ``request`` in a build thread, its progress shown as ``label…`` until the first report.

        Refused (an error, False) while another job runs. Gestures and polishes under way stop first.
        A file asked at a vertex count is read first, to check the count (:class:`FileBuildAtCount`).
        """
        w = self.w
        if self._refused():
            return False
        # the polish only, not the settle: a settle under way may go on while the thread builds, and
        # install_build completes it before the build goes on display
        w.controller.cancel()
        w.polisher.cancel()
        if request.mesh is None and is_count(request.cage_size):
            job = FileBuildAtCount(request, self)
            job.size_fitted.connect(self._size_fitted)
        else:
            job = BuildWorker(request, self)
        job.progress.connect(self._progress)
        job.shape_read.connect(self._shape_read)
        job.succeeded.connect(self._succeeded)
        job.failed.connect(self._failed)
        job.crashed.connect(self._crashed)
        job.cancelled.connect(self._cancelled)
        job.finished.connect(self._finished)
        self.worker = job
        self.progress.setValue(0)
        self.progress.setFormat(f"{label}…")
        self._show_bar(True)
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

    def _shape_read(self, mesh, look, up) -> None:
        """The job read a new shape: the window shows it while the cage and binding are built."""
        if self.worker is not None and not self.worker.cancel_requested:
            self.w.loading.preview_shape(mesh, look, up)

    def _succeeded(self, result: BuildResult) -> None:
        w = self.w
        if result.look is None and isinstance(self.worker, FileBuildAtCount):
            result.look = self.worker.look  # (read before the build, which started from the shape read)
        self._box_before = None  # the box shows the new cage's size (install_build)
        try:
            rebuilt, note = w.loading.install_build(result)
            note = "; ".join(n for n in (self.size_note, note) if n) or None
            w.status.message(built_message(result, w.session, rebuilt, note))
        except Exception as e:  # noqa: BLE001
            w.loading.end_preview()  # (the shape on display before comes back)
            if is_crash(e):
                self._report(e, result.request, "showing")
            else:
                w.status.show_error("Could not show the shape", str(e))

    def _failed(self, message: str) -> None:
        self.w.loading.end_preview()
        req = self.worker.request if self.worker is not None else None
        rebuilding = req is not None and req.rebuild
        self.w.status.show_error("Could not rebuild the cage" if rebuilding else "Could not open the mesh", message)

    def _crashed(self, error: BaseException) -> None:
        """The build raised an unexpected error: the shape on display before is back (or none), reported."""
        self.w.loading.end_preview()
        if self.worker is not None:
            self._report(error, self.worker.request, "building")

    def _report(self, error: BaseException, req: BuildRequest, stage: str) -> None:
        """One line and a crash report for a build that failed unexpectedly while ``stage`` ("building",
        "showing"), naming its shape and what is on display now."""
        w = self.w
        name = req.path.name if req.path is not None else (req.mesh.name if req.mesh is not None else None)
        what = f"{'rebuild of the cage of' if req.rebuild else 'build of'} {name or 'the shape'}"
        kept = ("the shape and edit on display are kept" if req.rebuild else "the shape on display is kept") \
            if w.session is not None else "no shape is open"
        w.status.report_crash(error, what=f"The {what} failed", context=what, kept=kept,
                              details={"building": f"{name or 'a shape'} at cage size {req.cage_size}"
                                                   f"{f' from {req.path}' if req.path is not None else ''}",
                                       "failed while": stage})

    def _cancelled(self) -> None:
        self.w.loading.end_preview()
        self.w.status.message("Cancelled; the current shape and edit are unchanged.")

    def _finished(self) -> None:
        job, self.worker = self.worker, None
        release(job)
        self.w.loading.end_preview()  # (a job that showed a shape and did not install it: the one before is back)
        if self._box_before is not None:  # not built: the box goes back to what it had (unless changed since)
            asked, of_shape, set_here = self._box_before
            if self.w.cage_control.value() == set_here:
                self.w.cage_control.set_value(asked, of_shape=of_shape)
        self._box_before = None
        self.size_note = None
        self._show_bar(False)
        self.busy_changed.emit(False)
