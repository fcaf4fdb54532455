"""Building a shape's engine for editing, with no Qt: the file read, the kernels compiled on a first run,
the cage and binding built (from the cache when it holds them), the editor and the view's index sets
set up; progress reported at every step and the build stoppable at each report.

The window's build thread (:class:`~hybridedit.viewer.jobs.build_worker.BuildWorker`) and the browser's
(:mod:`hybridedit.web.opening_job`) run it; each turns its reports into what it shows.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...binding.rig import build_rig
from ...core.mesh import Mesh
from ...core.region_metrics import ShapeMetrics
from ...deform.editor import HybridEditor
from ...fileio.meshfiles import read_document
from ...fileio.up_axes import shape_key, up_axis_of
from .look import Look, shown_look

__all__ = ["Build", "BuildRequest", "BuildResult", "Cancelled"]

REPORT_SECONDS = 0.05
"""Within a stage, a report is passed on at most this often (a bar redrawn 20 times a second)."""


class Cancelled(Exception):
    """Raised from a build's progress report once the build was cancelled."""


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


class Build:
    """One build: :meth:`run` in a worker thread, :meth:`cancel` from any other.

    Parameters
    ----------
    request : what to build.
    progress : told ``(stage, fraction)`` as the build goes (from the build's thread; a new stage, the
        end, or at most every :data:`REPORT_SECONDS`).
    shape_read : told ``(mesh, look, up)`` once a new shape is read (its look or None; its up axis, whether
        remembered, and its key), before its cage and binding are built: a front end shows it meanwhile.
    stop : the event :meth:`cancel` sets (default: a new one).
    """

    def __init__(self, request: BuildRequest, *, progress: Callable[[str, float], None] | None = None,
                 shape_read: Callable[[Mesh, Look | None, tuple], None] | None = None,
                 stop: threading.Event | None = None) -> None:
        self.request = request
        self._progress = progress
        self._shape_read = shape_read
        self._stop = stop if stop is not None else threading.Event()
        self._last_emit = 0.0
        self._last_stage = ""
        self.up: tuple[str, bool, str] | None = None  # the new shape's up axis, once read

    def cancel(self) -> None:
        """Stop the build at its next progress report (:meth:`run` raises :class:`Cancelled`)."""
        self._stop.set()

    @property
    def cancel_requested(self) -> bool:
        return self._stop.is_set()

    def report(self, stage: str, fraction: float) -> None:
        """A step of the build (the engine's progress callback); raises :class:`Cancelled` once cancelled."""
        if self._stop.is_set():
            raise Cancelled()
        now = time.perf_counter()
        if self._progress is not None and (stage != self._last_stage or fraction >= 1.0
                                           or now - self._last_emit > REPORT_SECONDS):
            self._last_stage, self._last_emit = stage, now
            self._progress(stage, float(fraction))

    def announce(self, mesh: Mesh, look: Look | None) -> None:
        """A new shape is read: its up axis (remembered, else guessed), told to ``shape_read``, once."""
        if self.up is not None:
            return
        key = shape_key(mesh)
        self.up = (*up_axis_of(mesh, path=self.request.path, key=key), key)
        if self._shape_read is not None:
            self._shape_read(mesh, look, self.up)

    def compile_kernels_once(self) -> None:
        """First run after a plain install (scripts/setup.sh does this at set-up): compile every kernel
        here, before there is anything to drag, and say so."""
        from ... import warmup

        if warmup.is_warm():
            return
        stage = "compiling the kernels for this computer (first run only, about a minute)"
        self.report(stage, 0.0)
        steps = iter(np.linspace(0.05, 0.95, 12))
        warmup.run(progress=lambda _stage, _f: self.report(stage, float(next(steps, 0.95))))

    def run(self, look: Look | None = None) -> BuildResult:
        """Build what the request asks (``look``: the file's, when the caller read it already).

        Raises
        ------
        Cancelled
            :meth:`cancel` was called.
        MemoryError, MeshError, MeshFileError, ValueError, OSError
            As reading and building raise them.
        """
        t0 = time.perf_counter()
        req = self.request
        self.compile_kernels_once()
        mesh = req.mesh
        if mesh is None:
            document = read_document(req.path, progress=self.report)  # ("reading NAME", from 0 to 1)
            mesh = document.mesh
            look = shown_look(document)
        if not req.rebuild:
            self.announce(mesh, look)
        # the on-disk cache makes reopening a shape (or going back to a cage size) instant
        rig = build_rig(mesh, cage_size=req.cage_size, cache=req.use_cache, progress=self.report)
        # the editor's own set-up (the shape's Laplacian, the residual, the selection maps) takes a
        # while on a big shape: said, so that "100%" is the end of the work
        self.report("setting up the editor", 0.0)
        editor = HybridEditor(rig)
        metrics = None
        if not req.rebuild:  # (a rebuild keeps the shape, and the view's sets of it)
            self.report("preparing the view", 0.0)
            metrics = ShapeMetrics(mesh.vertices, mesh.faces)
        self.report("done", 1.0)
        return BuildResult(req, mesh, editor, time.perf_counter() - t0, look, self.up, metrics)
