"""Selecting in the window: the target (the ROI or the active handle group), the selection gestures
the view controller reports, the Select menu's commands, Select Through and Mirror, new and next
handle groups; and the warning when a selection would tear the shape.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np
from qtpy import QtGui

from ...deform.roles import FREE, handle as handle_role
from ...deform.selection import SelectionError
from ..model.selection_masks import HANDLE, ROI
from ..render.palette import ROLE_COLOR_NAMES, ROLE_COLORS, role_rows
from .interfaces import ActionChecks, Cancels
from .slot_errors import guarded

if TYPE_CHECKING:
    from ..model.session import Session


@runtime_checkable
class Gestures(Protocol):
    """The view controller as the selection sees it: the colour of its rubber band and brush, whether a
    gesture is under way, and Select Through."""

    target_color: QtGui.QColor
    @property
    def busy(self) -> bool: ...
    def set_select_through(self, on: bool) -> None: ...


@runtime_checkable
class Guard(Protocol):
    """The pose side as the selection sees it (:class:`~.posing.Posing`)."""

    def finish_settle(self) -> None: ...
    def settle_and_stop_polish(self) -> None: ...


@runtime_checkable
class Redraws(Protocol):
    """The scene's upkeep as the selection sees it (:class:`~.scene_sync.SceneSync`)."""

    def refresh_selection(self) -> None: ...


@runtime_checkable
class Says(Protocol):
    """The status bar as the selection sees it."""

    def message(self, text: str, *, fix: QtGui.QAction | None = None) -> None: ...
    def clear_message(self) -> None: ...
    def show_error(self, title: str, text: str) -> None: ...


@runtime_checkable
class Hint(Protocol):
    """The first-steps hint as the selection sees it (:class:`~.first_steps.FirstSteps`)."""

    def selected(self) -> None: ...


@runtime_checkable
class SelectHost(Protocol):
    """What :class:`Selecting` asks of the window (:class:`~.main_window.MainWindow`)."""

    @property
    def session(self) -> Session | None: ...
    @property
    def controller(self) -> Gestures: ...
    @property
    def posing(self) -> Guard: ...
    @property
    def polisher(self) -> Cancels: ...
    @property
    def sync(self) -> Redraws: ...
    @property
    def status(self) -> Says: ...
    @property
    def actions_(self) -> ActionChecks: ...
    @property
    def first_steps(self) -> Hint: ...


class Selecting:
    """The selection side of a :class:`~.main_window.MainWindow`: it changes the session's masks and
    handle groups, has them redrawn (``sync``) and says what happened in the status bar.

    It is what the view controller's selection gestures call
    (:class:`~..input.mouse_gestures.SelectionHandler`).

    Parameters
    ----------
    window : the window, as far as selecting needs it (:class:`SelectHost`).

    Attributes
    ----------
    target : what selections change, ``ROI`` or ``HANDLE`` (the active handle group).
    """

    def __init__(self, window: SelectHost) -> None:
        self.w = window
        self.target = ROI
        self._stroke_target: str | None = None  # the target of the latest gesture

    def set_target(self, target: str) -> None:
        """Selections change ``target`` from now on; the rectangle and brush take its colour."""
        w = self.w
        self.target = target
        w.actions_["target_roi" if target == ROI else "target_handle"].setChecked(True)
        active = w.session.selection.active if w.session is not None else 0
        rgb = ROLE_COLORS[role_rows(FREE if target == ROI else handle_role(active))]
        w.controller.target_color = QtGui.QColor(int(rgb[0]), int(rgb[1]), int(rgb[2]))

    def _target_name(self, target: str) -> str:
        s = self.w.session
        if target == ROI:
            return "ROI"
        sel = s.selection if s is not None else None
        return f"Handle group {sel.active + 1}" if sel is not None and sel.n_groups > 1 else "Handle"

    # ------------------------------------------------------------------ gestures (called by the view controller)
    # cage_points completes the settle only, not the guard: it reads the pose and changes nothing (it also
    # runs on every mouse move in Select mode, to draw the points near the cursor, which must not stop a
    # polish); a gesture cancels the polish when it begins (begin_select)
    def cage_points(self) -> np.ndarray | None:
        """(c, 3) the cage's pose (a settle under way is completed first), or None without a shape."""
        self.w.posing.finish_settle()
        s = self.w.session
        return None if s is None else s.cage_positions

    def cage_edges(self) -> np.ndarray | None:
        """(e, 2) the cage's edges (a selection takes the part it is drawn over through its thickness)."""
        s = self.w.session
        return None if s is None else s.editor.cage_edges

    def cage_thickness(self) -> np.ndarray | None:
        """(c,) how thick the shape is at each cage point (a selection grows through a part's thickness)."""
        s = self.w.session
        return None if s is None else s.selection.cage_thickness()

    def begin_select(self) -> bool:
        """A selection gesture begins (after the guard: ``settle_and_stop_polish``); False: no shape."""
        w = self.w
        w.posing.settle_and_stop_polish()
        if w.session is None:
            return False
        self._stroke_target = self.target
        w.session.selection.begin_stroke(self.target)
        return True

    def select_hits(self, hits: np.ndarray, op: str) -> None:
        """The gesture took the (c,) bool cage points ``hits`` with ``op`` (replace, add, remove)."""
        w = self.w
        if w.session is None:
            return
        w.session.selection.stroke(hits, op)
        w.sync.refresh_selection()

    def missed(self) -> None:
        """A click took no cage point: the selection is kept, and said so."""
        self.w.status.message("No cage point there: the selection is kept")

    def end_select(self) -> None:
        """A selection gesture ended: one undo step; a gesture that emptied its target says how to get it back."""
        w = self.w
        s = w.session
        if s is None:
            return
        if s.selection.end_stroke():
            w.first_steps.selected()
            target = self._stroke_target or self.target
            if not s.selection.mask(target).any():
                w.status.message(f"{self._target_name(target)} cleared (Ctrl+Z restores it)")
            elif not self._warn_if_tearing():
                w.status.clear_message()
        w.sync.refresh_selection()
        w.actions_.refresh()

    def _warn_if_tearing(self) -> bool:
        """Say so, offering the fix (and return True), when a handle group touches held cage points with
        nothing free between them: a drag would tear the shape there
        (:meth:`~..model.selection_masks.Selection.tearing`)."""
        s = self.w.session
        warning = s.selection.tearing_warning() if s is not None else None
        if warning is None:
            return False
        self.w.status.message(warning, fix=self.w.actions_["free_around_handle"])
        return True

    @guarded
    def free_around_handles(self) -> None:
        """Select ▸ Free Around Handle: the held cage points where a handle touches them join the ROI (one
        undo step), so that a drag bends the shape there instead of tearing it."""
        w = self.w
        s = w.session
        if s is None or w.controller.busy:
            return
        w.posing.settle_and_stop_polish()
        n = s.selection.free_around_handles()
        w.sync.refresh_selection()
        w.actions_.refresh()
        if n == 0:
            w.status.message("No handle touches the held part: nothing to free")
        elif not self._warn_if_tearing():
            w.status.message(f"Freed {n} held cage point{'s' if n != 1 else ''} around the handle: they join the "
                             "ROI (Ctrl+Z restores them)")

    # ------------------------------------------------------------------ the Select menu
    def selection_op(self, op: str) -> None:
        """Select all / invert / clear the current target, or clear everything ("clear_all"): one undo step."""
        w = self.w
        s = w.session
        if s is None or w.controller.busy:
            return
        w.posing.settle_and_stop_polish()
        if op == "clear_all":
            changed = s.selection.clear_all()
            said = "Selection cleared: the ROI and every handle group (Ctrl+Z restores them)"
        else:
            sel = s.selection
            changed = {"all": sel.select_all, "clear": sel.clear, "invert": sel.invert}[op](self.target)
            said = f"{self._target_name(self.target)} cleared (Ctrl+Z restores it)" if op == "clear" else ""
        if op == "clear_all" and changed:
            self.set_target(self.target)  # (back to one handle group: its colour)
        if changed:
            w.first_steps.selected()
        if changed and said:
            w.status.message(said)
        elif op in ("clear", "clear_all") and not changed:
            w.status.message("Nothing to clear")
        elif not self._warn_if_tearing():
            w.status.clear_message()
        w.sync.refresh_selection()
        w.actions_.refresh()

    def toggle_select_through(self) -> None:
        """Select ▸ Select Through: the cage points hidden behind another part are taken too (or not)."""
        w = self.w
        on = w.actions_["select_through"].isChecked()
        w.controller.set_select_through(on)
        w.status.message("Select Through: rectangle, brush and click also take the cage points hidden behind the "
                         "shape" if on else "Select Through off: the part drawn over is taken through its "
                                            "thickness, not what another part hides")

    @guarded
    def toggle_mirror(self, axis: str) -> None:
        """Mirror the selection across ``axis`` (or stop); a shape not symmetric enough is refused in words."""
        w = self.w
        s = w.session
        on = w.actions_[f"mirror_{axis}"].isChecked()
        for other in "xyz":
            if other != axis:
                w.actions_[f"mirror_{other}"].setChecked(False)
        if s is None:
            return
        w.posing.settle_and_stop_polish()
        before = s.selection.symmetry
        try:
            s.set_mirror(axis if on else None)
        except SelectionError as e:
            w.actions_[f"mirror_{axis}"].setChecked(before == axis)
            w.status.show_error(f"Cannot mirror across {axis.upper()}", str(e))
            return
        w.sync.refresh_selection()
        w.actions_.refresh()
        w.status.message(f"Mirror {axis.upper()}: the selection and the drag are mirrored across the shape's "
                         "middle plane" if on else "Mirror off")

    # ------------------------------------------------------------------ handle groups
    def _group_name(self) -> str:
        """The active group in words: "handle group 2 of 3 (magenta)"."""
        sel = self.w.session.selection
        colour = ROLE_COLOR_NAMES[role_rows(handle_role(sel.active))]
        return f"handle group {sel.active + 1} of {sel.n_groups} ({colour})"

    @guarded
    def new_group(self) -> None:
        """Mode ▸ New Handle Group: start one, and select its cage points next (Handle target)."""
        w = self.w
        s = w.session
        if s is None or w.controller.busy:
            return
        # only the polish is dropped here, not the whole guard: a new, empty group moves no point and selects
        # none, and Selection.new_group completes a settle under way itself (the settle timer's next tick then
        # shows the final pose and may start a polish: after_drag)
        w.polisher.cancel()
        if not s.selection.new_group():
            w.status.message("The current handle group is still empty: select its cage points first")
            return
        self.set_target(HANDLE)
        w.sync.refresh_selection()
        w.actions_.refresh()
        w.status.message(f"New {self._group_name()}: select its cage points (Select mode, Handle target)")

    @guarded
    def next_group(self) -> None:
        """Mode ▸ Next Handle Group: the next one (cycling) is the one selections and drags act on."""
        w = self.w
        s = w.session
        if s is None or w.controller.busy:
            return
        s.selection.next_group()
        self.set_target(self.target)
        w.sync.refresh_selection()
        w.status.message(f"Now {self._group_name()}: selections and drags act on it")
