"""The pose in the window after a drag: the one guard before anything changes the pose or the
selection (:meth:`Posing.settle_and_stop_polish`), the settle on release, the polish on release and
its result on display.

The drags themselves, frame by frame, are :class:`~..input.drags.DragFrames`'.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from ..model.crash_reports import describe, is_crash
from .interfaces import ActionChecks

if TYPE_CHECKING:
    from pathlib import Path

    from ..jobs.polish_worker import PolishOutcome
    from ..model.session import Session


@runtime_checkable
class Finishes(Protocol):
    """The drags as the pose side sees them: a frame or a settle under way completed now."""

    def finish(self) -> None: ...


@runtime_checkable
class Polisher(Protocol):
    """The polish scheduler as the pose side sees it (:class:`~..jobs.polish_scheduler.PolishScheduler`)."""

    enabled: bool
    def start(self, session: Session) -> bool: ...
    def cancel(self) -> None: ...


@runtime_checkable
class Redraws(Protocol):
    """The scene's upkeep as the pose side sees it (:class:`~.scene_sync.SceneSync`)."""

    def refresh_pose(self) -> None: ...
    def show_shape(self) -> None: ...
    def refresh_all(self) -> None: ...


@runtime_checkable
class Says(Protocol):
    """The status bar as the pose side sees it (a polish that failed unexpectedly reported)."""

    def message(self, text: str) -> None: ...
    def show_polishing(self) -> None: ...
    def report_crash(self, error: BaseException, *, what: str, context: str, kept: str | None = None,
                     details: dict | None = None) -> Path | None: ...


@runtime_checkable
class PosingHost(Protocol):
    """What :class:`Posing` asks of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def dragging(self) -> Finishes: ...
    @property
    def polisher(self) -> Polisher: ...
    @property
    def sync(self) -> Redraws: ...
    @property
    def status(self) -> Says: ...
    @property
    def actions_(self) -> ActionChecks: ...


class Posing:
    """The pose side of a :class:`~.main_window.MainWindow`: the guard, what follows a drag (the final
    pose shown, a polish started), the polish's result adopted and shown (or its failure said, the
    settled pose kept), and Edit ▸ Settle / Polish on Release.

    Parameters
    ----------
    window : the window, as far as the pose side needs it (:class:`PosingHost`).

    Attributes
    ----------
    settle_on_release : Edit ▸ Settle on Release (each new session takes it).
    last_polish : the latest polish shown (:class:`~..jobs.polish_worker.PolishOutcome`), or None.
    """

    def __init__(self, window: PosingHost) -> None:
        self.w = window
        self.settle_on_release = True
        self.last_polish: PolishOutcome | None = None

    def finish_settle(self) -> None:
        """Complete a drag frame or a settle under way now (before anything reads or changes the pose)."""
        self.w.dragging.finish()

    def settle_and_stop_polish(self) -> None:
        """The guard before anything that changes the pose or the selection (undo, a gesture, an edit file, ...).

        Completes a drag frame or a settle under way (:meth:`finish_settle`; a settle completed here shows
        its pose and may start a polish), then cancels any polish running or queued: its result would be
        of a pose or a selection that is gone. The places that do only one of the two say why.
        """
        self.finish_settle()
        self.w.polisher.cancel()

    def after_drag(self) -> None:
        """A drag ended and settled: show the final pose, and polish it when that is on."""
        w = self.w
        w.sync.refresh_pose()
        w.actions_.refresh()
        if w.session is not None and w.polisher.start(w.session):
            w.status.show_polishing()

    def toggle_settle(self) -> None:
        """Edit ▸ Settle on Release, for this session and the next ones."""
        w = self.w
        self.settle_on_release = w.actions_["settle"].isChecked()
        if w.session is not None:
            w.session.settle_on_release = self.settle_on_release

    # ------------------------------------------------------------------ polish on release (worker thread)
    @property
    def polished(self) -> np.ndarray | None:
        """The polished pose on display, (n, 3), or None."""
        s = self.w.session
        return None if s is None else s.polished

    def drop_polished(self) -> None:
        """A drag starts: the pose on display (polished or not, the engine's own) is no longer called polished."""
        s = self.w.session
        if s is not None:
            s.polished = None

    def toggle_polish(self) -> None:
        """Edit ▸ Polish on Release."""
        w = self.w
        w.polisher.enabled = w.actions_["polish"].isChecked()
        if not w.polisher.enabled:
            # the polish only: switching it off changes neither the pose nor the selection, so a settle
            # under way goes on
            w.polisher.cancel()

    def show_polish(self, out: PolishOutcome) -> None:
        """A current polish result: the engine's pose from now on (the next edit starts from it), shown."""
        w = self.w
        s = w.session
        if s is None:
            return
        try:
            s.adopt_polish(out.request.job, out.result)
        except Exception as e:  # noqa: BLE001 -- the settled pose (the history's current step) comes back
            s.cancel_drag()
            w.sync.refresh_all()
            self.polish_failed(e)
            return
        self.last_polish = out
        w.sync.show_shape()
        r = out.result
        w.actions_.refresh()
        w.status.message(f"polished: {r.iterations} iterations, edge error {out.error_before:.2f}% → "
                         f"{out.error_after:.2f}% ({out.seconds:.2f} s); Ctrl+Z undoes the polish")

    def polish_failed(self, error: BaseException) -> None:
        """A polish raised ``error`` (on its thread): it is dropped, nothing of it adopted, and the pose on
        display stays the settled one; said in one line, an unexpected error with its crash report."""
        if is_crash(error):
            self.w.status.report_crash(error, what="The polish failed", context="polish",
                                       kept="the settled pose is kept")
        else:
            self.w.status.message(f"Polish failed: {describe(error, named=False)}; the settled pose is kept.")
