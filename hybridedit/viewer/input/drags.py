"""Dragging the handle in the window: a drag's frames, from the mouse to the screen, and its settle.

Each mouse move becomes a handle transform; its frame (the engine's solve, the
moving region's points, normals and edge error) is computed on the frame
thread (:mod:`.frame_thread`) beside the render of the previous one, and the
finished frame is copied into VTK's buffers on the UI thread and rendered. On
release the engine settles in short slices on the UI thread's timer (the last
interactive frame stays on screen meanwhile), then the window shows the final
pose and may start a polish.

:class:`DragFrames` draws through the scene and the view it is given, and asks
the rest of the window only what :class:`DragHost` names.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
from qtpy import QtCore

from ...deform.selection import SelectionError
from ..model.crash_reports import describe, is_crash
from .frame_thread import DragFrame, FrameThread, Job

if TYPE_CHECKING:
    from pathlib import Path

    from .mouse_gestures import Gesture
    from ..render.scene import Scene
    from ..model.session import Session
    from ..render.view import View

ERROR_INTERVAL = 0.25
"""Seconds between edge-error measurements during a drag (each walks the moving region's edges)."""
SETTLE_SLICE = 0.015
"""Seconds of settling per timer tick after a release, so the window stays responsive."""


@runtime_checkable
class GestureHolder(Protocol):
    """The view controller as a drag sees it: a failed frame ends the gesture under way."""

    gesture: Gesture | None


@runtime_checkable
class Says(Protocol):
    """The status bar as a drag sees it: an error (an unexpected one reported), or the message on show
    made out of date."""

    def show_error(self, title: str, text: str) -> None: ...
    def report_crash(self, error: BaseException, *, what: str, context: str, kept: str | None = None,
                     details: dict | None = None) -> Path | None: ...
    def clear_message(self) -> None: ...


@runtime_checkable
class Marks(Protocol):
    """The unsaved-pose mark as a drag sees it: a drag frame makes the pose unsaved."""

    def set_modified(self, modified: bool) -> None: ...


@runtime_checkable
class PoseSide(Protocol):
    """The window's pose side as a drag sees it (:class:`~..window.posing.Posing`): the guard before a
    drag, and what follows one."""

    def settle_and_stop_polish(self) -> None: ...
    def drop_polished(self) -> None: ...
    def after_drag(self) -> None: ...


@runtime_checkable
class Redraws(Protocol):
    """The scene's upkeep as a drag sees it (:class:`~..window.scene_sync.SceneSync`)."""

    def measure(self, everything: bool | None = None) -> None: ...
    def refresh_all(self) -> None: ...


@runtime_checkable
class DragHost(Protocol):
    """What :class:`DragFrames` asks of the window (:class:`~..window.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def controller(self) -> GestureHolder: ...
    @property
    def posing(self) -> PoseSide: ...
    @property
    def sync(self) -> Redraws: ...
    @property
    def status(self) -> Says: ...
    @property
    def unsaved(self) -> Marks: ...


class DragFrames(QtCore.QObject):
    """The drags of a :class:`~..window.main_window.MainWindow`, frame by frame.

    Parameters
    ----------
    window : the window, as far as a drag needs it (:class:`DragHost`).
    scene : the actors a frame is written into.
    view : the 3D view that renders the frames.
    parent : the Qt parent (the window).

    Attributes
    ----------
    frames : the frame thread (:class:`~.frame_thread.FrameThread`).
    settle_timer : the timer that settles the pose in slices after a release.
    engine_ms : the engine's solve in the latest frame, milliseconds (0 before the first).
    thread_ms : all the frame thread did for the latest frame (the solve, the moving region's points,
        normals and edge error, the cage's normals), milliseconds (0 before the first).
    error : the latest frame's edge error in percent, not yet shown (the status tick shows it
        a few times a second; a label repaint every frame costs), or None.
    """

    def __init__(self, window: DragHost, scene: Scene, view: View,
                 parent: QtCore.QObject | None = None) -> None:
        super().__init__(parent)
        self.w = window
        self.scene = scene
        self.view = view
        self.frames = FrameThread(self._show, self)
        self.settle_timer = QtCore.QTimer(self)
        self.settle_timer.setInterval(0)
        self.settle_timer.timeout.connect(self._settle_tick)
        self.engine_ms = 0.0
        self.thread_ms = 0.0
        #: when the latest drag frame was shown (``time.perf_counter()``; 0 before the first)
        self.frame_shown_at = 0.0
        self.error: float | None = None
        self._T0 = np.eye(4)  # the handle's transform when the drag began
        self._failed = False  # a frame of this drag failed (the drag was undone)
        self._error_time = 0.0  # when a frame last measured the edge error
        self._settle_chunk = 2

    # ------------------------------------------------------------------ a drag (called by the view controller)
    def handle_center(self) -> np.ndarray | None:
        """(3,) the active handle group's centroid (where the gizmo is), or None; a settle under way is
        completed first (this reads the pose and changes nothing)."""
        self.finish()
        s = self.w.session
        return None if s is None else s.handle_centroid()

    def begin(self) -> bool:
        """Start a drag of the active handle group; False (and said why) when there is none to drag."""
        w = self.w
        w.posing.settle_and_stop_polish()  # a drag changes the pose: the frame or settle under way ends, a polish stops
        s = w.session
        if s is None:
            return False
        w.posing.drop_polished()  # the drag starts from the engine's pose
        try:
            self._T0 = s.begin_drag()
        except SelectionError as e:
            w.status.show_error("Cannot drag", str(e))
            return False
        w.status.clear_message()
        self._failed = False
        self.scene.set_dragging(True)  # (the cage points hide meanwhile, unless asked otherwise)
        self.scene.set_moving(s.moving_vertices())
        w.sync.measure()  # every edge once: then each frame only the moving region's
        return True

    def move(self, D: np.ndarray) -> None:
        """A new handle transform D (4, 4) from the mouse, relative to the drag's start. Its frame is
        computed on the frame thread (beside the render of the previous one); moves that arrive
        meanwhile collapse into one frame."""
        s = self.w.session
        if s is None or not s.applied:
            return
        # a move that arrives while the previous frame waits to be drawn is computed beside that render
        self.frames.submit(self._job(np.asarray(D) @ self._T0), beside_render=self.view.render_pending)

    def _job(self, T: np.ndarray) -> Job:
        """The frame for handle transform T, as a job for the frame thread: the engine's solve, the
        moving region's points, normals and edge error (and stretch map when shown). No Qt or VTK."""
        s, scene = self.w.session, self.scene
        stretch = scene.stretch_visible
        # the edge error for the status bar a few times a second (every frame with the stretch map)
        measure = stretch or time.perf_counter() - self._error_time >= ERROR_INTERVAL
        if measure:
            self._error_time = time.perf_counter()

        def job() -> DragFrame:
            t0 = time.perf_counter()
            V = s.drag_to(T)
            t1 = time.perf_counter()
            normals_s, points_s = scene.write_shape(V)
            error = s.metrics.update_error(V) if measure else None
            if stretch:
                s.metrics.write_stretch(scene.stretch32)
            cage = s.cage_positions
            geometry, centroid = scene.cage_geometry(cage), s.handle_centroid()
            return DragFrame(s, t1 - t0, normals_s, points_s, error, stretch, cage, geometry, centroid,
                             time.perf_counter() - t0)

        return job

    def _show(self, ok: bool, frame) -> None:
        """A finished frame (UI thread): into VTK's buffers, and render; a failed one undoes the drag."""
        s = self.w.session
        if s is None or (ok and frame.session is not s):
            return
        if not ok:
            self._fail(frame)
            return
        try:
            self._draw(frame)
        except Exception as e:  # noqa: BLE001 -- said, and the drag undone
            self._fail(e)

    def _draw(self, frame: DragFrame) -> None:
        """A frame the thread computed, drawn: the changed rows into VTK's buffers, the cage, the gizmo."""
        w = self.w
        scene = self.scene
        upload_s = scene.show_shape()
        if frame.stretch:
            scene.stretch_modified()
        scene.update_cage(frame.cage, frame.cage_geometry)
        scene.gizmo.place(frame.centroid)
        split = self.view.split
        split.add("engine", frame.engine_s)
        split.add("points", frame.points_s)
        split.add("normals", frame.normals_s)
        split.add("vtk update", upload_s)
        self.engine_ms = frame.engine_s * 1e3
        self.thread_ms = frame.thread_s * 1e3
        self.frame_shown_at = time.perf_counter()
        if frame.error is not None:
            self.error = frame.error
        w.unsaved.set_modified(True)
        self.view.request_render()

    def _fail(self, error: BaseException, *, what: str = "The drag frame failed",
              context: str = "drag frame") -> None:
        """A frame, the release or the settle of a drag raised ``error``: no later frame or settle, the
        gesture ended, the session back at its state before the drag (the history's current step, the last
        good pose) and drawn; said in one line, and an unexpected error reported
        (:meth:`~..window.status_bar.StatusBar.report_crash`)."""
        w = self.w
        self.frames.discard()  # no later frame of this drag
        self.settle_timer.stop()
        self._failed = True
        w.controller.gesture = None  # (its release is then no drag's: end() is not called for it)
        if self.scene.dragging:
            self.scene.set_dragging(False)
        restored = True
        try:
            w.session.cancel_drag()
            w.sync.refresh_all()
        except Exception as again:  # noqa: BLE001 -- the way back failed too: that is the state now
            if again.__context__ is None:
                again.__context__ = error  # (the report shows both)
            error, restored = again, False
        if not restored:
            w.status.report_crash(error, what=what, context=context,
                                  kept="the pose before the drag could not be restored")
        elif is_crash(error):
            w.status.report_crash(error, what=what, context=context,
                                  kept="the drag was undone and the last good pose kept")
        else:  # e.g. a transform the engine refuses: said in its words
            w.status.show_error("Drag failed", f"{describe(error, named=False)}; the drag was undone.")

    def end(self) -> None:
        """The button was released: the last move's frame, then the settle in slices (or the final pose)."""
        w = self.w
        if self.scene.dragging:
            self.scene.set_dragging(False)
            self.view.request_render()
        s = w.session
        if s is None or not s.applied:
            return
        self.frames.flush()  # the frame of the last mouse position
        if self._failed:
            return
        try:
            if not np.all(np.isfinite(s.shape_positions)):
                s.cancel_drag()
                w.sync.refresh_all()
                w.status.show_error("Drag failed", "The deformation became non-finite; the drag was undone.")
                return
            settles = s.end_drag()
        except Exception as e:  # noqa: BLE001 -- said, and the drag undone
            self._fail(e, what="The end of the drag failed", context="drag release")
            return
        if settles:
            self._settle_chunk = 2
            self.settle_timer.start()  # settle in slices; the last interactive frame stays on screen
        else:
            w.posing.after_drag()

    # ------------------------------------------------------------------ settling after a release
    def _settle_tick(self) -> None:
        w = self.w
        s = w.session
        if s is None:
            self.settle_timer.stop()
            return
        done = True
        if s.settling:  # (something may have read the pose, which completes the settle)
            t0 = time.perf_counter()
            try:
                done = s.settle_step(self._settle_chunk)
            except Exception as e:  # noqa: BLE001 -- said once (the timer stops), and the drag undone
                self._fail(e, what="The settle after the drag failed", context="settle")
                return
            per = (time.perf_counter() - t0) / max(self._settle_chunk, 1)
            self._settle_chunk = int(min(max(SETTLE_SLICE / max(per, 1e-6), 1), 30))
        if done:
            self.settle_timer.stop()
            w.posing.after_drag()

    def finish(self) -> None:
        """Complete a frame or a settle under way now (before anything reads or changes the pose)."""
        self.frames.flush()
        s = self.w.session
        if s is not None and s.settling:
            self.settle_timer.stop()
            try:
                s.finish_settle()
            except Exception as e:  # noqa: BLE001 -- said, and the drag undone
                self._fail(e, what="The settle after the drag failed", context="settle")
                return
            self.w.posing.after_drag()

    def flush(self) -> None:
        """Hand the frames under way over now (drawn), before the scene is drawn from the session."""
        self.frames.flush()

    def stop(self) -> None:
        """No more frames or settling (the window closes)."""
        self.settle_timer.stop()
        self.frames.stop()
