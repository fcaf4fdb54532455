"""Undo / redo over editing snapshots (selection masks and cage pose)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Snapshot:
    """Everything needed to return to a moment of an editing session.

    Attributes
    ----------
    roi : (c,) bool mask over the cage vertices.
    handle : (c,) int8 the session's ``handle_group``: the role of the handle group each cage vertex
        is in (``roles.handle(g)``), or 0 (:data:`~.selection_masks.NO_GROUP`).
    positions : (c, 3) cage vertex positions.
    transform : (G, 4, 4) transform of each handle group since the selection was applied.
    anchor : (c, 3) cage pose when the selection was applied, or None when the
        selection has not been applied to the engine (no drag since it changed).
    label : what led here ("select ROI", "drag", ...), for the Edit menu.
    active : the handle group selections and drags act on.
    editor, cage_size : the engine (cage and binding) these masks and positions belong to, and
        its cage size: a rebuild adds snapshots on a new cage, and undo goes back to the old one.
    symmetry : the mirror axis of the selection, or None.
    engine, engine_masks, anchor_state : the engine's own state (exact shape-space
        constraints included) and what it was set from.
    bases, anchor_bases : (G, 4, 4) each group's transform (since the selection was applied)
        at the pose the engine's drags start from now, and at ``anchor_state``; identities
        until a polish makes its pose the engine's own.
    """

    roi: np.ndarray
    handle: np.ndarray
    positions: np.ndarray
    transform: np.ndarray
    anchor: np.ndarray | None
    label: str = ""
    active: int = 0
    editor: object = None
    cage_size: int | float | None = None
    symmetry: str | None = None
    #: the engine's selection and pose (:meth:`hybridedit.HybridEditor.save_state`),
    #: the mask key they were set from, and the engine state at the anchor
    engine: object = None
    engine_masks: tuple | None = None
    anchor_state: object = None
    bases: np.ndarray | None = None
    anchor_bases: np.ndarray | None = None


class History:
    """A linear undo stack: push after every change; undo/redo move a cursor.

    The first snapshot pushed (after :meth:`clear`) is the base state and cannot
    be undone. Pushing after an undo drops the redo branch.
    """

    def __init__(self, limit: int = 200) -> None:
        self.limit = int(limit)
        self._items: list[Snapshot] = []
        self._pos = -1

    def clear(self) -> None:
        self._items.clear()
        self._pos = -1

    def push(self, snap: Snapshot) -> None:
        del self._items[self._pos + 1:]
        self._items.append(snap)
        if len(self._items) > self.limit:
            del self._items[0]
        self._pos = len(self._items) - 1

    @property
    def current(self) -> Snapshot | None:
        return self._items[self._pos] if self._pos >= 0 else None

    def can_undo(self) -> bool:
        return self._pos > 0

    def can_redo(self) -> bool:
        return self._pos < len(self._items) - 1

    def undo_label(self) -> str:
        return self._items[self._pos].label if self.can_undo() else ""

    def redo_label(self) -> str:
        return self._items[self._pos + 1].label if self.can_redo() else ""

    def undo(self) -> Snapshot | None:
        """Step back; returns the snapshot to restore, or None at the base state."""
        if not self.can_undo():
            return None
        self._pos -= 1
        return self._items[self._pos]

    def redo(self) -> Snapshot | None:
        """Step forward; returns the snapshot to restore, or None at the newest state."""
        if not self.can_redo():
            return None
        self._pos += 1
        return self._items[self._pos]

    def __len__(self) -> int:
        return len(self._items)
