"""Selecting in the window: the target (the ROI or the active handle group), the selection gestures
the view controller reports, the Select menu's commands, Select Through and Mirror; and the warning
when a selection would tear the shape.
"""

from __future__ import annotations

import numpy as np
from qtpy import QtGui

from ...deform.selection import SelectionError
from ...deform.roles import FREE, handle as handle_role
from ..render.palette import ROLE_COLORS, role_rows
from ..model.selection_masks import ROI
from .slot_errors import guarded


class SelectingMixin:
    """The selection side of a :class:`~.main_window.MainWindow` (a mixin): it changes the ``session``'s
    masks, redraws them (``_refresh_selection``) and says what happened in the status bar.

    Attributes
    ----------
    target : what selections change, ``ROI`` or ``HANDLE`` (the active handle group).
    """

    def _set_target(self, target: str) -> None:
        """Selections change ``target`` from now on; the rectangle and brush take its colour."""
        self.target = target
        self.actions_["target_roi" if target == ROI else "target_handle"].setChecked(True)
        active = self.session.active if self.session is not None else 0
        rgb = ROLE_COLORS[role_rows(FREE if target == ROI else handle_role(active))]
        self.controller.target_color = QtGui.QColor(int(rgb[0]), int(rgb[1]), int(rgb[2]))

    def _target_name(self, target: str) -> str:
        s = self.session
        if target == ROI:
            return "ROI"
        return f"Handle group {s.active + 1}" if s is not None and s.n_groups > 1 else "Handle"

    # ------------------------------------------------------------------ gestures (called by the view controller)
    def cage_edges(self) -> np.ndarray | None:
        """(e, 2) the cage's edges (a selection takes the part it is drawn over through its thickness)."""
        return None if self.session is None else self.session.editor.cage_edges

    def begin_select(self) -> bool:
        """A selection gesture begins (after the guard: :meth:`settle_and_stop_polish`); False: no shape."""
        self.settle_and_stop_polish()
        if self.session is None:
            return False
        self._stroke_target = self.target
        self.session.begin_stroke(self.target)
        return True

    def select_hits(self, hits: np.ndarray, op: str) -> None:
        """The gesture took the (c,) bool cage points ``hits`` with ``op`` (replace, add, remove)."""
        if self.session is None:
            return
        self.session.stroke(hits, op)
        self._refresh_selection()

    def missed(self) -> None:
        """A click took no cage point: the selection is kept, and said so."""
        self.status.message("No cage point there: the selection is kept")

    def end_select(self) -> None:
        """A selection gesture ended: one undo step; a gesture that emptied its target says how to get it back."""
        s = self.session
        if s is None:
            return
        if s.end_stroke():
            target = getattr(self, "_stroke_target", self.target)
            if not s.mask(target).any():
                self.status.message(f"{self._target_name(target)} cleared (Ctrl+Z restores it)")
            elif not self._warn_if_tearing():
                self.status.clear_message()
        self._refresh_selection()
        self._update_actions()

    def _warn_if_tearing(self) -> bool:
        """Say so (and return True) when a handle group touches held cage points with nothing free between
        them: a drag would tear the shape there (:meth:`Session.tearing`)."""
        s = self.session
        tears = s.tearing() if s is not None and s.all_handles.any() and s.roi.any() else {}
        if not tears:
            return False
        g, n = max(tears.items(), key=lambda kv: kv[1])
        who = f"Handle group {g + 1}" if s.n_groups > 1 else "The handle"
        self.status.message(f"{who} touches the held part at {n} cage point{'s' if n != 1 else ''} with nothing free "
                     "between them: a drag tears the shape there (the back of a limb left out of the ROI?). Take "
                     "the ROI around the handle (R, Shift+drag), or select through (Alt+Z).")
        return True

    # ------------------------------------------------------------------ the Select menu
    def _selection_op(self, op: str) -> None:
        """Select all / invert / clear the current target, or clear everything ("clear_all"): one undo step."""
        s = self.session
        if s is None or self.controller.busy:
            return
        self.settle_and_stop_polish()
        if op == "clear_all":
            changed = s.clear_all()
            said = "Selection cleared: the ROI and every handle group (Ctrl+Z restores them)"
        else:
            changed = {"all": s.select_all, "clear": s.clear, "invert": s.invert}[op](self.target)
            said = f"{self._target_name(self.target)} cleared (Ctrl+Z restores it)" if op == "clear" else ""
        if op == "clear_all" and changed:
            self._set_target(self.target)  # (back to one handle group: its colour)
        if changed and said:
            self.status.message(said)
        elif op in ("clear", "clear_all") and not changed:
            self.status.message("Nothing to clear")
        elif not self._warn_if_tearing():
            self.status.clear_message()
        self._refresh_selection()
        self._update_actions()

    def _toggle_select_through(self) -> None:
        on = self.actions_["select_through"].isChecked()
        self.controller.set_select_through(on)
        self.status.message("Select Through: rectangle, brush and click also take the cage points hidden behind the shape"
                     if on else "Select Through off: the part drawn over is taken through its thickness, not what "
                                "another part hides")

    @guarded
    def _toggle_mirror(self, axis: str) -> None:
        """Mirror the selection across ``axis`` (or stop); a shape not symmetric enough is refused in words."""
        s = self.session
        on = self.actions_[f"mirror_{axis}"].isChecked()
        for other in "xyz":
            if other != axis:
                self.actions_[f"mirror_{other}"].setChecked(False)
        if s is None:
            return
        self.settle_and_stop_polish()
        before = s.symmetry
        try:
            s.set_symmetry(axis if on else None)  # a shape too asymmetric is refused here, nothing changed
            if s.handle.any():
                s.apply_selection()  # the mirrored selection is drawn on both sides at once
        except SelectionError as e:
            if s.symmetry != before:
                s.undo()  # back to the selection before the toggle
            self.actions_[f"mirror_{axis}"].setChecked(before == axis)
            self.status.show_error(f"Cannot mirror across {axis.upper()}", str(e))
            return
        self._refresh_selection()
        self._update_actions()
        self.status.message(f"Mirror {axis.upper()}: the selection and the drag are mirrored across the shape's middle plane"
                     if on else "Mirror off")
