"""Shapes coming into the window: opening a file or a mesh, rebuilding the cage, the new shape shown
while its cage and binding are built, and a finished build installed as the session on display.

The builds themselves run in :mod:`..jobs.build_jobs`'s worker thread.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

from ...deform.selection import SelectionError
from ..model.session import Session
from .slot_errors import guarded
from ..jobs.build_worker import BuildResult, BuildWorker

if TYPE_CHECKING:
    from ...core.mesh import Mesh


class LoadingMixin:
    """The shape loading of a :class:`~.main_window.MainWindow` (a mixin): it starts builds (``jobs``) and,
    when one finishes, makes or updates the ``session`` and shows it (``_show_engine``)."""

    @property
    def worker(self) -> BuildWorker | None:
        """The cage and binding build running now, or None."""
        return self.jobs.worker

    @guarded
    def open_path(self, path: str | os.PathLike) -> bool:
        """Read a mesh and build its cage and binding in the worker thread (asks first if the pose is unsaved)."""
        return self.jobs.open_file(path)

    def open_mesh(self, mesh: Mesh, path: Path | None = None) -> bool:
        """Build an already loaded shape (used by tests and scripts)."""
        return self.jobs.open_mesh(mesh, path)

    @guarded
    def rebuild(self) -> bool:
        """Build the cage and binding again at the toolbar's size; selection, pose and undo history carry over."""
        return self.jobs.rebuild()

    def cancel_job(self) -> None:
        """Cancel the cage and binding build under way; the shape on display stays."""
        self.jobs.cancel()

    # ------------------------------------------------------------------ while a new shape is built
    def preview_shape(self, mesh: Mesh, look, up: tuple[str, bool, str]) -> None:
        """A new shape is read: show it at once, plain, its up axis up, while its cage and binding are built.
        The camera works on it; editing waits for the build. The shape on display before is put aside,
        and comes back if the build is cancelled or fails."""
        if self._aside is None:
            self._aside = (self.session,)
        self._previewed = mesh
        self.controller.cancel()
        self.session = None
        self.scene.up_axis = up[0]
        self.scene.show_preview(mesh.vertices, mesh.faces)
        self.status.show_building(mesh.n_vertices, mesh.n_faces)
        self._update_actions()
        self.view.request_render()
        self.status.message("The shape is read: turn it and look while its cage and binding are built; editing starts "
                     "when they are done.")

    def end_preview(self) -> None:
        """The build shown by :meth:`preview_shape` did not finish: the shape on display before is back."""
        if self._aside is None:
            return
        (s,), self._aside = self._aside, None
        self._previewed = None
        self.session = s
        if s is not None:
            self._show_engine()
        else:
            self.scene.clear()
            self.status.show_session()
            self.view.request_render()
        self._update_actions()

    # ------------------------------------------------------------------ a finished build
    def install_build(self, result: BuildResult) -> tuple[bool, str | None]:
        """Show a finished build: a new session for a new shape, or the edit carried over to the new cage.

        Returns
        -------
        rebuilt : the build was a new cage for the shape being edited.
        note : what carrying the edit over said (rebuilds), or why Mirror is off for a new shape, or None.
        """
        req = result.request
        self.controller.cancel()
        self.settle_and_stop_polish()
        # a settle the session completed by itself leaves the timer running: its tick would show (and polish)
        # the pose after the build is on display
        self.settle_timer.stop()
        self._aside = None  # (a shape put aside for this one's preview: replaced)
        if req.rebuild and self.session is not None and self.session.mesh is result.mesh:
            note = self.session.adopt(result.editor, req.cage_size)
            rebuilt = True
        else:
            note = self._install_new_shape(result)
            rebuilt = False
        self.session.settle_on_release = self.settle_on_release
        self.last_polish = None
        previewed, self._previewed = self._previewed, None
        self._show_engine()
        if not rebuilt and result.mesh is not previewed:  # (a shape shown while built keeps the user's camera)
            self.scene.reset_camera()
        self.unsaved.update_title()
        self._update_actions()
        return rebuilt, note

    def _install_new_shape(self, result: BuildResult) -> str | None:
        """The session of a newly opened shape, with what its file says it looks like and which way is up;
        returns a note for the status bar (Mirror off, what the look could not show), or None."""
        session, note = self._new_session(result.editor, result.request, result.metrics)
        session.look = result.look  # what the file says the shape looks like (None: plain)
        if result.up is not None:  # which way is up: remembered for this shape, or guessed
            session.up_axis, _, session.shape_key = result.up
        if result.look is not None and result.look.notes:
            note = "; ".join(([note] if note else []) + result.look.notes)
        self.session = session
        self.polisher.forget_shape()
        self.files.forget_paths()
        self.unsaved.set_modified(False)
        return note

    def _new_session(self, ed, req, metrics=None) -> tuple[Session, str | None]:
        """A session for a newly opened shape (``metrics``: its view's index sets, when the build made
        them), mirrored as the Mode menu says when the shape allows it; and a sentence when it does not."""
        axis = next((a for a in "xyz" if self.actions_[f"mirror_{a}"].isChecked()), None)
        if axis is not None:
            try:
                return Session(ed, path=req.path, cage_size=req.cage_size, symmetry=axis, metrics=metrics), None
            except SelectionError as e:
                self.actions_[f"mirror_{axis}"].setChecked(False)
                return (Session(ed, path=req.path, cage_size=req.cage_size, metrics=metrics),
                        f"Mirror {axis.upper()} is off: {e}")
        return Session(ed, path=req.path, cage_size=req.cage_size, metrics=metrics), None
