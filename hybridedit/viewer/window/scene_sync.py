"""Keeping the scene in step with the session: the pose, the selection, or everything again (after
undo, redo, an edit file); the scene rebuilt for a session's engine; and the edge error and stretch
map measured on the shape on display.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

from .interfaces import ActionChecks, Renders

if TYPE_CHECKING:
    from ..model.session import Session
    from ..render.scene import Scene


@runtime_checkable
class Flushes(Protocol):
    """The drags as the scene's upkeep sees them: the frames under way drawn first."""

    def flush(self) -> None: ...


@runtime_checkable
class Fields(Protocol):
    """The status bar as the scene's upkeep sees it: the sizes, the selection's counts, the edge error."""

    def show_session(self) -> None: ...
    def show_edge_error(self, err: float | None) -> None: ...


@runtime_checkable
class CageBox(Protocol):
    """The toolbar's cage size box, which shows the cage on display's size."""

    def set_value(self, size: int | float, *, of_shape: bool = False) -> None: ...


@runtime_checkable
class SyncHost(Protocol):
    """What :class:`SceneSync` asks of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def scene(self) -> Scene: ...
    @property
    def dragging(self) -> Flushes: ...
    @property
    def view(self) -> Renders: ...
    @property
    def status(self) -> Fields: ...
    @property
    def cage_control(self) -> CageBox: ...
    @property
    def actions_(self) -> ActionChecks: ...


class SceneSync:
    """Redraws the session of a :class:`~.main_window.MainWindow` in its scene and renders the view;
    the sizes, counts and edge error go to the status bar.

    Every redraw hands the drag frames under way over first, so that what is drawn is the session's
    state now.

    Parameters
    ----------
    window : the window, as far as the scene's upkeep needs it (:class:`SyncHost`).
    """

    def __init__(self, window: SyncHost) -> None:
        self.w = window
        self._rrms_full = True  # the next measure must walk every edge (the pose changed outside a drag)
        self._generation = -1  # the session's engine generation the scene shows

    def refresh_pose(self) -> None:
        """Draw the session's pose (shape, cage, gizmo), and measure it again."""
        w = self.w
        w.dragging.flush()
        s = w.session
        if s is None:
            return
        w.scene.update_shape(s.shown_positions, everything=True)
        w.scene.update_cage(s.cage_positions)
        w.scene.gizmo.place(s.handle_centroid())
        self._pose_shown_changed()
        w.view.request_render()

    def refresh_selection(self) -> None:
        """Draw the session's selection (the roles' colours, the gizmo) and its counts."""
        w = self.w
        w.dragging.flush()
        s = w.session
        if s is None:
            return
        w.scene.update_roles(s.selection.cage_roles(), s.selection.shape_roles())
        w.scene.gizmo.place(s.handle_centroid())
        w.status.show_session()
        w.view.request_render()

    def refresh_all(self) -> None:
        """Show the session's whole state again (after undo, redo, loading an edit, ...)."""
        w = self.w
        w.dragging.flush()
        s = w.session
        if s is not None and s.generation != self._generation:
            self.show_engine()  # undo or redo went across a rebuild: the other cage
        self.refresh_pose()
        self.refresh_selection()
        w.actions_.refresh()

    def show_engine(self) -> None:
        """(Re)build the scene for the session's engine (a new shape, a rebuild, or undo across one)."""
        w = self.w
        s = w.session
        self._generation = s.generation
        w.cage_control.set_value(s.cage_size, of_shape=True)
        w.scene.up_axis = s.up_axis
        w.scene.load(s.metrics, s.shown_positions, s.cage_positions, s.editor.cage.faces, s.selection.cage_roles(),
                     s.selection.shape_roles(), look=s.look, mode=s.look_mode)
        s.look_mode = w.scene.look_mode
        w.scene.gizmo.place(s.handle_centroid())
        self._rrms_full = True
        self.measure()
        w.status.show_session()
        w.view.request_render()

    def show_shape(self) -> None:
        """The session's shape changed (a polish adopted): drawn again, and measured."""
        w = self.w
        w.scene.update_shape(w.session.shown_positions, everything=True)
        self._pose_shown_changed()
        w.view.request_render()

    # ------------------------------------------------------------------ edge error and stretch map
    def _pose_shown_changed(self) -> None:
        """The shape on display changed outside a drag: edge error and stretch map are measured again."""
        self._rrms_full = True
        self.measure()

    def measure(self, everything: bool | None = None) -> None:
        """Edge error (status bar) and, when shown, the stretch map of the shape on display.

        During a drag only the edges of the moving region are measured again
        (:class:`~hybridedit.core.region_metrics.ShapeMetrics`); after any other change, every edge.
        """
        w = self.w
        s = w.session
        if s is None:
            w.status.show_edge_error(None)
            return
        full = self._rrms_full if everything is None else everything
        self._rrms_full = False
        w.status.show_edge_error(s.metrics.update_error(s.shown_positions, everything=full))
        if w.scene.stretch_visible:
            s.metrics.write_stretch(w.scene.stretch32, everything=full)
            w.scene.stretch_modified()
            w.view.request_render()
