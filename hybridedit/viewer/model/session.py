"""The editing state of one loaded shape, on top of :class:`hybridedit.deform.editor.HybridEditor`.

No Qt here: the window turns user actions into calls on a :class:`Session`. The
selection (the ROI and handle-group masks, the gestures that change them, the roles
they give) is the session's :attr:`~Session.selection`, a
:class:`~.selection_masks.Selection` that sees the session as its
:class:`~.selection_masks.SelectionOwner`; here are the engine, the pose, drags and
their settle, polish, undo, rebuilds and edit files.

Vocabulary
----------
applying a selection
    The engine takes a selection with ``set_selection``; that pose becomes the
    *anchor* and the handle transform restarts at the identity. The window
    applies a changed selection lazily, when the next drag starts.
handle transform
    ``transform`` is the 4x4 transform of the handle since the selection was
    applied (what the edit file stores). The engine's own transform of group g is
    relative to the pose its drags start from: ``transforms[g] @ inv(_bases[g])``,
    where ``_bases[g]`` is the group's transform at that pose (the identity, until
    a polish makes its pose the engine's own).
settling
    At the end of a drag the final transform is solved again from the anchor
    with the batch settings (``settle_frames`` x ``settle_iterations`` ARAP
    iterations, the defaults of ``hybridedit deform``), so what the window shows
    is what ``hybridedit deform`` computes from a saved edit.
the pose is the engine's
    What is shown and saved is the engine's pose; a polish on release is given to
    the engine (:meth:`Session.adopt_polish`, one undo step), so that the next drag
    or selection starts from it and undo and redo return to exact poses. A new
    selection starts from the current pose (the engine measures the next edit's
    ARAP energy against it): nothing outside the new region moves.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...defaults import CAGE_SIZE, ITERATIONS, SETTLE_FRAMES
from ...fileio.editfile import Edit
from ...deform.editor import HybridEditor
from ...deform.selection import SelectionError
from ...core.mesh import Mesh, rrms_edge_error
from .history import History, Snapshot, default_budget
from .pose_library import PoseLibrary
from ...core.region_metrics import ShapeMetrics
from .selection_masks import Selection


class Session:
    """One shape being edited: engine, selection, handle transform and undo history.

    Parameters
    ----------
    editor : the engine, already built (cage and binding).
    path : the file the shape was read from (None for generated shapes).
    cage_size : the cage size the editor was built with (int count or float fraction).
    roi, handle : initial selection masks over the cage vertices (default: empty).
    symmetry : mirror the selection across this axis's mid-plane ("x", "y", "z"), or None.
    metrics : the shape's :class:`~hybridedit.core.region_metrics.ShapeMetrics` when made already
        (the window's build makes it off the UI thread); default: made here.
    history_budget : the undo history's memory budget in bytes (past it, the oldest steps are dropped);
        None: :func:`~.history.default_budget`, sized to the shape.

    Raises
    ------
    SelectionError
        ``symmetry`` given for a shape that is not symmetric enough across it (the
        message gives the measured asymmetry).

    Attributes
    ----------
    selection : the ROI and handle groups, and the gestures and commands that change them
        (:class:`~.selection_masks.Selection`; each handle group has a transform here).
    poses : the poses kept of the shape (:class:`~.pose_library.PoseLibrary`; not in the undo history).
    """

    def __init__(self, editor: HybridEditor, path: Path | None = None, cage_size: int | float = CAGE_SIZE,
                 roi: np.ndarray | None = None, handle: np.ndarray | None = None,
                 symmetry: str | None = None, *, metrics: ShapeMetrics | None = None,
                 history_budget: int | None = None) -> None:
        self.editor = editor
        self.mesh: Mesh = editor.mesh
        self.path = Path(path) if path is not None else None
        self.cage_size = cage_size
        self.metrics = metrics if metrics is not None else ShapeMetrics(self.mesh.vertices, self.mesh.faces)
        self.dominant = editor.dominant_cage_vertex
        self.selection = Selection(self, roi, handle, symmetry)
        #: transform of each handle group since the selection was applied
        self.transforms: list[np.ndarray] = [np.eye(4)]
        self._settle_left = 0
        self._settle_label: str | None = None
        self._bases: list[np.ndarray] = [np.eye(4)]
        self._anchor: np.ndarray | None = None
        self._anchor_state = None  # the engine's state a settle starts from (the selection applied, or polished)
        self._anchor_bases: list[np.ndarray] = [np.eye(4)]
        #: what the file says the shape looks like (:class:`~.look.Look`: textures, colours), or None
        self.look = None
        #: how the shape is drawn ("texture", "colors", "plain"); None: what the file has
        self.look_mode: str | None = None
        #: the shape's up axis (:mod:`hybridedit.fileio.up_axes`), and the key it is remembered under (None: not yet)
        self.up_axis = "+Y"
        self.shape_key: str | None = None
        self.settle_on_release = True
        self.settle_frames = SETTLE_FRAMES
        self.settle_iterations = ITERATIONS
        self.last_frame_seconds = 0.0
        #: the polished pose on display ((n, 3), given to the engine), or None since the last change
        self.polished: np.ndarray | None = None
        #: bumps when the engine (cage and binding) changes: a rebuild, or undo across one
        self.generation = 0
        self.poses = PoseLibrary()
        self.history = History(budget=default_budget(self.mesh.n_vertices) if history_budget is None
                               else history_budget)
        self._push("open")

    # ------------------------------------------------------------------ state
    @property
    def cage_positions(self) -> np.ndarray:
        """Current cage pose, (c, 3) (a copy; completes a settle under way)."""
        self.finish_settle()
        return self.editor.cage_positions

    @property
    def shape_positions(self) -> np.ndarray:
        """Current deformed shape, (n, 3) (a view the engine updates; completes a settle under way)."""
        self.finish_settle()
        return self.editor.deformed_vertices

    @property
    def transform(self) -> np.ndarray:
        """(4, 4) transform of the active handle group since the selection was applied."""
        return self.transforms[self.selection.active]

    @transform.setter
    def transform(self, T) -> None:
        self.transforms = list(self.transforms)
        self.transforms[self.selection.active] = np.asarray(T, dtype=np.float64).copy()

    def _all_transforms(self, active: np.ndarray | None = None) -> dict[int, np.ndarray]:
        """{group: transform} for the engine, with the active group at ``active`` when given."""
        Ts = {g: T for g, T in enumerate(self.transforms)}
        if active is not None:
            Ts[self.selection.active] = active
        return Ts

    def reset_transforms(self) -> None:
        """Every handle group's transform back to the identity, and the pose its drags start from."""
        self.transforms = [np.eye(4) for _ in range(self.selection.n_groups)]
        self._bases = [np.eye(4) for _ in range(self.selection.n_groups)]

    def group_added(self, label: str) -> None:
        """A handle group was added (:meth:`~.selection_masks.Selection.new_group`): its transform
        starts at the identity; one undo step."""
        self.transforms = list(self.transforms) + [np.eye(4)]
        self._bases = list(self._bases) + [np.eye(4)]
        self._push(label)

    def _keep_groups(self, kept: list[int]) -> None:
        """The transforms of the handle groups the selection kept (``kept[k]``: group k's old number)."""
        self.transforms = [self.transforms[g] for g in kept] or [np.eye(4)]
        self._bases = [self._bases[g] if g < len(self._bases) else np.eye(4) for g in kept] or [np.eye(4)]

    def _engine_transforms(self, active: np.ndarray | None = None) -> dict[int, np.ndarray]:
        """{group: transform} relative to the pose the engine's drags start from (see ``_bases``)."""
        Ts = self._all_transforms(active)
        bases = self._bases
        return {g: T if g >= len(bases) or np.array_equal(bases[g], np.eye(4)) else T @ np.linalg.inv(bases[g])
                for g, T in Ts.items()}

    @property
    def n_cage(self) -> int:
        """The cage's vertex count (the length of the selection's masks)."""
        return self.editor.cage.n_vertices

    @property
    def shown_positions(self) -> np.ndarray:
        """The pose on display and saved, (n, 3): the engine's (a polish is given to it)."""
        return self.shape_positions

    @property
    def applied(self) -> bool:
        """The selection has been given to the engine (a drag has started since it changed)."""
        return self._anchor is not None

    @property
    def replayable(self) -> bool:
        """The edit file :meth:`to_edit` gives replays to the pose on display (see
        :attr:`~hybridedit.HybridEditor.replayable`)."""
        self.finish_settle()
        return self.editor.replayable

    @property
    def edges(self) -> np.ndarray:
        """(e, 2) unique edges of the shape."""
        return self.metrics.edges

    def moving_vertices(self) -> np.ndarray | None:
        """The shape vertices a drag of the applied selection can move, (k,) int64 (None: no selection)."""
        if self._anchor is None:
            return None
        return self.editor.moving_vertices

    def handle_centroid(self) -> np.ndarray | None:
        """Centroid of the handle's cage vertices in the current pose, or None without a handle."""
        handle = self.selection.handle
        if not handle.any():
            return None
        return self.cage_positions[handle].mean(axis=0)

    def rrms_error(self) -> float:
        """Relative RMS edge-length error of the current pose, in percent."""
        return rrms_edge_error(self.mesh.vertices, self.shape_positions, self.edges)

    def is_posed(self) -> bool:
        return not np.array_equal(self.cage_positions, self.editor.cage.vertices)

    # ------------------------------------------------------------------ history
    def _snapshot(self, label: str) -> Snapshot:
        sel = self.selection
        return Snapshot(
            roi=sel.roi.copy(), handle=sel.handle_group.copy(), positions=self.cage_positions,
            transform=np.stack(self.transforms), active=sel.active,
            anchor=None if self._anchor is None else self._anchor.copy(), label=label,
            editor=self.editor, cage_size=self.cage_size, symmetry=sel.symmetry,
            engine=self.editor.save_state(), engine_masks=sel.given, anchor_state=self._anchor_state,
            bases=np.stack(self._bases), anchor_bases=np.stack(self._anchor_bases),
        )

    def _push(self, label: str) -> None:
        self.history.push(self._snapshot(label))

    def restore(self, snap: Snapshot) -> None:
        """Put the session back into a snapshot's state (selection, pose, transform)."""
        self._settle_left, self._settle_label = 0, None
        self.polished = None
        if snap.editor is not None and snap.editor is not self.editor:
            self._use_editor(snap.editor, snap.cage_size)
        self.selection.restore(snap)
        Ts = np.asarray(snap.transform).reshape(-1, 4, 4)
        self.editor.restore_state(snap.engine)
        self._anchor_state = snap.anchor_state
        if snap.anchor is not None:
            self._anchor = snap.anchor.copy()
            self.transforms = [T.copy() for T in Ts] + [np.eye(4)] * (self.selection.n_groups - len(Ts))
            self._bases = self._padded(snap.bases)
            self._anchor_bases = self._padded(snap.anchor_bases)
        else:
            self._anchor = None
            self.reset_transforms()
        # a pose a polish made, nothing dragged since (a selection changed, a rebuild), is still the polish
        self.polished = self.editor.deformed_vertices if self._pose_is_a_polish() else None

    def _pose_is_a_polish(self) -> bool:
        """The engine's pose is the end of a polish: its last step was polished and nothing dragged since."""
        r = self.editor.record
        return not r.dragged and r.last_polish is not None

    def _padded(self, stack: np.ndarray | None) -> list[np.ndarray]:
        """One transform per handle group from a snapshot's stack (identities where it has none)."""
        got = [] if stack is None else [T.copy() for T in np.asarray(stack).reshape(-1, 4, 4)]
        n = self.selection.n_groups
        return got[:n] + [np.eye(4)] * max(n - len(got), 0)

    def undo(self) -> bool:
        self.finish_settle()
        snap = self.history.undo()
        if snap is None:
            return False
        self.restore(snap)
        return True

    def redo(self) -> bool:
        self.finish_settle()
        snap = self.history.redo()
        if snap is None:
            return False
        self.restore(snap)
        return True

    # ------------------------------------------------------------------ a new cage
    def _use_editor(self, editor: HybridEditor, cage_size: int | float | None) -> None:
        if editor.mesh.n_vertices != self.mesh.n_vertices:
            raise ValueError("the new engine is for another shape")
        self.editor = editor
        self.dominant = editor.dominant_cage_vertex
        if cage_size is not None:
            self.cage_size = cage_size
        self.selection.engine_replaced()
        self.polished = None
        self.generation += 1

    def adopt(self, editor: HybridEditor, cage_size: int | float) -> str | None:
        """Go on with a new cage and binding of the same shape (a rebuild).

        The pose carries over exactly (the new engine takes the shape as it is shown,
        :meth:`~hybridedit.HybridEditor.carry_pose`, and the next drag starts from it; a saved
        edit replays the steps before the rebuild on the old cage);
        the selection carries over through the shape; the undo history stays, and
        undoing the rebuild goes back to the old cage and its exact pose. Returns a
        sentence for the status bar, or None.
        """
        self.finish_settle()
        old = self.editor
        posed = self.is_posed()
        dominant = self.dominant
        self._use_editor(editor, cage_size)
        self.selection.carry_over(dominant)
        self._anchor = None
        self.reset_transforms()
        if posed:
            self.editor.carry_pose(old)  # the pose exactly, and the steps that made it (each on its cage)
        else:
            self.editor.reset()
        self._push("rebuild cage")
        return "the pose was carried over to the new cage as it is; the next drag starts from it" if posed else None

    # ------------------------------------------------------------------ selection and the engine
    def selection_changed(self, label: str) -> None:
        """The masks changed (:class:`~.selection_masks.Selection`): one undo step; a selection given
        to the engine before is no longer the one dragged next."""
        if self._anchor is not None and not self.selection.engine_has_masks():
            self._anchor = None
            self.reset_transforms()
        self._push(label)

    def apply_selection(self) -> None:
        """Give the selection to the engine; the current pose becomes the anchor.

        Raises
        ------
        SelectionError
            Empty handle, or a cage part with no fixed or handle vertex.
        """
        sel = self.selection
        if not sel.handle.any():
            which = f"Handle group {sel.active + 1}" if sel.n_groups > 1 else "The handle"
            raise SelectionError(
                f"{which} is empty. Choose the Handle target and select the cage vertices to drag first"
                + (" (G switches group)." if sel.n_groups > 1 else ".")
            )
        kept = sel.give_to_engine()
        if kept is not None:
            self._keep_groups(kept)
        self._anchor = self.cage_positions
        self.reset_transforms()
        self._mark_anchor()

    def set_mirror(self, axis: str | None) -> None:
        """Mirror the selection across ``axis``'s mid-plane ("x", "y", "z"), or stop (None): one undo step,
        and a selection with a handle is given to the engine at once (drawn on both sides).

        Raises
        ------
        SelectionError
            The shape is not symmetric enough across ``axis`` (the measured asymmetry), or the mirrored
            selection cannot be dragged; nothing changed.
        """
        sel = self.selection
        before = sel.symmetry
        try:
            sel.set_symmetry(axis)  # a shape too asymmetric is refused here, nothing changed
            if sel.handle.any():
                self.apply_selection()
        except SelectionError:
            if sel.symmetry != before:
                self.undo()  # back to the selection before the toggle
            raise

    def _mark_anchor(self) -> None:
        """The engine's state now is where a settle starts from (with the groups' transforms there)."""
        self._anchor_state = self.editor.save_state()
        self._anchor_bases = [B.copy() for B in self._bases]

    def polish_job(self, *, max_iterations: int, tolerance: float):
        """A polish of the pose on display (:meth:`~hybridedit.HybridEditor.polish_job`), to run in a
        worker thread and give back with :meth:`adopt_polish`; None when there is nothing to polish."""
        if not self.applied or self.settling or not self.editor.free_mask.any():
            return None
        return self.editor.polish_job(max_iterations=max_iterations, tolerance=tolerance)

    def adopt_polish(self, job, result) -> None:
        """Make a polish of the engine's current pose the engine's own, as one undo step: it is
        what is shown and saved, the next drag or selection starts from it exactly, and the
        edit file records it (:meth:`~hybridedit.HybridEditor.adopt_polish`; a ValueError when
        the pose changed since ``job`` was made)."""
        self.finish_settle()
        self.editor.adopt_polish(job, result)
        self._polished_here()
        self._push("polish")

    def _polished_here(self) -> None:
        """The engine's pose is a polish it adopted: shown as polished, the drags start from it."""
        self.polished = self.editor.deformed_vertices  # (the engine's pose itself: read-only, no copy)
        if self._anchor is not None:
            self._bases = [T.copy() for T in self.transforms]  # the engine's drags now start here
            self._mark_anchor()

    # ------------------------------------------------------------------ dragging
    def begin_drag(self) -> np.ndarray:
        """Start a drag gesture: applies a changed selection; returns the current handle transform."""
        self.finish_settle()
        self.polished = None  # a drag starts from the engine's pose
        if self._anchor is None or not self.selection.engine_has_masks():
            self.apply_selection()
        return self.transform.copy()

    def drag_to(self, T: np.ndarray, iterations: int | None = None) -> np.ndarray:
        """One interactive frame with the handle at ``T`` (relative to the anchor); returns the shape."""
        self.finish_settle()
        if self._anchor is None:
            raise SelectionError("no selection applied; start a drag first")
        T = np.asarray(T, dtype=np.float64)
        V = self.editor.drag(transforms=self._engine_transforms(T), iterations=iterations)
        self.transform = T.copy()
        fs = self.editor.frame_seconds
        self.last_frame_seconds = fs[-1]
        if len(fs) > 4096:
            del fs[:-64]
        return V

    @property
    def settling(self) -> bool:
        """A settle is under way: the engine's pose is intermediate until it finishes."""
        return self._settle_left > 0

    def start_settle(self) -> None:
        """Begin solving the current transform again from the anchor (see :meth:`settle_step`)."""
        if self._anchor is None:
            return
        self.editor.restore_state(self._anchor_state)
        self._bases = [B.copy() for B in self._anchor_bases]
        self._settle_left = self.settle_frames

    def settle_step(self, frames: int = 1) -> bool:
        """Run up to ``frames`` settle frames; returns True when the settle is complete.

        Any split into steps gives the same result as ``settle_frames`` calls of
        ``drag(transform, settle_iterations)`` from the anchor (what ``hybridedit
        deform`` runs): the handle target does not change between the calls.
        """
        k = min(int(frames), self._settle_left)
        if k > 0:
            self.editor.drag(transforms=self._engine_transforms(), iterations=k * self.settle_iterations)
            self._settle_left -= k
        if self._settle_left == 0 and self._settle_label is not None:
            label, self._settle_label = self._settle_label, None
            self._push(label)
        return self._settle_left == 0

    def finish_settle(self) -> None:
        """Complete a settle under way (no-op otherwise)."""
        if self._settle_left > 0:
            self.settle_step(self._settle_left)

    def settle(self) -> np.ndarray:
        """Solve the current transform again from the anchor with the batch settings, at once."""
        self.start_settle()
        self.finish_settle()
        return self.shape_positions

    def end_drag(self, label: str = "drag") -> bool:
        """Finish a drag gesture and record it for undo.

        With ``settle_on_release`` the settle is started and True returned: the
        caller runs :meth:`settle_step` until it completes (or :meth:`finish_settle`),
        and the undo step is recorded then.
        """
        if self._anchor is None:
            return False
        if self.settle_on_release:
            self.start_settle()
            self._settle_label = label
            return True
        self._push(label)
        return False

    def cancel_drag(self) -> None:
        """Abandon a drag gesture: back to the state before it started."""
        snap = self.history.current
        if snap is not None:
            self.restore(snap)

    def reset_pose(self) -> None:
        """Back to the rest pose; the selection stays and is anchored at rest."""
        self.finish_settle()
        self.polished = None
        self.editor.reset()
        self.reset_transforms()
        if self._anchor is not None:
            self._anchor = self.cage_positions
            self._mark_anchor()
        self._push("reset pose")

    # ------------------------------------------------------------------ edit files
    def to_edit(self) -> Edit:
        """How the pose on display was made, as a shape-space edit (the engine's
        :attr:`~hybridedit.HybridEditor.edit`): every step since the rest pose (selections,
        their settled transforms, polishes, the cage each ran on), which ``hybridedit deform``
        replays to this pose. A selection not dragged yet is its last step.
        """
        self.finish_settle()
        sel = self.selection
        if not sel.all_handles.any() and not self.is_posed():
            raise SelectionError("The handle is empty: there is nothing to save. Select a handle first.")
        if sel.all_handles.any() and (self._anchor is None or not sel.engine_has_masks()):
            self.apply_selection()  # the selection as it is now, not dragged yet
        return self.editor.edit

    def _replay(self, edit: Edit, path: str | None = None) -> None:
        """Replay an edit from the rest pose as ``hybridedit deform`` does (on this cage); its last
        step is run here, so that its selection is the session's, anchored where it starts."""
        self.editor.reset()
        self.editor.apply_edit(edit, frames=0, path=path)
        Ts = self.editor.edit_transforms(edit)
        self.selection.take_from_engine(len(Ts))
        self.transforms = [np.asarray(Ts[g], dtype=np.float64) for g in range(len(Ts))] or [np.eye(4)]
        self._anchor = self.editor.cage_positions
        self._bases = [np.eye(4) for _ in range(self.selection.n_groups)]
        self._mark_anchor()
        if edit.iterations is None and edit.converge is None:
            self.settle()
        elif edit.iterations:
            self.editor.drag(transforms=self._engine_transforms(), iterations=edit.iterations)
        if edit.converge is not None:  # as hybridedit.deform.replay runs it: to the fixed point
            self.editor.converge(transforms=self._engine_transforms(), tolerance=edit.converge["tolerance"],
                                 max_iterations=edit.converge["max_iterations"],
                                 start="current" if edit.iterations is not None else "base")
        if edit.polish is not None:
            self.editor.polish(iterations=edit.polish)
            self._polished_here()

    def load_edit(self, edit: Edit, path: str | None = None, *, label: str = "load edit") -> None:
        """Replay an edit as ``hybridedit deform`` does: from the rest pose, step by step; one undo
        step named ``label``.

        On any error (an edit for another mesh: EditFileError; a selection that does
        not fit: SelectionError) the session is left as it was.
        """
        self.finish_settle()
        before = self._snapshot("")
        try:
            self._replay(edit, path)
        except Exception:
            self.restore(before)
            raise
        if edit.polish is None:
            self.polished = None
        self._push(label)

    def replayed(self, edit: Edit, path: str | None = None) -> np.ndarray:
        """The pose ``edit`` replays to, (n, 3), exactly as :meth:`load_edit` shows it, the session left
        as it was (no undo step): a kept pose read back from a file. Raises as :meth:`load_edit`."""
        self.finish_settle()
        before = self._snapshot("")
        try:
            self._replay(edit, path)
            return self.shown_positions.copy()
        finally:
            self.restore(before)
