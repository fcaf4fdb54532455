"""The poses kept of one shape (Qt-free): the window's pose library, as Blender's shape keys, glTF's
morph targets or ZBrush's layers.

A :class:`KeptPose` holds what makes it exactly re-creatable, the session's edit (every step since the
rest pose, :meth:`~.session.Session.to_edit`, which :meth:`~.session.Session.load_edit` replays to the
same positions), and those positions, (n, 3), for display and export (:func:`hybridedit.save_poses`).
A :class:`PoseLibrary` is the ordered list of them, by unique names: keep the pose on display, rename,
remove, move, and *continue from* one (its edit loaded into the session, one undo step, so that editing
goes on from it). An edit file keeps the library beside its own edit (``"poses"``,
:func:`hybridedit.fileio.editfile.save_edit`), and so does the recovery file (:mod:`.recovery`).
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from ...deform.selection import SelectionError
from ...fileio.editfile import Edit

__all__ = ["KeptPose", "PoseLibrary", "PoseLibraryError", "replay_poses"]

DEFAULT_NAME = "Pose {}"
"""The name a kept pose gets when none is given: "Pose 1", "Pose 2", ..."""


class PoseLibraryError(ValueError):
    """A library operation refused (an empty or taken name, nothing to keep); the message is one line."""


@dataclass(frozen=True)
class KeptPose:
    """A pose kept in a :class:`PoseLibrary`.

    Attributes
    ----------
    name : its name, unique in its library.
    edit : how it was made from the rest pose (:class:`~hybridedit.fileio.editfile.Edit`).
    positions : (n, 3) float64, read-only: the shape in that pose.
    """

    name: str
    edit: Edit
    positions: np.ndarray

    def renamed(self, name: str) -> "KeptPose":
        return KeptPose(name, self.edit, self.positions)


@runtime_checkable
class Poses(Protocol):
    """A session as the library sees it (:class:`~.session.Session`): its pose as an edit and as
    positions, an edit replayed into it (one undo step), and an edit's positions without changing it."""

    @property
    def shown_positions(self) -> np.ndarray: ...
    def to_edit(self) -> Edit: ...
    def load_edit(self, edit: Edit, path: str | None = None, *, label: str = "load edit") -> None: ...
    def replayed(self, edit: Edit, path: str | None = None) -> np.ndarray: ...


def _frozen(positions: np.ndarray) -> np.ndarray:
    V = np.array(positions, dtype=np.float64, copy=True)
    V.flags.writeable = False
    return V


def replay_poses(session: Poses, entries: Sequence[tuple[str, Edit]], *, path: str) -> list[KeptPose]:
    """The poses of ``entries`` (``[(name, edit), ...]``, as an edit file or a recovery file holds them),
    each replayed on ``session`` from the rest pose for its positions; the session is left as it was.

    Raises
    ------
    hybridedit.fileio.editfile.EditFileError, SelectionError, ValueError
        A pose that does not replay on this shape (the message names ``path`` and the pose); nothing
        is changed.
    """
    out = []
    for name, edit in entries:
        out.append(KeptPose(name, edit, _frozen(session.replayed(edit, f"{path}: pose {name!r}"))))
    return out


class PoseLibrary:
    """The kept poses of a shape, in order, by unique names.

    Attributes
    ----------
    revision : bumps at every change (kept, renamed, removed, moved, read back).
    unsaved : it changed since :meth:`mark_saved` (an empty library that never changed: False).

    Examples
    --------
    >>> import trimesh, hybridedit as he
    >>> from hybridedit.viewer.model.session import Session
    >>> ball = trimesh.creation.icosphere(3)
    >>> s = Session(he.HybridEditor(he.Mesh(ball.vertices, ball.faces), 100), cage_size=100)
    >>> _ = s.selection.set_mask("roi", s.cage_positions[:, 0] > 0)
    >>> _ = s.selection.set_mask("handle", s.cage_positions[:, 0] > 0.8)
    >>> library = PoseLibrary()
    >>> library.keep(s).name, library.keep(s).name
    ('Pose 1', 'Pose 2')
    >>> library.rename(1, "Pose 1")
    Traceback (most recent call last):
    ...
    hybridedit.viewer.model.pose_library.PoseLibraryError: There is a pose named 'Pose 1' already.
    """

    def __init__(self) -> None:
        self._poses: list[KeptPose] = []
        self.revision = 0
        self._saved_revision = 0

    # ------------------------------------------------------------------ reading
    def __len__(self) -> int:
        return len(self._poses)

    def __iter__(self) -> Iterator[KeptPose]:
        return iter(list(self._poses))

    def __getitem__(self, index: int) -> KeptPose:
        return self._poses[index]

    @property
    def names(self) -> list[str]:
        return [p.name for p in self._poses]

    def index_of(self, name: str) -> int:
        """The place of the pose named ``name`` (ValueError when there is none)."""
        return self.names.index(name)

    def entries(self) -> list[tuple[str, Edit]]:
        """``[(name, edit), ...]``: what an edit file or a recovery file keeps of the library."""
        return [(p.name, p.edit) for p in self._poses]

    @property
    def unsaved(self) -> bool:
        return self.revision != self._saved_revision

    def mark_saved(self) -> None:
        """The library as it is now is saved (in an edit file)."""
        self._saved_revision = self.revision

    def _changed(self) -> None:
        self.revision += 1

    # ------------------------------------------------------------------ names
    def default_name(self) -> str:
        """The first of "Pose N", N from the library's length + 1 on, that no pose has."""
        taken, k = set(self.names), len(self) + 1
        while DEFAULT_NAME.format(k) in taken:
            k += 1
        return DEFAULT_NAME.format(k)

    def _checked(self, name: str, *, other_than: int | None = None) -> str:
        """``name`` without its outer spaces, refused (PoseLibraryError) when empty or another pose's."""
        name = str(name).strip()
        if not name:
            raise PoseLibraryError("A pose needs a name.")
        if "\n" in name or "\r" in name:
            raise PoseLibraryError("A pose's name is one line.")
        if any(p.name == name for i, p in enumerate(self._poses) if i != other_than):
            raise PoseLibraryError(f"There is a pose named {name!r} already.")
        return name

    def _free_name(self, name: str) -> str:
        """``name``, or "name (2)", "name (3)", ... when a pose has it."""
        taken, k, out = set(self.names), 2, name
        while out in taken:
            out, k = f"{name} ({k})", k + 1
        return out

    # ------------------------------------------------------------------ changing
    def keep(self, session: Poses, name: str | None = None) -> KeptPose:
        """Keep the pose on display of ``session`` (its edit and positions) at the end, as ``name``
        (default :meth:`default_name`).

        Raises
        ------
        PoseLibraryError
            Nothing to keep (the rest pose with no selection), or ``name`` empty or taken.
        """
        name = self.default_name() if name is None else self._checked(name)
        try:
            edit = session.to_edit()
        except SelectionError:
            raise PoseLibraryError("Nothing to keep: the shape is at its rest pose and nothing is selected.") from None
        pose = KeptPose(name, edit, _frozen(session.shown_positions))
        self._poses.append(pose)
        self._changed()
        return pose

    def rename(self, index: int, name: str) -> KeptPose:
        """Rename pose ``index`` (its outer spaces dropped); PoseLibraryError for an empty or taken name."""
        name = self._checked(name, other_than=index)
        if name != self._poses[index].name:
            self._poses[index] = self._poses[index].renamed(name)
            self._changed()
        return self._poses[index]

    def remove(self, index: int) -> KeptPose:
        """Remove pose ``index``; returns it."""
        pose = self._poses.pop(index)
        self._changed()
        return pose

    def move(self, index: int, by: int) -> int:
        """Move pose ``index`` by ``by`` places (up: negative), within the list; returns its new place."""
        to = min(max(index + by, 0), len(self) - 1)
        if to != index:
            self._poses.insert(to, self._poses.pop(index))
            self._changed()
        return to

    def continue_from(self, session: Poses, index: int) -> KeptPose:
        """Load pose ``index``'s edit into ``session`` (one undo step, "continue from NAME"): the shape is
        that pose exactly, and the next drag goes on from it. On an error the session is as it was
        (:meth:`~.session.Session.load_edit`)."""
        pose = self._poses[index]
        session.load_edit(pose.edit, path=f"pose {pose.name!r}", label=f"continue from {pose.name}")
        return pose

    def take(self, poses: Sequence[KeptPose], *, saved: bool) -> bool:
        """Poses read back (an edit file, a recovery file): they replace the library when it holds nothing
        unsaved, else they are added after its own (a name taken gets " (2)"), so that nothing kept is
        lost. ``saved``: they are saved where they were read from. Returns True when they replaced it."""
        replace = not self.unsaved or not self._poses
        if replace:
            self._poses = list(poses)
        else:
            for p in poses:
                self._poses.append(p.renamed(self._free_name(p.name)))
        self._changed()
        if replace and saved:
            self.mark_saved()
        return replace
