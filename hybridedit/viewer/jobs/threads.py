"""Letting a worker thread that has finished go (the build and the polish workers alike)."""

from __future__ import annotations

from qtpy import QtCore


def release(thread: QtCore.QThread | None) -> None:
    """Let a worker thread that has finished go: wait for its run to return, then delete it from
    the event loop."""
    if thread is not None:
        thread.wait()
        thread.deleteLater()
