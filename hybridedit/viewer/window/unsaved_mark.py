"""The unsaved-work mark: the title's ``*`` while the pose on display is not the one last saved (or
opened), or the kept poses (:mod:`..model.pose_library`) changed since they were last saved in an edit
file; and the title itself, which names the shape's file."""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
from qtpy import QtWidgets

from .interfaces import Named

if TYPE_CHECKING:
    from ..model.session import Session


@runtime_checkable
class MarkHost(Protocol):
    """What :class:`UnsavedMark` reads of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def files(self) -> Named: ...


class UnsavedMark:
    """Whether the pose on display and the kept poses are saved, and the window's title that shows it.

    The saved pose is remembered (the undo history's own copy when it has one), so that undo and
    redo back to it clear the ``*`` again; the kept poses say themselves whether they are saved
    (:attr:`~..model.pose_library.PoseLibrary.unsaved`).

    Parameters
    ----------
    window : the window, as far as the mark needs it (:class:`MarkHost`).
    parent : the main window whose title this is.

    Attributes
    ----------
    pose_modified : the pose on display is not saved.
    """

    def __init__(self, window: MarkHost, parent: QtWidgets.QWidget) -> None:
        self.w = window
        self.parent = parent
        self.pose_modified = False
        self._shown = False  # what the title shows
        self._saved_pose: np.ndarray | None = None  # the pose last saved or opened (see pose_saved)

    @property
    def modified(self) -> bool:
        """Work would be lost: the pose on display or the kept poses are not saved (the title's ``*``)."""
        return self.pose_modified or self.poses_unsaved()

    def poses_unsaved(self) -> bool:
        """The kept poses changed since they were last saved (or read from an edit file)."""
        s = self.w.session
        return s is not None and s.poses.unsaved

    def set_modified(self, modified: bool) -> None:
        """The pose on display is (not) saved; ``False`` also remembers it as the saved pose, so that undo and
        redo back to it clear the title's ``*`` again."""
        if not modified:
            self._saved_pose = self._pose_reference()
        self.pose_modified = bool(modified)
        self.poses_changed()

    def poses_changed(self) -> None:
        """The kept poses changed, or were saved: the title's ``*`` shows it."""
        if self.modified == self._shown:
            return  # (every drag frame says so: no window-title event each time)
        self._shown = self.modified
        self.parent.setWindowModified(self._shown)

    def _pose_reference(self) -> np.ndarray | None:
        """The pose on display, as an array to compare with later: the undo history's own copy of it when it
        has one (no copy made), else a copy."""
        s = self.w.session
        if s is None:
            return None
        shown = s.shown_positions
        kept = getattr(getattr(s.history.current, "engine", None), "shape", None)
        return kept if kept is not None and np.array_equal(kept, shown) else shown.copy()

    def pose_saved(self) -> bool:
        """The pose on display is the one last saved (or opened)."""
        s, ref = self.w.session, self._saved_pose
        return s is not None and ref is not None and ref.shape == s.shown_positions.shape and \
            np.array_equal(ref, s.shown_positions)

    def update_title(self) -> None:
        """The title names the shape's file (the one last saved to by Save As, else the one opened), with
        ``*`` while the pose on display is not saved."""
        name = self.w.files.document_name
        self.parent.setWindowTitle("hybridedit" if name is None else f"hybridedit — {name}[*]")
        self._shown = self.modified
        self.parent.setWindowModified(self._shown)
