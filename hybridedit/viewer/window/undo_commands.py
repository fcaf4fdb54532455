"""Undo, redo and Reset Pose in the window (Edit menu); the history itself is the session's
(:class:`~..model.history.History`)."""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from .interfaces import Busy, RedrawsAll
from .slot_errors import guarded

if TYPE_CHECKING:
    from ..model.session import Session


@runtime_checkable
class Guard(Protocol):
    """The pose side as the history sees it (:class:`~.posing.Posing`)."""

    def settle_and_stop_polish(self) -> None: ...


@runtime_checkable
class Marks(Protocol):
    """The unsaved-pose mark as the history sees it: back to the saved pose, the title's ``*`` goes."""

    def set_modified(self, modified: bool) -> None: ...
    def pose_saved(self) -> bool: ...


@runtime_checkable
class Says(Protocol):
    """The status bar as the history sees it (and where an unexpected error goes: :func:`~.slot_errors.guarded`)."""

    def message(self, text: str) -> None: ...
    def show_error(self, title: str, text: str) -> None: ...


@runtime_checkable
class UndoHost(Protocol):
    """What :class:`UndoCommands` asks of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def controller(self) -> Busy: ...
    @property
    def posing(self) -> Guard: ...
    @property
    def unsaved(self) -> Marks: ...
    @property
    def sync(self) -> RedrawsAll: ...
    @property
    def status(self) -> Says: ...


class UndoCommands:
    """Edit ▸ Undo, Redo and Reset Pose of a :class:`~.main_window.MainWindow`: each one step of the
    session's history, after the guard, shown, and the unsaved mark set again.

    Parameters
    ----------
    window : the window, as far as the history commands need it (:class:`UndoHost`).
    """

    def __init__(self, window: UndoHost) -> None:
        self.w = window
        self._told = None  # (a weak reference to) the history whose dropped steps were told of

    def note_dropped(self) -> None:
        """Say once for each session, when its undo history first drops its oldest steps for room, that
        it is full (:class:`~..model.history.History`: at most its limit of steps and its memory budget)."""
        s = self.w.session
        h = None if s is None else s.history
        if h is None or not h.dropped or (self._told is not None and self._told() is h):
            return
        self._told = weakref.ref(h)
        budget = "" if h.budget is None else f", {h.budget / 2**20:.0f} MB"
        self.w.status.message(f"Undo history full (at most {h.limit} steps{budget}): the oldest {h.dropped} "
                              f"{'was' if h.dropped == 1 else 'were'} dropped, and older steps go as new ones come")

    def _ready(self) -> bool:
        """A shape and no gesture under way; the guard is passed."""
        w = self.w
        if w.session is None or w.controller.busy:
            return False
        w.posing.settle_and_stop_polish()
        return True

    def _shown(self, said: str) -> None:
        w = self.w
        w.unsaved.set_modified(not w.unsaved.pose_saved())
        w.sync.refresh_all()
        w.status.message(said)

    @guarded
    def undo(self) -> None:
        """Edit ▸ Undo: the session one step back (a selection, a drag, a polish, a rebuild, ...)."""
        if not self._ready():
            return
        s = self.w.session
        label = s.history.undo_label()
        if s.undo():
            self._shown(f"Undid: {label}")

    @guarded
    def redo(self) -> None:
        """Edit ▸ Redo."""
        if not self._ready():
            return
        s = self.w.session
        label = s.history.redo_label()
        if s.redo():
            self._shown(f"Redid: {label}")

    @guarded
    def reset_pose(self) -> None:
        """Edit ▸ Reset Pose: back to the rest pose, the selection kept (one undo step)."""
        if not self._ready():
            return
        self.w.session.reset_pose()
        self._shown("Back to the rest pose")
