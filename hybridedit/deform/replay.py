"""The one replay loop: an edit's steps, in order, on an editor (``hybridedit deform``, the
window's Load Edit, :meth:`hybridedit.HybridEditor.apply_edit`).

Each step sets its selection on the pose the steps before it made (a step that
*continues* keeps the selection and starts again from that pose), runs its ARAP
iterations at its handle transforms (the count it recorded, else ``frames`` x
``iterations``, or none for a step that converges), then its converge (the cage's
ARAP to its fixed point, :meth:`hybridedit.HybridEditor.converge`), then its polish
(the recorded count of full-resolution iterations). These are the calls the window
made, in the same order, so the replay of an edit saved in the window is the pose it
showed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

from ..defaults import SETTLE_FRAMES
from ..fileio.editfile import Edit, EditFileError, check_mesh

if TYPE_CHECKING:
    from .editor import HybridEditor
    from ..binding.rig import Progress

__all__ = ["replay", "cage_of"]


def cage_of(editor: "HybridEditor") -> dict:
    """``{"size": ..., "vertices": ...}``: the cage an editor works on, as a step records it."""
    size = editor.rig.cage_size
    return {"size": size if isinstance(size, int) else float(size), "vertices": int(editor.cage.n_vertices)}


def _runs_on(step: Edit, current: "HybridEditor", home: "HybridEditor",
             editor_for_cage: Callable[[dict], "HybridEditor"] | None, made: dict) -> "HybridEditor":
    """The editor ``step`` runs on: the one of the cage it records (given by ``editor_for_cage``,
    kept in ``made``), or ``home`` when it records none, it is home's, or no other is to be had."""
    if editor_for_cage is None or step.cage is None or step.cage == cage_of(home):
        return home
    if step.cage == cage_of(current):
        return current
    key = (step.cage["size"], step.cage["vertices"])
    if key not in made:
        made[key] = editor_for_cage(step.cage)
    return made[key]


#: units of work a converge counts for in a replay's progress (about a converge's iterations)
CONVERGE_UNITS = 200


def _plan(step: Edit, frames: int, per: int) -> list[int]:
    """The ARAP iterations of each drag a step runs: its recorded count (in drags of ``per``, as
    the window's settle ran them in slices: the split does not change the pose), else ``frames``
    drags of ``per`` each, or none when the step converges (that settles it)."""
    if step.iterations is None:
        return [] if step.converge is not None else [per] * frames
    size = max(per, 1)
    return [min(size, step.iterations - i) for i in range(0, step.iterations, size)]


def replay(editor: "HybridEditor", edit: Edit, *, frames: int = SETTLE_FRAMES, iterations: int | None = None,
           progress: "Progress | None" = None, path: str | None = None,
           editor_for_cage: Callable[[dict], "HybridEditor"] | None = None):
    """Replay ``edit`` on ``editor``, from its current pose (call ``editor.reset()`` first
    to start from the rest pose, as ``hybridedit deform`` does).

    Parameters
    ----------
    editor : HybridEditor
    edit : Edit
        Its :attr:`~hybridedit.fileio.editfile.Edit.steps`, oldest first.
    frames : int
        Drags run by a step that does not record its iterations (``iterations`` each); 0: the
        last step's selection is set and nothing of it is run.
    iterations : int, optional
        ARAP iterations a drag (default ``editor.iterations``).
    progress : callable(stage, fraction), optional
    path : str, optional
        The edit file's name, for messages.
    editor_for_cage : callable, optional
        ``editor_for_cage({"size": s, "vertices": c})`` gives an editor of the same shape on
        that cage: a step that ran on another cage than ``editor``'s runs there, the pose carried
        over (:meth:`~hybridedit.HybridEditor.carry_pose`), as the window's rebuild carried it.

    Returns
    -------
    (n, 3) float64 array, ``editor``'s deformed shape.

    Raises
    ------
    EditFileError
        The edit was made for another mesh, or a step continues a step that is not there.
    SelectionError
        A selection does not fit this mesh.

    Examples
    --------
    >>> ed.reset(); replay(ed, he.load_edit("pose.json"))  # doctest: +SKIP
    """
    if frames < 0:
        raise ValueError(f"frames must be >= 0, got {frames}")
    per = editor.iterations if iterations is None else int(iterations)
    if per < 0:
        raise ValueError(f"iterations must be >= 0, got {per}")
    name = path or "<edit>"
    check_mesh(edit, editor.mesh, name)
    say = progress or (lambda stage, fraction: None)
    steps = edit.steps
    plans = _plans(steps, frames, per)
    # a drag of c iterations counts c + 1 units (its propagation), a polish its iterations
    total = sum(sum(p) + len(p) for p in plans) + sum(s.polish or 0 for s in steps) \
        + CONVERGE_UNITS * sum(s.converge is not None for s in steps[:len(steps) - (frames == 0)])
    work = _Work(total=max(total, 1), say=say)
    current, made = editor, {}
    for k, step in enumerate(steps):
        target = _runs_on(step, current, editor, editor_for_cage, made)
        if target is not current:
            target.carry_pose(current)
            current = target
        _select(current, step, k, name)
        if k == len(steps) - 1 and frames == 0:
            break
        _run(current, step, plans[k], work)
    say("deforming", 1.0)
    if current is not editor:
        editor.carry_pose(current)
    return editor.deformed_vertices


def _plans(steps: list[Edit], frames: int, per: int) -> list[list[int]]:
    """Each step's :func:`_plan`; with ``frames`` 0, nothing of the last step is run."""
    plans = [_plan(s, frames, per) for s in steps]
    if frames == 0:
        plans[-1] = []
    return plans


@dataclass
class _Work:
    """How far a replay is: ``done`` of ``total`` units (an ARAP iteration, a drag, a polish
    iteration), told to ``say``."""

    total: int
    say: "Progress"
    done: int = 0

    def tell(self, stage: str, units: int) -> None:
        """Say ``stage`` at the fraction done so far, then count ``units`` more as done."""
        self.say(stage, self.done / self.total)
        self.done += units


def _select(current: "HybridEditor", step: Edit, k: int, name: str) -> None:
    """Set the selection of ``step`` (the ``k``-th, 0 first) on ``current``, or for a step that
    *continues*, start again from the pose with the selection there."""
    if step.continues:
        if current.n_groups != len(step.handles):
            raise EditFileError(f"{name}: step {k + 1} continues a selection of {len(step.handles)} handle "
                                f"groups; the one before has {current.n_groups}")
        if not current.record.continues or current.record.dragged:  # (a polish has started it already)
            current.continue_from_pose()
    else:
        current.set_selection([h.indices for h in step.handles], fixed=step.fixed, roi=step.roi,
                              space=step.space, symmetry=step.symmetry)


def _run(current: "HybridEditor", step: Edit, plan: list[int], work: _Work) -> None:
    """The drags of ``plan`` at the transforms of ``step``, then its converge and its polish."""
    Ts = current.edit_transforms(step)
    for chunk in plan:
        work.tell("deforming", chunk + 1)
        current.drag(transforms=Ts, iterations=chunk)
    if step.converge is not None:
        work.tell("converging", CONVERGE_UNITS)
        # (a step whose iterations are not recorded converges from its start pose, as it was replayed)
        current.converge(transforms=Ts, tolerance=step.converge["tolerance"],
                         max_iterations=step.converge["max_iterations"],
                         start="current" if step.iterations is not None else "base")
    if step.polish is not None:
        work.tell("polishing", step.polish)
        current.polish(iterations=step.polish)
