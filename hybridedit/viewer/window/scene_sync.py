"""Keeping the scene in step with the session: the pose, the selection, or everything again (after
undo, redo, an edit file); the scene rebuilt for a session's engine; and the edge error and stretch
map measured on the shape on display.
"""

from __future__ import annotations


class RefreshMixin:
    """Redraws the ``session`` in the ``scene`` of a :class:`~.main_window.MainWindow` (a mixin), and renders
    the ``view``; the edge error goes to the status bar (``_show_error_value``), the sizes and counts too
    (``_update_labels``)."""

    def _refresh_pose(self) -> None:
        self.frames.flush()
        s = self.session
        if s is None:
            return
        self.scene.update_shape(s.shown_positions, everything=True)
        self.scene.update_cage(s.cage_positions)
        self.scene.gizmo.place(s.handle_centroid())
        self._pose_shown_changed()
        self.view.request_render()

    def _refresh_selection(self) -> None:
        self.frames.flush()
        s = self.session
        if s is None:
            return
        self.scene.update_roles(s.cage_roles(), s.shape_roles())
        self.scene.gizmo.place(s.handle_centroid())
        self.status.show_session()
        self.view.request_render()

    def refresh_all(self) -> None:
        """Show the session's whole state again (after undo, redo, loading an edit, ...)."""
        self.frames.flush()
        s = self.session
        if s is not None and s.generation != self._generation:
            self._show_engine()  # undo or redo went across a rebuild: the other cage
        self._refresh_pose()
        self._refresh_selection()
        self._update_actions()

    def _show_engine(self) -> None:
        """(Re)build the scene for the session's engine (a new shape, a rebuild, or undo across one)."""
        s = self.session
        self._generation = s.generation
        self.set_cage_size(s.cage_size, of_shape=True)
        self.scene.up_axis = s.up_axis
        self.scene.load(s.metrics, s.shown_positions, s.cage_positions, s.editor.cage.faces, s.cage_roles(),
                        s.shape_roles(), look=s.look, mode=s.look_mode)
        s.look_mode = self.scene.look_mode
        self.scene.gizmo.place(s.handle_centroid())
        self._rrms_full = True
        self.measure()
        self.status.show_session()
        self.view.request_render()

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
        s = self.session
        if s is None:
            self.status.show_edge_error(None)
            return
        full = self._rrms_full if everything is None else everything
        self._rrms_full = False
        self.status.show_edge_error(s.metrics.update_error(s.shown_positions, everything=full))
        if self.scene.stretch_visible:
            s.metrics.write_stretch(self.scene.stretch32, everything=full)
            self.scene.stretch_modified()
            self.view.request_render()
