"""Undo / redo over editing snapshots (selection masks and cage pose), within a memory budget."""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Callable

import numpy as np

from ...core.heap import trim_heap
from ...core.held_bytes import held_buffers

#: Steps kept at most, whatever their size.
LIMIT = 200
#: The default budget, in copies of the shape's positions ((n, 3) float64): a drag or a polish holds
#: one (its pose), a new selection more (its base pose and residual, its region's solver); a cycle of
#: select, drag and polish of a fifth of the creature holds 11, so 128 (295 MB) keep its last 42 steps.
SHAPE_COPIES = 128
#: The default budget's floor (a small shape keeps its LIMIT steps) and ceiling (a share of the memory).
FLOOR = 64 * 2**20
MEMORY_SHARE = 0.25


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




def physical_memory() -> int | None:
    """The machine's memory in bytes, or None where the system does not say."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):
        return None


def default_budget(n_vertices: int, *, memory: int | None = None) -> int:
    """The undo history's default memory budget for a shape of ``n_vertices``, bytes: :data:`SHAPE_COPIES`
    copies of its positions, at least :data:`FLOOR`, at most :data:`MEMORY_SHARE` of ``memory`` (default:
    the machine's, :func:`physical_memory`; no ceiling where it is unknown)."""
    budget = max(SHAPE_COPIES * int(n_vertices) * 3 * 8, FLOOR)
    memory = physical_memory() if memory is None else memory
    if memory:
        budget = min(budget, max(int(MEMORY_SHARE * memory), FLOOR))
    return int(budget)


def snapshot_buffers(snap: Snapshot) -> dict[int, int]:
    """The memory a snapshot holds: {id of a buffer's owner: bytes} (:func:`~hybridedit.core.held_bytes.held_buffers`):
    its masks, poses and transforms, and its engine states (:meth:`hybridedit.HybridEditor.state_buffers`:
    without what the engine holds for its whole life)."""
    out = held_buffers(snap.roi, snap.handle, snap.positions, snap.transform, snap.anchor, snap.bases,
                       snap.anchor_bases)
    for state in (snap.engine, snap.anchor_state):
        if state is None:
            continue
        if hasattr(snap.editor, "state_buffers"):
            snap.editor.state_buffers(state, out=out)
        else:
            held_buffers(state, out=out)
    return out


class History:
    """A linear undo stack: push after every change; undo/redo move a cursor.

    The first snapshot pushed (after :meth:`clear`) is the base state and cannot
    be undone. Pushing after an undo drops the redo branch. Past ``limit`` steps or
    ``budget`` bytes (the distinct buffers the snapshots hold, each counted once: they
    share arrays), the oldest steps are dropped: the oldest kept becomes the base
    state. The newest two are always kept (the last change can be undone). Once
    half the budget has been let go, the C heap's free pages go back to the system
    (:func:`~hybridedit.core.heap.trim_heap`: else the resident set stays, and
    fragments, where the dropped steps left it; about 50 ms for 300 MB).

    Parameters
    ----------
    limit : steps kept at most.
    budget : bytes kept at most (None: no budget but the count).
    measure : what a snapshot holds, {id of a buffer's owner: bytes} (default :func:`snapshot_buffers`).

    Attributes
    ----------
    dropped : steps dropped for room since :meth:`clear`.
    nbytes : the memory the snapshots kept hold, bytes.
    """

    def __init__(self, limit: int = LIMIT, *, budget: int | None = None,
                 measure: Callable[[Snapshot], dict[int, int]] = snapshot_buffers) -> None:
        self.limit = int(limit)
        self.budget = None if budget is None else int(budget)
        self._measure = measure
        self._items: list[Snapshot] = []
        self._held: list[dict[int, int]] = []  # what each kept snapshot holds
        self._refs: dict[int, int] = {}  # buffer -> snapshots holding it
        self._pos = -1
        self.dropped = 0
        self.nbytes = 0
        self._let_go = 0  # bytes released since the heap was last trimmed

    def clear(self) -> None:
        self._items.clear()
        self._held.clear()
        self._refs.clear()
        self._pos = -1
        self.dropped = 0
        self.nbytes = 0

    def _release(self, held: dict[int, int]) -> None:
        for k, b in held.items():
            n = self._refs[k] - 1
            if n:
                self._refs[k] = n
            else:
                del self._refs[k]
                self.nbytes -= b
                self._let_go += b

    def push(self, snap: Snapshot) -> int:
        """Add a snapshot after the current one (the redo branch goes); returns how many of the
        oldest steps were dropped to keep within ``limit`` and ``budget``."""
        for held in self._held[self._pos + 1:]:
            self._release(held)
        del self._items[self._pos + 1:]
        del self._held[self._pos + 1:]
        held = self._measure(snap)
        for k, b in held.items():
            n = self._refs.get(k, 0)
            self._refs[k] = n + 1
            if not n:
                self.nbytes += b
        self._items.append(snap)
        self._held.append(held)
        dropped = 0
        while len(self._items) > 2 and (len(self._items) > self.limit
                                        or (self.budget is not None and self.nbytes > self.budget)):
            self._release(self._held.pop(0))
            del self._items[0]
            dropped += 1
        self._pos = len(self._items) - 1
        self.dropped += dropped
        if self.budget is not None and self._let_go > self.budget // 2:
            trim_heap()
            self._let_go = 0
        return dropped

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
