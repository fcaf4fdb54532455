"""The small interfaces that several of the window's collaborators see one another through.

Each collaborator's module declares the rest of what it needs of the window itself; these are the
ones that read the same from every side.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from qtpy import QtGui


@runtime_checkable
class ActionChecks(Protocol):
    """The window's actions (:class:`~.actions.ActionSet`): one by name (to read or set its check),
    and all of them enabled and checked again as the session is now."""

    def __getitem__(self, name: str) -> QtGui.QAction: ...
    def refresh(self) -> None: ...


@runtime_checkable
class Busy(Protocol):
    """Something that may be under way: a gesture, a build, a polish."""

    @property
    def busy(self) -> bool: ...


@runtime_checkable
class Cancels(Protocol):
    """Something under way that can be stopped: a gesture, a polish."""

    def cancel(self) -> None: ...


@runtime_checkable
class Renders(Protocol):
    """The 3D view, asked for a frame."""

    def request_render(self) -> None: ...


@runtime_checkable
class Named(Protocol):
    """The file actions (:class:`~.file_actions.FileActions`): the name the shape goes by."""

    @property
    def document_name(self) -> str | None: ...


@runtime_checkable
class RedrawsAll(Protocol):
    """The scene's upkeep (:class:`~.scene_sync.SceneSync`): the session's whole state shown again."""

    def refresh_all(self) -> None: ...
