"""How the current pose was made from the rest pose: the steps an edit file replays.

The editor keeps a :class:`PoseRecord` beside its pose and takes it back with the
pose on undo (it is part of :class:`~hybridedit.deform.editor_state.EditorState`). A *step* is
a selection set on a pose, the ARAP iterations run at its handle transforms, and
a converge to the fixed point at them (:meth:`~hybridedit.HybridEditor.converge`), and
an optional full-resolution polish; the next selection (or the next drag after a
polish) starts the next step from the pose it left. A step describes the pose it
makes exactly when every iteration since the selection was set ran at the same
transforms (a settle, or a script's frames at one transform): then the replay
runs the same iterations and gets the same pose. Interactive frames at changing
transforms make a pose that depends on the mouse's path; such a step is *not
settled*, and its replay settles it instead.

A converge after settled iterations (or from the base pose) keeps the step settled:
its replay runs the same iterations, then the same converge from the same start, bit
for bit. A converge warm-started from unsettled frames (the window's or an add-on's
settle after a drag), or drags after a converge, leave the step not settled: its
replay converges from the step's start pose to the same tolerance instead (the same
fixed point to within it, where the energy has only the one near there).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace

from ..fileio.editfile import Edit
from .packed_step import PackedStep

__all__ = ["PoseRecord"]


@dataclass(frozen=True)
class PoseRecord:
    """The steps behind a pose (never modified: each change makes a new record).

    Attributes
    ----------
    packed : tuple of PackedStep
        The steps closed before the current selection's start pose, oldest first, kept small
        (:class:`~hybridedit.deform.packed_step.PackedStep`; :attr:`done` unpacks them).
    dragged : bool
        A drag ran since the current selection's start pose.
    iterations : int
        ARAP iterations run since then.
    settled : bool
        Every one of them ran at the current transforms.
    continues : bool
        The current selection is the last done step's, continued from its polished pose.
    converge : dict or None
        ``{"tolerance": t, "max_iterations": k}`` of the converge that ran since then, if any
        (after the ``iterations``).
    unknown : str or None
        Why the pose cannot be replayed from the rest pose (it was set from outside,
        e.g. :meth:`~hybridedit.HybridEditor.set_pose`); ``done`` then holds only the
        steps since. None: it can.
    """

    packed: tuple[PackedStep, ...] = ()
    dragged: bool = False
    iterations: int = 0
    settled: bool = True
    continues: bool = False
    unknown: str | None = None
    converge: dict | None = None

    @classmethod
    def of(cls, steps: Iterable[Edit], *, unknown: str | None = None) -> "PoseRecord":
        """A record of these closed steps (oldest first), nothing dragged since."""
        return cls(packed=tuple(PackedStep.of(s) for s in steps), unknown=unknown)

    @property
    def done(self) -> tuple[Edit, ...]:
        """The closed steps, oldest first (unpacked: new :class:`~hybridedit.fileio.editfile.Edit` objects)."""
        return tuple(p.unpack() for p in self.packed)

    @property
    def last_polish(self) -> int | None:
        """The polish iterations that closed the last step (None: no step, or not polished)."""
        return self.packed[-1].polish if self.packed else None

    def restarted(self, *, continues: bool = False) -> "PoseRecord":
        """A new step starts from the pose as it is (nothing dragged since)."""
        return replace(self, dragged=False, iterations=0, settled=True, continues=continues, converge=None)

    def after_drag(self, *, same_transforms: bool, iterations: int) -> "PoseRecord":
        """A drag of ``iterations`` ARAP iterations ran (``same_transforms``: at the transforms of the
        drags before it). After a converge the step is no longer settled (its replay converges)."""
        settled = self.settled and self.converge is None and (same_transforms or not self.dragged)
        return replace(self, dragged=True, iterations=self.iterations + int(iterations), settled=settled)

    def after_converge(self, spec: dict, *, same_transforms: bool, from_start: bool) -> "PoseRecord":
        """A converge ran (``spec``: its tolerance and iteration cap) at the transforms of the drags
        before it (``same_transforms``), warm-started from the pose they left, or (``from_start``)
        from the step's start pose: then it alone makes the pose."""
        if from_start:
            return replace(self, dragged=True, iterations=0, settled=True, converge=dict(spec))
        settled = self.settled and self.converge is None and (same_transforms or not self.dragged)
        return replace(self, dragged=True, settled=settled, converge=dict(spec))

    def closed(self, step: Edit) -> "PoseRecord":
        """The current step is done (``step`` describes it); a new one starts where it left off."""
        return replace(self, packed=self.packed + (PackedStep.of(step),)).restarted()

    @classmethod
    def from_outside(cls, reason: str) -> "PoseRecord":
        """A pose that no step made: nothing before it can be replayed."""
        return cls(unknown=reason)

    @property
    def replayable(self) -> bool:
        """Replaying :meth:`~hybridedit.HybridEditor.edit` from the rest pose gives the pose
        (every step settled or polished; none set from outside)."""
        return self.unknown is None and self.settled and all(s.iterations is not None for s in self.packed)
