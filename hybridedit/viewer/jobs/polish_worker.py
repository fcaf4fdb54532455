"""Polish on release in a worker thread: full-resolution ARAP of the edited region, cancellable,
with the shape's factorized set-up kept for the next polish."""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass

import numpy as np
from qtpy import QtCore

from ...core.heap import trim_heap
from ...core.mesh import Mesh


class ShapeARAPHolder:
    """The full-resolution ARAP set-up of one loaded shape, built lazily by the first polish.

    Only one :class:`PolishWorker` uses it at a time (the window runs them one after the other).
    """

    def __init__(self, mesh: Mesh) -> None:
        self.mesh = mesh
        self.shape_arap = None
        self.build_seconds = 0.0

    def get(self):
        if self.shape_arap is None:
            from ...deform.polish import ShapeARAP

            t0 = time.perf_counter()
            self.shape_arap = ShapeARAP(self.mesh)
            self.build_seconds = time.perf_counter() - t0
        return self.shape_arap


@dataclass
class PolishRequest:
    """One polish: the engine's ``job`` (:class:`~hybridedit.deform.polish.PolishJob`: the start pose, the
    free vertices, the stopping rule), run with the shape's set-up in ``holder``.

    ``token`` identifies the request; the window drops a result whose token is stale.
    """

    holder: ShapeARAPHolder
    job: object  # hybridedit.deform.polish.PolishJob
    edges: np.ndarray
    token: int = 0

    @property
    def vertices(self) -> np.ndarray:
        """(n, 3) the pose polished."""
        return self.job.start


@dataclass
class PolishOutcome:
    request: PolishRequest
    result: object  # polish.PolishResult
    error_before: float  # relative RMS edge error in percent, hybrid pose
    error_after: float  # the same, polished pose
    setup_seconds: float  # ShapeARAP set-up and factorization for this free set
    seconds: float  # wall time of the whole job


class PolishWorker(QtCore.QThread):
    """Runs one :class:`PolishRequest` off the GUI thread.

    Signals
    -------
    succeeded(PolishOutcome)
    failed(error)   the exception the polish raised, with its traceback (the window says it, and
                    reports an unexpected one)
    cancelled()
    """

    succeeded = QtCore.Signal(object)
    failed = QtCore.Signal(object)
    cancelled = QtCore.Signal()

    def __init__(self, request: PolishRequest, parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.request = request
        self._cancel = threading.Event()

    def cancel(self) -> None:
        """Stop after the current iteration (or set-up step); the result is dropped."""
        self._cancel.set()

    @property
    def cancel_requested(self) -> bool:
        return self._cancel.is_set()

    def run(self) -> None:  # runs in the worker thread
        self._polish()
        # the polish's working arrays are freed now: handed back here (off the UI thread), else glibc
        # keeps them and its heap fragments release after release (a long session's resident set grew
        # 8% from cycle 150 to 300 of the soak, with what Python held flat)
        trim_heap()

    def _polish(self) -> None:
        from ...core.mesh import rrms_edge_error

        t0 = time.perf_counter()
        req = self.request
        try:
            sa = req.holder.get()
            if self._cancel.is_set():
                self.cancelled.emit()
                return
            sa.prepare(req.job.free)  # factor once per free set (cached by ShapeARAP)
            setup = time.perf_counter() - t0
            if self._cancel.is_set():
                self.cancelled.emit()
                return
            res = req.job.run(sa, should_stop=self._cancel.is_set)
            if self._cancel.is_set() or res.stopped == "cancelled":
                self.cancelled.emit()
                return
            rest = req.holder.mesh.vertices
            e0 = rrms_edge_error(rest, req.vertices, req.edges)
            e1 = rrms_edge_error(rest, res.vertices, req.edges)
        except MemoryError:
            self.failed.emit(MemoryError("not enough memory to polish this shape"))
        except Exception as e:  # noqa: BLE001 -- handed to the UI thread, which says (and reports) it
            self.failed.emit(e)
        else:
            self.succeeded.emit(PolishOutcome(req, res, e0, e1, setup, time.perf_counter() - t0))
