"""Drag frames computed on a worker thread while the window renders the previous one.

A drag frame has two halves: the engine's solve with the moving region's
normals and edge error (pure numpy and compiled kernels, no Qt or VTK), and
showing the result (copying the changed rows into VTK's buffers and
rendering). The render releases Python's lock while it draws, so the next
frame's solve runs beside it, on the other core: the window's displayed frame
is then about the render alone instead of the render plus the solve.

:class:`FrameThread` runs one job at a time. A job submitted while one runs
waits as the pending job, and a newer submission replaces it (the latest
mouse position wins). Each finished job's result is handed to the handler on
the UI thread, before the pending job starts, so the handler reads the engine
while nothing else touches it. :meth:`FrameThread.flush` finishes everything
under way and hands the results over before anything else reads or changes
the session.
"""

from __future__ import annotations

import os
import threading
from dataclasses import dataclass
from typing import Callable

import numba
import numpy as np
from qtpy import QtCore

Job = Callable[[], object]
"""A job: runs on the worker thread, returns its result (or raises)."""
ALL_THREADS = numba.config.NUMBA_NUM_THREADS
"""Threads of the compiled kernels for a job submitted while the worker is idle and no render is
due: the window waits for that one, so it gets every core. A pending job starts as the previous
frame goes to the screen, and a job submitted while a frame waits to be drawn starts just before
its render: both run beside the render, whose software rasterizer keeps the cores busy, so they
run serially, as a parallel region there waits for its slowest thread (the 173K armadillo's
propagation takes about 13 times as long in parallel beside the render as serially)."""


NICE = 10
"""Scheduling niceness of the frame thread: a frame computed beside the render waits for spare
cycles rather than slowing the render down."""


@dataclass
class DragFrame:
    """What a drag job hands to the UI thread: the session it ran on, its seconds (engine solve,
    normals, points), the edge error in percent (None: not measured this frame), whether the stretch
    buffer was written, the cage pose (c, 3) with its normals and bounds (the scene's
    ``cage_geometry``), the handle centroid (3,) or None, and the job's seconds in all. The shape
    itself is in the scene's buffers."""

    session: object
    engine_s: float
    normals_s: float
    points_s: float
    error: float | None
    stretch: bool
    cage: np.ndarray
    cage_geometry: tuple
    centroid: np.ndarray | None
    thread_s: float = 0.0


class FrameThread(QtCore.QObject):
    """One worker thread for drag frames.

    Parameters
    ----------
    handler : called on the UI thread with (ok, value) for each finished job: ``ok`` True and
        the job's return value, or False and the exception it raised.
    parent : the owning QObject.
    """

    _finished = QtCore.Signal()

    def __init__(self, handler: Callable[[bool, object], None], parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.handler = handler
        self._cond = threading.Condition()
        self._job: Job | None = None  # the job to run next on the worker
        self._threads = 1  # and the compiled kernels' threads for it
        self._running = False
        self._result: tuple[bool, object] | None = None  # finished, not yet handed over
        self._pending: Job | None = None  # submitted while busy
        self._stopped = False
        self._finished.connect(self._deliver, QtCore.Qt.ConnectionType.QueuedConnection)
        self._thread = threading.Thread(target=self._loop, name="hybridedit-frames", daemon=True)
        self._thread.start()

    @property
    def busy(self) -> bool:
        """A job runs, waits, or its result has not been handed over yet."""
        with self._cond:
            return self._occupied() or self._pending is not None

    def _occupied(self) -> bool:
        """A job runs or waits to run, or its result is not handed over (call with the lock held)."""
        return self._running or self._job is not None or self._result is not None

    def submit(self, job: Job, *, beside_render: bool = False) -> None:
        """Run ``job`` now if the worker is free, else make it the pending job (replacing any).

        ``beside_render``: a render is due before the window needs this job's result (a frame
        was just handed over and is about to be drawn), so the job runs on one thread, as a
        pending job does; otherwise the window waits for it and it gets every core.
        """
        self._start(job, 1 if beside_render else ALL_THREADS)

    def _start(self, job: Job, threads: int) -> None:
        with self._cond:
            if self._stopped:
                return
            if self._occupied():
                self._pending = job
                return
            self._job, self._threads = job, threads
            self._cond.notify_all()

    def flush(self) -> None:
        """Finish the running and the pending job, handing each result to the handler (UI thread)."""
        while True:
            with self._cond:
                while self._running or self._job is not None:
                    self._cond.wait()
                idle = self._result is None and self._pending is None
            if idle:
                return
            self._deliver()

    def discard(self) -> None:
        """Drop the pending job, wait for the running one and drop its result too."""
        with self._cond:
            self._pending = None
            while self._running or self._job is not None:
                self._cond.wait()
            self._result = None

    def stop(self) -> None:
        """Discard everything and end the worker thread."""
        self.discard()
        with self._cond:
            self._stopped = True
            self._cond.notify_all()
        self._thread.join(timeout=5.0)

    # ------------------------------------------------------------------ internals
    def _loop(self) -> None:  # the worker thread
        try:  # yield the cores to the render's threads when both want them (Linux: per thread)
            os.setpriority(os.PRIO_PROCESS, threading.get_native_id(), NICE)
        except (AttributeError, OSError):
            pass
        while True:
            with self._cond:
                while self._job is None and not self._stopped:
                    self._cond.wait()
                if self._stopped:
                    return
                job, self._running = self._job, True
                self._job = None
                numba.set_num_threads(self._threads)  # (per thread: the rest of the program keeps its own)
            try:
                result = (True, job())
            except Exception as e:  # noqa: BLE001 -- handed to the UI thread, which reports it
                result = (False, e)
            with self._cond:
                self._result = result
                self._running = False
                self._cond.notify_all()
            self._finished.emit()

    def _deliver(self) -> None:  # the UI thread
        with self._cond:
            result, self._result = self._result, None  # (None: handed over already, by flush)
        try:
            if result is not None:
                self.handler(*result)
        finally:
            with self._cond:
                job, self._pending = self._pending, None
            if job is not None:
                self._start(job, 1)
