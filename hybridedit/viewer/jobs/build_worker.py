"""Reading a mesh and building the cage and binding in a worker thread, with progress and cancel.

Cancelling makes the engine's progress callback raise :class:`Cancelled`; the
half-built editor is dropped and the window keeps its current state.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from qtpy import QtCore

from ...deform.editor import HybridEditor
from ...binding.rig import build_rig
from ...core.region_metrics import ShapeMetrics
from ...fileio.up_axes import shape_key, up_axis_of
from ...fileio.meshfiles import read_document
from ..model.crash_reports import is_crash
from ..model.look import Look, shown_look
from ...core.mesh import Mesh


class Cancelled(Exception):
    """Raised from the progress callback when the user cancels."""


@dataclass
class BuildRequest:
    """What to build: a file to read (``path``) or a shape already loaded (``mesh``).

    ``rebuild``: a new cage for the shape being edited (the window carries the edit over).
    """

    cage_size: int | float
    path: Path | None = None
    mesh: Mesh | None = None
    rebuild: bool = False
    use_cache: bool = True


@dataclass
class BuildResult:
    request: BuildRequest
    mesh: Mesh
    editor: HybridEditor
    seconds: float
    #: what the file says the shape looks like (textures, colours), for a newly read file; else None
    look: Look | None = None
    #: a new shape's up axis, whether it was remembered (else guessed), and the key it is remembered
    #: under (:mod:`hybridedit.fileio.up_axes`); None for a rebuild
    up: tuple[str, bool, str] | None = None
    #: a new shape's per-frame index sets for the view (made here, off the UI thread); None for a rebuild
    metrics: ShapeMetrics | None = None


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
        self.request = request
        self._cancel = threading.Event()
        self._last_emit = 0.0
        self._last_stage = ""
        self._up: tuple[str, bool, str] | None = None  # the new shape's up axis, once read

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

    def announce(self, mesh: Mesh, look: Look | None) -> None:
        """A new shape is read: its up axis (remembered, else guessed) and ``shape_read`` for the window, once."""
        if self._up is not None:
            return
        key = shape_key(mesh)
        self._up = (*up_axis_of(mesh, path=self.request.path, key=key), key)
        self.shape_read.emit(mesh, look, self._up)

    def _compile_kernels_once(self) -> None:
        """First run after a plain install (scripts/setup.sh does this at set-up): compile every kernel
        here, before there is anything to drag, and say so."""
        from ... import warmup

        if warmup.is_warm():
            return
        stage = "compiling the kernels for this computer (first run only, about a minute)"
        self._report(stage, 0.0)
        steps = iter(np.linspace(0.05, 0.95, 12))
        warmup.run(progress=lambda _stage, _f: self._report(stage, float(next(steps, 0.95))))

    def run(self) -> None:  # runs in the worker thread
        t0 = time.perf_counter()
        req = self.request
        try:
            self._compile_kernels_once()
            mesh, look = req.mesh, getattr(self, "look", None)
            if mesh is None:
                document = read_document(req.path, progress=self._report)  # ("reading NAME", from 0 to 1)
                mesh = document.mesh
                look = shown_look(document)
            if not req.rebuild:
                self.announce(mesh, look)
            # the on-disk cache makes reopening a shape (or going back to a cage size) instant
            rig = build_rig(mesh, cage_size=req.cage_size, cache=req.use_cache, progress=self._report)
            # the editor's own set-up (the shape's Laplacian, the residual, the selection maps) takes a
            # while on a big shape: said, so that "100%" is the end of the work
            self._report("setting up the editor", 0.0)
            editor = HybridEditor(rig)
            metrics = None
            if not req.rebuild:  # (a rebuild keeps the shape, and the view's sets of it)
                self._report("preparing the view", 0.0)
                metrics = ShapeMetrics(mesh.vertices, mesh.faces)
            up = self._up
            self._report("done", 1.0)
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
            self.succeeded.emit(BuildResult(req, mesh, editor, time.perf_counter() - t0, look, up, metrics))
