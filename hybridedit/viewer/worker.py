"""Reading a mesh and building the cage and binding in a worker thread, with progress and cancel.

Cancelling makes the engine's progress callback raise :class:`Cancelled`; the
half-built editor is dropped and the window keeps its current state.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from qtpy import QtCore

from ..editor import HybridEditor
from ..io import read_mesh
from ..mesh import Mesh


class Cancelled(Exception):
    """Raised from the progress callback when the user cancels."""


@dataclass
class BuildRequest:
    """What to build: a file to read (``path``) or a shape already loaded (``mesh``).

    ``carry`` is passed through to the result untouched (the window uses it to
    carry a selection across a cage rebuild).
    """

    cage_size: int | float
    path: Path | None = None
    mesh: Mesh | None = None
    carry: dict = field(default_factory=dict)
    use_cache: bool = True


@dataclass
class BuildResult:
    request: BuildRequest
    mesh: Mesh
    editor: HybridEditor
    seconds: float


class BuildWorker(QtCore.QThread):
    """Runs one :class:`BuildRequest` off the GUI thread.

    Signals
    -------
    progress(stage: str, fraction: float)
    succeeded(BuildResult)
    failed(message: str)   a one-line message for the user (never a traceback)
    cancelled()
    """

    progress = QtCore.Signal(str, float)
    succeeded = QtCore.Signal(object)
    failed = QtCore.Signal(str)
    cancelled = QtCore.Signal()

    def __init__(self, request: BuildRequest, parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.request = request
        self._cancel = threading.Event()
        self._last_emit = 0.0
        self._last_stage = ""

    def cancel(self) -> None:
        """Ask the job to stop at its next progress report."""
        self._cancel.set()

    @property
    def cancel_requested(self) -> bool:
        return self._cancel.is_set()

    def _report(self, stage: str, fraction: float) -> None:
        if self._cancel.is_set():
            raise Cancelled()
        now = time.perf_counter()
        if stage != self._last_stage or fraction >= 1.0 or now - self._last_emit > 0.05:
            self._last_stage, self._last_emit = stage, now
            self.progress.emit(stage, float(fraction))

    def run(self) -> None:  # runs in the worker thread
        t0 = time.perf_counter()
        req = self.request
        try:
            mesh = req.mesh
            if mesh is None:
                self._report(f"reading {req.path.name}", 0.0)
                mesh = read_mesh(req.path)
                self._report(f"reading {req.path.name}", 1.0)
            # the on-disk cache makes reopening a shape (or going back to a cage size) instant
            editor = HybridEditor(mesh, req.cage_size, progress=self._report, cache=req.use_cache)
            self._report("done", 1.0)
        except Cancelled:
            self.cancelled.emit()
        except MemoryError:
            self.failed.emit("not enough memory to build the cage and binding for this shape")
        except Exception as e:  # noqa: BLE001 -- every failure becomes a message, never a traceback
            msg = str(e).strip() or e.__class__.__name__
            if not isinstance(e, (ValueError, OSError)):
                msg = f"{e.__class__.__name__}: {msg}"
            self.failed.emit(msg)
        else:
            self.succeeded.emit(BuildResult(req, mesh, editor, time.perf_counter() - t0))
