"""Posing in the window: the drag gestures the view controller reports (run by
:class:`~..input.drags.DragFrames`), the settle after a drag, the polish on release and its result, and
the one guard before anything changes the pose or the selection (:meth:`PosingMixin.settle_and_stop_polish`).
"""

from __future__ import annotations

import numpy as np
from qtpy import QtCore

from ..input.frame_thread import FrameThread
from ..jobs.polish_worker import PolishOutcome


class PosingMixin:
    """The pose side of a :class:`~.main_window.MainWindow` (a mixin): it hands drags to ``dragging``, polish
    to ``polisher``, and shows their results (``_refresh_pose``, ``measure``, the status bar).

    Attributes
    ----------
    settle_on_release : Edit ▸ Settle on Release (each new session takes it).
    last_polish : the latest polish shown (:class:`~..jobs.polish_worker.PolishOutcome`), or None.
    """

    # cage_points and handle_center complete the settle only, not the guard: they read the pose and change
    # nothing (cage_points also runs on every mouse move in Select mode, to draw the points near the cursor,
    # which must not stop a polish); a gesture cancels the polish when it begins (begin_select, begin_drag)
    def cage_points(self) -> np.ndarray | None:
        """(c, 3) the cage's pose (a settle under way is completed first), or None without a shape."""
        self.finish_settle()
        return None if self.session is None else self.session.cage_positions

    def handle_center(self) -> np.ndarray | None:
        """(3,) the active handle group's centroid (where the gizmo is), or None."""
        self.finish_settle()
        return None if self.session is None else self.session.handle_centroid()

    # ------------------------------------------------------------------ drags (called by the view controller)
    def begin_drag(self) -> bool:
        """A drag gesture begins (:meth:`~..input.drags.DragFrames.begin`); False: nothing to drag (said why)."""
        return self.dragging.begin()

    def drag(self, D: np.ndarray) -> None:
        """The handle's (4, 4) transform ``D`` since the drag began."""
        self.dragging.move(D)

    def end_drag(self) -> None:
        """The button was released: the settle in slices when it is on, then :meth:`after_drag`."""
        self.dragging.end()

    @property
    def frames(self) -> FrameThread:
        """The drag frames' thread."""
        return self.dragging.frames

    @property
    def settle_timer(self) -> QtCore.QTimer:
        """The timer that settles the pose in slices after a drag."""
        return self.dragging.settle_timer

    def finish_settle(self) -> None:
        """Complete a drag frame or a settle under way now (before anything reads or changes the pose)."""
        self.dragging.finish()

    def settle_and_stop_polish(self) -> None:
        """The guard before anything that changes the pose or the selection (undo, a gesture, an edit file, ...).

        Completes a drag frame or a settle under way (:meth:`finish_settle`; a settle completed here shows
        its pose and may start a polish), then cancels any polish running or queued: its result would be
        of a pose or a selection that is gone. The places that do only one of the two say why.
        """
        self.finish_settle()
        self.polisher.cancel()

    def after_drag(self) -> None:
        """A drag ended and settled: show the final pose, and polish it when that is on."""
        self._refresh_pose()
        self._update_actions()
        if self.session is not None and self.polisher.start(self.session):
            self.status.show_polishing()

    def _toggle_settle(self) -> None:
        self.settle_on_release = self.actions_["settle"].isChecked()
        if self.session is not None:
            self.session.settle_on_release = self.settle_on_release

    # ------------------------------------------------------------------ polish on release (worker thread)
    @property
    def polished(self) -> np.ndarray | None:
        """The polished pose on display, (n, 3), or None."""
        return None if self.session is None else self.session.polished

    def drop_polished(self) -> None:
        """A drag starts: the pose on display (polished or not, the engine's own) is no longer called polished."""
        s = self.session
        if s is not None:
            s.polished = None

    def _toggle_polish(self) -> None:
        self.polisher.enabled = self.actions_["polish"].isChecked()
        if not self.polisher.enabled:
            # the polish only: switching it off changes neither the pose nor the selection, so a settle
            # under way goes on
            self.polisher.cancel()

    def _polish_succeeded(self, out: PolishOutcome) -> None:
        s = self.session
        if s is None:
            return
        self.last_polish = out
        s.adopt_polish(out.request.job, out.result)  # the engine's pose from now on: the next edit starts from it
        self.scene.update_shape(s.shown_positions, everything=True)
        self._pose_shown_changed()
        self.view.request_render()
        r = out.result
        self._update_actions()
        self.status.message(f"polished: {r.iterations} iterations, edge error {out.error_before:.2f}% → "
                     f"{out.error_after:.2f}% ({out.seconds:.2f} s); Ctrl+Z undoes the polish")
