"""Shapes coming into the window: opening a file or a mesh, rebuilding the cage, the new shape shown
while its cage and binding are built, and a finished build installed as the session on display.

The builds themselves run in :mod:`..jobs.build_jobs`'s worker thread.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Protocol, runtime_checkable

from qtpy import QtCore

from ...deform.selection import SelectionError
from ..model.session import Session
from .file_check import why_unopenable
from .interfaces import ActionChecks, Cancels, Renders
from .slot_errors import guarded

if TYPE_CHECKING:
    from ...core.mesh import Mesh
    from ..jobs.build_worker import BuildResult
    from ..render.scene import Scene


@runtime_checkable
class Builds(Protocol):
    """The build jobs as the loading sees them (:class:`~..jobs.build_jobs.BuildJobs`)."""

    def open_file(self, path: str | os.PathLike) -> bool: ...
    def open_mesh(self, mesh: Mesh, path: Path | None = None) -> bool: ...
    def rebuild(self) -> bool: ...
    def cancel(self) -> None: ...


@runtime_checkable
class PoseSide(Protocol):
    """The pose side as the loading sees it (:class:`~.posing.Posing`)."""

    settle_on_release: bool
    last_polish: object
    def settle_and_stop_polish(self) -> None: ...


@runtime_checkable
class SettleTimer(Protocol):
    """The drags as the loading sees them: the timer that settles a released drag in slices."""

    @property
    def settle_timer(self) -> QtCore.QTimer: ...


@runtime_checkable
class ForgetsShape(Protocol):
    """The polish scheduler as the loading sees it: a new shape, a new full-resolution set-up."""

    def forget_shape(self) -> None: ...


@runtime_checkable
class ForgetsPaths(Protocol):
    """The file actions as the loading sees them: a new shape, nothing saved yet."""

    def forget_paths(self) -> None: ...


@runtime_checkable
class Marks(Protocol):
    """The unsaved-pose mark and the title."""

    def set_modified(self, modified: bool) -> None: ...
    def update_title(self) -> None: ...


@runtime_checkable
class Redraws(Protocol):
    """The scene's upkeep as the loading sees it: the scene built for the session's engine."""

    def show_engine(self) -> None: ...


@runtime_checkable
class Says(Protocol):
    """The status bar as the loading sees it (and where an unexpected error goes: :func:`~.slot_errors.guarded`)."""

    def message(self, text: str) -> None: ...
    def show_error(self, title: str, text: str) -> None: ...
    def show_building(self, n_vertices: int, n_faces: int) -> None: ...
    def show_session(self) -> None: ...


@runtime_checkable
class Recovers(Protocol):
    """The autosave as the loading sees it (:class:`~.autosave.Autosave`): a build is on display."""

    def shape_installed(self, rebuilt: bool) -> None: ...


@runtime_checkable
class LoadingHost(Protocol):
    """What :class:`ShapeLoading` asks of the window (:class:`~.main_window.MainWindow`)."""

    session: Session | None
    @property
    def jobs(self) -> Builds: ...
    @property
    def controller(self) -> Cancels: ...
    @property
    def posing(self) -> PoseSide: ...
    @property
    def dragging(self) -> SettleTimer: ...
    @property
    def polisher(self) -> ForgetsShape: ...
    @property
    def files(self) -> ForgetsPaths: ...
    @property
    def unsaved(self) -> Marks: ...
    @property
    def sync(self) -> Redraws: ...
    @property
    def scene(self) -> Scene: ...
    @property
    def view(self) -> Renders: ...
    @property
    def status(self) -> Says: ...
    @property
    def actions_(self) -> ActionChecks: ...
    @property
    def autosave(self) -> Recovers: ...


class ShapeLoading:
    """The shapes of a :class:`~.main_window.MainWindow`: it starts builds (``jobs``) and, when one
    finishes, makes or updates the window's ``session`` and shows it; while a new shape is built it
    shows it, and puts the one before back when the build does not finish.

    Parameters
    ----------
    window : the window, as far as loading needs it (:class:`LoadingHost`); it sets ``window.session``.
    """

    def __init__(self, window: LoadingHost) -> None:
        self.w = window
        #: while a new shape read is shown and its cage is built: (the session put aside,) (see preview_shape)
        self._aside: tuple[Session | None] | None = None
        self._previewed: Mesh | None = None  # the shape shown by preview_shape

    @guarded
    def open_path(self, path: str | os.PathLike) -> bool:
        """Read a mesh and build its cage and binding in the worker thread (asks first if the pose is unsaved).

        A file that cannot be opened is refused first, in one line, with nothing asked and the shape on
        display kept (:func:`~.file_check.why_unopenable`)."""
        refusal = why_unopenable(path)
        if refusal is not None:
            self.w.status.show_error("Could not open the mesh", refusal)
            return False
        return self.w.jobs.open_file(path)

    def open_mesh(self, mesh: Mesh, path: Path | None = None) -> bool:
        """Build an already loaded shape (used by tests and scripts)."""
        return self.w.jobs.open_mesh(mesh, path)

    @guarded
    def rebuild(self) -> bool:
        """Build the cage and binding again at the toolbar's size; selection, pose and undo history carry over."""
        return self.w.jobs.rebuild()

    def cancel_job(self) -> None:
        """Cancel the cage and binding build under way; the shape on display stays."""
        self.w.jobs.cancel()

    # ------------------------------------------------------------------ while a new shape is built
    def preview_shape(self, mesh: Mesh, look, up: tuple[str, bool, str]) -> None:
        """A new shape is read: show it at once, plain, its up axis up, while its cage and binding are built.
        The camera works on it; editing waits for the build. The shape on display before is put aside,
        and comes back if the build is cancelled or fails."""
        w = self.w
        if self._aside is None:
            self._aside = (w.session,)
        self._previewed = mesh
        w.controller.cancel()
        w.session = None
        w.scene.up_axis = up[0]
        w.scene.show_preview(mesh.vertices, mesh.faces)
        w.status.show_building(mesh.n_vertices, mesh.n_faces)
        w.actions_.refresh()
        w.view.request_render()
        w.status.message("The shape is read: turn it and look while its cage and binding are built; editing "
                         "starts when they are done.")

    def end_preview(self) -> None:
        """The build shown by :meth:`preview_shape` did not finish: the shape on display before is back."""
        w = self.w
        if self._aside is None:
            return
        (s,), self._aside = self._aside, None
        self._previewed = None
        w.session = s
        if s is not None:
            w.sync.show_engine()
        else:
            w.scene.clear()
            w.status.show_session()
            w.view.request_render()
        w.actions_.refresh()

    # ------------------------------------------------------------------ a finished build
    def install_build(self, result: BuildResult) -> tuple[bool, str | None]:
        """Show a finished build: a new session for a new shape, or the edit carried over to the new cage.

        Returns
        -------
        rebuilt : the build was a new cage for the shape being edited.
        note : what carrying the edit over said (rebuilds), or why Mirror is off for a new shape, or None.
        """
        w = self.w
        req = result.request
        w.controller.cancel()
        w.posing.settle_and_stop_polish()
        # a settle the session completed by itself leaves the timer running: its tick would show (and polish)
        # the pose after the build is on display
        w.dragging.settle_timer.stop()
        self._aside = None  # (a shape put aside for this one's preview: replaced)
        if req.rebuild and w.session is not None and w.session.mesh is result.mesh:
            note = w.session.adopt(result.editor, req.cage_size)
            rebuilt = True
        else:
            note = self._install_new_shape(result)
            rebuilt = False
        w.session.settle_on_release = w.posing.settle_on_release
        w.posing.last_polish = None
        previewed, self._previewed = self._previewed, None
        w.sync.show_engine()
        if not rebuilt and result.mesh is not previewed:  # (a shape shown while built keeps the user's camera)
            w.scene.reset_camera()
        w.unsaved.update_title()
        w.actions_.refresh()
        w.autosave.shape_installed(rebuilt)
        return rebuilt, note

    def _install_new_shape(self, result: BuildResult) -> str | None:
        """The session of a newly opened shape, with what its file says it looks like and which way is up;
        returns a note for the status bar (Mirror off, what the look could not show), or None."""
        w = self.w
        session, note = self._new_session(result.editor, result.request, result.metrics)
        session.look = result.look  # what the file says the shape looks like (None: plain)
        if result.up is not None:  # which way is up: remembered for this shape, or guessed
            session.up_axis, _, session.shape_key = result.up
        if result.look is not None and result.look.notes:
            note = "; ".join(([note] if note else []) + result.look.notes)
        w.session = session
        w.polisher.forget_shape()
        w.files.forget_paths()
        w.unsaved.set_modified(False)
        return note

    def _new_session(self, ed, req, metrics=None) -> tuple[Session, str | None]:
        """A session for a newly opened shape (``metrics``: its view's index sets, when the build made
        them), mirrored as the Mode menu says when the shape allows it; and a sentence when it does not."""
        actions = self.w.actions_
        axis = next((a for a in "xyz" if actions[f"mirror_{a}"].isChecked()), None)
        if axis is not None:
            try:
                return Session(ed, path=req.path, cage_size=req.cage_size, symmetry=axis, metrics=metrics), None
            except SelectionError as e:
                actions[f"mirror_{axis}"].setChecked(False)
                return (Session(ed, path=req.path, cage_size=req.cage_size, metrics=metrics),
                        f"Mirror {axis.upper()} is off: {e}")
        return Session(ed, path=req.path, cage_size=req.cage_size, metrics=metrics), None
