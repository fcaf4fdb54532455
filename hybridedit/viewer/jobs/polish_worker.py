"""Polish on release in a worker thread (:func:`..model.polishing.polish`, cancellable)."""

from __future__ import annotations

import threading

from qtpy import QtCore

from ...core.heap import trim_heap
from ..model.polishing import PolishOutcome, PolishRequest, ShapeARAPHolder, polish

__all__ = ["PolishOutcome", "PolishRequest", "PolishWorker", "ShapeARAPHolder"]


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
        try:
            out = polish(self.request, self._cancel.is_set)
        except Exception as e:  # noqa: BLE001 -- handed to the UI thread, which says (and reports) it
            self.failed.emit(e)
        else:
            if out is None:
                self.cancelled.emit()
            else:
                self.succeeded.emit(out)
