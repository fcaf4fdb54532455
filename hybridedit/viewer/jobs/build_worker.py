"""Reading a mesh and building the cage and binding in a worker thread, with progress and cancel
(:class:`~..model.building.Build`, Qt-free, turned into signals here).

Cancelling makes the build's progress report raise :class:`Cancelled`; the
half-built editor is dropped and the window keeps its current state.
"""

from __future__ import annotations

from qtpy import QtCore

from ..model.building import Build, BuildRequest, BuildResult, Cancelled
from ..model.crash_reports import is_crash
from ..model.look import Look
from ...core.mesh import Mesh

__all__ = ["BuildRequest", "BuildResult", "BuildWorker", "Cancelled"]


class BuildWorker(QtCore.QThread):
    """Runs one :class:`BuildRequest` off the GUI thread.

    Signals
    -------
    progress(stage: str, fraction: float)
    shape_read(mesh, look, up)   a new shape is read (its look or None, its up axis): the window shows
                                 it while the cage and binding are built (not for a rebuild)
    succeeded(BuildResult)
    failed(message: str)   a one-line message for the user (never a traceback): the input's problem
    crashed(error)         an unexpected error (:func:`~..model.crash_reports.is_crash`), with its
                           traceback: the window reports it
    cancelled()
    """

    progress = QtCore.Signal(str, float)
    shape_read = QtCore.Signal(object, object, object)
    succeeded = QtCore.Signal(object)
    failed = QtCore.Signal(str)
    crashed = QtCore.Signal(object)
    cancelled = QtCore.Signal()

    def __init__(self, request: BuildRequest, parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self._build = Build(request, progress=self.progress.emit, shape_read=self.shape_read.emit)

    @property
    def request(self) -> BuildRequest:
        return self._build.request

    @request.setter
    def request(self, request: BuildRequest) -> None:
        self._build.request = request

    def cancel(self) -> None:
        """Ask the job to stop at its next progress report."""
        self._build.cancel()

    @property
    def cancel_requested(self) -> bool:
        return self._build.cancel_requested

    def _report(self, stage: str, fraction: float) -> None:
        self._build.report(stage, fraction)

    def announce(self, mesh: Mesh, look: Look | None) -> None:
        """A new shape is read: its up axis (remembered, else guessed) and ``shape_read`` for the window, once."""
        self._build.announce(mesh, look)

    def run(self) -> None:  # runs in the worker thread
        try:
            result = self._build.run(look=getattr(self, "look", None))
        except Cancelled:
            self.cancelled.emit()
        except MemoryError:
            self.failed.emit("not enough memory to build the cage and binding for this shape")
        except Exception as e:  # noqa: BLE001 -- a message, or a crash report: never a traceback on screen
            if is_crash(e):
                self.crashed.emit(e)
            else:  # the input's problem (a ValueError, an OSError), in the words it was raised with
                self.failed.emit(str(e).strip() or e.__class__.__name__)
        else:
            self.succeeded.emit(result)
