"""Handle groups in the window: Mode ▸ New Handle Group and Next Handle Group, and each group's
name in the status bar (its number and colour).
"""

from __future__ import annotations

from ...deform.roles import handle as handle_role
from ..render.palette import ROLE_COLOR_NAMES, role_rows
from ..model.selection_masks import HANDLE
from .slot_errors import guarded


class HandleGroupsMixin:
    """The handle-group commands of a :class:`~.main_window.MainWindow` (a mixin): they change the
    ``session``'s groups, the target (:meth:`~.selecting.SelectingMixin._set_target`) and what is drawn."""

    def _group_name(self) -> str:
        """The active group in words: "handle group 2 of 3 (magenta)"."""
        s = self.session
        return f"handle group {s.active + 1} of {s.n_groups} ({ROLE_COLOR_NAMES[role_rows(handle_role(s.active))]})"

    @guarded
    def new_group(self) -> None:
        """Start a new handle group and select its cage points next (Handle target, Select mode)."""
        s = self.session
        if s is None or self.controller.busy:
            return
        # only the polish is dropped here, not the whole guard: a new, empty group moves no point and selects
        # none, and Session.new_group completes a settle under way itself (the settle timer's next tick then
        # shows the final pose and may start a polish: after_drag)
        self.polisher.cancel()
        if not s.new_group():
            self.status.message("The current handle group is still empty: select its cage points first")
            return
        self._set_target(HANDLE)
        self._refresh_selection()
        self._update_actions()
        self.status.message(f"New {self._group_name()}: select its cage points (Select mode, Handle target)")

    @guarded
    def next_group(self) -> None:
        """Make the next handle group (cycling) the one selections and drags act on."""
        s = self.session
        if s is None or self.controller.busy:
            return
        s.next_group()
        self._set_target(self.target)
        self._refresh_selection()
        self.status.message(f"Now {self._group_name()}: selections and drags act on it")
