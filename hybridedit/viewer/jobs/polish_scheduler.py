"""Polish on release: scheduling full-resolution ARAP of the edited region in background threads.

One :class:`~.polish_worker.PolishWorker` runs at a time (they share the shape's
factorized set-up); a newer request cancels the running one and waits in a
queue of one. A result is only delivered while it is current: anything that
changes the pose calls :meth:`PolishScheduler.cancel`, which makes every
earlier request stale.
"""

from __future__ import annotations

from qtpy import QtCore

from ...defaults import POLISH_MAX_ITERATIONS, POLISH_TOLERANCE
from ..model.session import Session
from .polish_worker import PolishOutcome, PolishRequest, PolishWorker, ShapeARAPHolder
from .threads import release


class PolishScheduler(QtCore.QObject):
    """Starts, queues, cancels polishes and delivers current results.

    Signals
    -------
    started()                  a polish thread started
    succeeded(PolishOutcome)   a current result (stale ones are dropped)
    failed(error)              the exception a polish raised (its result is dropped: nothing is adopted)
    """

    started = QtCore.Signal()
    succeeded = QtCore.Signal(object)
    failed = QtCore.Signal(object)

    def __init__(self, parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.enabled = True
        # the stopping rule, never the clock: the edit file records the iterations run, and a replay
        # runs exactly those (hybridedit deform gives the window's pose on any machine)
        self.iterations = POLISH_MAX_ITERATIONS
        self.tolerance = POLISH_TOLERANCE
        self.worker: PolishWorker | None = None
        self.holder: ShapeARAPHolder | None = None
        self._next: PolishRequest | None = None
        self._token = 0
        self._session: Session | None = None

    @property
    def busy(self) -> bool:
        return self.worker is not None

    def start(self, session: Session) -> bool:
        """Polish the session's (engine) pose in the background; False when there is nothing to polish."""
        if not self.enabled:
            return False
        job = session.polish_job(max_iterations=self.iterations, tolerance=self.tolerance)
        if job is None:
            return False
        if self.holder is None or self.holder.mesh is not session.mesh:
            self.holder = ShapeARAPHolder(session.mesh)  # built by the shape's first polish
        self._token += 1
        self._session = session
        req = PolishRequest(self.holder, job, session.edges, token=self._token)
        if self.worker is not None:  # one at a time: queue it
            self.worker.cancel()
            self._next = req
        else:
            self._launch(req)
        return True

    def _launch(self, req: PolishRequest) -> None:
        w = PolishWorker(req, self)
        w.succeeded.connect(self._succeeded)
        w.failed.connect(self.failed)
        w.finished.connect(self._finished)
        self.worker = w
        w.start()
        self.started.emit()

    def cancel(self) -> None:
        """Stop a polish under way (or queued); its result will be dropped."""
        self._token += 1
        self._next = None
        if self.worker is not None:
            self.worker.cancel()

    def wait(self, ms: int = 30000) -> None:
        """Cancel and wait for the thread to end (before closing)."""
        self.cancel()
        if self.worker is not None:
            self.worker.wait(ms)

    def forget_shape(self) -> None:
        """A new shape is loaded: its full-resolution set-up is built by its first polish."""
        self.cancel()
        self.holder = None

    def _succeeded(self, out: PolishOutcome) -> None:
        s = self._session
        current = (out.request.token == self._token and s is not None and not s.settling
                   and out.request.holder is self.holder and s.mesh is out.request.holder.mesh)
        if current:
            self.succeeded.emit(out)

    def _finished(self) -> None:
        w, self.worker = self.worker, None
        release(w)
        req, self._next = self._next, None
        if req is not None and req.token == self._token:
            self._launch(req)
